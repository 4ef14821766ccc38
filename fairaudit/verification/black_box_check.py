"""The black-box worst case re-derived exactly: the largest L and L̄ over every decision model behind the filter.

For a utility free of the group and the identity on the context (what ``worst_model`` certifies in closed form or by
its programs, ``proofs/black_box.md``), a model enters L only through h[x, ã] = Σ_u K[x, ã, u] g(u, x), which takes
every value in [min_u g(u, x), max_u g(u, x)]. So

* L = max over live x and a ≠ a' of max (M_A[a]·h)/(M_A[a']·h) over h in the box of x with the floors
  M_A[a'']·h ≥ τ for every group a'' (the other contexts' floors concern other variables);
* L̄ = max over a ≠ a' of max (Σ_x P(x | a) M_A[a]·h_x)/(Σ_x P(x | a') M_A[a']·h_x) over every context's box and
  floors.

Each is a small linear-fractional program with rational data, solved exactly
(:func:`~fairaudit.base.exact_programs.maximize_ratio`). Randomized response's rows hold e^ε, irrational:
its worst case is non-decreasing in e^ε (randomized response at a smaller ε is the one at a larger ε followed by
more randomized response, so its laws are among the larger one's), and the programs are solved at the two
50-digit rational ends of e^ε, which enclose it. Behind randomized response every pair of groups is alike
(averaging a solution over the permutations that fix a and a' keeps it feasible and keeps its ratio), so the
variables are h_a, h_a' and one h for the k − 2 others, and one pair is solved (for L̄ when P(x | a) is the same for
every group).
"""

from __future__ import annotations

import functools
import heapq
import math
import operator
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, NamedTuple

from fairaudit.base.exact_duality import on_one_denominator
from fairaudit.base.exact_programs import Polytope, maximize_ratio_over_product
from fairaudit.verification.dual_check import BlockProgram, Evidence, MissingDual, without_duals
from fairaudit.verification.enclosures import (
    INF,
    Enclosure,
    RecordedMechanism,
    exact,
    recorded_array,
)
from fairaudit.verification.kernel_check import KernelSetting, kernel_settings
from fairaudit.verification.screens import pair_screens
from fairaudit.verification.table_check import table_global, table_local

__all__ = [
    "MAX_GROUPS",
    "MAX_VARIABLES",
    "PairEnclosures",
    "WorstCaseEnclosures",
    "black_box_enclosures",
    "pair_enclosures",
]

MAX_VARIABLES = 64
"""The largest program (variables per block) solved exactly; a larger one is bounded from the dual point the
certificate records (:mod:`~fairaudit.verification.dual_check`), or the black box is listed as not re-derived."""

MAX_GROUPS = 32
"""The most floors (groups of a matrix mechanism) of a program solved exactly; beyond, as for :data:`MAX_VARIABLES`."""

MAX_FLOORS = 128
"""Beyond :data:`MAX_GROUPS`, a program of at most :data:`MAX_VARIABLES` variables and this many floors whose
certificate records no dual is still solved exactly: certify records none where its exact basis, not the rounded
duals, proves the value, or where its rational simplex solved the program, and the exact solve is then the proof."""

Number = Fraction | float


@dataclass(frozen=True)
class WorstCaseEnclosures:
    """The exact worst ratios (not their logarithms) of L and L̄, enclosed; None with a reason when not re-derived."""

    local: Enclosure | None
    global_: Enclosure | None
    reason: str
    independent: bool = False  # P(x | a) is the same for every group, exactly
    group_free: bool = True  # g does not depend on the group (then L ≤ ε(M_A), and L̄ ≤ ε(M_A) when independent)
    from_duals: bool = False  # an upper end rests on a recorded dual: its lower end is a recorded point's, if any


@dataclass(frozen=True)
class _Setting:
    """The data of the programs at one end of e^ε: the rows of M_A, the boxes, the floors, the population."""

    rows: tuple[tuple[Fraction, ...], ...] | None  # M_A's rows (a matrix); None: randomized response (p, q) below
    p: Fraction
    q: Fraction
    k: int
    low: list[Fraction]  # per live context
    high: list[Fraction]
    tau: Fraction | None
    weights: list[list[Fraction]]  # P(x | a), [live x][a]
    present: list[int]  # the groups with P(A = a) > 0
    live: list[int]  # the live contexts' positions in the population
    evidence: Evidence  # the certificate's duals and witness points (a matrix's programs beyond the exact size)


def _alike(weights: Sequence[Sequence[Fraction]], present: Sequence[int]) -> bool:
    """P(x | a) is the same for every group present (X and A independent among them), exactly."""
    return all(w[a] == w[present[0]] for w in weights for a in present)


