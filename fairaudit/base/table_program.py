"""The program over the model's table in rationals: max (p·K)/(q·K) over tables K whose rows (x̃, ã) are
distributions over the decisions, with floors F_f·K ≥ τ (one per live context and group), bounded by weak duality,
relaxed to one floor, and its maximisers proved by complementary slackness. Certify (``worstcase``) certifies its
linear programs' values over the model's table with it, and ``fairaudit verify`` re-derives the black box there with
it (``verification.table_check``).

For any ν ≥ 0 and λ, at every table meeting the floors (the simplices kept in the inner maximum: a partial
Lagrangian),

    (p − λq)·K ≤ (p − λq + Σ_f ν_f F_f)·K − τ Σ_f ν_f ≤ B(λ) = Σ_rows max_u r[row, u] − τ Σ_f ν_f,

r = p − λq + Σ_f ν_f F_f. So B(λ) ≤ 0 proves the ratio at most λ. With ν = 0 the floors are dropped, and B(λ) is the
maximum of (p − λq)·K over the product of simplices itself: its smallest root is the value without floors, exactly,
and where its maximising table meets the floors, the program's value. B is convex, piecewise linear and
non-increasing in λ (q ≥ 0), so Newton's method from the left reaches its smallest root exactly, in finitely many
steps. ``proofs/verification.md`` §4f; the one-floor relaxation §4g.
"""

from __future__ import annotations

import collections
import functools
import math
import operator
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from fractions import Fraction
from typing import cast

import numpy as np

from fairaudit.base.exact_duality import (
    ACTIVE_TOLERANCES,
    on_one_denominator,
    smallest_root,
    smallest_root_of_integers,
)
from fairaudit.base.exact_programs import Polytope, maximize_linear
from fairaudit.base.exact_vertex import gauss_jordan
from fairaudit.base.outward import quotient_nearest

__all__ = ["EXACT_CHOICES", "EXACT_SHARES", "POINTED_CHOICES", "PointedMaximum", "TableProgram"]

INF = math.inf
Number = Fraction | float
Row = Sequence[Fraction]
Table = Sequence[Row]

EXACT_SHARES = 64
"""The most rows :meth:`TableProgram.floor_bound` shares between two decisions by the rational simplex (at most twice
as many floors), to find among the relaxation's maximisers one that meets every floor."""

POINTED_CHOICES = 96
"""The most decisions, summed over the rows, beyond each row's first that :meth:`TableProgram.pointed_value` keeps for
its restricted program by default (one unknown each; a program of 96 takes about 0.1 s): a degenerate optimum whose
multipliers tie whole rows needs them all (seven rows of ten decisions at randomized response's 10 nats: 71)."""

EXACT_CHOICES = 512
"""The most decisions, summed over the rows, beyond each row's first that the rational simplex takes for
:meth:`TableProgram.pointed_maximiser`'s restricted program where certify asks for the value itself: 18 groups behind
a product with three contexts behind a matrix, where dozens of programs tie exactly by the groups' symmetry, keep 300
to 450 of 540 (54 rows of 11 decisions, 54 floors), each solved in about 2 s."""

POLYTOPES_KEPT = 8
"""How many restricted programs' polytopes (one per set of choices, with the basis of its last solve) a program and
those :meth:`TableProgram.with_ratio` gives from it keep (each about 10 MB at 91 rows of 130 unknowns)."""


