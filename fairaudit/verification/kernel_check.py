"""The black-box worst case over the decision model's table itself: for a utility that depends on the group, or behind
a context mechanism other than the identity, where :mod:`~fairaudit.verification.black_box_check`'s reduction to a box
does not hold.

The variables are the model's table K[x̃, ã, u] = P(u | x̃, ã), each row (x̃, ã) a distribution over the decisions.
E[g | x, a] = Σ_{x̃, ã, u} M_X[x, x̃] M_A[a, ã] K[x̃, ã, u] g(u, x, a) is linear in K, and so is
E[g | a] = Σ_x P(x | a) E[g | x, a]; the floors E[g | x, a] ≥ τ hold in every live context and for every group. So

* L = max over live x and a ≠ a' of max E[g | x, a]/E[g | x, a'] over the tables that meet the floors;
* L̄ = max over groups a ≠ a' with P(A = a), P(A = a') > 0 of max E[g | a]/E[g | a'] over the same tables.

A row's last decision is written as 1 minus the others (n_U − 1 variables in [0, 1], their sum at most 1), and one
variable s, fixed at 1, carries the constants, so each program is a linear-fractional program over a polytope, solved
exactly by :func:`~fairaudit.base.exact_programs.maximize_ratio`. With M_X the identity, L at x involves only the rows
of x (the floors of the other contexts bind other rows), and the rows of every live context are checked to meet their
floors by the programs of L. Randomized response (on either attribute) is solved at both 50-digit rational ends of
its e^ε: the worst case is non-decreasing in e^ε, since randomized response at a smaller ε is the one at a larger ε
followed by more randomized response, so the models behind the smaller one are among the larger one's. The ratio
conventions are the tool's: c/0 = +inf for c > 0 and 0/0 = 1. ``proofs/verification.md`` §4d.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

from fairaudit.base.exact_programs import Polytope, maximize_linear, maximize_ratio_over_product
from fairaudit.verification.dual_check import Evidence
from fairaudit.verification.enclosures import INF, RecordedMechanism, exact, recorded_array

__all__ = ["KernelSetting", "kernel_global", "kernel_local", "kernel_settings", "reached_rows", "three_cell_settings"]

Number = Fraction | float
Rows = tuple[tuple[Fraction, ...], ...]


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
        :mod:`~fairaudit.verification.black_box_check`'s setting has it.
    present : list of int
        The groups with P(A = a) > 0, ascending.
    group_free : bool
        Whether g(u, x, a) is the same for every group (then L ≤ ε holds as well).
    max_variables : int
        The largest program (variables, the constant s included) :func:`kernel_local` and :func:`kernel_global`
        solve; a larger one is bounded by :mod:`~fairaudit.verification.table_check`.
    evidence : Evidence
        The certificate's recorded multipliers and witness tables, for the programs beyond ``max_variables``.
    """

    sensitive: Rows  # M_A, (n_groups, n_released_groups)
    context: Rows | None  # M_X, (n_contexts, n_released_contexts); None: the identity
    g: list[list[list[Fraction]]]  # g(u, x, a) as [x][a][u]
    tau: Fraction | None
    live: list[int]
    weights: list[list[Fraction]]
    present: list[int]
    group_free: bool
    max_variables: int
    evidence: Evidence = field(default_factory=Evidence)

    @property
    def k(self) -> int:
        return len(self.sensitive)

    @functools.cached_property
    def small(self) -> bool:
        """Whether every program of L and L̄ has at most ``max_variables`` variables (with M_X the identity each
        context is a block of its own; otherwise every context's rows are one)."""
        contexts = [[x] for x in self.live] if self.context is None else [self.live]
        return max((len(reached_rows(self, c)) for c in contexts), default=0) * (len(self.g[0][0]) - 1) + 1 <= (
            self.max_variables
        )


