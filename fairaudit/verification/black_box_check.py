"""The black-box worst case re-derived from the certificate's proofs: the largest L and L̄ over every decision model
behind the filter. Nothing is solved here.

Every program is over the model's table K[x̃, ã, u] = P(u | x̃, ã), each row (x̃, ã) a distribution over the
decisions. E[g | x, a] = Σ_{x̃, ã, u} M_X[x, x̃] M_A[a, ã] K[x̃, ã, u] g(u, x, a) is linear in K, and so is
E[g | a] = Σ_x P(x | a) E[g | x, a]; the floors E[g | x, a] ≥ τ hold in every live context and for every group. So

* L = max over live x and a ≠ a' of max E[g | x, a]/E[g | x, a'] over the tables that meet the floors;
* L̄ = max over a ≠ a' with P(A = a), P(A = a') > 0 of max E[g | a]/E[g | a'] over the same tables.

The module reads, in this order: weak duality over the table (:class:`TableProgram`); the proofs and witnesses a
certificate records for its black box (``bound_details.black_box``, :class:`Evidence`); the programs' data at each end
of e^ε (:class:`KernelSetting`); each program bounded from its recorded proof, its lower end read off the recorded
table (:func:`table_local`, :func:`table_global`); and the worst cases (:func:`black_box_enclosures`,
:func:`pair_enclosure`).

Weak duality over the table is :mod:`~fairaudit.verification.table_program`; the recorded proofs are read by
:mod:`~fairaudit.verification.evidence`.

**The ends of e^ε.** With M_X the identity, L at x involves only the rows of x. Randomized response's rows hold e^ε,
irrational: its worst case is non-decreasing in e^ε (randomized response at a smaller ε is the one at a larger ε
followed by more randomized response, so its models are among the larger one's), and the programs are bounded at
the two rational ends of e^ε, which enclose it. Behind randomized response on the group, the identity on the context
and a utility free of the group, every pair of groups is alike, and the programs of one pair over three cells stand
for every pair (:func:`three_cell_settings`; for L̄ when P(x | a) is the same for every group present).
``proofs/verification.md`` §4, §4d, §4f.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from fractions import Fraction
from typing import Any, NamedTuple

import numpy as np

from fairaudit.verification.enclosures import (
    INF,
    Enclosure,
    RecordedMechanism,
    exact,
    group_free,
    integers,
    recorded_array,
    rr_matrix,
)
from fairaudit.verification.evidence import Evidence
from fairaudit.verification.table_program import Number, Table, TableProgram

__all__ = ["KernelSetting", "black_box_enclosures", "pair_enclosure"]

Rows = tuple[tuple[Fraction, ...], ...]
Ends = tuple[Number, Number, bool]


@dataclass(frozen=True)
class KernelSetting:
    """The data of the programs at one end of e^ε: M_A's and M_X's rows, g, τ and the population.

    Attributes
    ----------
    sensitive : tuple of tuple of Fraction, shape (n_groups, n_released_groups)
        M_A[a, ã] = P(ã | a), each row summing to 1.
    context : tuple of tuple of Fraction, shape (n_contexts, n_released_contexts), or None
        M_X[x, x̃]; None for the identity.
    g : nested list of Fraction, indexed ``[x][a][u]``, shape (n_contexts, n_groups, n_decisions)
        The utility g(u, x, a) ≥ 0.
    tau : Fraction or None
        The floor E[g | x, a] ≥ τ in every live context and for every group; None for no floor.
    live : list of int
        The contexts with P(X = x) > 0, ascending.
    weights : nested list of Fraction, indexed ``[live x][a]``
        P(x | a) over the live contexts (0 for a group absent from the population), as
        :func:`black_box_enclosures`' setting has it.
    present : list of int
        The groups with P(A = a) > 0, ascending.
    group_free : bool
        Whether g(u, x, a) is the same for every group (then L ≤ ε holds as well).
    evidence : Evidence
        The certificate's recorded proofs and witness tables.
    cells : bool
        Randomized response's three cells (:func:`three_cell_settings`): the pair (0, 1) stands for every pair.
    """

    sensitive: Rows  # M_A, (n_groups, n_released_groups)
    context: Rows | None  # M_X, (n_contexts, n_released_contexts); None: the identity
    g: list[list[list[Fraction]]]  # g(u, x, a) as [x][a][u]
    tau: Fraction | None
    live: list[int]
    weights: list[list[Fraction]]
    present: list[int]
    group_free: bool
    evidence: Evidence = field(default_factory=Evidence)
    cells: bool = False

    @property
    def k(self) -> int:
        return len(self.sensitive)

    def case(
        self, key: tuple[int, ...], program: TableProgram, kept: Fraction | None, keys: Sequence[tuple[int, int]]
    ) -> _Case:
        """``program`` (of ``key``: (x, a, b) for L's, (a, b) for L̄'s; over the rows ``keys``) with what the
        certificate records for it: the floors' ν (per context and group, flattened, but for L's program of one
        context behind the identity), θ, and the table (:func:`_table`)."""
        own = len(key) == 3 and self.context is None  # (L's program at one context behind the identity)
        nu, point = self.evidence.nu.get(key), self.evidence.points.get(key)
        flat = nu if nu is None or own else [nu[x][c] for x in self.live for c in range(self.k)]
        table = None if point is None else _table(self, point, keys, own)
        return _Case(program, flat, self.evidence.theta.get(key), kept, table)


def kernel_settings(
    inputs: Mapping[str, Any],
    sensitive: RecordedMechanism,
    context: RecordedMechanism,
    evidence: Evidence | None = None,
) -> list[KernelSetting]:
    """The programs' data at each end of the mechanisms' e^ε.

    Parameters
    ----------
    inputs : mapping
        A certificate's ``inputs``: its ``utility`` (``values``, an (n_decisions,) list or an (n_contexts, n_groups,
        n_decisions) nested list, and ``tau``) and ``population`` (``probabilities``, (n_contexts, n_groups)) are read.
    sensitive, context : RecordedMechanism
        M_A and M_X as recorded (randomized response, a matrix, or the identity for the context).
    evidence : Evidence, optional
        The certificate's recorded multipliers and witness tables (default none).

    Returns
    -------
    list of KernelSetting
        One setting when neither mechanism is randomized response; else two, at the lower and the upper rational end
        of its e^ε (the worst case is non-decreasing in e^ε, so the two bound it; beyond ε = 10^6 the upper end is the
        identity).

    Raises
    ------
    InputError
        Naming the field of a recorded number that is not a finite number or ``"inf"``.

    Notes
    -----
    ``proofs/verification.md`` §4d.

    Examples
    --------
    Keep 3/4 on two groups, one context, g(yes, a) = 1, g(yes, b) = 1/2, g(no, ·) = 0:

    >>> keep = {"inputs": ["a", "b"], "outputs": ["a", "b"], "kind": "matrix", "matrix": [[0.75, 0.25], [0.25, 0.75]]}
    >>> same = {"inputs": ["x"], "outputs": ["x"], "kind": "identity"}
    >>> inputs = {"utility": {"values": [[[1.0, 0.0], [0.5, 0.0]]], "tau": None},
    ...           "population": {"probabilities": [[0.5, 0.5]]}}
    >>> m_a = RecordedMechanism.from_record(keep, "sensitive_mechanism")
    >>> m_x = RecordedMechanism.from_record(same, "context_mechanism")
    >>> [s] = kernel_settings(inputs, m_a, m_x)
    >>> s.sensitive[0], s.context, s.group_free
    ((Fraction(3, 4), Fraction(1, 4)), None, False)
    """
    exact_rows = sensitive.kind != "randomized_response" and context.kind != "randomized_response"
    return [
        KernelSetting(
            _rows(sensitive, end), None if context.kind == "identity" else _rows(context, end),
            *population(inputs, sensitive.k), evidence or Evidence(),
        )
        for end in ((0,) if exact_rows else (0, 1))
    ]  # fmt: skip


def three_cell_settings(
    inputs: Mapping[str, Any],
    sensitive: RecordedMechanism,
    evidence: Evidence,
    pair: tuple[int, int],
) -> list[KernelSetting]:
    """Randomized response's programs for the ordered pair ``pair`` = (a, a') over three cells, at each end of e^ε:
    the released groups a, a' and one for the k − 2 others, behind the identity on the context, for a utility free
    of the group (two cells for k = 2).

    Every pair of groups is alike behind randomized response, and averaging a table over the permutations of the
    other groups keeps it feasible and keeps E[g | x, a]/E[g | x, a'] and E[g | a]/E[g | a'] where P(x | ·) is the
    same for every group: at an optimum the k − 2 others' rows may be taken equal, one row standing for all of
    them. Its coefficients are k − 2 times one other's, and one floor (every other group's, equal) stands for the
    k − 2 others' (``proofs/verification.md`` §4). The recorded evidence of ``pair`` is carried over: its
    multipliers with the others' summed (weak duality of the reduced program at that ν is at most the full one's
    at the multipliers averaged over the others, by convexity), its witness with the others' values averaged.

    Returns
    -------
    list of KernelSetting
        Two, at the lower and upper rational end of e^ε, with ``sensitive`` the reduced rows (3 × 3, or 2 × 2),
        groups (0, 1) the pair, and the weights of a and a' (and their mean for the others' cell).
    """
    k, (a, b) = sensitive.k, pair
    g, tau, live, weights, _, group_free = population(inputs, k)
    others = [c for c in range(k) if c not in pair]
    n = 3 if others else 2

    def cells(v: Sequence[Fraction]) -> list[Fraction]:
        return [v[a], v[b], sum((v[c] for c in others), Fraction(0))][:n]

    def mean(v: Sequence[Any]) -> list[Any]:
        return [v[a], v[b], sum((v[c] for c in others), Fraction(0)) / len(others)][:n] if others else [v[a], v[b]]

    def moved(found: Mapping[tuple[int, ...], Any], by: Any) -> dict[tuple[int, ...], Any]:
        """``pair``'s records onto the cells' pair (0, 1): ``by`` of L's, of each context's row of L-bar's."""
        return {key[:-2] + (0, 1): by(v) if len(key) == 3 else [by(row) for row in v]
                for key, v in found.items() if key[-2:] == pair}  # fmt: skip

    theta = {key[:-2] + (0, 1): t for key, t in evidence.theta.items() if key[-2:] == pair}
    ev = Evidence(moved(evidence.nu, cells), theta, moved(evidence.points, mean))
    reduced, w, out = [[row[0]] * n for row in g], [mean(row) for row in weights], []
    for p, q in sensitive.rr_ends():
        o = q * len(others)
        rows = ((p, q, o), (q, p, o), (q, q, p + q * (len(others) - 1))) if others else ((p, q), (q, p))
        out.append(KernelSetting(rows, None, reduced, tau, live, w, list(range(n)), group_free, ev, True))
    return out