@dataclass(frozen=True)
class PointedMaximum:
    """The outcome of :meth:`TableProgram.pointed_maximiser`: the program's value, proved, with a table attaining it.

    Attributes
    ----------
    nu : sequence of Fraction
        The multipliers given, one per floor (a solver's, read exactly), that pointed to the table.
    value : Fraction
        The program's value, exactly (a ratio; its log is in nats).
    table : list of list of Fraction, shape (n_rows, n_decisions)
        A table attaining it, indexed [row, decision] as :attr:`TableProgram.tops`, meeting every floor.
    multipliers : list of Fraction, shape (n_floors,)
        ν* ≥ 0 on the floors with :meth:`TableProgram.dual_bound` (ν*) = ``value``: the proof.
    choices : int
        The decisions, summed over the rows, beyond each row's first that the restricted program proved kept (any
        limit at least this finds the same).

    Notes
    -----
    ``proofs/verification.md`` §4f, "From the multipliers alone": the restricted program's multipliers and the column
    generation (Gilmore & Gomory 1961, *Operations Research* 9: 849–859).
    """

    nu: Row
    value: Fraction
    table: list[list[Fraction]]
    multipliers: list[Fraction]
    choices: int


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
    _bounds: dict[tuple[Number, ...] | None, Number] = field(
        default_factory=dict, init=False, repr=False, compare=False
    )

    def with_ratio(self, tops: Table, bottoms: Table) -> TableProgram:
        """The program with the same floors and τ over the same rows and decisions, and the ratio (p·K)/(q·K) of
        ``tops`` and ``bottoms``: the floors' integer matrix and their sum per cell are built once, for every ratio
        asked of them (the ordered pairs of groups over one context's floors).

        Parameters
        ----------
        tops, bottoms : sequence of sequence of Fraction, shape (n_rows, n_decisions)
            p and q, q ≥ 0, of the shape of :attr:`tops`.

        Returns
        -------
        TableProgram

        Raises
        ------
        ValueError
            Where ``tops`` or ``bottoms`` is not of the shape of :attr:`tops`.

        Examples
        --------
        The class's program with the ratio b over a: 3/2 without the floors, b's row alone on yes, (3/8)/(1/4) (a over
        b gives 6, a's row alone on yes).

        >>> F = Fraction
        >>> p, q = [[F(3, 4), F(0)], [F(1, 4), F(0)]], [[F(1, 8), F(0)], [F(3, 8), F(0)]]
        >>> floors = [{0: [F(3, 4), F(0)], 1: [F(1, 4), F(0)]}, {0: [F(1, 8), F(0)], 1: [F(3, 8), F(0)]}]
        >>> program = TableProgram(p, q, floors, F(1, 4))
        >>> program.with_ratio(q, p).dual_bound(), program.dual_bound()
        (Fraction(3, 2), Fraction(6, 1))
        """
        shape = [len(row) for row in self.tops]
        for name, rows in (("tops", tops), ("bottoms", bottoms)):
            if [len(row) for row in rows] != shape:
                widths = sorted({len(row) for row in rows})
                raise ValueError(
                    f"{name} must have {len(shape)} rows of {shape[0] if shape else 0} decisions (got {len(rows)} rows"
                    f" of {' or '.join(map(str, widths)) or 'no'} decisions)"
                )
        program = TableProgram(tops, bottoms, self.floors, self.tau)
        for built in ("_floor_matrix", "_floor_weights", "_polytopes"):  # (cached properties: built here if not yet)
            program.__dict__[built] = getattr(self, built)
        return program

    def dual_bound(self, nu: Row | None = None) -> Number:
        """The smallest λ ≥ 0 with B(λ) ≤ 0 (see the module), exactly: an upper bound on the program's value. Found
        once per ν: the program keeps it for the next call at the same ν.

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
        key = None if nu is None else tuple(nu)
        if key not in self._bounds:  # (its callers ask again at the same ν: one exact root each)
            self._bounds[key] = self._dual_bound(nu)
        return self._bounds[key]

    def _dual_bound(self, nu: Row | None) -> Number:
        constant = Fraction(0)
        if nu is not None and self.tau is not None:
            if len(nu) != len(self.floors) or any(v < 0 for v in nu):
                return INF
            constant = -self.tau * sum(nu, Fraction(0))
        if not self.tops:
            lam = smallest_root([], [], constant)
        else:
            (top, d), (q, e) = self._integer_pq
            live = [] if nu is None or self.tau is None else [f for f, v in enumerate(nu) if v]
            if live:  # c = p + Σ_f ν_f F_f over one denominator d·n·g: top·n·g + d·(ν's integers)·(the floors')
                assert nu is not None  # (live is empty without ν)
                (weights,), n = on_one_denominator([[nu[f] for f in live]])
                floors, g = self._floor_matrix
                added = np.array(weights, dtype=object) @ floors[live]
                top, d = top * (n * g) + d * added.reshape(top.shape), d * n * g
            lam = smallest_root_of_integers(top, d, q, e, constant)
        if lam is None:
            return INF
        zero = all(any(qi == 0 for qi in qr) for qr in self.bottoms)
        return max(lam, Fraction(1)) if zero else lam

    @functools.cached_property
    def _integer_pq(self) -> tuple[tuple[np.ndarray, int], tuple[np.ndarray, int]]:
        """p and q as integers over one denominator each: object arrays of shape (n_rows, n_decisions)."""
        out = []
        for rows in (self.tops, self.bottoms):
            ints, d = on_one_denominator(rows)
            out.append((np.array(ints, dtype=object).reshape(len(rows), -1), d))
        return out[0], out[1]

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
        for i, ((pr, qr), fr) in enumerate(zip(rows, self._floor_weights, strict=True)):
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
        for pr, qr, fr in zip(self.tops, self.bottoms, self._floor_weights, strict=True):
            if lam == INF:
                u = max((i for i in range(len(pr)) if qr[i] == 0), key=lambda i: (pr[i], fr[i]))
            else:
                u = max(range(len(pr)), key=lambda i: (pr[i] - lam * qr[i], qr[i], fr[i]))
            table.append([Fraction(int(i == u)) for i in range(len(pr))])
        return table

    @functools.cached_property
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
    def _polytopes(self) -> collections.OrderedDict[tuple[tuple[int, ...], ...], tuple[Polytope, list[int]]]:
        """The restricted programs' polytopes (:meth:`_restricted`) and the floors each keeps, by their choices, the
        most recently used last (at most :data:`POLYTOPES_KEPT`): each keeps the basis its last solve ended at,
        feasible, and the programs of :meth:`with_ratio`, which share them, have the same floors, so the same polytope
        over the same choices: phase 1 runs once for all of them."""
        return collections.OrderedDict()

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
        used = [i for i, v in enumerate(cells) if v]  # (a table is mostly 0s: one decision or two per row)
        sums = ints[:, used].dot(np.array([cells[i] for i in used], dtype=object)) if used else [0] * len(ints)
        return [Fraction(int(v), d * e) for v in list(sums)]

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
        proved = self._proved(table)
        return None if proved is None else proved[0]

    def _proved(self, table: Table) -> tuple[Fraction, list[list[Fraction]]] | None:
        """:meth:`proved_value`'s value, with the reading of the table it proves optimal."""
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
                return lam, reading
        return None

    def pointed_value(self, nu: Row) -> Fraction | None:
        """The program's value, where the multipliers ν point to a maximiser that the exact multipliers of a
        restricted program prove; None where none is (the program is then bounded otherwise, by :meth:`dual_bound`
        (ν) for one).

        At λ = :meth:`dual_bound` (ν), each row is restricted to the decisions within a tolerance of its largest
        r = p − λq + Σ_f ν_f F_f (complementary slackness: an optimal table uses no other where ν is optimal; of
        decisions alike in p, q and every floor only the first, the others changing nothing), and the program over
        those cells is solved exactly, every floor kept (:func:`~fairaudit.base.exact_programs.maximize_ratio`),
        which gives its value λ* at a table and its exact multipliers ν* ≥ 0 on the floors (the last step's dual).
        :meth:`dual_bound` (ν*) = λ* proves λ* the program's value. Where the bound is larger, some row has decisions
        whose r at (λ*, ν*) exceeds its largest over its choices: they are added and the program solved again
        (column generation: Gilmore & Gomory 1961, *Operations Research* 9: 849–859), while the rows' choices beyond
        their first are at most :data:`POINTED_CHOICES` (:meth:`pointed_maximiser` takes another limit). Where no
        table over the choices meets the floors, decisions are first added until one does (phase 1: max z with
        F_f·K ≥ τ + z, z ≤ 0, its multipliers y on the floors adding a row's decisions whose Σ_f y_f F_f exceeds
        its largest over the choices); where none gains, none can, and the next of
        :data:`~fairaudit.base.exact_duality.ACTIVE_TOLERANCES` (relative to the largest |r|) is tried. Nothing here
        needs to be right: λ* is a table's ratio, the table meets every constraint, and ν* bounds the program by λ*,
        exactly.

        Parameters
        ----------
        nu : sequence of Fraction
            ν, one per floor (a solver's multipliers, read exactly: floats suffice).

        Returns
        -------
        Fraction or None
            The program's value (a ratio; its log is in nats), or None; None also without τ, with a ν < 0 or of the
            wrong length, or where :meth:`dual_bound` (ν) is +inf.

        Notes
        -----
        ``proofs/verification.md`` §4f, "From the multipliers alone".

        Examples
        --------
        The class's program, ν = (0, 8/3) on the floors as a float reads it: both decisions of b's row are within
        tolerance of its largest r at λ = dual_bound(ν), a hair above 10/3; the program over them puts P(yes | b̃) at
        1/3, proved optimal at 10/3 by ν* = (0, 8/3) exactly.

        >>> F = Fraction
        >>> p, q = [[F(3, 4), F(0)], [F(1, 4), F(0)]], [[F(1, 8), F(0)], [F(3, 8), F(0)]]
        >>> floors = [{0: [F(3, 4), F(0)], 1: [F(1, 4), F(0)]}, {0: [F(1, 8), F(0)], 1: [F(3, 8), F(0)]}]
        >>> program = TableProgram(p, q, floors, F(1, 4))
        >>> nu = [F(0), F(8 / 3)]
        >>> program.dual_bound(nu) > F(10, 3), program.pointed_value(nu)
        (True, Fraction(10, 3))
        """
        found = self.pointed_maximiser(nu)
        return None if found is None else found.value

    def pointed_maximiser(self, nu: Row, choices: int | None = None) -> PointedMaximum | None:
        """:meth:`pointed_value`'s value with the table that attains it (a maximiser of the program, for a witness)
        and the exact multipliers that prove it.

        Parameters
        ----------
        nu : sequence of Fraction
            ν, one per floor, as :meth:`pointed_value` takes it.
        choices : int, optional
            The most decisions, summed over the rows, beyond each row's first that the restricted program keeps
            (default :data:`POINTED_CHOICES`; :data:`EXACT_CHOICES` is as many as the rational simplex takes).

        Returns
        -------
        PointedMaximum or None
            The program's value (a ratio; its log is in nats), a table attaining it exactly, shape (n_rows,
            n_decisions), indexed [row, decision] as :attr:`tops`, and ν*, shape (n_floors,), with
            :meth:`dual_bound` (ν*) the value; None where :meth:`pointed_value` is None.

        Notes
        -----
        ``proofs/verification.md`` §4f, "From the multipliers alone"; the table as certify's witness:
        ``proofs/black_box.md`` §6.

        Examples
        --------
        The class's program of :meth:`pointed_value`: P(yes | b̃) = 1/3 attains 10/3, and ν* = (0, 8/3) proves it.
        From ν = (0, 3) (the bound 7/2) each row is pointed to yes alone: ratio 2 there, every floor met, so ν* = 0,
        whose bound is 6; at λ* = 2 and ν* = 0, b's "no" gains (r = 0 against −1/2), and the program with it is the
        first's.

        >>> F = Fraction
        >>> p, q = [[F(3, 4), F(0)], [F(1, 4), F(0)]], [[F(1, 8), F(0)], [F(3, 8), F(0)]]
        >>> floors = [{0: [F(3, 4), F(0)], 1: [F(1, 4), F(0)]}, {0: [F(1, 8), F(0)], 1: [F(3, 8), F(0)]}]
        >>> found = TableProgram(p, q, floors, F(1, 4)).pointed_maximiser([F(0), F(8 / 3)])
        >>> found.value, [str(v) for v in found.table[1]], found.multipliers
        (Fraction(10, 3), ['1/3', '2/3'], [Fraction(0, 1), Fraction(8, 3)])
        >>> again = TableProgram(p, q, floors, F(1, 4)).pointed_maximiser([F(0), F(3)])
        >>> (again.value, again.table, again.multipliers) == (found.value, found.table, found.multipliers)
        True
        >>> found.choices, again.choices
        (1, 1)
        """
        lam, limit = self.dual_bound(nu), POINTED_CHOICES if choices is None else choices
        if self.tau is None or not isinstance(lam, Fraction) or not self.tops:
            return None
        near = _nearest(lam)  # (the restricted maximum is at most λ, near it: a float's worth is guess enough)
        guess = Fraction(near) if math.isfinite(near) else lam
        r = self._reduced(lam, nu)
        gaps = np.array([[_nearest(max(row) - v) for v in row] for row in r])  # (≥ 0; +inf beyond the floats)
        scale = max(_nearest(max(abs(v) for row in r for v in row)), np.finfo(float).tiny)
        for tolerance in ACTIVE_TOLERANCES:
            chosen = [
                list(dict.fromkeys(twins[u] for u in np.flatnonzero(row <= tolerance * scale).tolist()))
                for row, twins in zip(gaps, self._twins, strict=True)
            ]  # (of decisions alike in p, q and every floor, the first: the others change nothing)
            while (kept := sum(len(c) - 1 for c in chosen)) <= limit:
                found = self._restricted(chosen, guess)
                if found is None:  # (no table over these choices meets the floors: phase 1 adds decisions until one
                    more = self._feasible(chosen, limit)  # does; failing that, the next tolerance chooses more)
                    if more is None or more == chosen:
                        break
                    chosen = more
                    continue
                value, table, multipliers = found
                if self.point_ratio(table) == value and self.dual_bound(multipliers) == value:  # (attained, bounded)
                    return PointedMaximum(nu, value, table, multipliers, kept)
                r = self._reduced(value, multipliers)
                more = [  # (the decisions that gain, each row's: what the restricted program lacked)
                    list(dict.fromkeys([*c, *(twins[u] for u, v in enumerate(row) if v > max(row[w] for w in c))]))
                    for row, c, twins in zip(r, chosen, self._twins, strict=True)
                ]
                if more == chosen:
                    return None  # (none gains, yet the bound is not the value: 0/0 counted as 1 beyond it)
                chosen, guess = more, value
            else:
                return None  # (more choices than the limit, here and at every larger tolerance)
        return None

    def _reduced(self, lam: Fraction, nu: Row) -> list[list[Fraction]]:
        """r = p − λq + Σ_f ν_f F_f over the cells, shape (n_rows, n_decisions), exactly."""
        r = [[p - lam * q for p, q in zip(pr, qr, strict=True)] for pr, qr in zip(self.tops, self.bottoms, strict=True)]
        for v, floor in zip(nu, self.floors, strict=True):
            for row, coefficients in floor.items() if v else ():
                r[row] = [ri + v * fi for ri, fi in zip(r[row], coefficients, strict=True)]
        return r

    @functools.cached_property
    def _twins(self) -> list[list[int]]:
        """Per row, each decision's first twin: the first decision with the same p, q and coefficient in every floor
        (a row no floor or ratio tells apart, such as a context's rows where nothing is released, has one)."""
        n_u = len(self.tops[0]) if self.tops else 0
        ints = self._floor_matrix[0] if self.floors else np.zeros((0, len(self.tops) * n_u), dtype=object)
        out = []
        for r, (pr, qr) in enumerate(zip(self.tops, self.bottoms, strict=True)):
            first: dict[tuple[object, ...], int] = {}
            keys = [(pr[u], qr[u], *ints[:, r * n_u + u].tolist()) for u in range(n_u)]
            out.append([first.setdefault(key, u) for u, key in enumerate(keys)])
        return out

    def _restricted(
        self, chosen: Sequence[Sequence[int]], guess: Fraction
    ) -> tuple[Fraction, list[list[Fraction]], list[Fraction]] | None:
        """The program with row i on the decisions ``chosen[i]`` only, solved exactly: (its value, a table attaining
        it, its multipliers ν on the floors), None where no such table meets the floors. Its unknowns are one per
        chosen decision after a row's first (whose share is 1 less the others'), and h₀ = 1 carrying what the rows fix
        (:meth:`_affine`); its rows are :meth:`_restricted_rows`. ν is the last step's dual on the floors' rows
        (:attr:`~fairaudit.base.exact_programs.RatioOptimum.multipliers`): with the rows' sums kept in the inner
        maximum, it bounds the restricted program by its value. Its steps start at ``guess``
        (:meth:`~fairaudit.base.exact_programs.Polytope.maximize_ratio`'s ``start``), near its maximum, and its
        simplex at the basis the last solve over the same choices and floors ended at, if any (:attr:`_polytopes`);
        the polytope depends on the choices and the floors, not on the ratio, so only p and q are built again."""
        key = tuple(map(tuple, chosen))
        polytope, kept = self._polytopes.pop(key) if key in self._polytopes else self._new_polytope(chosen)
        self._polytopes[key] = polytope, kept
        while len(self._polytopes) > POLYTOPES_KEPT:
            self._polytopes.popitem(last=False)
        found = polytope.maximize_ratio(
            self._affine(chosen, self.tops), self._affine(chosen, self.bottoms), start=guess
        )
        if found.status != "optimal" or found.value is None or found.point is None or found.multipliers is None:
            return None
        n_u = len(self.tops[0])
        table = [[Fraction(0)] * n_u for _ in chosen]
        for i, c in enumerate(chosen):
            table[i][c[0]] = Fraction(1)
        columns = [(i, u) for i, c in enumerate(chosen) for u in c[1:]]
        for (i, u), share in zip(columns, found.point[1:], strict=True):
            table[i][chosen[i][0]] -= share
            table[i][u] = share
        nu = [Fraction(0)] * len(self.floors)
        for f, y in zip(kept, found.multipliers, strict=False):  # (the floors' rows come first)
            nu[f] = y
        return found.value, table, nu

    def _new_polytope(self, chosen: Sequence[Sequence[int]]) -> tuple[Polytope, list[int]]:
        """The restricted program's polytope over ``chosen`` (h₀ = 1, the other unknowns in [0, 1], the rows of
        :meth:`_restricted_rows`) and the floors it keeps. Its phase 1 starts at the table with each row on its
        chosen decision of largest Σ_f F_f (:attr:`_floor_weights`; the first of ties). Where every floor's
        coefficients in a row are multiples ≥ 0 of one g (a utility of the decision only; of the decision and the
        context, behind the identity on the context), that table maximises every floor at once, so it meets them
        all where any table over the choices does, and phase 1 takes no step; elsewhere it is only where phase 1
        starts."""
        kept, a_ub, b_ub = self._restricted_rows(chosen)
        at_upper, column = [], 1
        for c, weights in zip(chosen, self._floor_weights, strict=True):
            best = max(c, key=lambda u: weights[u])  # (max keeps the first of ties: c[0], no unknown, where it ties)
            if best != c[0]:
                at_upper.append(column + c.index(best) - 1)
            column += len(c) - 1
        lower, upper = [Fraction(1)] + [Fraction(0)] * (column - 1), [Fraction(1)] * column
        return Polytope(lower, upper, a_ub, b_ub, column, at_upper=at_upper), kept

    @staticmethod
    def _affine(chosen: Sequence[Sequence[int]], rows: Sequence[Row | None] | Mapping[int, Row]) -> list[Fraction]:
        """Coefficients over the cells, ``rows`` (row i's over the decisions; a mapping may leave rows out: 0), as an
        affine form over the restricted program's unknowns: h₀ = 1 carrying each row's first choice, then one unknown
        per chosen decision after a row's first, in the rows' order (its coefficient less the first's)."""
        out = [Fraction(0)]
        for i, c in enumerate(chosen):
            row = rows.get(i) if isinstance(rows, Mapping) else rows[i]
            if row is None:
                out.extend(Fraction(0) for _ in c[1:])
                continue
            first = row[c[0]]
            out[0] += first
            out.extend(row[u] - first for u in c[1:])
        return out

    def _restricted_rows(
        self, chosen: Sequence[Sequence[int]]
    ) -> tuple[list[int], list[list[Fraction]], list[Fraction]]:
        """The restricted program's rows over :meth:`_affine`'s unknowns: (the floors kept, A_ub and b_ub with those
        floors' rows first, as −F_f·h ≤ −τ, then each row's shares summing to at most 1 where it has more than one).
        A floor every choice meets is left out."""
        tau = cast(Fraction, self.tau)
        forms = [self._affine(chosen, floor) for floor in self.floors]
        kept = [f for f, form in enumerate(forms) if sum((v for v in form[1:] if v < 0), form[0]) < tau]
        a_ub = [[-v for v in forms[f]] for f in kept]
        b_ub = [-tau] * len(a_ub)
        start = 1
        width = sum(len(c) - 1 for c in chosen) + 1
        for c in chosen:
            if len(c) > 2:
                a_ub.append([Fraction(int(start <= j < start + len(c) - 1)) for j in range(width)])
                b_ub.append(Fraction(1))
            start += len(c) - 1
        return kept, a_ub, b_ub

    def _feasible(self, chosen: list[list[int]], limit: int) -> list[list[int]] | None:
        """``chosen`` with decisions added until some table over them meets every floor (phase 1 by column
        generation): max z with F_f·K ≥ τ + z over the choices, z ≤ 0, solved exactly; where z < 0, its multipliers
        y ≥ 0 on the floors weigh each cell w = Σ_f y_f F_f, and a row's decisions whose w exceeds its largest over
        its choices are added (with the rows' sums kept in the inner maximum, y bounds z over every decision by its
        value over the choices where none does: then no table meets the floors). None there, or beyond ``limit``
        choices after the rows' first."""
        while sum(len(c) - 1 for c in chosen) <= limit:
            kept, a_ub, b_ub = self._restricted_rows(chosen)
            floors = len(kept)
            if not floors:
                return chosen
            width = len(a_ub[0])
            low = min(sum((-v for v in row[1:] if v > 0), -row[0]) for row in a_ub[:floors])  # (min F·K over h)
            found = maximize_linear(
                [Fraction(0)] * width + [Fraction(1)],
                [Fraction(1)] + [Fraction(0)] * (width - 1) + [min(low - cast(Fraction, self.tau), Fraction(0))],
                [Fraction(1)] * width + [Fraction(0)],
                [[*row, Fraction(int(f < floors))] for f, row in enumerate(a_ub)],
                b_ub,
            )
            if found.status != "optimal" or found.value is None or found.multipliers is None:
                return None  # (not reached: z at its lower end meets every row)
            if found.value == 0:
                return chosen
            y = found.multipliers[:floors]
            weights = [[Fraction(0)] * len(row) for row in self.tops]
            for f, v in zip(kept, y, strict=True):
                for row, coefficients in self.floors[f].items() if v else ():
                    weights[row] = [w + v * c for w, c in zip(weights[row], coefficients, strict=True)]
            more = [
                list(dict.fromkeys([*c, *(twins[u] for u, v in enumerate(row) if v > max(row[w] for w in c))]))
                for row, c, twins in zip(weights, chosen, self._twins, strict=True)
            ]
            if more == chosen:
                return None  # (y shows no table over any decisions meets the floors)
            chosen = more
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


def _nearest(x: Fraction) -> float:
    """x to the nearest float, ±inf beyond the floats (it only chooses)."""
    return quotient_nearest(x.numerator, x.denominator)


def _dot(a: Row, b: Row) -> Fraction:
    return sum(map(operator.mul, a, b), Fraction(0))
