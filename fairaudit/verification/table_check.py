"""The black box over the model's table: each program bounded by weak duality from the proof its certificate
records (:mod:`~fairaudit.verification.table_duality`), its lower end read off the recorded table.

A program of :mod:`~fairaudit.verification.kernel_check` is max (p·K)/(q·K) over tables K whose rows (x̃, ã) are
distributions over the decisions, with floors F_f·K ≥ τ (one per live context and group). Its upper end is the bound
of the proof recorded for it: the floors' multipliers ν (``bound_details.black_box.duals``), the one-floor threshold
θ (``bound_details.black_box.screens``), the smaller of the two where both are, or, with neither, the bound of the
table without its floors. Nothing is solved: a program whose recorded proof does not reach the certified value shows
as an upper end above it, and that check fails. ``proofs/verification.md`` §4f.
"""

from __future__ import annotations

from collections.abc import Sequence
from fractions import Fraction
from typing import Any, NamedTuple

import numpy as np

from fairaudit.verification.enclosures import INF
from fairaudit.verification.kernel_check import KernelSetting, reached_rows
from fairaudit.verification.table_duality import TableProgram, integers

__all__ = ["table_global", "table_local"]

Number = Fraction | float
Row = Sequence[Fraction]
Table = Sequence[Row]
Ends = tuple[Number, Number, bool]


class _Case(NamedTuple):
    """One program with what its certificate records for it."""

    program: TableProgram
    nu: Sequence[Fraction] | None  # the floors' multipliers
    theta: Fraction | None  # the one-floor threshold, on the floor Q·K ≥ kept
    kept: Fraction | None
    table: Table | None  # the maximiser's table


def _largest(cases: Sequence[_Case], start: Number) -> Ends:
    """max of ``start`` and the programs' bounds (each the least its proofs give: θ, ν, and no multiplier, the latter
    two only where needed), enclosed: (lower end, upper end, whether they differ).

    The programs are taken in decreasing order of their θ bound (+inf without θ), and one whose θ bound is at most
    the largest bound found is passed over: it cannot raise it. The lower end is the largest ratio attained exactly:
    at a recorded table (meeting every floor, each row normalised to sum to 1 exactly), or at the table of the rows'
    maximisers where a bound is attained there (without floors, the bound itself); at least ``start``. Nothing is
    solved: what a certificate's proofs do not prove fails, and a lower end no recorded table reaches is left lower."""
    thetas = [case.program.theta_bound(case.theta, case.kept) if case.theta is not None and case.kept else INF
              for case in cases]  # fmt: skip
    low = high = start
    for i in sorted(range(len(cases)), key=lambda i: -thetas[i]):
        case, bound = cases[i], thetas[i]
        if bound <= high and bound != INF:
            continue
        reached: Number = Fraction(0)  # (the largest ratio this program is shown to attain)
        for nu in (case.nu, None) if case.nu is not None else (None,):
            if bound > high:
                proved, attained = case.program.dual_bound(nu)
                bound = min(bound, proved)
                reached = reached if attained is None else max(reached, attained)
        low = max(low, reached)
        high = max(high, bound)
        if case.table is not None and (ratio := case.program.point_ratio(_normalised(case.table))) is not None:
            low = max(low, ratio)
    return min(low, high), high, low < high


def _normalised(table: Table) -> list[list[Fraction]]:
    """Each row divided by its exact sum (a recorded row of floats may sum to 1 only to rounding)."""
    return [[v / total for v in row] if (total := sum(row, Fraction(0))) > 0 else list(row) for row in table]


def _per_context(s: KernelSetting, keys: Sequence[tuple[int, int]], xs: Sequence[int]) -> tuple[np.ndarray, int]:
    """E[g | x, c] over the rows ``keys`` (x̃, ã) for each context x of ``xs`` and each group c, as integers over one
    denominator, shape (len(xs), groups, rows, decisions): the coefficient of K[x̃, ã, u] is
    M_X[x, x̃] M_A[c, ã] g(u, x, c) (L's forms, and the floors E[g | x, c] ≥ τ)."""
    (m_a,), d_a = integers([s.sensitive])
    g, d_g = integers([s.g[x] for x in xs])
    if s.context is None:
        m_x, d_x = np.array([[int(xr == x) for xr, _ in keys] for x in xs], dtype=object), 1
    else:
        (m_x,), d_x = integers([[s.context[x] for x in xs]])
        m_x = m_x[:, [xr for xr, _ in keys]]
    coefficients = m_x[:, None, :] * m_a[:, [ar for _, ar in keys]][None, :, :]
    return coefficients[..., None] * g[:, :, None, :], d_a * d_g * d_x


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