def black_box_enclosures(inputs: Mapping[str, Any], recorded: Mapping[str, Any] | None = None) -> WorstCaseEnclosures:
    """The worst ratios behind the recorded filter, for the recorded utility, τ and population, enclosed.

    Parameters
    ----------
    inputs : mapping
        A certificate's ``inputs`` (checked against the schema).
    recorded : mapping, optional
        Its ``bound_details.black_box``: the dual points and the witness point that bound a matrix's programs
        beyond the exact size (:class:`~fairaudit.verification.dual_check.Evidence`).

    Returns
    -------
    WorstCaseEnclosures
        ``local`` and ``global_`` enclose max E[g | x, a]/E[g | x, a'] and max E[g | a]/E[g | a'] over every model
        (+inf when unbounded); None, with ``reason``, for what is not re-derived here: a single group, randomized
        response beyond ε = 10^6 (finite), programs larger than :data:`MAX_VARIABLES` (or with more than
        :data:`MAX_GROUPS` floors) whose bound needs a dual the certificate does not record, floors that
        no model meets exactly (τ at max g with rows that sum to just below 1 in binary). L̄ compares the groups with
        P(A = a) > 0 only (1, L̄ = 0, with fewer than two). Where a recorded dual bounds a program, the upper end is
        its bound and the lower end the ratio at the recorded witness point, when that point meets every constraint
        exactly (``from_duals``).

    Raises
    ------
    InputError
        Naming the field of ``inputs`` that holds a value that is not a number (``inputs.utility.values[2]``), or the
        field of ``recorded`` whose label or shape is not the inputs'.

    Notes
    -----
    The reduction, the monotonicity in e^ε and the three-variable programs: ``proofs/verification.md`` §4
    (from ``proofs/black_box.md`` §6); the programs are solved by
    :func:`~fairaudit.base.exact_programs.maximize_ratio` (Dinkelbach 1967), or bounded by weak duality (§4e).
    """
    settings = _settings(inputs, Evidence.from_record(recorded, inputs))
    if isinstance(settings, str):
        return WorstCaseEnclosures(None, None, settings)
    try:
        ends = [(_local(s), _global(s)) for s in settings]
    except MissingDual as exc:
        return WorstCaseEnclosures(None, None, str(exc))
    except ValueError as exc:  # floors above what the recorded rows reach exactly: no model meets tau
        return WorstCaseEnclosures(
            None, None, f"{exc}: no model meets E[g | x, a] >= tau with the recorded rows exactly"
        )
    local = Enclosure(ends[0][0][0], ends[-1][0][1])
    low_global, high_global = ends[0][1], ends[-1][1]
    global_ = None if low_global is None or high_global is None else Enclosure(low_global[0], high_global[1])
    why = "" if global_ is not None else f"L-bar: programs beyond {MAX_VARIABLES} variables without a recorded dual"
    independent = _alike(settings[0].weights, settings[0].present)
    group_free = not isinstance(settings[0], KernelSetting) or settings[0].group_free
    duals = any(end[2] for pair in ends for end in pair if end is not None)
    return WorstCaseEnclosures(local, global_, why, independent, group_free, duals)


class PairEnclosures(NamedTuple):
    """The worst ratios of one pair (:func:`pair_enclosures`): on L at its context, on L̄; ``from_duals`` when an
    upper end is a recorded dual's (or, without one, the relaxation's): then only the lower end, a recorded point's
    ratio, shows what the pair attains."""

    local: Enclosure | None
    global_: Enclosure | None
    from_duals: bool = False


def pair_enclosures(
    inputs: Mapping[str, Any],
    context: Any,
    group: Any,
    other_group: Any,
    recorded: Mapping[str, Any] | None = None,
    *,
    only: str | None = None,
) -> PairEnclosures:
    """The exact worst ratios of one named pair: L's at ``context`` and L̄'s, enclosed as in
    :func:`black_box_enclosures`; None where a label is not the inputs' (or the context has P(X = x) = 0, or the
    group P(A = a) = 0 for L̄), or where the black box is not re-derived.

    The maximiser a certificate names holds when its pair's program reaches the recorded value (``verify``, within
    the search's 1e-8): a pair that is not a maximiser fails. The programs are those of :func:`black_box_enclosures`
    for one (context, a, a') and one (a, a') (``proofs/verification.md`` §4, §4c).

    Parameters
    ----------
    inputs : mapping
        A certificate's ``inputs`` (checked against the schema).
    context : label
        A context of ``inputs.population.contexts`` (the local worst case's).
    group, other_group : label
        Two distinct groups of ``inputs.population.groups``: the ratio is E[g | group] over E[g | other_group].
    recorded : mapping, optional
        The certificate's ``bound_details.black_box`` (:func:`black_box_enclosures`).
    only : {"local", "global"}, optional
        Enclose that worst case only (the other is None): each program may take seconds to solve exactly.

    Returns
    -------
    PairEnclosures
        The pair's worst ratios (not logarithms) on L at ``context`` and on L̄; +inf when unbounded.

    Examples
    --------
    Binary randomized response keeping 3/4, as its matrix, g = 1{yes}: the worst model's ratio is 3 for either pair.

    >>> m = {"inputs": ["a", "b"], "outputs": ["a", "b"], "kind": "matrix", "matrix": [[0.75, 0.25], [0.25, 0.75]]}
    >>> inputs = {"sensitive_mechanism": m, "context_mechanism": {"inputs": ["x"], "outputs": ["x"], "kind": "identity"},
    ...           "utility": {"values": [1.0, 0.0], "tau": None},
    ...           "population": {"contexts": ["x"], "groups": ["a", "b"], "probabilities": [[0.5, 0.5]]}}
    >>> pair_enclosures(inputs, "x", "b", "a")
    PairEnclosures(local=Enclosure(lo=Fraction(3, 1), hi=Fraction(3, 1)), global_=Enclosure(lo=Fraction(3, 1), hi=Fraction(3, 1)), from_duals=False)
    >>> pair_enclosures(inputs, "y", "b", "a")[0] is None    # not a context of the inputs
    True
    """
    settings = _settings(inputs, Evidence.from_record(recorded, inputs))
    pop = inputs["population"]
    contexts, groups = list(pop["contexts"]), list(pop["groups"])
    if isinstance(settings, str) or group not in groups or other_group not in groups or group == other_group:
        return PairEnclosures(None, None)
    a, b = groups.index(group), groups.index(other_group)
    probabilities = recorded_array(pop["probabilities"], "inputs.population.probabilities")
    live = [x for x in range(len(probabilities)) if sum(probabilities[x]) > 0]
    i = live.index(contexts.index(context)) if context in contexts and contexts.index(context) in live else None
    try:
        local_ends = (
            None if i is None or only == "global" else [_local(s, (i, a, b), True) for s in (settings[0], settings[-1])]
        )
        present = a in settings[0].present and b in settings[0].present and only != "local"
        ends = [_global(s, (a, b), True) for s in (settings[0], settings[-1])] if present else [None, None]
    except ValueError:
        return PairEnclosures(None, None)
    local = None if local_ends is None else Enclosure(local_ends[0][0], local_ends[1][1])
    global_ = None if ends[0] is None or ends[1] is None else Enclosure(ends[0][0], ends[1][1])
    duals = any(e[2] for e in [*(local_ends or []), *ends] if e is not None)
    return PairEnclosures(local, global_, duals)


