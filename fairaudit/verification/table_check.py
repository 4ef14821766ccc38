"""The black box over the model's table beyond the exact size: each program bounded by weak duality from the floors'
recorded multipliers or by its one-floor relaxation (solved outright where that decides), its lower end read off the
recorded table.

A program of :mod:`~fairaudit.verification.kernel_check` is max (p·K)/(q·K) over tables K whose rows (x̃, ã) are
distributions over the decisions, with floors F_f·K ≥ τ (one per live context and group). For
any ν ≥ 0 and λ, at every table meeting the floors (the simplices kept in the inner maximum: a partial Lagrangian),

    (p − λq)·K ≤ (p − λq + Σ_f ν_f F_f)·K − τ Σ_f ν_f ≤ B(λ) = Σ_rows max_u r[row, u] − τ Σ_f ν_f,

r = p − λq + Σ_f ν_f F_f. So B(λ) ≤ 0 proves the ratio at most λ. With ν = 0 the floors are dropped, and B(λ) is the
maximum of (p − λq)·K over the product of simplices itself: its smallest root is the value without floors, exactly,
and where its maximising table meets the floors, the program's value. B is convex, piecewise linear and
non-increasing in λ (q ≥ 0), so Newton's method from the left reaches its smallest root exactly, in finitely many
steps. ``proofs/verification.md`` §4f.

Where the floors bind and no ν is recorded (certify decided the program by its closed-form relaxation), the program
with the denominator's floor q·K ≥ t its only one is solved exactly (:meth:`TableProgram.floor_bound`, §4g): its
value bounds the program, and is the program's where the table attaining it meets every floor.

Before either, every pair gets its screen (:func:`~fairaudit.base.table_relaxation.relaxation_bounds`, §4h): that
relaxation's bound at a threshold floating point proposes, computed exactly, from one array per group. The pairs are
taken best first, so those whose screen is below the largest value found are never relaxed.
"""

from __future__ import annotations

import functools
import heapq
import operator
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, NamedTuple, cast

import numpy as np

from fairaudit.base.exact_duality import ACTIVE_TOLERANCES, on_one_denominator, smallest_root
from fairaudit.base.exact_programs import maximize_linear
from fairaudit.base.exact_vertex import gauss_jordan
from fairaudit.base.table_relaxation import relaxation_bounds
from fairaudit.verification.dual_check import without_duals
from fairaudit.verification.enclosures import INF
from fairaudit.verification.kernel_check import KernelSetting, kernel_global, kernel_local, reached_rows

__all__ = ["TableProgram", "table_global", "table_local"]

Number = Fraction | float
Row = Sequence[Fraction]
Table = Sequence[Row]
Ends = tuple[Number, Number, bool]

EXACT_SHARES = 64
"""The most rows :meth:`TableProgram.floor_bound` shares between two decisions by the rational simplex (at most twice
as many floors), to find among the relaxation's maximisers one that meets every floor."""