def table_local(s: KernelSetting, at: tuple[int, int, int] | None = None) -> Ends:
    """L's worst ratio over the model's table, enclosed from the certificate's proofs: (lower end, upper end, whether
    they differ).

    With M_X the identity, L at x is over the rows of x with the floors of x; otherwise over every row reached with
    every live context's floors (they bind the same rows), its ν recorded per context.

    Parameters
    ----------
    s : KernelSetting
        The programs' data at one end of e^ε, with the certificate's evidence.
    at : (int, int, int), optional
        (index into ``s.live``, a, a'): that program only.

    Returns
    -------
    (Fraction or float, Fraction or float, bool)
        The lower and upper ends of e^L (a ratio, dimensionless; L in nats is its log; +inf when a table gives
        c/0 with c > 0), and whether they differ (the lower end is then a recorded table's ratio, or 0).

    Notes
    -----
    ``proofs/verification.md`` §4f.

    Examples
    --------
    The module's setting (``kernel_check.kernel_local``'s example): 6, exactly, the floors not binding.

    >>> from fractions import Fraction as F
    >>> s = KernelSetting(((F(3, 4), F(1, 4)), (F(1, 4), F(3, 4))), None, [[[F(1), F(0)], [F(1, 2), F(0)]]],
    ...                   None, [0], [[F(1), F(1)]], [0, 1], False)
    >>> table_local(s)
    (Fraction(6, 1), Fraction(6, 1), False)
    """
    own = s.context is None  # (then a program per context)
    evidence = s.evidence
    cases = []
    every = None if own else _per_context(s, reached_rows(s, s.live), s.live)  # (one polytope for every context)
    for i in range(len(s.live)) if at is None else [at[0]]:
        x = s.live[i]
        keys = reached_rows(s, [x] if own else s.live)
        forms, d = _per_context(s, keys, [x]) if every is None else every
        here = 0 if own else i
        floors = forms.reshape(-1, *forms.shape[2:])  # (every context's, and every group's)
        pairs = [(a, b) for a in range(s.k) for b in range(s.k) if a != b] if at is None else [at[1:]]
        for a, b in pairs:
            recorded = evidence.local.get((x, a, b))
            nu = recorded if recorded is None or own else [recorded[y][c] for y in s.live for c in range(s.k)]
            point = evidence.local_point
            table = _table(s, point[3], keys, own) if point is not None and point[:3] == (x, a, b) else None
            program = TableProgram(forms[here, a], forms[here, b], floors, d, s.tau)
            cases.append(_Case(program, nu, evidence.local_theta.get((x, a, b)), s.tau, table))
    return _largest(cases, Fraction(0))


def table_global(s: KernelSetting, at: tuple[int, int] | None = None) -> Ends:
    """L̄'s worst ratio over the model's table, enclosed as in :func:`table_local` (every row reached,
    E[g | a] = Σ_x P(x | a) E[g | x, a], every live context's floors); 1 with fewer than two groups present.

    Parameters
    ----------
    s : KernelSetting
        The programs' data at one end of e^ε, with the certificate's evidence.
    at : (int, int), optional
        The ordered pair (a, a') of groups present: that program only.

    Returns
    -------
    (Fraction or float, Fraction or float, bool)
        The ends of e^L̄ and whether they differ, as :func:`table_local` (the lower end at least 1).

    Notes
    -----
    ``proofs/verification.md`` §4f.

    Examples
    --------
    With τ = 1/4 and θ = 2/3 recorded for the pair (0, 1), E[g | b] ≥ 1/4 its one floor proves 10/3; the recorded
    maximiser P(yes | ·) = (1, 1/3) attains it (no table of the rows' maximisers does); the pair (1, 0) needs no
    proof (its bound without floors is 1/6 < 1):

    >>> from fractions import Fraction as F
    >>> from fairaudit.verification.dual_check import Evidence
    >>> s = KernelSetting(((F(3, 4), F(1, 4)), (F(1, 4), F(3, 4))), None, [[[F(1), F(0)], [F(1, 2), F(0)]]],
    ...                   F(1, 4), [0], [[F(1), F(1)]], [0, 1], False,
    ...                   Evidence(global_point=(0, 1, [[[F(1), F(0)], [F(1, 3), F(2, 3)]]]), global_theta={(0, 1): F(2, 3)}))
    >>> table_global(s)
    (Fraction(10, 3), Fraction(10, 3), False)
    """
    if len(s.present) < 2:
        return Fraction(1), Fraction(1), False
    keys = reached_rows(s, s.live)
    pairs = [(a, b) for a in s.present for b in s.present if a != b] if at is None else [at]
    groups = sorted({a for pair in pairs for a in pair})
    per_context, d = _per_context(s, keys, s.live)
    (weights,), d_w = integers([s.weights])
    forms = {a: (per_context[:, a] * weights[:, a, None, None]).sum(axis=0) for a in groups}
    # E[g | a] = Σ_x P(x | a) E[g | x, a]: the numerator where a is first, the denominator where second
    kept = {b: None if s.tau is None else s.tau * sum((w[b] for w in s.weights), Fraction(0)) for b in groups}
    floors = per_context.reshape(-1, *per_context.shape[2:]) * d_w
    evidence = s.evidence
    cases = []
    for a, b in pairs:
        recorded = evidence.global_.get((a, b))
        nu = None if recorded is None else [recorded[x][c] for x in s.live for c in range(s.k)]
        point = evidence.global_point
        table = _table(s, point[2], keys, False) if point is not None and point[:2] == (a, b) else None
        program = TableProgram(forms[a], forms[b], floors, d * d_w, s.tau)
        cases.append(_Case(program, nu, evidence.global_theta.get((a, b)), kept[b], table))
    return _largest(cases, Fraction(1))