def _settings(inputs: Mapping[str, Any], evidence: Evidence) -> list[_Setting] | list[KernelSetting] | str:
    """The programs' data at each end of e^ε (one for a matrix), or why the black box is not re-derived."""
    m = RecordedMechanism.from_record(inputs["sensitive_mechanism"], "inputs.sensitive_mechanism")
    context = RecordedMechanism.from_record(inputs["context_mechanism"], "inputs.context_mechanism")
    u = inputs["utility"]
    if m.k < 2:
        return "a single group: no pair of groups to compare"
    values = recorded_array(u["values"], "inputs.utility.values")
    pop = recorded_array(inputs["population"]["probabilities"], "inputs.population.probabilities")
    live = [x for x in range(len(pop)) if sum(pop[x]) > 0]
    group_free = not isinstance(values[0], list) or all(
        values[x][a] == values[x][0] for x in range(len(values)) for a in range(len(values[x]))
    )
    # no privacy on the group (the identity, randomized response at ε = inf): its rows are the identity's
    if m.kind == "identity" or (m.kind == "randomized_response" and m.t().lo == INF):
        return kernel_settings(inputs, m, context, MAX_VARIABLES, evidence)
    if context.kind != "identity" or not group_free:  # no box: the programs over the model's table
        return kernel_settings(inputs, m, context, MAX_VARIABLES, evidence)
    if isinstance(values[0], list):  # g(u, x): its range per context
        low = [min(values[x][0]) for x in live]
        high = [max(values[x][0]) for x in live]
    else:
        low, high = [min(values)] * len(live), [max(values)] * len(live)
    tau = None if u["tau"] is None else exact(u["tau"], "inputs.utility.tau")
    mass = [sum(pop[x][a] for x in live) for a in range(m.k)]
    weights = [[pop[x][a] / mass[a] if mass[a] else Fraction(0) for a in range(m.k)] for x in live]
    present = [a for a in range(m.k) if mass[a]]  # L-bar compares only the groups with P(A = a) > 0
    ends = [(Fraction(0), Fraction(0))] if m.rows is not None else list(m.rr_ends())  # (a matrix: its rows)
    return [_Setting(m.rows, p, q, m.k, low, high, tau, weights, present, live, evidence)  # type: ignore[arg-type]
            for p, q in ends]  # fmt: skip


def _rows_of(s: _Setting, a: int, b: int) -> tuple[list[Fraction], list[Fraction], list[list[Fraction]], list[int]]:
    """(row of a, row of b, the floor rows, the multiplicities) over the program's cells for one context.

    Randomized response: three cells (a's own, b's own, the k − 2 others together, each of those at one h); a
    matrix: M_A's outputs.
    """
    if s.rows is not None:
        n = len(s.rows[0])
        return list(s.rows[a]), list(s.rows[b]), [list(r) for r in s.rows], [1] * n
    p, q, others = s.p, s.q, s.k - 2
    row_a, row_b = [p, q, q * others], [q, p, q * others]
    floors = [row_a, row_b] + ([[q, q, p + q * (others - 1)]] if others else [])
    return row_a, row_b, floors, [1, 1, max(others, 0)]