def population(
    inputs: Mapping[str, Any], k: int
) -> tuple[list[list[list[Fraction]]], Fraction | None, list[int], list[list[Fraction]], list[int], bool]:
    """The recorded utility and population, exactly, in :class:`KernelSetting`'s order.

    Parameters
    ----------
    inputs : mapping
        A certificate's ``inputs``: its ``utility`` (``values``, ``tau``) and ``population`` are read.
    k : int
        The number of groups.

    Returns
    -------
    tuple
        g indexed ``[x][a][u]``, τ (None for no floor), the live contexts (P(X = x) > 0), P(x | a) indexed
        ``[live x][a]`` (0 for a group absent), the groups present (P(A = a) > 0) and whether g is free of the group
        (``proofs/verification.md`` §4d).

    Examples
    --------
    >>> inputs = {"utility": {"values": [1.0, 0.0], "tau": None}, "population": {"probabilities": [[0.5, 0.0]]}}
    >>> g, tau, live, weights, present, group_free = population(inputs, 2)
    >>> live, weights, present, group_free
    ([0], [[Fraction(1, 1), Fraction(0, 1)]], [0], True)
    """
    u = inputs["utility"]
    pop = recorded_array(inputs["population"]["probabilities"], "inputs.population.probabilities")
    values = recorded_array(u["values"], "inputs.utility.values")
    n_x = len(pop)
    g = values if isinstance(values[0], list) else [[list(values)] * k] * n_x
    live = [x for x in range(n_x) if sum(pop[x]) > 0]
    mass = [sum(pop[x][a] for x in live) for a in range(k)]
    weights = [[pop[x][a] / mass[a] if mass[a] else Fraction(0) for a in range(k)] for x in live]
    present = [a for a in range(k) if mass[a]]
    tau = None if u["tau"] is None else Fraction(exact(u["tau"], "inputs.utility.tau"))
    group_free = all(g[x][a] == g[x][0] for x in range(n_x) for a in range(k))
    return g, tau, live, weights, present, group_free


