"""The observed local and global g-fairness behind the filter, re-derived exactly from the recorded kernel.

The law behind the recorded mechanisms is composed at both ends of their enclosures (randomized response's rows hold
e^ε, irrational), E[g | x, a] follows, and the largest ratios are enclosed (``proofs/verification.md``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

from fairaudit.verification.checks import Check, equal, judge
from fairaudit.verification.enclosures import INF, Enclosure, RecordedMechanism, ln_of, recorded_array

__all__ = [
    "ObservedEnclosures",
    "composed_law",
    "expected_utility",
    "fairness_checks",
    "max_ratio",
    "observed_checks",
    "observed_enclosures",
    "ratio_of",
]


def composed_law(
    kernel: Sequence[Any], sensitive: RecordedMechanism, context: RecordedMechanism, low: bool
) -> list[Any]:
    """The law ``Q[x][a][u]`` = Σ M_X[x, x̃] M_A[a, ã] K[x̃, ã, u] at one end of the mechanisms' enclosures.

    Parameters
    ----------
    kernel : nested lists of Fraction
        ``K[x̃][ã][u]``, the recorded kernel read exactly (:func:`~fairaudit.verification.enclosures.recorded_array`).
    sensitive, context : RecordedMechanism
        M_A and M_X.
    low : bool
        The low end (randomized response's keep p and off-diagonal q at the low ends of their enclosures) or the
        high end. Each entry of Q is a sum of p, q and exact rows times entries of K, all ≥ 0: it increases from the
        low end to the high end, so the exact law lies between the two entrywise (``proofs/verification.md`` §2b).

    Returns
    -------
    list
        ``Q[x][a][u]`` as Fractions, indexed [context, group, decision] (the mechanisms' inputs).

    Examples
    --------
    >>> half = RecordedMechanism.from_record({"inputs": ["a", "b"], "outputs": ["a", "b"], "kind": "matrix",
    ...                                       "matrix": [[0.5, 0.5], [0.0, 1.0]]}, "m")
    >>> alone = RecordedMechanism.from_record({"inputs": ["x"], "outputs": ["x"], "kind": "identity"}, "m")
    >>> composed_law([[[Fraction(1), Fraction(0)], [Fraction(0), Fraction(1)]]], half, alone, True)
    [[[Fraction(1, 2), Fraction(1, 2)], [Fraction(0, 1), Fraction(1, 1)]]]
    """
    rows_a = sensitive.matrix_rows()
    if rows_a is None:  # randomized response: Q = p K + q (S − K), S the sum over released groups
        p, q = sensitive.rr_rows()
        pe, qe = (p.lo, q.lo) if low else (p.hi, q.hi)
        by_a = []
        for plane in kernel:
            total = [sum(col) for col in zip(*plane)]
            by_a.append([[pe * c + qe * (s - c) for c, s in zip(cell, total)] for cell in plane])
    else:
        by_a = [
            [[sum(w * plane[j][u] for j, w in enumerate(row) if w) for u in range(len(plane[0]))] for row in rows_a]
            for plane in kernel
        ]
    rows_x = context.matrix_rows()
    if context.kind == "identity":
        return by_a
    if rows_x is None:
        p, q = context.rr_rows()
        pe, qe = (p.lo, q.lo) if low else (p.hi, q.hi)
        rows_x = tuple(tuple(Fraction(pe if i == j else qe) for j in range(context.k)) for i in range(context.k))
    return [
        [
            [sum(w * by_a[j][a][u] for j, w in enumerate(row) if w) for u in range(len(by_a[0][0]))]
            for a in range(len(by_a[0]))
        ]
        for row in rows_x
    ]


def expected_utility(law: list[Any], g: list[Any]) -> list[list[Fraction]]:
    """E[g | x, a] = Σ_u Q[x, a, u] g[x, a, u], exactly.

    Parameters
    ----------
    law : nested lists of Fraction
        ``Q[x][a][u]``.
    g : list of Fraction, or nested lists
        g(u), one row over the decisions, or the full table ``g[x][a][u]``.

    Returns
    -------
    list of list of Fraction
        E[g | x, a], indexed [context, group].

    Examples
    --------
    >>> expected_utility([[[Fraction(1, 4), Fraction(3, 4)]]], [Fraction(1), Fraction(0)])
    [[Fraction(1, 4)]]
    """
    flat = not isinstance(g[0], list)
    return [
        [sum(q * (g[u] if flat else g[x][a][u]) for u, q in enumerate(cell)) for a, cell in enumerate(plane)]
        for x, plane in enumerate(law)
    ]


def ratio_of(top: Fraction, bottom: Fraction) -> Fraction | float:
    """top/bottom with the conventions of ``docs/design.md`` "Conventions": 0/0 = 1 (parity), c/0 = +inf (c > 0).

    Examples
    --------
    >>> ratio_of(Fraction(3), Fraction(4)), ratio_of(Fraction(0), Fraction(0)), ratio_of(Fraction(1), Fraction(0))
    (Fraction(3, 4), Fraction(1, 1), inf)
    """
    if bottom == 0:
        return Fraction(1) if top == 0 else INF
    return top / bottom


@dataclass(frozen=True)
class ObservedEnclosures:
    """The observed L and L̄ behind a mechanism, as enclosed ratios (not logarithms), and E[g | x, a] at both ends."""

    local: Enclosure  # max over live x of max_a E[g | x, a] / min_a E[g | x, a]
    global_: Enclosure  # max_a E[g | a] / min_a E[g | a], E[g | a] = Σ_x P(x, a) E[g | x, a] / P(a)
    ends: list[Any]  # E[g | x, a] at the low and at the high end of the mechanisms' enclosures
    present: int  # the groups with P(A = a) > 0: L̄ is undefined with fewer than two
    laws: list[Any]  # the law Q[x][a][u] at the low and at the high end (each entry increases from one to the other)


def observed_enclosures(
    inputs: Mapping[str, Any], sensitive: RecordedMechanism, context: RecordedMechanism
) -> ObservedEnclosures | str:
    """The observed L and L̄ of the recorded kernel behind ``sensitive`` and ``context``, enclosed; or why not.

    Parameters
    ----------
    inputs : mapping
        A certificate's ``inputs`` (its kernel, utility and population are used; its mechanisms are not).
    sensitive, context : RecordedMechanism
        M_A and M_X (the certificate's, or a calibrated member of the family).

    Returns
    -------
    ObservedEnclosures or str
        The enclosures; a str, the reason, when there is no kernel, it has empty cells, or M_A is too large to
        compose exactly.

    Raises
    ------
    CertificateError
        Naming the field of ``inputs`` that holds a value that is not a number.

    Notes
    -----
    Local and global g-fairness are the paper's definitions (``proofs/main_theorem.md``); the composition
    Q = M_X K M_A at both ends of the mechanisms' enclosures, ``proofs/verification.md`` §2b.

    Examples
    --------
    A model that sees the group (the identity): E[g | a] = 3/4 and 1/4, so L = L̄ = ln 3, the ratio exactly 3.

    >>> identity = lambda labels: RecordedMechanism.from_record(
    ...     {"inputs": labels, "outputs": labels, "kind": "identity"}, "mechanism")
    >>> inputs = {"kernel": {"probabilities": [[[0.75, 0.25], [0.25, 0.75]]]}, "utility": {"values": [1.0, 0.0]},
    ...           "population": {"probabilities": [[0.5, 0.5]]}}
    >>> found = observed_enclosures(inputs, identity(["a", "b"]), identity(["x"]))
    >>> found.local.lo, found.local.hi, found.global_.hi, found.present
    (Fraction(3, 1), Fraction(3, 1), Fraction(3, 1), 2)
    """
    if inputs["kernel"] is None:
        return "the certificate records no model"
    kernel = recorded_array(inputs["kernel"]["probabilities"], "inputs.kernel.probabilities")
    if any(v is None for plane in kernel for cell in plane for v in cell):
        return "the kernel has empty cells"
    if sensitive.kind == "matrix" and len(sensitive.outputs) * sensitive.k > 10**6:
        return "the mechanism's matrix is too large to compose exactly"
    g = recorded_array(inputs["utility"]["values"], "inputs.utility.values")
    pop = recorded_array(inputs["population"]["probabilities"], "inputs.population.probabilities")
    laws = [composed_law(kernel, sensitive, context, low) for low in (True, False)]
    ends = [expected_utility(law, g) for law in laws]
    live = [x for x in range(len(pop)) if sum(pop[x]) > 0]
    local = max_ratio([[(e_lo, e_hi) for e_lo, e_hi in zip(ends[0][x], ends[1][x])] for x in live])
    by_group = []
    for a in range(len(pop[0])):
        mass = sum(pop[x][a] for x in range(len(pop)))
        if mass == 0:
            continue
        lo = sum(pop[x][a] * ends[0][x][a] for x in range(len(pop))) / mass
        hi = sum(pop[x][a] * ends[1][x][a] for x in range(len(pop))) / mass
        by_group.append((lo, hi))
    return ObservedEnclosures(local, max_ratio([by_group]), ends, len(by_group), laws)


def observed_checks(
    cert: Mapping[str, Any], sensitive: RecordedMechanism, context: RecordedMechanism, skipped: list[tuple[str, str]]
) -> list[Check]:
    """The observed local and global g-fairness behind the filter, and their maximising context and groups.

    Parameters
    ----------
    cert : mapping
        A certificate (checked against its schema): its ``observed`` section against its ``inputs``.
    sensitive, context : RecordedMechanism
        M_A and M_X as the certificate records them.
    skipped : list of (str, str)
        Appended to: what is not re-derived, and why.

    Returns
    -------
    list of Check
        ``observed.local.value`` and ``observed.global.value`` (measured values, nats, within the tolerance of the
        exact ones), and the ratio at the recorded context and groups (a swapped pair fails); none without a model.
    """
    inputs = cert["inputs"]
    if inputs["kernel"] is not None and "observed" not in cert and "observed_omitted" in cert:
        skipped.append(("observed", f"left out by certify: {cert['observed_omitted']}"))
    if inputs["kernel"] is None or "observed" not in cert:
        return []
    found = observed_enclosures(inputs, sensitive, context)
    if isinstance(found, str):
        skipped.append(("observed", found))
        return []
    return fairness_checks("observed", cert["observed"], found, inputs)


def fairness_checks(
    name: str, section: Mapping[str, Any], found: ObservedEnclosures, inputs: Mapping[str, Any]
) -> list[Check]:
    """A section's local and global g-fairness (``local.value``, ``global.value``) and its local maximiser.

    Parameters
    ----------
    name : str
        The section's name in the certificate (``observed``, ``unfiltered``), for the checks' names.
    section : mapping
        The section (``cert["observed"]``).
    found : ObservedEnclosures
        The enclosures of its law (:func:`observed_enclosures`).
    inputs : mapping
        The certificate's ``inputs`` (the population's labels name the context and groups).

    Returns
    -------
    list of Check
        ``<name>.local.value`` and ``<name>.global.value`` (measured values, nats, within the tolerance of the exact
        ones; L̄ null with fewer than two groups present), and the ratio at the recorded context and groups (a swapped
        pair or a label not among the inputs' fails).
    """
    contexts, groups = inputs["population"]["contexts"], inputs["population"]["groups"]
    local = section["local"]
    out = [judge(f"{name}.local.value", local["value"], ln_of(found.local), "estimate")]
    named = _named_ratio(found.ends, contexts.index(local["context"]) if local["context"] in contexts else None,
                         groups, local["group"], local["other_group"])  # fmt: skip
    where = f"the ratio at {local['context']!r}: {local['group']!r} over {local['other_group']!r}"
    check = f"{name}.local (its context and groups)"
    if named is None:
        out.append(
            equal(check, [local["context"], local["group"], local["other_group"]], "labels of the inputs", where)
        )
    else:
        out.append(judge(check, local["value"], ln_of(named), "estimate", where))
    if found.present < 2:  # no pair of groups present: the metrics leave L-bar undefined (NaN, null in JSON)
        out.append(
            equal(f"{name}.global.value", section["global"]["value"], None, "fewer than two groups with P(A = a) > 0")
        )
    else:
        out.append(judge(f"{name}.global.value", section["global"]["value"], ln_of(found.global_), "estimate"))
    return out


def max_ratio(planes: list[list[tuple[Fraction, Fraction]]]) -> Enclosure:
    """max over planes of max_a E / min_a E (:func:`ratio_of`), enclosed from each E's (low, high) ends.

    Parameters
    ----------
    planes : list of list of (Fraction, Fraction)
        Per plane (a context, or a context and a decision), the enclosure of each group's quantity E ≥ 0.
        Planes with fewer than two entries are left out.

    Returns
    -------
    Enclosure
        The largest ratio: its low end from the low ends of the tops and the high ends of the bottoms, its high
        end the other way round (the ratio increases in the top and decreases in the bottom; 1 when no plane has two
        entries).

    Examples
    --------
    >>> max_ratio([[(Fraction(1), Fraction(2)), (Fraction(4), Fraction(4))], [(Fraction(1), Fraction(1))]])
    Enclosure(lo=Fraction(2, 1), hi=Fraction(4, 1))
    """
    lo: Fraction | float = Fraction(1)
    hi: Fraction | float = Fraction(1)
    for plane in planes:
        if len(plane) < 2:
            continue
        lo = max(lo, ratio_of(max(e[0] for e in plane), min(e[1] for e in plane)))
        hi = max(hi, ratio_of(max(e[1] for e in plane), min(e[0] for e in plane)))
    return Enclosure(lo, hi)


def _named_ratio(ends: list[Any], x: int | None, groups: list[Any], group: Any, other: Any) -> Enclosure | None:
    """E[g | x, group] / E[g | x, other], enclosed; None when a label is unknown."""
    if x is None or group not in groups or other not in groups:
        return None
    a, b = groups.index(group), groups.index(other)
    return Enclosure(ratio_of(ends[0][x][a], ends[1][x][b]), ratio_of(ends[1][x][a], ends[0][x][b]))