def _pairs(s: _Setting) -> list[tuple[int, int]]:
    """The pairs of groups solved: one behind randomized response, every ordered pair behind a matrix."""
    return [(0, 1)] if s.rows is None else [(a, b) for a in range(s.k) for b in range(s.k) if a != b]


def _local(s: _Setting | KernelSetting, at: tuple[int, int, int] | None = None, loose: bool = False) -> _Ends:
    """max over live contexts and pairs of the worst ratio, enclosed (exact, unless a recorded dual bounds a
    program); with ``at`` = (live context, a, a'), that one's (behind randomized response every pair is alike: the
    pair (0, 1) stands for it); ``loose``: as :func:`_largest`."""
    if isinstance(s, KernelSetting):  # (the pairs in decreasing order of their bounds, solved exactly where small)
        return table_local(s, at)
    # contexts with the same box have the same programs: one case per box and pair (_largest); behind randomized
    # response the pair (0, 1) stands for every pair
    boxes = [(s.low[at[0]], s.high[at[0]])] if at is not None else list(dict.fromkeys(zip(s.low, s.high)))
    pairs = [(at[1], at[2])] if at is not None else _pairs(s)
    floors = [_rows_of(s, *pairs[0])[2]]  # (every group's: the same for every pair)
    small = len(floors[0][0]) <= MAX_VARIABLES and (s.rows is None or s.k <= MAX_GROUPS)
    duals, point = _local_evidence(s)
    screens = {}
    if s.rows is not None and at is None:  # (behind a matrix: k(k − 1) pairs, most of them below the top)
        screens = {box: pair_screens(s.rows, [[Fraction(1)] * s.k], [box[0]], [box[1]], s.tau or None, range(s.k))
                   for box in boxes}  # fmt: skip

    def case(a: int, b: int, lo: Fraction, hi: Fraction) -> _Case:
        row_a, row_b, _, _ = _rows_of(s, a, b)
        key = (lo, hi, a, b)
        return _Case((lo, hi), [row_a], [row_b], floors, [lo], [hi], s.tau, None, small, duals.get(key), point.get(key))

    cases = [_Lazy(screens.get((lo, hi), {}).get((a, b), INF), (lo, hi), functools.partial(case, a, b, lo, hi),
                   (lo, hi, a, b) in point)
             for a, b in pairs for lo, hi in boxes]  # fmt: skip
    return _largest(cases, Fraction(0), loose)


_Ends = tuple[Number, Number, bool]
"""(lower end, upper end, whether a recorded dual gave the upper end)."""


def _local_evidence(s: _Setting) -> tuple[dict[tuple[Any, ...], list[list[Fraction]]], dict[tuple[Any, ...], Any]]:
    """The recorded duals and witness point of L's programs, by (box, a, a') (a context's program is its box's)."""
    if s.rows is None:
        return {}, {}
    position = {x: i for i, x in enumerate(s.live)}
    duals = {}
    for (x, a, b), nu in s.evidence.local.items():
        if x in position:
            i = position[x]
            duals[(s.low[i], s.high[i], a, b)] = [nu]
    point = {}
    if s.evidence.local_point is not None and s.evidence.local_point[0] in position:
        x, a, b, h = s.evidence.local_point
        i = position[x]
        point[(s.low[i], s.high[i], a, b)] = [h]
    return duals, point


@dataclass(frozen=True)
class _Case:
    """One pair's program (:func:`_solve_blocks`' arguments); ``key`` names its feasible set (the box, for L)."""

    key: Any
    tops: list[list[Fraction]]
    bottoms: list[list[Fraction]]
    floors: list[list[list[Fraction]]]
    low: list[Fraction]
    high: list[Fraction]
    tau: Fraction | None
    kept: Fraction | None = None  # t of the floor the denominator keeps, q·h ≥ t (τ, or Σ_x P(x | a') τ for L̄)
    small: bool = True  # within the rational simplex's size: solved exactly, else bounded by ``dual``
    dual: list[list[Fraction]] | None = None  # the recorded ν per block
    point: list[list[Fraction]] | None = None  # the recorded witness point per block

    def bound(self) -> tuple[Number, list[Fraction] | None]:
        """An upper bound on the program's value: the floor relaxation's (a positive floor: the denominator's own,
        E[g | a'] ≥ t, which every model meeting the floors meets), with its maximiser over every block's cells (the
        value, where that meets every floor), else the box's bound, with None."""
        t = self.tau if self.kept is None else self.kept
        p = [v for row in self.tops for v in row]
        q = [v for row in self.bottoms for v in row]
        low = [lo for lo, row in zip(self.low, self.tops) for _ in row]
        high = [hi for hi, row in zip(self.high, self.tops) for _ in row]
        if self.tau and t:
            found = _floor_relaxation(p, q, t, low, high)
            if found is None:  # no h of the box meets the floor of a': no model meets the floors
                raise ValueError("the worst-case program is infeasible")
            return found
        return _box_bound(p, q, low, high)

    def meets(self, h: Sequence[Fraction], scaled: dict[int, tuple[list[list[int]], int]]) -> bool:
        """Whether the point h (every block's cells in turn) meets every block's floors, exactly (no floors: yes)."""
        if self.tau is None:
            return True
        start = 0
        for rows in self.floors:
            if id(rows) not in scaled:  # (the floors of one block as integers over one denominator, once)
                scaled[id(rows)] = on_one_denominator(rows)
            width = len(rows[0])
            if not _meets(*scaled[id(rows)], h[start : start + width], self.tau):
                return False
            start += width
        return True

    def feasible(self) -> bool:
        """Whether some point meets every floor: h = high in every block, exactly (the floors' rows are ≥ 0)."""
        return not self.tau or all(
            sum(row, Fraction(0)) * hi >= self.tau for rows, hi in zip(self.floors, self.high) for row in rows
        )

    def program(self) -> BlockProgram:
        """The program, to bound from its dual and evaluate at its point."""
        return BlockProgram(self.tops, self.bottoms, self.floors, self.low, self.high, self.tau)

    def dual_bound(self) -> Number:
        """The recorded dual's bound (:meth:`~fairaudit.verification.dual_check.BlockProgram.dual_bound`); +inf
        without one."""
        return INF if self.dual is None else self.program().dual_bound(self.dual)

    def point_ratio(self) -> Fraction | None:
        """The ratio at the recorded point or a vertex it stands for, where that meets every constraint exactly."""
        return None if self.point is None else self.program().vertex_ratio(self.point)