@dataclass(frozen=True)
class TableProgram:
    """max (p·K)/(q·K) over tables K, each row a distribution over the decisions, with floors F_f·K ≥ τ, in rationals.

    Attributes
    ----------
    tops, bottoms : sequence of sequence of Fraction, shape (n_rows, n_decisions)
        p and q, q ≥ 0.
    floors : sequence of mapping of int to sequence of Fraction
        F_f per floor, as {row: its coefficients over the decisions} (the rows it does not name are 0).
    tau : Fraction or None
        The floors' right-hand side (None: no floors).

    Examples
    --------
    Keep 3/4 on two groups, g(yes, a) = 1, g(yes, b) = 1/2, g(no, ·) = 0 (``proofs/verification.md`` §4d): the
    ratio a over b is 6 without floors; with τ = 1/4, ν = (0, 8/3) on the floors certifies 10/3, attained at
    P(yes | ã) = (1, 1/3).

    >>> F = Fraction
    >>> p = [[F(3, 4), F(0)], [F(1, 4), F(0)]]
    >>> q = [[F(1, 8), F(0)], [F(3, 8), F(0)]]
    >>> floors = [{0: [F(3, 4), F(0)], 1: [F(1, 4), F(0)]}, {0: [F(1, 8), F(0)], 1: [F(3, 8), F(0)]}]
    >>> program = TableProgram(p, q, floors, F(1, 4))
    >>> program.dual_bound(), program.dual_bound([F(0), F(8, 3)])
    (Fraction(6, 1), Fraction(10, 3))
    >>> program.point_ratio([[F(1), F(0)], [F(1, 3), F(2, 3)]])
    Fraction(10, 3)
    """

    tops: Table
    bottoms: Table
    floors: Sequence[Mapping[int, Row]]
    tau: Fraction | None

    def dual_bound(self, nu: Row | None = None) -> Number:
        """The smallest λ ≥ 0 with B(λ) ≤ 0 (see the module), exactly: an upper bound on the program's value.

        Parameters
        ----------
        nu : sequence of Fraction, optional
            ν, one per floor (ignored without τ). Default: 0, the program without its floors, whose value this is.

        Returns
        -------
        Fraction or float
            +inf when some ν < 0 or no λ has B(λ) ≤ 0 (a table with q·K = 0 < p·K); at least 1 where every row has
            a decision with q = 0 (a table there has q·K = 0, and 0/0 counts as 1).
        """
        c = [list(p) for p in self.tops]
        constant = Fraction(0)
        if nu is not None and self.tau is not None:
            if len(nu) != len(self.floors) or any(v < 0 for v in nu):
                return INF
            constant = -self.tau * sum(nu, Fraction(0))
            for v, floor in zip(nu, self.floors, strict=True):
                for row, coefficients in floor.items() if v else ():
                    c[row] = [ci + v * fi for ci, fi in zip(c[row], coefficients, strict=True)]
        lam = smallest_root(c, self.bottoms, constant)
        if lam is None:
            return INF
        zero = all(any(qi == 0 for qi in qr) for qr in self.bottoms)
        return max(lam, Fraction(1)) if zero else lam

    def floor_bound(self, kept: Fraction) -> tuple[Fraction, list[list[Fraction]]] | None:
        """The program's value with q·K ≥ ``kept`` its only floor, exactly, with a table attaining it: an upper bound
        on the value where every table meeting the floors has q·K ≥ kept > 0 (certify's closed-form floor relaxation).

        For every θ, f(θ) = θ + max(R(θ), 0)/kept with R(θ) = Σ_rows max_u (p − θq)[row, u] bounds it (weak
        duality, ν = f(θ) − θ on the one floor); f is convex, least at R's smallest root θ₀ or at θ_c, the largest θ
        where the rows' maximisers with the largest q reach q·K ≥ kept (a breakpoint of a row's upper hull of the
        points (q_u, p_u)). The table is every row on a maximiser of p − θq, the rows' q·K brought to ``kept`` by one
        row between its two (at θ_c), so its ratio is f there. None when no table has q·K ≥ kept.
        ``proofs/verification.md`` §4g.

        Parameters
        ----------
        kept : Fraction
            The floor's right-hand side, > 0.

        Returns
        -------
        (Fraction, list of list of Fraction) or None
            The value (a ratio) and a table, shape (n_rows, n_decisions), meeting q·K ≥ kept at that ratio; None when
            Σ_rows max q < kept.

        Examples
        --------
        The class's program with q·K ≥ 1/4 its only floor: θ_c = 2/3, 2/3 + R(2/3)/(1/4) = 10/3, at P(yes | ã) =
        (1, 1/3), which meets the other floor too.

        >>> F = Fraction
        >>> p, q = [[F(3, 4), F(0)], [F(1, 4), F(0)]], [[F(1, 8), F(0)], [F(3, 8), F(0)]]
        >>> value, table = TableProgram(p, q, [], None).floor_bound(F(1, 4))
        >>> value, table[1]
        (Fraction(10, 3), [Fraction(1, 3), Fraction(2, 3)])
        """
        rows = list(zip(self.tops, self.bottoms, strict=True))
        events: list[tuple[Fraction, Fraction]] = []  # (slope of a hull edge, its rise in q), every row's
        reach = Fraction(0)  # Σ_rows min q: the rows' q·K at θ = +inf
        for pr, qr in rows:
            hull: list[tuple[Fraction, Fraction]] = []
            for q, p in sorted(zip(qr, pr, strict=True), key=lambda v: (v[0], -v[1])):
                if hull and hull[-1][0] == q:
                    continue  # (the largest p at this q is already in)
                while len(hull) > 1 and (hull[-1][1] - hull[-2][1]) * (q - hull[-1][0]) <= (p - hull[-1][1]) * (
                    hull[-1][0] - hull[-2][0]
                ):
                    hull.pop()
                hull.append((q, p))
            reach += hull[0][0]
            events += [((b[1] - a[1]) / (b[0] - a[0]), b[0] - a[0]) for a, b in zip(hull, hull[1:])]
        theta_c: Fraction | None = None
        if reach < kept:
            for slope, rise in sorted(events, reverse=True):
                reach += rise
                if reach >= kept:
                    theta_c = slope
                    break
            else:
                return None  # Σ_rows max q < kept
        theta_0 = smallest_root([list(p) for p in self.tops], self.bottoms, Fraction(0))
        if theta_0 is not None and (theta_c is None or theta_0 <= theta_c):
            table = self.relaxed_table(theta_0)  # (its q·K ≥ kept: S at θ₀ is at least S at θ_c)
            return theta_0, table
        assert theta_c is not None  # (R has a root unless some row has p > 0 = q everywhere, where S ≥ kept never)
        table, total = [], Fraction(0)
        split: list[tuple[int, int, int]] = []
        for i, ((pr, qr), fr) in enumerate(zip(rows, self._floor_weights(), strict=True)):
            values = [pi - theta_c * qi for pi, qi in zip(pr, qr, strict=True)]
            top = max(values)
            best = [u for u, v in enumerate(values) if v == top]
            low, high = min(best, key=lambda u: (qr[u], -fr[u])), max(best, key=lambda u: (qr[u], fr[u]))
            table.append([Fraction(int(u == low)) for u in range(len(pr))])
            total += qr[low]
            if qr[high] > qr[low]:
                split.append((i, low, high))
        shares = self._shares(table, split, kept - total)
        for (i, low, high), share in zip(split, shares, strict=True):
            table[i][low], table[i][high] = 1 - share, share
        r = sum(max(pi - theta_c * qi for pi, qi in zip(pr, qr, strict=True)) for pr, qr in rows)
        return theta_c + max(r, Fraction(0)) / kept, table

    def _shares(self, table: Table, split: Sequence[tuple[int, int, int]], need: Fraction) -> list[Fraction]:
        """How far to move each row of ``split`` (i, from, to) from the one decision to the other so that q·K rises by
        ``need`` > 0: the first rows first; where that misses a floor and the moves and floors are few, shares that
        meet every floor, found by the rational simplex (none: the first rows first)."""
        rises = [self.bottoms[i][high] - self.bottoms[i][low] for i, low, high in split]
        greedy, left = [], need
        for rise in rises:
            share = min(Fraction(1), max(Fraction(0), left / rise))
            greedy.append(share)
            left -= share * rise
        floors = self.floors if self.tau is not None else []
        if not floors or len(split) > EXACT_SHARES or len(floors) > 2 * EXACT_SHARES:
            return greedy
        moved = [list(row) for row in table]
        for (i, low, high), share in zip(split, greedy, strict=True):
            moved[i][low], moved[i][high] = 1 - share, share
        if self.meets(moved):
            return greedy
        zero = [Fraction(0)] * len(split)
        a_ub, b_ub = [rises, [-v for v in rises]], [need, -need]
        for floor, start in zip(floors, self.floor_values(table), strict=True):  # (at the rows' starting decisions)
            change = [floor[i][high] - floor[i][low] if i in floor else Fraction(0) for i, low, high in split]
            a_ub.append([-v for v in change])
            b_ub.append(start - cast(Fraction, self.tau))
        found = maximize_linear(zero, zero, [Fraction(1)] * len(split), a_ub, b_ub)
        return list(found.point) if found.status == "optimal" and found.point is not None else greedy

    def relaxed_table(self, lam: Number) -> list[list[Fraction]]:
        """A table attaining the value ``lam`` = :meth:`dual_bound` () without the floors: each row on a decision
        maximising p − λq, the one with the largest q among ties; for +inf, on a decision with q = 0 maximising p."""
        table = []
        for pr, qr, fr in zip(self.tops, self.bottoms, self._floor_weights(), strict=True):
            if lam == INF:
                u = max((i for i in range(len(pr)) if qr[i] == 0), key=lambda i: (pr[i], fr[i]))
            else:
                u = max(range(len(pr)), key=lambda i: (pr[i] - lam * qr[i], qr[i], fr[i]))
            table.append([Fraction(int(i == u)) for i in range(len(pr))])
        return table

    def _floor_weights(self) -> list[list[Fraction]]:
        """Σ_f F_f per cell: among a row's tied decisions the one that helps the floors most is taken (all of them
        at once for a utility of the decision only, whose floors' coefficients in a row are multiples of g)."""
        n_u = len(self.tops[0]) if self.tops else 0
        if self.tau is None or not self.floors:
            return [[Fraction(0)] * n_u for _ in self.tops]
        ints, d = self._floor_matrix
        sums = [Fraction(int(v), d) for v in ints.sum(axis=0).tolist()]
        return [sums[r * n_u : (r + 1) * n_u] for r in range(len(self.tops))]

    @functools.cached_property
    def _floor_matrix(self) -> tuple[np.ndarray, int]:
        """The floors' coefficients over every cell (row-major: [floor, row · n_decisions + decision]), as integers
        over one denominator (an object array)."""
        n_u = len(self.tops[0]) if self.tops else 0
        dense = [[Fraction(0)] * (len(self.tops) * n_u) for _ in self.floors]
        for row, floor in zip(dense, self.floors, strict=True):
            for r, coefficients in floor.items():
                row[r * n_u : (r + 1) * n_u] = coefficients
        ints, d = on_one_denominator(dense)
        return np.array(ints, dtype=object).reshape(len(self.floors), len(self.tops) * n_u), d

    def floor_values(self, table: Table) -> list[Fraction]:
        """F_f·K for every floor, exactly (integers over one denominator, one matrix product).

        Parameters
        ----------
        table : sequence of sequence of Fraction, shape (n_rows, n_decisions)
            K, indexed [row, decision] as :attr:`tops`.

        Returns
        -------
        list of Fraction, shape (n_floors,)
            F_f·K in the order of :attr:`floors` (E[g | x, a] of each floor's context and group: a utility's mean,
            in g's units); empty without floors.

        Examples
        --------
        The class's floors at P(yes | ã) = (1, 1/3): 3/4 + 1/4·1/3 and 1/8 + 3/8·1/3.

        >>> F = Fraction
        >>> floors = [{0: [F(3, 4), F(0)], 1: [F(1, 4), F(0)]}, {0: [F(1, 8), F(0)], 1: [F(3, 8), F(0)]}]
        >>> program = TableProgram(*[[[F(0), F(0)]] * 2] * 2, floors, F(1, 4))
        >>> program.floor_values([[F(1), F(0)], [F(1, 3), F(2, 3)]])
        [Fraction(5, 6), Fraction(1, 4)]
        """
        if not self.floors:
            return []
        ints, d = self._floor_matrix
        (cells,), e = on_one_denominator([[v for row in table for v in row]])
        return [Fraction(int(v), d * e) for v in ints.dot(np.array(cells, dtype=object)).tolist()]

    def meets(self, table: Table) -> bool:
        """Whether the table's cells are ≥ 0, its rows sum to 1 and it meets every floor, exactly."""
        if any(v < 0 for row in table for v in row) or any(sum(row, Fraction(0)) != 1 for row in table):
            return False
        return self.tau is None or all(v >= self.tau for v in self.floor_values(table))

    def point_ratio(self, table: Table) -> Fraction | None:
        """(p·K)/(q·K) at the table K, exactly, when it :meth:`meets` every constraint and q·K > 0; None otherwise."""
        if not self.meets(table):
            return None
        num = sum(map(_dot, self.tops, table), Fraction(0))
        den = sum(map(_dot, self.bottoms, table), Fraction(0))
        return num / den if den > 0 else None

    def vertex_ratio(self, table: Table) -> Fraction | None:
        """The largest ratio :meth:`point_ratio` gives at the table or at a vertex it stands for; None when none meets
        every constraint.

        At each of :data:`~fairaudit.base.exact_duality.ACTIVE_TOLERANCES`, a cell within it of 0 is put at 0, and the
        rows' sums and the floors within it of τ are solved as equalities for the other cells, exactly
        (:func:`~fairaudit.base.exact_vertex.gauss_jordan`; a cell they leave free keeps its value). A wrong reading is
        refused by :meth:`point_ratio`, never a wrong ratio.
        """
        found = [ratio for reading in self._readings(table) if (ratio := self.point_ratio(reading)) is not None]
        return max(found, default=None)

    def proved_value(self, table: Table) -> Fraction | None:
        """The program's value, where the table (or a vertex it stands for, as :meth:`vertex_ratio` reads it) is a
        maximiser that complementary slackness proves: multipliers ν ≥ 0 on the floors it meets with equality, and
        each row's largest value m of r = p − λq + Σ_f ν_f F_f (λ its ratio), solved exactly from r = m on every cell
        the table uses (the other unknowns at 0); :meth:`dual_bound` at that ν is then λ itself. None where no reading
        is proved so (the program is then solved or bounded otherwise).

        Parameters
        ----------
        table : sequence of sequence of Fraction, shape (n_rows, n_decisions)
            The recorded table K, indexed [row, decision] (a certificate's ``witness_point``, read exactly).

        Returns
        -------
        Fraction or None
            The program's value, a ratio (its log is in nats), or None.

        Notes
        -----
        Complementary slackness with each row's simplex kept in the inner maximum (the bound of :meth:`dual_bound`):
        ``proofs/verification.md`` §4f, "A recorded table proved optimal".

        Examples
        --------
        The class's maximiser P(yes | ã) = (1, 1/3) at 10/3: the floor of b holds with equality, ν = 8/3 on it.

        >>> F = Fraction
        >>> p, q = [[F(3, 4), F(0)], [F(1, 4), F(0)]], [[F(1, 8), F(0)], [F(3, 8), F(0)]]
        >>> floors = [{0: [F(3, 4), F(0)], 1: [F(1, 4), F(0)]}, {0: [F(1, 8), F(0)], 1: [F(3, 8), F(0)]}]
        >>> TableProgram(p, q, floors, F(1, 4)).proved_value([[F(1), F(0)], [F(1, 3), F(2, 3)]])
        Fraction(10, 3)
        """
        for reading in self._readings(table):
            lam = self.point_ratio(reading)
            if lam is None:
                continue
            values = self.floor_values(reading) if self.tau is not None else []
            active = [f for f, v in enumerate(values) if v == self.tau]
            width = len(active)  # (the unknowns: ν on the active floors, then each row's maximum m)
            equations: list[tuple[dict[int, Fraction], Fraction, bool]] = []
            for r, row in enumerate(reading):
                for u in (u for u, v in enumerate(row) if v > 0):
                    touched = [(j, self.floors[f][r][u]) for j, f in enumerate(active) if r in self.floors[f]]
                    terms = {j: c for j, c in touched if c}
                    terms[width + r] = Fraction(-1)
                    equations.append((terms, lam * self.bottoms[r][u] - self.tops[r][u], True))
            pivots = gauss_jordan(equations)
            if pivots is None:
                continue
            nu = [Fraction(0)] * len(self.floors)
            for j, f in enumerate(active):
                nu[f] = pivots[j][1] if j in pivots else Fraction(0)
            if self.dual_bound(nu if self.tau is not None else None) == lam:
                return lam
        return None

    def _readings(self, table: Table) -> list[list[list[Fraction]]]:
        """The table itself, then the vertex it stands for at each of
        :data:`~fairaudit.base.exact_duality.ACTIVE_TOLERANCES` (see :meth:`vertex_ratio`)."""
        out = [[list(row) for row in table]]
        n_u = len(table[0]) if table else 0
        values = self.floor_values(table) if self.tau is not None else []
        for tolerance in ACTIVE_TOLERANCES:
            tol = Fraction(tolerance)
            free = {r * n_u + u for r, row in enumerate(table) for u, v in enumerate(row) if v > tol}
            equations: list[tuple[dict[int, Fraction], Fraction, bool]] = [
                ({r * n_u + u: Fraction(1) for u in range(n_u) if r * n_u + u in free}, Fraction(1), True)
                for r in range(len(table))
            ]
            for floor, value in zip(self.floors, values, strict=True):
                assert self.tau is not None  # (no floors without τ)
                if value - self.tau <= tol * (1 + self.tau):
                    terms = {r * n_u + u: f[u] for r, f in floor.items() for u in range(n_u) if f[u]}
                    equations.append(({i: v for i, v in terms.items() if i in free}, self.tau, False))
            pivots = gauss_jordan(equations)
            if pivots is None:
                continue
            cells = [
                v if r * n_u + u in free else Fraction(0) for r, row in enumerate(table) for u, v in enumerate(row)
            ]
            for i, (terms, rhs) in pivots.items():  # (the free cells keep their values)
                cells[i] = rhs - sum((v * cells[j] for j, v in terms.items()), Fraction(0))
            out.append([cells[r * n_u : (r + 1) * n_u] for r in range(len(table))])
        return out