def _rows(m: RecordedMechanism, end: int) -> Rows:
    """A mechanism's exact rows; randomized response's at the lower (``end`` 0) or upper (1) end of its e^ε."""
    rows = m.matrix_rows()  # (randomized response's: the identity's at ε = +inf, and as the upper end beyond 10^6)
    return rows if rows is not None else rr_matrix((m.t().lo, m.t().hi)[end], m.k)


def reached_rows(s: KernelSetting, contexts: Sequence[int]) -> list[tuple[int, int]]:
    """The rows (x̃, ã) of K that ``contexts`` reach, in order: released contexts M_X[x, x̃] > 0 for one of them
    (x̃ = x for the identity), released groups M_A[a, ã] > 0 for some group; the other rows enter no program.

    Parameters
    ----------
    s : KernelSetting
        The programs' data.
    contexts : sequence of int
        True contexts (population positions).

    Returns
    -------
    list of (int, int)
        (released context, released group) pairs, released context major (``proofs/verification.md`` §4d).

    Examples
    --------
    >>> from fractions import Fraction as F
    >>> s = KernelSetting(((F(1), F(0)), (F(1), F(0))), None, [[[F(1), F(0)]] * 2] * 2, None, [0, 1],
    ...                   [[F(1, 2)] * 2] * 2, [0, 1], True)
    >>> reached_rows(s, [1])    # the second released group is reached by no group
    [(1, 0)]
    """
    reached = [c for c in range(len(s.sensitive[0])) if any(r[c] for r in s.sensitive)]  # (the others' rows are free)
    if s.context is None:
        released_contexts = list(contexts)
    else:
        released_contexts = [c for c in range(len(s.context[0])) if any(s.context[x][c] for x in contexts)]
    return [(xr, ar) for xr in released_contexts for ar in reached]


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
    for bound, case in sorted(zip(thetas, cases), key=lambda theta_case: -theta_case[0]):
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