class _Lazy(NamedTuple):
    """One program of :func:`_largest`, built only when needed."""

    screen: Number  # an upper bound on its value (pair_screens), +inf where none is known
    key: Any  # its feasible set (the box, for L)
    build: Callable[[], _Case]
    pointed: bool  # whether the certificate records a witness point for it


def _largest(cases: Sequence[_Lazy], start: Number, loose: bool = False) -> _Ends:
    """max of ``start`` and the programs' values, enclosed, solving as few as it can (``proofs/verification.md``
    §4, §4e, §4h).

    Best first: each program is taken in decreasing order of its best bound known, its screen
    (:func:`~fairaudit.verification.screens.pair_screens`), then its relaxation's (:meth:`_Case.bound`: its
    value where the relaxation's maximiser meets every floor), then solved exactly, until no bound left exceeds the
    upper end found. A key none of whose programs is known feasible then has its floors checked at h = high, where
    floors no model meets are found (ValueError). A program beyond the exact size is taken again at the bound its
    recorded dual gives, an upper end where it is above every value found (:class:`MissingDual` without one, unless
    its bound is within
    :data:`~fairaudit.verification.dual_check.SEARCH_STOP` of the upper end found, or ``loose``: its bound, the
    relaxation's, is then an upper end), and a recorded point that meets every constraint gives a lower end.
    """
    low = high = start
    duals, known = False, set()
    deferred: list[Number] = []  # the bounds of programs beyond the exact size without a recorded dual
    polytopes: dict[Any, Polytope] = {}  # (the pairs of one feasible set share it: phase 1 once)
    scaled: dict[int, tuple[list[list[int]], int]] = {}  # the floors of one block as integers over one denominator

    @functools.cache
    def case_of(i: int) -> _Case:  # (each program built once, when first needed)
        return cases[i].build()

    for i, entry in enumerate(cases):
        attained = case_of(i).point_ratio() if entry.pointed else None
        if attained is not None:
            low = max(low, attained)
    heap: list[tuple[Number, int, int]] = [(-entry.screen, i, 0) for i, entry in enumerate(cases)]
    heapq.heapify(heap)  # (−bound, position, stage: 0 its screen, 1 its relaxation's, 2 its dual's): best first
    while heap and -heap[0][0] > high:
        negative, i, stage = heapq.heappop(heap)
        case = case_of(i)
        if stage == 0:
            bound, h = case.bound()
            if h is not None and case.meets(h, scaled):
                low, high = max(low, bound), max(high, bound)
                known.add(case.key)
            else:
                heapq.heappush(heap, (-bound, i, 1))
            continue
        bound = -negative
        if stage == 2:  # (its dual's bound is above every value found: the upper end)
            high, duals = max(high, bound), True
            continue
        known.add(case.key)
        if case.small:
            value = _solve_blocks(case.tops, case.bottoms, case.floors, case.low, case.high, case.tau, polytopes)
            low, high = max(low, value), max(high, value)
            continue
        if not case.feasible():
            raise ValueError("the worst-case program is infeasible")
        if case.dual is not None:  # (taken again at its dual's bound: set aside where at most the largest found)
            heapq.heappush(heap, (-min(bound, case.dual_bound()), i, 2))
        elif len(case.tops[0]) <= MAX_VARIABLES and len(case.floors[0]) <= MAX_FLOORS:
            value = _solve_blocks(case.tops, case.bottoms, case.floors, case.low, case.high, case.tau, polytopes)
            low, high = max(low, value), max(high, value)
        elif loose:
            high, duals = max(high, bound), True
        else:
            deferred.append(bound)
    for _, i, _ in heap:  # (every bound left is at most the upper end: only the floors of a key not yet seen)
        if cases[i].key not in known:
            known.add(cases[i].key)
            if not case_of(i).feasible():
                raise ValueError("the worst-case program is infeasible")
    high, raised = without_duals(deferred, high, f"programs beyond {MAX_VARIABLES} variables or {MAX_GROUPS} floors")
    return low, high, duals or raised