def kernel_settings(
    inputs: Mapping[str, Any],
    sensitive: RecordedMechanism,
    context: RecordedMechanism,
    max_variables: int,
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
    max_variables : int
        The largest program solved exactly; beyond it the programs are bounded by
        :mod:`~fairaudit.verification.table_check`.
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
    >>> [s] = kernel_settings(inputs, m_a, m_x, 64)
    >>> s.sensitive[0], s.context, s.group_free
    ((Fraction(3, 4), Fraction(1, 4)), None, False)
    """
    exact_rows = sensitive.kind != "randomized_response" and context.kind != "randomized_response"
    return [
        KernelSetting(
            _rows(sensitive, end), None if context.kind == "identity" else _rows(context, end),
            *_population(inputs, sensitive.k), max_variables, evidence or Evidence(),
        )
        for end in ((0,) if exact_rows else (0, 1))
    ]  # fmt: skip


def three_cell_settings(
    inputs: Mapping[str, Any],
    sensitive: RecordedMechanism,
    max_variables: int,
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
    g, tau, live, weights, _, group_free = _population(inputs, k)
    others = [c for c in range(k) if c not in pair]
    n = 3 if others else 2

    def cells(v: Sequence[Fraction]) -> list[Fraction]:
        return [v[a], v[b], sum((v[c] for c in others), Fraction(0))][:n]

    def mean(v: Sequence[Any]) -> list[Any]:
        return [v[a], v[b], sum((v[c] for c in others), Fraction(0)) / len(others)][:n] if others else [v[a], v[b]]

    e = evidence
    ev = Evidence(
        {(x, 0, 1): cells(nu) for (x, i, j), nu in e.local.items() if (i, j) == pair},
        {(0, 1): [cells(row) for row in nu] for (i, j), nu in e.global_.items() if (i, j) == pair},
        None
        if e.local_point is None or e.local_point[1:3] != pair
        else (e.local_point[0], 0, 1, mean(e.local_point[3])),
        None if e.global_point is None or e.global_point[:2] != pair else (0, 1, [mean(h) for h in e.global_point[2]]),
        {(x, 0, 1): t for (x, i, j), t in e.local_theta.items() if (i, j) == pair},
        {(0, 1): t for ij, t in e.global_theta.items() if ij == pair},
    )
    out = []
    for p, q in sensitive.rr_ends():
        o = q * len(others)
        rows = ((p, q, o), (q, p, o), (q, q, p + q * (len(others) - 1))) if others else ((p, q), (q, p))
        reduced = [[g[x][0]] * n for x in range(len(g))]
        w = [mean(row) for row in weights]
        out.append(KernelSetting(rows, None, reduced, tau, live, w, list(range(n)), group_free, max_variables, ev))
    return out


def _population(
    inputs: Mapping[str, Any], k: int
) -> tuple[list[list[list[Fraction]]], Fraction | None, list[int], list[list[Fraction]], list[int], bool]:
    """The recorded utility and population, exactly, in :class:`KernelSetting`'s order: (g as [x][a][u], τ, the live
    contexts, P(x | a) as [live x][a], the groups present, whether g is free of the group)."""
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
    exact_rows = m.matrix_rows()
    if exact_rows is not None:
        return exact_rows
    p, q = m.rr_ends()[end]  # (the identity's (1, 0) at ε = +inf, and as the upper end beyond ε = 10^6)
    return tuple(tuple(p if i == j else q for j in range(m.k)) for i in range(m.k))


def kernel_local(s: KernelSetting, at: tuple[int, int, int] | None = None) -> Number:
    """The exact local worst case: max over tables meeting the floors of E[g | x, a]/E[g | x, a'].

    Parameters
    ----------
    s : KernelSetting
        The programs' data at one end of e^ε.
    at : (int, int, int), optional
        (index into ``s.live``, a, a'): that context and ordered pair only. Default: the maximum over every live
        context and ordered pair a ≠ a'.

    Returns
    -------
    Fraction or float
        The ratio e^L (dimensionless; L in nats is its log), exact; ``float("inf")`` when a table gives c/0 with
        c > 0. 0/0 counts as 1.

    Raises
    ------
    ValueError
        When no table meets the floors.

    Notes
    -----
    ``proofs/verification.md`` §4d.

    Examples
    --------
    The setting of :func:`kernel_settings`'s example: k = P(yes | ·) = (1, 0) gives (3/4)/((1/4)/2) = 6.

    >>> from fractions import Fraction as F
    >>> s = KernelSetting(((F(3, 4), F(1, 4)), (F(1, 4), F(3, 4))), None, [[[F(1), F(0)], [F(1, 2), F(0)]]],
    ...                   None, [0], [[F(1), F(1)]], [0, 1], False, 64)
    >>> kernel_local(s), kernel_local(s, at=(0, 1, 0))
    (Fraction(6, 1), Fraction(3, 2))
    """
    best: Number = Fraction(0)
    # with M_X the identity a context's programs depend on its utility table alone: one context per table
    contexts = (
        list({tuple(map(tuple, s.g[x])): i for i, x in reversed(list(enumerate(s.live)))}.values())
        if s.context is None
        else range(len(s.live))
    )
    cases = [(i, a, b) for i in contexts for a in range(s.k) for b in range(s.k) if a != b] if at is None else [at]
    programs: dict[int, _Polytope] = {}
    for i, a, b in cases:
        x = s.live[i]
        key = x if s.context is None else -1
        if key not in programs:
            programs[key] = _Polytope.of(s, [x] if s.context is None else s.live)
        poly = programs[key]
        top, bottom = poly.coefficients(s, {x: Fraction(1)}, a), poly.coefficients(s, {x: Fraction(1)}, b)
        best = max(best, _solve([poly], [top], [bottom]))
    return best


def kernel_global(s: KernelSetting, at: tuple[int, int] | None = None) -> Number | None:
    """The exact global worst case: max over tables meeting the floors of E[g | a]/E[g | a'].

    Contexts with the same M_X row (or, under the identity, the same utility table) and proportional P(x | a) are
    merged first; this is exact (``proofs/verification.md`` §4).

    Parameters
    ----------
    s : KernelSetting
        The programs' data at one end of e^ε.
    at : (int, int), optional
        The ordered pair (a, a') of groups present only. Default: the maximum over every ordered pair of groups
        present.

    Returns
    -------
    Fraction, float or None
        The ratio e^L̄, exact; ``float("inf")`` for c/0 with c > 0; 1 (L̄ = 0) with fewer than two groups present;
        None when a block exceeds ``s.max_variables`` variables: with M_X the identity each merged context is a
        block, solved apart (:func:`~fairaudit.base.exact_programs.maximize_ratio_over_product`); otherwise
        every context's rows are one block.

    Raises
    ------
    ValueError
        When no table meets the floors.

    Notes
    -----
    ``proofs/verification.md`` §4d.

    Examples
    --------
    One context, so L̄ is L: 6 (see :func:`kernel_local`).

    >>> from fractions import Fraction as F
    >>> s = KernelSetting(((F(3, 4), F(1, 4)), (F(1, 4), F(3, 4))), None, [[[F(1), F(0)], [F(1, 2), F(0)]]],
    ...                   None, [0], [[F(1), F(1)]], [0, 1], False, 64)
    >>> kernel_global(s)
    Fraction(6, 1)
    """
    if len(s.present) < 2:
        return Fraction(1)
    weights = _merged(s)
    contexts = list(weights)
    # with M_X the identity each context's rows and floors are its own: the program is over a product, a block per
    # context; otherwise one block over every context's rows
    blocks = [[x] for x in contexts] if s.context is None else [contexts]
    if not s.small:  # (the merged contexts are among the live ones: no block is larger than those of ``small``)
        return None
    polytopes = [_Polytope.of(s, b) for b in blocks]
    pairs = [(a, b) for a in s.present for b in s.present if a != b] if at is None else [at]
    best: Number = Fraction(1)
    for a, b in pairs:
        tops = [poly.coefficients(s, {x: weights[x][a] for x in block}, a) for poly, block in zip(polytopes, blocks)]
        bottoms = [poly.coefficients(s, {x: weights[x][b] for x in block}, b) for poly, block in zip(polytopes, blocks)]
        best = max(best, _solve(polytopes, tops, bottoms))
    return best


def _merged(s: KernelSetting) -> dict[int, list[Fraction]]:
    """P(x | a) over the live contexts for L̄ (context → its row over the groups); with M_X the identity, the contexts
    with the same g(·, x, ·) and P(x | a) proportional over the groups present merged into the first, their weights
    summed. Exact: their rows of K enter L̄ and the floors alike, so their weighted mean (a table meeting the same
    floors) gives the same E[g | a], and it is reached by giving every merged context that mean."""
    merged: dict[tuple[Any, ...], tuple[int, list[Fraction]]] = {}
    for i, x in enumerate(s.live):
        w = s.weights[i]
        total = sum(w[a] for a in s.present)
        shape = tuple(w[a] / total for a in s.present) if total and s.context is None else (x,)
        key = (tuple(tuple(row) for row in s.g[x]), shape)
        first, sums = merged.get(key, (x, [Fraction(0)] * len(w)))
        merged[key] = (first, [a + b for a, b in zip(sums, w, strict=True)])
    return dict(merged.values())


def _linear_form(
    s: KernelSetting, blocks: Sequence[tuple[int, int]], n_free: int, weight: Mapping[int, Fraction], a: int
) -> list[Fraction]:
    """Σ_x weight[x] E[g | x, a] as a linear form in the variables K[x̃, ã, u < last] of ``blocks``, then s."""
    out = [Fraction(0)] * (len(blocks) * n_free + 1)
    for x, w in weight.items():
        if not w:
            continue
        g = s.g[x][a]
        last = g[-1]
        for i, (xr, ar) in enumerate(blocks):
            m = w * s.sensitive[a][ar] * (Fraction(int(xr == x)) if s.context is None else s.context[x][xr])
            if not m:
                continue
            for u in range(n_free):
                out[i * n_free + u] += m * (g[u] - last)
            out[-1] += m * last
    return out


def _released_groups(s: KernelSetting) -> list[int]:
    """The released groups some group reaches (M_A[a, ã] > 0 for some a), ascending: the others' rows are free."""
    return [c for c in range(len(s.sensitive[0])) if any(r[c] for r in s.sensitive)]


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
    ...                   [[F(1, 2)] * 2] * 2, [0, 1], True, 64)
    >>> reached_rows(s, [1])    # the second released group is reached by no group
    [(1, 0)]
    """
    reached = _released_groups(s)
    if s.context is None:
        released_contexts = list(contexts)
    else:
        released_contexts = [c for c in range(len(s.context[0])) if any(s.context[x][c] for x in contexts)]
    return [(xr, ar) for xr in released_contexts for ar in reached]


@dataclass(frozen=True)
class _Polytope:
    """The tables' polytope over the rows (x̃, ã) that ``contexts`` reach, with their floors: the variables are
    K[x̃, ã, u] for u below the last decision, row by row, then s = 1."""

    blocks: list[tuple[int, int]]  # (x̃, ã)
    n_free: int  # n_U − 1 variables per row
    lower: list[Fraction]
    upper: list[Fraction]
    rows: list[list[Fraction]]
    bounds: list[Fraction]
    exact: Polytope  # phase 1 once: the pairs' programs start each from the last one's basis

    @classmethod
    def of(cls, s: KernelSetting, contexts: Sequence[int]) -> _Polytope:
        n_u = len(s.g[0][0])
        blocks = reached_rows(s, contexts)
        n = len(blocks) * (n_u - 1) + 1
        rows: list[list[Fraction]] = []
        for i in range(len(blocks) if n_u > 2 else 0):  # Σ_{u < last} K[x̃, ã, u] ≤ 1
            row = [Fraction(0)] * n
            row[i * (n_u - 1) : (i + 1) * (n_u - 1)] = [Fraction(1)] * (n_u - 1)
            rows.append(row)
        bounds = [Fraction(1)] * len(rows)
        lower, upper = [Fraction(0)] * (n - 1) + [Fraction(1)], [Fraction(1)] * n
        if s.tau:  # E[g | x, a] ≥ τ in every context of the program and for every group
            for x in contexts:
                for a in range(s.k):
                    rows.append([-v for v in _linear_form(s, blocks, n_u - 1, {x: Fraction(1)}, a)])
                    bounds.append(-s.tau)
        return cls(blocks, n_u - 1, lower, upper, rows, bounds, Polytope(lower, upper, rows, bounds, n))

    def coefficients(self, s: KernelSetting, weight: Mapping[int, Fraction], a: int) -> list[Fraction]:
        """Σ_x weight[x] E[g | x, a] as a linear form in the variables (the constants on s)."""
        return _linear_form(s, self.blocks, self.n_free, weight, a)


def _solve(polytopes: Sequence[_Polytope], p: Sequence[list[Fraction]], q: Sequence[list[Fraction]]) -> Number:
    """max (Σ_i p_i·h_i)/(Σ_i q_i·h_i) over the product of the polytopes, with c/0 = +inf and 0/0 = 1."""
    result = maximize_ratio_over_product([poly.exact for poly in polytopes], p, q)
    if result.status == "infeasible":
        raise ValueError("no decision model meets the floors")
    if result.status == "optimal":
        return result.value  # type: ignore[return-value]
    # q·h = 0 somewhere: each q_i·h_i ≥ 0 (E[g | ...] ≥ 0 on every table), so there each is 0; the ratio is +inf
    # where p·h > 0 there, and 0/0 = 1 otherwise
    top = Fraction(0)
    for poly, p_i, q_i in zip(polytopes, p, q, strict=True):
        found = maximize_linear(p_i, poly.lower, poly.upper, [*poly.rows, q_i], [*poly.bounds, Fraction(0)])
        if found.status != "optimal":  # (not reached: where q·h = 0 somewhere, each block has q_i·h_i = 0 there)
            return Fraction(1)
        top += found.value  # type: ignore[operator]
    return INF if top > 0 else Fraction(1)