def _dot(a: Row, b: Row) -> Fraction:
    return sum(map(operator.mul, a, b), Fraction(0))


@dataclass(frozen=True)
class _Case:
    """One program: its bound (without the floors, or with the denominator's floor q·K ≥ t its only one:
    :meth:`TableProgram.floor_bound`), whether that bound is its value, the recorded ν and the recorded witness table
    over its rows."""

    program: TableProgram
    bound: Number
    exact: bool  # the bound is the value: the table attaining it meets the floors
    nu: list[Fraction] | None
    table: list[list[Fraction]] | None
    solve: Callable[[], Number | None] | None = None  # its exact value by the rational simplex, within its size


def _case(
    program: TableProgram, kept: Fraction | None, nu: Any, table: Any, solve: Callable[[], Number | None] | None
) -> _Case:
    """The program's case: without floors its bound is its value; with them, where the table attaining the bound
    without them meets them (at +inf: a table with E[g | a'] = 0 < E[g | a]; finite: one at its ratio), else where
    the table attaining the one-floor relaxation's value (q·K ≥ ``kept``) meets them."""
    relaxed = program.dual_bound()
    at = program.relaxed_table(relaxed)
    if program.tau is None or not program.floors:
        exact = True
    elif relaxed == INF:
        exact = program.meets(at)
    else:
        exact = program.point_ratio(at) == relaxed
    bound = relaxed
    if kept and not exact:  # E[g | a'] ≥ t on every table meeting the floors: certify's floor relaxation
        relaxation = program.floor_bound(kept)
        if relaxation is not None and relaxation[0] < bound:
            bound, at = relaxation
            exact = program.point_ratio(at) == bound
    return _Case(program, bound, exact, nu, table, solve)