def _meets(rows: list[list[int]], d: int, h: Sequence[Fraction], tau: Fraction) -> bool:
    """Whether (rows/d)·h ≥ τ for every row, exactly, in integers."""
    e = math.lcm(*(x.denominator for x in h))
    point = [x.numerator * (e // x.denominator) for x in h]
    floor = Fraction(tau) * d * e
    return all(sum(map(operator.mul, row, point)) * floor.denominator >= floor.numerator for row in rows)


def _floor_relaxation(
    p: Sequence[Fraction], q: Sequence[Fraction], t: Fraction, low: Sequence[Fraction], high: Sequence[Fraction]
) -> tuple[Number, list[Fraction]] | None:
    """max (p·h)/(q·h) over the box low ≤ h ≤ high with q·h ≥ t (p, q ≥ 0, t > 0), exactly, and an h attaining it;
    None when q·high < t (no h meets the floor).

    The maximum over q·h > 0 is at a prefix of the cells in decreasing order of p_i/q_i (the threshold rule, as
    :func:`_box_bound`); where that prefix has q·h < t, the maximum is on q·h = t (along the segment to any
    feasible h the ratio is monotone, so it crosses q·h = t at a ratio at least that h's), where it is max p·h/t, a
    fractional knapsack: the cells with q_i = 0 high, then the others raised in the same order until q·h = t. So
    the maximum is the largest of the prefixes with q·h ≥ t and that point (``proofs/verification.md`` §4). The
    cells outside the ratio (p_i = q_i = 0) are put high in the point: the same ratio, and no floor lower.

    In integers: p, q over one denominator (P, Q), the box and t over another (L, H, T), so each prefix's ratio is
    (Σ P·X)/(Σ Q·X) with X the point over the box's denominator, compared by cross-multiplying.
    """
    (big_p, big_q), _ = on_one_denominator([p, q])
    (lo, hi, (floor,)), d_box = on_one_denominator([low, high, [t]])
    d_rows = math.lcm(*(v.denominator for v in (*p, *q)))
    floor *= d_rows  # q·h ≥ t is Σ Q·X ≥ T·d_rows
    if sum(map(operator.mul, big_q, hi)) < floor:
        return None
    order = _ratio_order(big_p, big_q, lo, hi)
    num, below = sum(map(operator.mul, big_p, lo)), sum(map(operator.mul, big_q, lo))
    den = below
    best: tuple[int, int, int] | None = (num, den, 0) if den >= floor else None
    for j, i in enumerate(order, 1):
        num, den = num + big_p[i] * (hi[i] - lo[i]), den + big_q[i] * (hi[i] - lo[i])
        if den >= floor and (best is None or num * best[1] > best[0] * den):
            best = (num, den, j)
    at_floor = None
    if below < floor:  # the point of q·h = t with the largest p·h
        h, budget, top = list(low), floor - below, Fraction(sum(map(operator.mul, big_p, lo)))
        for i in order:
            full = big_q[i] * (hi[i] - lo[i])
            if full <= budget or big_q[i] == 0:
                h[i], budget, top = high[i], budget - full, top + big_p[i] * (hi[i] - lo[i])
            else:
                h[i], budget, top = (
                    low[i] + Fraction(budget, big_q[i] * d_box),
                    0,
                    top + Fraction(big_p[i] * budget, big_q[i]),
                )
            if budget == 0 and big_q[i]:
                break
        at_floor = (top / floor, h)  # p·h/t = (Σ P·X)/(T·d_rows)
    value: Number
    if best is None or (at_floor is not None and at_floor[0] > Fraction(best[0], best[1])):
        assert at_floor is not None  # (q·high ≥ t: either a prefix meets the floor or q·low < t)
        value, h = at_floor
    else:
        chosen = set(order[: best[2]])
        value, h = Fraction(best[0], best[1]), [high[i] if i in chosen else low[i] for i in range(len(p))]
    # the cells outside the ratio (p = q = 0) at the top of their box: the same ratio, and floors (rows ≥ 0) no lower
    return value, [high[i] if p[i] == q[i] == 0 else v for i, v in enumerate(h)]


def _ratio_order(p: Sequence[int], q: Sequence[int], low: Sequence[int], high: Sequence[int]) -> list[int]:
    """The cells with high > low in the threshold rule's order: those with q_i = 0 < p_i first, then the others with
    q_i > 0 in decreasing order of p_i/q_i (the cells with p_i = q_i = 0 change nothing and are left out).
    Integers (any common scale for p and q, and for the box), compared by cross-multiplying; ties keep their order.
    """
    moving = [i for i in range(len(p)) if high[i] > low[i]]
    free = [i for i in moving if q[i] == 0 < p[i]]
    ranked = [i for i in moving if q[i] > 0]

    def later(i: int, j: int) -> int:  # < 0 where p_i/q_i > p_j/q_j: larger ratios first
        return p[j] * q[i] - p[i] * q[j]

    ranked.sort(key=functools.cmp_to_key(later))
    return free + ranked


def _box_bound(
    p: Sequence[Fraction], q: Sequence[Fraction], low: Sequence[Fraction], high: Sequence[Fraction]
) -> tuple[Number, list[Fraction] | None]:
    """max (p·h)/(q·h) over the box low ≤ h ≤ high (p, q ≥ 0), exactly, with c/0 = +inf and 0/0 = 1 at h = low: an
    upper bound of the same ratio over any part of the box.

    The threshold rule (``proofs/linear_fractional.md``, the threshold solution): at the maximum λ*, h maximises
    (p − λ* q)·h, so it is high where p_i/q_i > λ* and low elsewhere; the maximum is among the n + 1 prefixes of the
    cells in decreasing order of p_i/q_i (the cells with q_i = 0 < p_i first, always high). 0/0 at h = low is counted
    as 1, which can only raise the bound. In integers, as :func:`_floor_relaxation`. With the bound, the prefix's
    point where its ratio is a point's (q·h > 0), else None.
    """
    (big_p, big_q), _ = on_one_denominator([p, q])
    (lo, hi), _ = on_one_denominator([low, high])
    order = _ratio_order(big_p, big_q, lo, hi)
    free = sum(1 for i in order if big_q[i] == 0)
    num = sum(map(operator.mul, big_p, lo)) + sum(big_p[i] * (hi[i] - lo[i]) for i in order[:free])
    den = sum(map(operator.mul, big_q, lo))
    if den == 0 and num > 0:
        return INF, None  # h = low but high on the cells a' never reaches: q·h = 0 < p·h
    best = (num, den, free) if den else (1, 1, -1)  # (-1: the 0/0 at h = low, no point's ratio)
    for j, i in enumerate(order[free:], free + 1):
        num, den = num + big_p[i] * (hi[i] - lo[i]), den + big_q[i] * (hi[i] - lo[i])
        if num * best[1] > best[0] * den:
            best = (num, den, j)
    if best[2] < 0:
        return Fraction(1), None
    chosen = set(order[: best[2]])
    return Fraction(best[0], best[1]), [high[i] if i in chosen else low[i] for i in range(len(p))]


def _global(s: _Setting | KernelSetting, at: tuple[int, int] | None = None, loose: bool = False) -> _Ends | None:
    """max over pairs of groups present of the worst ratio of E[g | a]/E[g | a'] (every live context's cells),
    enclosed as in :func:`_local` (``loose`` likewise); 1 (L-bar = 0) with fewer than two groups present; with ``at`` = (a, a'), that
    pair's; None where a program beyond the exact size has no recorded dual."""
    if isinstance(s, KernelSetting):
        return table_global(s, at)
    if len(s.present) < 2:
        return Fraction(1), Fraction(1), False
    alike = _alike(s.weights, s.present)
    if s.rows is None and alike:
        pairs, width = [(s.present[0], s.present[1])], 3  # every pair present is alike: three cells
    else:
        pairs = [(a, b) for a in s.present for b in s.present if a != b]  # a matrix, or P(x | a) differs
        width = s.k if s.rows is None else len(s.rows[0])
    low, high, weights, members = _merged(s)
    # one context's block (each context is a block of the product: _solve_blocks)
    small = width <= MAX_VARIABLES and (s.rows is None or s.k <= MAX_GROUPS)
    if at is not None:
        pairs = pairs if s.rows is None and alike else [at]
    cells = _rows_of if s.rows is not None else _full_rr_rows
    floors = [cells(s, *pairs[0])[2]] * len(weights)  # (every group's in each block: the same for every pair)
    duals, point = _global_evidence(s, members)
    screens = {}
    if len(pairs) > 1:  # (a matrix, or P(x | a) unlike: every pair of groups present)
        rows = s.rows if s.rows is not None else _full_rr_rows(s, *pairs[0])[2]
        screens = pair_screens(rows, weights, low, high, s.tau or None, s.present)

    def case(a: int, b: int) -> _Case:
        row_a, row_b = cells(s, a, b)[:2]
        tops = [[w[a] * v for v in row_a] for w in weights]
        bottoms = [[w[b] * v for v in row_b] for w in weights]
        kept = sum((w[b] for w in weights), Fraction(0)) * s.tau if s.tau else None  # E[g | b] = Σ_x P(x | b) E_x
        return _Case(0, tops, bottoms, floors, low, high, s.tau, kept, small, duals.get((a, b)), point.get((a, b)))

    cases = [_Lazy(screens.get((a, b), INF), 0, functools.partial(case, a, b), (a, b) in point) for a, b in pairs]
    try:
        return _largest(cases, Fraction(1), loose)
    except MissingDual:
        return None


def _merged(s: _Setting) -> tuple[list[Fraction], list[Fraction], list[list[Fraction]], list[list[int]]]:
    """The live contexts for L̄, those with the same box and P(x | a) proportional over the groups present merged into
    one, their weights summed (exact: Σ_x c_x v_a M[a]·h_x = (Σ_x c_x) v_a M[a]·h̄ with h̄ the c-weighted mean of the
    h_x, in the same box and meeting the same floors, and h̄ itself is reached by h_x = h̄; ``proofs/verification.md``
    §4): (low, high, weights, members), one entry per merged context; ``members`` lists the live contexts (their
    positions among the live ones) each holds."""
    merged: dict[tuple[Any, ...], list[Fraction]] = {}
    members: dict[tuple[Any, ...], list[int]] = {}
    for i, w in enumerate(s.weights):
        total = sum(w[a] for a in s.present)
        shape = tuple(w[a] / total for a in s.present) if total else (i,)
        key = (s.low[i], s.high[i], shape)
        if key in merged:
            merged[key] = [x + y for x, y in zip(merged[key], w, strict=True)]
            members[key].append(i)
        else:
            merged[key], members[key] = list(w), [i]
    keys = list(merged)
    return [k[0] for k in keys], [k[1] for k in keys], [merged[k] for k in keys], [members[k] for k in keys]


def _global_evidence(
    s: _Setting, members: list[list[int]]
) -> tuple[dict[tuple[int, int], list[list[Fraction]]], dict[tuple[int, int], list[list[Fraction]]]]:
    """The recorded duals and witness point of L̄'s programs, by pair, on the merged contexts (``members``): a merged
    block's ν is the sum of its contexts' (each block's B is at most the sum of theirs: the max over a box is
    subadditive), its point the mean of theirs weighted by Σ_a P(x | a) over the groups present (the merge's own
    weights, so the ratio is unchanged)."""
    if s.rows is None and _alike(s.weights, s.present):
        return {}, {}  # (randomized response's three cells)
    duals = {}
    for pair, nus in s.evidence.global_.items():
        duals[pair] = [[sum(col, Fraction(0)) for col in zip(*(nus[s.live[i]] for i in block))] for block in members]
    point = {}
    if s.evidence.global_point is not None:
        a, b, hs = s.evidence.global_point
        blocks = []
        for block in members:
            c = [sum((s.weights[i][g] for g in s.present), Fraction(0)) for i in block]
            total = sum(c, Fraction(0))
            n = len(hs[0])
            blocks.append([sum((ci * hs[s.live[i]][j] for ci, i in zip(c, block)), Fraction(0)) / total
                           if total else hs[s.live[block[0]]][j] for j in range(n)])  # fmt: skip
        point[(a, b)] = blocks
    return duals, point


def _full_rr_rows(
    s: _Setting, a: int, b: int
) -> tuple[list[Fraction], list[Fraction], list[list[Fraction]], list[int]]:
    """Randomized response's k × k rows, for L̄ when the pairs are not alike; the symmetric three cells otherwise."""
    if _alike(s.weights, s.present):
        return _rows_of(s, a, b)
    rows = [[s.p if i == j else s.q for j in range(s.k)] for i in range(s.k)]
    return rows[a], rows[b], rows, [1] * s.k


def _solve_blocks(
    tops: list[list[Fraction]],
    bottoms: list[list[Fraction]],
    floors: list[list[list[Fraction]]],
    low: list[Fraction],
    high: list[Fraction],
    tau: Fraction | None,
    polytopes: dict[Any, Polytope],
) -> Number:
    """max (Σ_i tops_i·h_i)/(Σ_i bottoms_i·h_i) over blocks h_i in [low_i, high_i]^n with floors_i·h_i ≥ τ.

    Each block's box and floors concern it alone, so the program is over a product and is solved block by block
    (:func:`~fairaudit.base.exact_programs.maximize_ratio_over_product`). c/0 = +inf and 0/0 = 1, as the tool's
    conventions: a point with Σ bottoms·h = 0 (the origin of boxes from 0) is left out, and the ratio is +inf when a
    model puts the utility only where a' never lands.
    """
    p = [v for row in tops for v in row]
    q = [v for row in bottoms for v in row]
    upper = [high[i] for i, row in enumerate(tops) for _ in row]
    lower = [low[i] for i, row in enumerate(tops) for _ in row]
    reach = any(qi == 0 and pi > 0 and hi > 0 for pi, qi, hi in zip(p, q, upper))
    if reach and not tau and all(lo == 0 for qi, lo in zip(q, lower) if qi > 0):
        return INF  # a model that puts the utility only where a' never lands (its box starts at 0 there)
    if max(upper, default=Fraction(0)) == 0:
        return Fraction(1)  # g = 0: every ratio is 0/0
    blocks = []
    for i, top in enumerate(tops):
        rows = [[-v for v in f] for f in floors[i]] if tau else []
        bounds = [-tau] * len(rows) if tau else []
        key = (low[i], high[i], len(top), tuple(map(tuple, rows)))
        if key not in polytopes:  # (the pairs of one setting share it: phase 1 once, each from the last basis)
            polytopes[key] = Polytope([low[i]] * len(top), [high[i]] * len(top), rows, bounds, len(top))
        blocks.append(polytopes[key])
    result = maximize_ratio_over_product(blocks, tops, bottoms)
    if result.status != "optimal":
        raise ValueError(f"the worst-case program is {result.status}")
    return result.value  # type: ignore[return-value]