def _mixed(g: Sequence[Fraction], value: Fraction) -> list[Fraction]:
    """The distribution over the decisions on g's largest and least values (the first of each) whose mean is the
    value, clipped to [min g, max g]."""
    high, low = max(range(len(g)), key=lambda u: g[u]), min(range(len(g)), key=lambda u: g[u])
    spread = g[high] - g[low]
    share = min(Fraction(1), max(Fraction(0), (value - g[low]) / spread)) if spread else Fraction(1)
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
    The setting of :func:`kernel_settings`' example: 6, exactly, the floors not binding.

    >>> from fractions import Fraction as F
    >>> s = KernelSetting(((F(3, 4), F(1, 4)), (F(1, 4), F(3, 4))), None, [[[F(1), F(0)], [F(1, 2), F(0)]]],
    ...                   None, [0], [[F(1), F(1)]], [0, 1], False)
    >>> table_local(s)
    (Fraction(6, 1), Fraction(6, 1), False)
    """
    if s.cells and (at is None or at[1:] != (0, 1)):  # the pair (0, 1) stands for every pair, in each live context
        ends = [table_local(s, (i, 0, 1)) for i in (range(len(s.live)) if at is None else [at[0]])]
        return max(e[0] for e in ends), max(e[1] for e in ends), any(e[2] for e in ends)
    own = s.context is None  # (then a program per context)
    cases = []
    every = None if own else _per_context(s, reached_rows(s, s.live), s.live)  # (one polytope for every context)
    for i in range(len(s.live)) if at is None else [at[0]]:
        x = s.live[i]
        keys = reached_rows(s, [x] if own else s.live)
        forms, d = _per_context(s, keys, [x]) if every is None else every
        here = 0 if own else i
        floors = forms.reshape(-1, *forms.shape[2:])  # (every context's, and every group's)
        for a, b in itertools.permutations(range(s.k), 2) if at is None else [at[1:]]:
            program = TableProgram(forms[here, a], forms[here, b], floors, d, s.tau)
            cases.append(s.case((x, a, b), program, s.tau, keys))
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
    >>> s = KernelSetting(((F(3, 4), F(1, 4)), (F(1, 4), F(3, 4))), None, [[[F(1), F(0)], [F(1, 2), F(0)]]],
    ...                   F(1, 4), [0], [[F(1), F(1)]], [0, 1], False,
    ...                   Evidence(theta={(0, 1): F(2, 3)}, points={(0, 1): [[[F(1), F(0)], [F(1, 3), F(2, 3)]]]}))
    >>> table_global(s)
    (Fraction(10, 3), Fraction(10, 3), False)
    """
    if len(s.present) < 2:
        return Fraction(1), Fraction(1), False
    at = (0, 1) if s.cells else at  # (the pair (0, 1) of the three cells stands for every pair)
    keys = reached_rows(s, s.live)
    pairs = list(itertools.permutations(s.present, 2)) if at is None else [at]
    groups = sorted({a for pair in pairs for a in pair})
    per_context, d = _per_context(s, keys, s.live)
    (weights,), d_w = integers([s.weights])
    forms = {a: (per_context[:, a] * weights[:, a, None, None]).sum(axis=0) for a in groups}
    # E[g | a] = Σ_x P(x | a) E[g | x, a]: the numerator where a is first, the denominator where second
    kept = {b: None if s.tau is None else s.tau * sum((w[b] for w in s.weights), Fraction(0)) for b in groups}
    floors = per_context.reshape(-1, *per_context.shape[2:]) * d_w
    programs = {(a, b): TableProgram(forms[a], forms[b], floors, d * d_w, s.tau) for a, b in pairs}
    return _largest([s.case(pair, p, kept[pair[1]], keys) for pair, p in programs.items()], Fraction(1))


