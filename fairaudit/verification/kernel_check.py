"""The programs of the black box over the decision model's table itself: their data at each end of e^ε, for a
utility that depends on the group, or behind a context mechanism other than the identity (and, reduced to three
cells, behind randomized response): :class:`KernelSetting`.

The variables are the model's table K[x̃, ã, u] = P(u | x̃, ã), each row (x̃, ã) a distribution over the decisions.
E[g | x, a] = Σ_{x̃, ã, u} M_X[x, x̃] M_A[a, ã] K[x̃, ã, u] g(u, x, a) is linear in K, and so is
E[g | a] = Σ_x P(x | a) E[g | x, a]; the floors E[g | x, a] ≥ τ hold in every live context and for every group. So

* L = max over live x and a ≠ a' of max E[g | x, a]/E[g | x, a'] over the tables that meet the floors;
* L̄ = max over groups a ≠ a' with P(A = a), P(A = a') > 0 of max E[g | a]/E[g | a'] over the same tables.

Nothing here is solved: :mod:`~fairaudit.verification.table_check` bounds each program from the proof its certificate
records. With M_X the identity, L at x involves only the rows of x. Randomized response (on either attribute) is taken
at both 50-digit rational ends of its e^ε: the worst case is non-decreasing in e^ε, since randomized response at a
smaller ε is the one at a larger ε followed by more randomized response, so the models behind the smaller one are
among the larger one's. ``proofs/verification.md`` §4d.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

from fairaudit.verification.dual_check import Evidence
from fairaudit.verification.enclosures import RecordedMechanism, exact, recorded_array

__all__ = ["KernelSetting", "kernel_settings", "population", "reached_rows", "three_cell_settings"]

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
    evidence : Evidence
        The certificate's recorded proofs and witness tables.
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

    @property
    def k(self) -> int:
        return len(self.sensitive)


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
        out.append(KernelSetting(rows, None, reduced, tau, live, w, list(range(n)), group_free, ev))
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
    exact_rows = m.matrix_rows()
    if exact_rows is not None:
        return exact_rows
    p, q = m.rr_ends()[end]  # (the identity's (1, 0) at ε = +inf, and as the upper end beyond ε = 10^6)
    return tuple(tuple(p if i == j else q for j in range(m.k)) for i in range(m.k))


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
    ...                   [[F(1, 2)] * 2] * 2, [0, 1], True)
    >>> reached_rows(s, [1])    # the second released group is reached by no group
    [(1, 0)]
    """
    reached = _released_groups(s)
    if s.context is None:
        released_contexts = list(contexts)
    else:
        released_contexts = [c for c in range(len(s.context[0])) if any(s.context[x][c] for x in contexts)]
    return [(xr, ar) for xr in released_contexts for ar in reached]