class _Lazy(NamedTuple):
    """One program of :func:`_largest`, its case built only when needed."""

    screen: Number  # an upper bound on its value (relaxation_bounds), +inf where none is known
    build: Callable[[], _Case]
    pointed: bool  # whether the certificate records a witness table for it


def _largest(cases: Sequence[_Lazy], start: Number, loose: bool) -> Ends:
    """max of ``start`` and the programs' values, enclosed (as ``black_box_check._largest``): best first, each at
    its screen, then at its bound (:func:`_case`), exact where its relaxed table meets the floors or its recorded
    table is proved optimal (:meth:`TableProgram.proved_value`), set aside where its recorded ν bounds it by the
    largest value found, else solved by the rational simplex within its size, else bounded by its ν, until no bound
    left exceeds the upper end found; a recorded table gives a lower end. Without a ν, a bound within
    :data:`~fairaudit.verification.dual_check.SEARCH_STOP` of the upper end found (certify's search leaves such a
    program unsolved), or any with ``loose``, is kept as an upper end; any other raises
    :class:`~fairaudit.verification.dual_check.MissingDual`. Where none was taken, the first is solved all the same:
    that is where floors no table meets are found (ValueError)."""
    low = high = start
    duals, deferred, taken = False, [], False
    attained: dict[int, Fraction | None] = {}

    @functools.cache
    def case_of(i: int) -> _Case:  # (each program built once, when first needed)
        return cases[i].build()

    for i, entry in enumerate(cases):
        if entry.pointed:
            case = case_of(i)
            found = attained[i] = None if case.table is None else case.program.vertex_ratio(case.table)
            low = low if found is None else max(low, found)
    heap: list[tuple[Number, int, bool]] = [(-entry.screen, i, False) for i, entry in enumerate(cases)]
    heapq.heapify(heap)  # (−bound, position, whether the bound is the case's): best first, ties in order
    while heap and -heap[0][0] > high:
        _, i, bounded = heapq.heappop(heap)
        case = case_of(i)
        if not bounded:
            heapq.heappush(heap, (-case.bound, i, True))
            continue
        taken = True
        value = attained.get(i)
        if case.exact or (value is not None and value >= case.bound):
            low, high = max(low, case.bound), max(high, case.bound)
        elif case.table is not None and (proved := case.program.proved_value(case.table)) is not None:
            low, high = max(low, proved), max(high, proved)  # (the recorded table, proved optimal exactly)
        elif case.solve is not None and case.nu is not None and case.program.dual_bound(case.nu) <= high:
            continue  # (its recorded multipliers bound it by the largest value found: no need to solve it)
        elif case.solve is not None and (solved := case.solve()) is not None:
            low, high = max(low, solved), max(high, solved)
        elif case.nu is not None:
            high, duals = max(high, min(case.bound, case.program.dual_bound(case.nu))), True
        elif loose:
            high, duals = max(high, case.bound), True
        else:
            deferred.append(case.bound)
    if not taken and heap and (first := case_of(heap[0][1])).solve is not None and first.program.tau:
        first.solve()  # (raises where no table meets the floors; its value is at most the bound, at most start)
    high, raised = without_duals(deferred, high, "programs over the model's table beyond the exact size")
    return low, high, duals or raised