@dataclass(frozen=True)
class WorstCaseEnclosures:
    """The exact worst ratios (not their logarithms) of L and L̄, enclosed; None with a reason when not re-derived."""

    local: Enclosure | None
    global_: Enclosure | None
    reason: str
    independent: bool = False  # P(x | a) is the same for every group, exactly
    group_free: bool = True  # g does not depend on the group (then L ≤ ε(M_A), and L̄ ≤ ε(M_A) when independent)
    from_duals: bool = False  # an upper end rests on a recorded proof: its lower end is a recorded point's, if any


def black_box_enclosures(inputs: Mapping[str, Any], recorded: Mapping[str, Any] | None = None) -> WorstCaseEnclosures:
    """The worst ratios behind the recorded filter, for the recorded utility, τ and population, enclosed.

    Parameters
    ----------
    inputs : mapping
        A certificate's ``inputs`` (checked against the schema).
    recorded : mapping, optional
        Its ``bound_details.black_box``: the proofs (``duals``, ``screens``) and witness points
        (:class:`Evidence`).

    Returns
    -------
    WorstCaseEnclosures
        ``local`` and ``global_`` enclose max E[g | x, a]/E[g | x, a'] and max E[g | a]/E[g | a'] over every model
        (+inf when unbounded): the upper end the least bound the recorded proofs give (a program without one: its
        bound without floors; nothing is solved), the lower end the largest ratio a
        recorded or proved table attains (``from_duals`` where the two differ). None, with ``reason``, for a
        single group. L̄ compares the groups with P(A = a) > 0 only (1, L̄ = 0, with fewer than two).

    Raises
    ------
    CertificateError
        Naming the field of ``inputs`` that holds a value that is not a number (``inputs.utility.values[2]``), or the
        field of ``recorded`` whose label or shape is not the inputs'.

    Notes
    -----
    ``proofs/verification.md`` §4 (the reductions), §4f (the proofs).
    """
    settings = _settings(inputs, Evidence.from_record(recorded, inputs))
    if isinstance(settings, str):
        return WorstCaseEnclosures(None, None, settings)
    local, global_ = [table_local(p[0]) for p in settings], [table_global(p[1]) for p in settings]
    duals = any(end[2] for end in local + global_)
    s = settings[0][1]  # (independent: P(x | a) the same for every group present, exactly)
    alike = s.cells or all(w[a] == w[s.present[0]] for w in s.weights for a in s.present)
    return WorstCaseEnclosures(_span(local), _span(global_), "", alike, s.group_free, duals)


