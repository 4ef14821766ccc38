"""The black-box worst case re-derived from the certificate's proofs: the largest L and L̄ over every decision model
behind the filter.

Every program is over the model's table K[x̃, ã, u] (:mod:`~fairaudit.verification.kernel_check` builds them from the
inputs, :mod:`~fairaudit.verification.table_check` bounds each from the proof its certificate records, by exact weak
duality, and reads its lower end off the recorded witness):

* L = max over live x and a ≠ a' of max E[g | x, a]/E[g | x, a'] over the tables that meet the floors;
* L̄ = max over a ≠ a' with P(A = a), P(A = a') > 0 of max E[g | a]/E[g | a'] over the same tables.

Randomized response's rows hold e^ε, irrational: its worst case is non-decreasing in e^ε (randomized response at a
smaller ε is the one at a larger ε followed by more randomized response, so its models are among the larger one's),
and the programs are bounded at the two 50-digit rational ends of e^ε, which enclose it. Behind randomized response
on the group, the identity on the context and a utility free of the group, every pair of groups is alike, and the
programs of one pair over three cells stand for every pair (:func:`~fairaudit.verification.kernel_check.
three_cell_settings`; for L̄ when P(x | a) is the same for every group present). ``proofs/verification.md`` §4.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, NamedTuple

from fairaudit.verification.dual_check import Evidence
from fairaudit.verification.enclosures import INF, Enclosure, RecordedMechanism, group_free
from fairaudit.verification.kernel_check import KernelSetting, kernel_settings, population, three_cell_settings
from fairaudit.verification.table_check import Ends, table_global, table_local

__all__ = ["PairEnclosures", "WorstCaseEnclosures", "black_box_enclosures", "pair_enclosures"]


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
        (:class:`~fairaudit.verification.dual_check.Evidence`).

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
    local, global_ = [_local(p) for p in settings], [_global(p) for p in settings]
    duals = any(end[2] for end in local + global_)
    first = settings[0]
    return WorstCaseEnclosures(_span(local), _span(global_), "", _alike(first), first.local.group_free, duals)


class PairEnclosures(NamedTuple):
    """The worst ratios of one pair (:func:`pair_enclosures`): on L at its context, on L̄; ``from_duals`` when an
    upper end is a recorded proof's: then only the lower end, a recorded point's ratio, shows what the pair
    attains."""

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
    group P(A = a) = 0 for L̄).

    The maximiser a certificate names holds when its pair's program reaches the recorded value (``verify``, within
    the search's 1e-8): a pair that is not a maximiser fails (``proofs/verification.md`` §4, §4c).

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
        Enclose that worst case only (the other is None).

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
    live = settings[0].local.live
    i = live.index(contexts.index(context)) if context in contexts and contexts.index(context) in live else None
    present = settings[0].several and {a, b} <= set(population(inputs, len(groups))[4])
    local_ends = None if i is None or only == "global" else [_local(p, (i, a, b)) for p in settings]
    global_ends = [_global(p, (a, b)) for p in settings] if present and only != "local" else None
    duals = any(e[2] for e in [*(local_ends or []), *(global_ends or [])])
    return PairEnclosures(_span(local_ends), _span(global_ends), duals)


def _span(ends: list[Ends] | None) -> Enclosure | None:
    """The enclosure from the lower end at the first setting (e^ε's lower end) to the upper end at the last."""
    return None if ends is None else Enclosure(ends[0][0], ends[-1][1])


def _settings(inputs: Mapping[str, Any], evidence: Evidence) -> list[_Programs] | str:
    """The programs' data at each end of e^ε (one for exact rows), or why the black box is not re-derived."""
    m = RecordedMechanism.from_record(inputs["sensitive_mechanism"], "inputs.sensitive_mechanism")
    context = RecordedMechanism.from_record(inputs["context_mechanism"], "inputs.context_mechanism")
    if m.k < 2:
        return "a single group: no pair of groups to compare"
    free = group_free(inputs["utility"]["values"])
    rr = m.kind == "randomized_response" and m.t().lo != INF  # (at ε = inf, the identity's rows)
    if not (rr and context.kind == "identity" and free):
        settings = kernel_settings(inputs, m, context, evidence)
        return [_Programs(s, s, False, False, len(s.present) >= 2) for s in settings]
    local = three_cell_settings(inputs, m, evidence, (0, 1))
    _, _, _, weights, present, _ = population(inputs, m.k)
    if len(present) < 2 or not all(w[a] == w[present[0]] for w in weights for a in present):
        full = kernel_settings(inputs, m, context, evidence) if len(present) >= 2 else local
        return [_Programs(s, f, True, False, len(present) >= 2) for s, f in zip(local, full, strict=True)]
    global_ = three_cell_settings(inputs, m, evidence, (present[0], present[1]))
    return [_Programs(s, t, True, True, True) for s, t in zip(local, global_, strict=True)]


class _Programs(NamedTuple):
    """One end's settings: L's and L̄'s, and whether each is randomized response's three cells (the pair (0, 1))."""

    local: KernelSetting
    global_: KernelSetting
    local_cells: bool
    global_cells: bool
    several: bool  # at least two groups have P(A = a) > 0 (else L̄ = 0)


def _alike(p: _Programs) -> bool:
    """P(x | a) is the same for every group present (X and A independent among them), exactly."""
    s = p.global_
    return p.global_cells or all(w[a] == w[s.present[0]] for w in s.weights for a in s.present)


def _local(p: _Programs, at: tuple[int, int, int] | None = None) -> Ends:
    """L's worst ratio over the model's table (:func:`table_local`); behind randomized response's three cells the pair
    (0, 1) stands for every pair, in every live context."""
    if not p.local_cells:
        return table_local(p.local, at)
    contexts = range(len(p.local.live)) if at is None else [at[0]]
    ends = [table_local(p.local, (i, 0, 1)) for i in contexts]
    return max(e[0] for e in ends), max(e[1] for e in ends), any(e[2] for e in ends)


def _global(p: _Programs, at: tuple[int, int] | None = None) -> Ends:
    """L̄'s worst ratio over the model's table (:func:`table_global`); behind the three cells, the pair (0, 1)."""
    if not p.several:
        return Fraction(1), Fraction(1), False
    return table_global(p.global_, (0, 1) if p.global_cells else at)