def _reach(s: KernelSetting, x: int) -> list[tuple[int, Fraction]]:
    """The released contexts x̃ with M_X[x, x̃] > 0, with that entry (x itself, with 1, for the identity)."""
    if s.context is None:
        return [(x, Fraction(1))]
    return [(xr, m) for xr, m in enumerate(s.context[x]) if m]


def _form(
    s: KernelSetting, keys: Sequence[tuple[int, int]], weights: Mapping[int, Fraction], a: int
) -> dict[int, list[Fraction]]:
    """Σ_x weights[x] E[g | x, a] as {row: its coefficients over the decisions}, over the rows ``keys`` (x̃, ã): the
    coefficient of K[x̃, ã, u] is Σ_x weights[x] M_X[x, x̃] M_A[a, ã] g(u, x, a); the rows it does not touch left out."""
    by_context: dict[int, list[int]] = {}
    for i, (xr, _) in enumerate(keys):
        by_context.setdefault(xr, []).append(i)
    out: dict[int, list[Fraction]] = {}
    for x, w in weights.items():
        g = s.g[x][a]
        for xr, mx in _reach(s, x) if w else ():
            for i in by_context.get(xr, ()):
                m = w * mx * s.sensitive[a][keys[i][1]]
                if m:
                    row = out.get(i) or [Fraction(0)] * len(g)
                    out[i] = [r + m * v for r, v in zip(row, g, strict=True)]
    return out