def pair_enclosure(
    inputs: Mapping[str, Any],
    recorded: Mapping[str, Any] | None,
    group: Any,
    other_group: Any,
    context: Any = None,
) -> tuple[Enclosure | None, bool]:
    """The exact worst ratio of one named pair: L's at ``context``, or L̄'s (``context`` None), enclosed as in
    :func:`black_box_enclosures`; None where a label is not the inputs' (or the context has P(X = x) = 0, or a
    group P(A = a) = 0 for L̄).

    The maximiser a certificate names holds when its pair's program reaches the recorded value (``verify``, within
    the search's 1e-8): a pair that is not a maximiser fails (``proofs/verification.md`` §4, §4c).

    Parameters
    ----------
    inputs : mapping
        A certificate's ``inputs`` (checked against the schema).
    recorded : mapping or None
        The certificate's ``bound_details.black_box`` (:func:`black_box_enclosures`).
    group, other_group : label
        Two distinct groups of ``inputs.population.groups``: the ratio is E[g | group] over E[g | other_group].
    context : label, optional
        A context of ``inputs.population.contexts``: the local worst case's there; None for L̄'s.

    Returns
    -------
    (Enclosure or None, bool)
        The pair's worst ratio (not its logarithm; +inf when unbounded), and whether its upper end is a recorded
        proof's (``from_duals``: then only the lower end, a recorded point's ratio, shows what the pair attains).

    Examples
    --------
    Binary randomized response keeping 3/4, as its matrix, g = 1{yes}: the worst model's ratio is 3 for either pair.

    >>> m = {"inputs": ["a", "b"], "outputs": ["a", "b"], "kind": "matrix", "matrix": [[0.75, 0.25], [0.25, 0.75]]}
    >>> inputs = {"sensitive_mechanism": m, "context_mechanism": {"inputs": ["x"], "outputs": ["x"], "kind": "identity"},
    ...           "utility": {"values": [1.0, 0.0], "tau": None},
    ...           "population": {"contexts": ["x"], "groups": ["a", "b"], "probabilities": [[0.5, 0.5]]}}
    >>> pair_enclosure(inputs, None, "b", "a", "x"), pair_enclosure(inputs, None, "b", "a")
    ((Enclosure(lo=Fraction(3, 1), hi=Fraction(3, 1)), False), (Enclosure(lo=Fraction(3, 1), hi=Fraction(3, 1)), False))
    >>> pair_enclosure(inputs, None, "b", "a", "y")    # not a context of the inputs
    (None, False)
    """
    settings = _settings(inputs, Evidence.from_record(recorded, inputs))
    pop = inputs["population"]
    contexts, groups = list(pop["contexts"]), list(pop["groups"])
    if isinstance(settings, str) or group not in groups or other_group not in groups or group == other_group:
        return None, False
    a, b = groups.index(group), groups.index(other_group)
    if context is None:
        present = {a, b} <= set(population(inputs, len(groups))[4])
        ends = [table_global(p[1], (a, b)) for p in settings] if present else None
    else:
        live = settings[0][0].live
        i = live.index(contexts.index(context)) if context in contexts and contexts.index(context) in live else None
        ends = None if i is None else [table_local(p[0], (i, a, b)) for p in settings]
    return _span(ends), any(e[2] for e in ends or [])


def _span(ends: list[Ends] | None) -> Enclosure | None:
    """The enclosure from the lower end at the first setting (e^ε's lower end) to the upper end at the last."""
    return None if ends is None else Enclosure(ends[0][0], ends[-1][1])


def _settings(inputs: Mapping[str, Any], evidence: Evidence) -> list[tuple[KernelSetting, KernelSetting]] | str:
    """L's and L̄'s programs' data at each end of e^ε (one for exact rows), or why the black box is not re-derived."""
    m = RecordedMechanism.from_record(inputs["sensitive_mechanism"], "inputs.sensitive_mechanism")
    context = RecordedMechanism.from_record(inputs["context_mechanism"], "inputs.context_mechanism")
    if m.k < 2:
        return "a single group: no pair of groups to compare"
    free = group_free(inputs["utility"]["values"])
    rr = m.kind == "randomized_response" and m.t().lo != INF  # (at ε = inf, the identity's rows)
    if not (rr and context.kind == "identity" and free):
        return [(s, s) for s in kernel_settings(inputs, m, context, evidence)]
    local = three_cell_settings(inputs, m, evidence, (0, 1))
    _, _, _, weights, present, _ = population(inputs, m.k)
    if len(present) < 2:  # (L-bar = 0)
        return [(s, replace(s, present=present)) for s in local]
    if not all(w[a] == w[present[0]] for w in weights for a in present):
        return list(zip(local, kernel_settings(inputs, m, context, evidence), strict=True))
    return list(zip(local, three_cell_settings(inputs, m, evidence, (present[0], present[1])), strict=True))
