"""The black box over the model's table beyond the exact size: each program bounded by weak duality from the floors'
recorded multipliers or by its one-floor relaxation (solved outright where that decides), its lower end read off the
recorded table.

A program of :mod:`~fairaudit.verification.kernel_check` is max (p·K)/(q·K) over tables K whose rows (x̃, ã) are
distributions over the decisions, with floors F_f·K ≥ τ (one per live context and group):
:class:`~fairaudit.base.table_program.TableProgram`, whose :meth:`~fairaudit.base.table_program.TableProgram.dual_bound`
at the recorded ν bounds it by weak duality (``proofs/verification.md`` §4f).

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
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, NamedTuple

from fairaudit.base.table_program import TableProgram
from fairaudit.base.table_relaxation import relaxation_bounds
from fairaudit.verification.dual_check import without_duals
from fairaudit.verification.enclosures import INF
from fairaudit.verification.kernel_check import KernelSetting, kernel_global, kernel_local, reached_rows

__all__ = ["table_global", "table_local"]

Number = Fraction | float
Row = Sequence[Fraction]
Table = Sequence[Row]
Ends = tuple[Number, Number, bool]


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
    table is proved optimal (:meth:`TableProgram.proved_value`), then, with a recorded ν, at the bound ν gives
    (:meth:`TableProgram.dual_bound`): exact where the table ν points to is proved optimal
    (:meth:`TableProgram.pointed_value`), else solved by the rational simplex within its size, else bounded by ν;
    until no bound left exceeds the upper end found (a program whose ν bounds it by the largest value found is never
    solved). A recorded table gives a lower end. Without a ν, a bound within
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
    heap: list[tuple[Number, int, int]] = [(-entry.screen, i, 0) for i, entry in enumerate(cases)]
    heapq.heapify(heap)  # (−bound, position, stage: 0 its screen, 1 its case's bound, 2 its ν's): best first
    while heap and -heap[0][0] > high:
        key, i, stage = heapq.heappop(heap)
        case = case_of(i)
        if stage == 0:
            heapq.heappush(heap, (-case.bound, i, 1))
            continue
        taken = True
        value = attained.get(i)
        if stage == 2:  # (its ν's bound is above every value found: its value is needed)
            assert case.nu is not None  # (only a case with a ν is taken at its ν's bound)
            if (proved := case.program.pointed_value(case.nu)) is not None:
                low, high = max(low, proved), max(high, proved)  # (the table its ν points to, proved optimal)
            elif case.solve is not None and (solved := case.solve()) is not None:
                low, high = max(low, solved), max(high, solved)
            else:
                high, duals = max(high, -key), True
        elif case.exact or (value is not None and value >= case.bound):
            low, high = max(low, case.bound), max(high, case.bound)
        elif case.table is not None and (proved := case.program.proved_value(case.table)) is not None:
            low, high = max(low, proved), max(high, proved)  # (the recorded table, proved optimal exactly)
        elif case.nu is not None:  # (taken again at its ν's bound, set aside where that is at most the largest found)
            heapq.heappush(heap, (-min(case.bound, case.program.dual_bound(case.nu)), i, 2))
        elif case.solve is not None and (solved := case.solve()) is not None:
            low, high = max(low, solved), max(high, solved)
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


def _floored(s: KernelSetting, keys: Sequence[tuple[int, int]], xs: Sequence[int]) -> TableProgram:
    """The floors E[g | x, c] ≥ τ for each context x of ``xs`` and each group c, in that order, over the rows
    ``keys``, as a program with the ratio 0/0 whose :meth:`~TableProgram.with_ratio` gives each pair's."""
    zeros = _dense({}, len(keys), len(s.g[0][0]))
    return TableProgram(zeros, zeros, [_form(s, keys, {x: Fraction(1)}, c) for x in xs for c in range(s.k)], s.tau)


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
    shared: dict[int, tuple[list[tuple[int, int]], TableProgram]] = {}  # rows, and their floors (a ratio of 0s)
    for i in range(len(s.live)) if at is None else [at[0]]:
        x = s.live[i]
        key = x if own else -1
        if key not in shared:
            keys = reached_rows(s, [x] if own else s.live)
            shared[key] = keys, _floored(s, keys, [x] if own else s.live)
        keys, floored = shared[key]
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
            program = floored.with_ratio(forms[a], forms[b])
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
    floored = _floored(s, keys, s.live)
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
        program = floored.with_ratio(forms[a], forms[b])
        build = functools.partial(_case, program, kept[b], nu, table, solve)
        out.append(_Lazy(screens.get((a, b), INF), build, table is not None))
    return _largest(out, Fraction(1), loose)