def _dense(form: Mapping[int, list[Fraction]], n_rows: int, n_u: int) -> list[list[Fraction]]:
    return [form.get(i) or [Fraction(0)] * n_u for i in range(n_rows)]


def _floors(s: KernelSetting, keys: Sequence[tuple[int, int]], xs: Sequence[int]) -> list[dict[int, list[Fraction]]]:
    """E[g | x, c] ≥ τ for each context x of ``xs`` and each group c, in that order, over the rows ``keys``."""
    return [_form(s, keys, {x: Fraction(1)}, c) for x in xs for c in range(s.k)]


def _table(s: KernelSetting, point: Any, keys: Sequence[tuple[int, int]], own: bool) -> list[list[Fraction]]:
    """The recorded table's rows for ``keys``: ``point[ã]`` where the point is one context's (``own``: L behind the
    identity), else ``point[x̃][ã]``. A utility free of the group behind the identity on the context records
    E[g | x, ã] instead: each such row is the table that reaches it with g's largest and least decisions,
    P(u_max) = (E − min g)/(max g − min g) (every table with the same E[g | x, ã] has the same ratio and floors)."""
    rows = [point[ar] for _, ar in keys] if own else [point[xr][ar] for xr, ar in keys]
    return [row if isinstance(row, list) else _mixed(s.g[xr][0], row) for (xr, _), row in zip(keys, rows, strict=True)]


def _mixed(g: Row, value: Fraction) -> list[Fraction]:
    """The distribution over the decisions on g's largest and least values (the first of each) whose mean is the
    value, clipped to [min g, max g]."""
    high, low = max(range(len(g)), key=lambda u: g[u]), min(range(len(g)), key=lambda u: g[u])
    share = (
        Fraction(1) if g[high] == g[low] else min(Fraction(1), max(Fraction(0), (value - g[low]) / (g[high] - g[low])))
    )
    row = [Fraction(0)] * len(g)
    row[low] += 1 - share
    row[high] += share
    return row


def table_local(s: KernelSetting, at: tuple[int, int, int] | None = None, loose: bool = False) -> Ends:
    """L's worst ratio over the model's table, at any size, enclosed: (lower end, upper end, whether a recorded ν or a
    relaxation gives the upper end).

    With M_X the identity, L at x is over the rows of x with the floors of x; otherwise over every row reached with
    every live context's floors (they bind the same rows), its ν recorded per context.

    Parameters
    ----------
    s : KernelSetting
        The programs' data at one end of e^ε, with the certificate's evidence.
    at : (int, int, int), optional
        (index into ``s.live``, a, a'): that program only.
    loose : bool
        Keep a program's bound as its upper end where no ν is recorded (else
        :class:`~fairaudit.verification.dual_check.MissingDual` is raised where that bound exceeds the values found
        by more than :data:`~fairaudit.verification.dual_check.SEARCH_STOP`).

    Returns
    -------
    (Fraction or float, Fraction or float, bool)
        The lower and upper ends of e^L (a ratio, dimensionless; L in nats is its log; +inf when a table gives
        c/0 with c > 0), and whether a recorded ν or a bound left without one gives the upper end (then the lower
        end is a recorded table's ratio, or 0 without one).

    Raises
    ------
    MissingDual
        Without ``loose``, where a program that needs a ν has none recorded.

    Notes
    -----
    Weak duality with each row's simplex kept, Newton's method from the left, the vertex read off a table:
    ``proofs/verification.md`` §4f.

    Examples
    --------
    The module's setting (``kernel_check.kernel_local``'s example): 6, exactly, the floors not binding.

    >>> from fractions import Fraction as F
    >>> s = KernelSetting(((F(3, 4), F(1, 4)), (F(1, 4), F(3, 4))), None, [[[F(1), F(0)], [F(1, 2), F(0)]]],
    ...                   None, [0], [[F(1), F(1)]], [0, 1], False, 64)
    >>> table_local(s)
    (Fraction(6, 1), Fraction(6, 1), False)
    """
    own = s.context is None  # (then a program per context)
    n_u = len(s.g[0][0])
    out = []
    evidence = s.evidence
    shared: dict[int, tuple[list[tuple[int, int]], list[dict[int, list[Fraction]]]]] = {}  # rows and floors
    for i in range(len(s.live)) if at is None else [at[0]]:
        x = s.live[i]
        key = x if own else -1
        if key not in shared:
            keys = reached_rows(s, [x] if own else s.live)
            shared[key] = keys, _floors(s, keys, [x] if own else s.live)
        keys, floors = shared[key]
        pairs = [(a, b) for a in range(s.k) for b in range(s.k) if a != b] if at is None else [at[1:]]
        groups = sorted({a for pair in pairs for a in pair})
        forms = {a: _dense(_form(s, keys, {x: Fraction(1)}, a), len(keys), n_u) for a in groups}
        screens = {} if at is not None else relaxation_bounds(forms, dict.fromkeys(groups, s.tau))
        for a, b in pairs:
            recorded = evidence.local.get((x, a, b))
            nu = recorded if recorded is None or own else [recorded[y][c] for y in s.live for c in range(s.k)]
            point = evidence.local_point
            table = _table(s, point[3], keys, own) if point is not None and point[:3] == (x, a, b) else None
            solve = functools.partial(kernel_local, s, (i, a, b)) if s.small else None
            program = TableProgram(forms[a], forms[b], floors, s.tau)
            build = functools.partial(_case, program, s.tau, nu, table, solve)
            out.append(_Lazy(screens.get((a, b), INF), build, table is not None))
    return _largest(out, Fraction(0), loose)


def table_global(s: KernelSetting, at: tuple[int, int] | None = None, loose: bool = False) -> Ends:
    """L̄'s worst ratio over the model's table, at any size, enclosed as in :func:`table_local` (every row reached,
    E[g | a] = Σ_x P(x | a) E[g | x, a], every live context's floors); 1 with fewer than two groups present.

    Parameters
    ----------
    s : KernelSetting
        The programs' data at one end of e^ε, with the certificate's evidence.
    at : (int, int), optional
        The ordered pair (a, a') of groups present: that program only.
    loose : bool
        As :func:`table_local`.

    Returns
    -------
    (Fraction or float, Fraction or float, bool)
        The ends of e^L̄ and whether a recorded ν or a bound left without one gives the upper end, as
        :func:`table_local` (the lower end at least 1).

    Raises
    ------
    MissingDual
        As :func:`table_local`.

    Notes
    -----
    ``proofs/verification.md`` §4f.

    Examples
    --------
    With τ = 1/4 and no ν recorded, the relaxation with E[g | b] ≥ 1/4 its only floor settles it: 10/3, at a table
    that meets the other floor too (:meth:`TableProgram.floor_bound`):

    >>> from fractions import Fraction as F
    >>> s = KernelSetting(((F(3, 4), F(1, 4)), (F(1, 4), F(3, 4))), None, [[[F(1), F(0)], [F(1, 2), F(0)]]],
    ...                   F(1, 4), [0], [[F(1), F(1)]], [0, 1], False, 64)
    >>> table_global(s)
    (Fraction(10, 3), Fraction(10, 3), False)
    """
    if len(s.present) < 2:
        return Fraction(1), Fraction(1), False
    keys = reached_rows(s, s.live)
    floors = _floors(s, keys, s.live)
    n_u = len(s.g[0][0])
    pairs = [(a, b) for a in s.present for b in s.present if a != b] if at is None else [at]
    groups = sorted({a for pair in pairs for a in pair})
    forms = {
        a: _dense(_form(s, keys, {x: s.weights[i][a] for i, x in enumerate(s.live)}, a), len(keys), n_u) for a in groups
    }  # E[g | a] = Σ_x P(x | a) E[g | x, a]: the numerator where a is first, the denominator where second
    kept = {b: None if s.tau is None else s.tau * sum((w[b] for w in s.weights), Fraction(0)) for b in groups}
    screens = {} if at is not None else relaxation_bounds(forms, kept)
    evidence = s.evidence
    out = []
    for a, b in pairs:
        recorded = evidence.global_.get((a, b))
        nu = None if recorded is None else [recorded[x][c] for x in s.live for c in range(s.k)]
        point = evidence.global_point
        table = _table(s, point[2], keys, False) if point is not None and point[:2] == (a, b) else None
        solve = functools.partial(kernel_global, s, (a, b)) if s.small else None
        program = TableProgram(forms[a], forms[b], floors, s.tau)
        build = functools.partial(_case, program, kept[b], nu, table, solve)
        out.append(_Lazy(screens.get((a, b), INF), build, table is not None))
    return _largest(out, Fraction(1), loose)
