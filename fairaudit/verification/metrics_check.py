"""The other metrics of the observed and unfiltered sections, re-derived exactly from the recorded kernel.

For the law behind the recorded mechanisms (``observed``) and the kernel on its own (``unfiltered``, identity
mechanisms), composed at both ends of the mechanisms' enclosures as :mod:`~fairaudit.verification.observed_check`
composes it: the ratios e^L and e^L̄, the global maximiser, the total-variation gaps L_dp and L_eo and the sups over
g of L and L̄ (:mod:`fairaudit.metrics.parity`, :mod:`fairaudit.metrics.sup_fairness`), each with its maximiser.
Every entry of the law lies between its two ends, and each metric is monotone in the entries it reads, so each is
enclosed by evaluating it at the right end of each entry (``proofs/verification.md`` §2b).
"""

from __future__ import annotations

from collections.abc import Mapping
from fractions import Fraction
from typing import Any

from fairaudit.verification.checks import Check, equal, judge
from fairaudit.verification.enclosures import Enclosure, RecordedMechanism, ln_of, recorded_array
from fairaudit.verification.observed_check import (
    ObservedEnclosures,
    fairness_checks,
    max_ratio,
    observed_enclosures,
    ratio_of,
)

__all__ = ["metric_checks"]

_UNDEFINED = "fewer than two groups with P(A = a) > 0"


def metric_checks(
    cert: Mapping[str, Any], sensitive: RecordedMechanism, context: RecordedMechanism, skipped: list[tuple[str, str]]
) -> list[Check]:
    """The ratios, gaps and sups of the ``observed`` and ``unfiltered`` sections, and their maximisers.

    Parameters
    ----------
    cert : mapping
        A certificate (checked against its schema): its ``observed`` and ``unfiltered`` sections against its
        ``inputs`` (the kernel, the utility, the population).
    sensitive, context : RecordedMechanism
        M_A and M_X as the certificate records them: ``observed`` is the law behind them; ``unfiltered`` is the
        kernel itself (identity mechanisms).
    skipped : list of (str, str)
        Appended to: what is not re-derived, and why (for ``observed``, :func:`observed_checks` says it).

    Returns
    -------
    list of Check
        For each section present, as measured values (side "estimate": within the tolerance of the exact value):
        ``local.ratio`` and ``global.ratio``; for ``unfiltered`` also ``local.value``, ``global.value`` and the local
        maximiser; the ratio E[g | group] / E[g | other_group] at the global maximiser; ``demographic_parity``,
        ``equalized_odds``, ``sup_local``, ``sup_global`` and ``details.<each>.value`` (and ``.ratio`` of the sups);
        and each detail's maximiser: P(event | group) − P(event | other_group) for the gaps (given the context, for
        L_eo) and ln of P(decision | group) / P(decision | other_group) for the sups (given the context, for the
        local sup) equal the value (a swapped pair, a label not among the inputs' or a changed event or decision
        fails). None without a model.

    Raises
    ------
    CertificateError
        Naming the field of ``inputs`` that holds a value that is not a number.

    Notes
    -----
    The definitions and conventions are those of :mod:`fairaudit.metrics.parity` and
    :mod:`fairaudit.metrics.sup_fairness`: contexts with P(X = x) = 0 are left out of L_eo and the local sup, groups
    with P(A = a) = 0 out of L_dp and the global sup (undefined, null, with fewer than two left); a ratio 0/0 is 1
    and c/0 is +inf. The enclosures: ``proofs/verification.md`` §2b.

    Examples
    --------
    A model that sees the group: P(yes | a) = 3/4, P(yes | b) = 1/4. By hand: L_dp = L_eo = 3/4 − 1/4 = 1/2 (the
    event "yes"), and the sups are ln 3 (3/4 over 1/4 at "yes", and at "no").

    >>> identity = {"inputs": ["a", "b"], "outputs": ["a", "b"], "kind": "identity"}
    >>> table = [[[0.75, 0.25], [0.25, 0.75]]]
    >>> inputs = {"kernel": {"contexts": ["x"], "groups": ["a", "b"], "decisions": ["yes", "no"],
    ...                      "probabilities": table}, "utility": {"values": [1.0, 0.0]},
    ...           "population": {"contexts": ["x"], "groups": ["a", "b"], "probabilities": [[0.5, 0.5]]}}
    >>> tv = {"value": 0.5, "context": None, "group": "a", "other_group": "b", "event": ["yes"]}
    >>> sup = {"value": 1.0986122886681098, "ratio": 3.0, "context": "x", "group": "a", "other_group": "b",
    ...        "decision": "yes"}
    >>> observed = {"local": {"value": 1.0986122886681098, "ratio": 3.0, "context": "x", "group": "a",
    ...                       "other_group": "b"},
    ...             "global": {"value": 1.0986122886681098, "ratio": 3.0, "group": "a", "other_group": "b"},
    ...             "demographic_parity": 0.5, "equalized_odds": 0.5, "sup_local": 1.0986122886681098,
    ...             "sup_global": 1.0986122886681098,
    ...             "details": {"demographic_parity": tv, "equalized_odds": {**tv, "context": "x"},
    ...                         "sup_local": sup, "sup_global": {**sup, "context": None}}}
    >>> m = RecordedMechanism.from_record(identity, "m")
    >>> x = RecordedMechanism.from_record({"inputs": ["x"], "outputs": ["x"], "kind": "identity"}, "m")
    >>> checks = metric_checks({"inputs": inputs, "observed": observed}, m, x, [])
    >>> len(checks), all(c.holds for c in checks)
    (17, True)
    >>> observed["details"]["demographic_parity"]["group"] = "b"  # a swapped pair: -1/2
    >>> [c.name for c in metric_checks({"inputs": inputs, "observed": observed}, m, x, []) if not c.holds]
    ['observed.details.demographic_parity (its pair and event)']
    """
    inputs = cert["inputs"]
    if inputs["kernel"] is None:
        return []
    out: list[Check] = []
    if "observed" in cert:
        found = observed_enclosures(inputs, sensitive, context)
        if not isinstance(found, str):  # else observed_checks lists the section with the reason
            out += _section_checks("observed", cert["observed"], found, inputs)
    if "unfiltered" in cert:
        out += _unfiltered_checks(cert, skipped)
    return out


def _identity(labels: list[Any]) -> RecordedMechanism:
    """The identity on ``labels``."""
    return RecordedMechanism.from_record({"inputs": labels, "outputs": labels, "kind": "identity"}, "identity")


def _unfiltered_checks(cert: Mapping[str, Any], skipped: list[tuple[str, str]]) -> list[Check]:
    """The ``unfiltered`` section: every metric of the kernel read as the law (identity mechanisms)."""
    inputs = cert["inputs"]
    kernel, population = inputs["kernel"], inputs["population"]
    if kernel["groups"] != population["groups"] or kernel["contexts"] != population["contexts"]:
        skipped.append(("unfiltered", "the model's labels are not the population's"))
        return []
    found = observed_enclosures(inputs, _identity(population["groups"]), _identity(population["contexts"]))
    if isinstance(found, str):
        skipped.append(("unfiltered", found))
        return []
    section = cert["unfiltered"]
    return fairness_checks("unfiltered", section, found, inputs) + _section_checks("unfiltered", section, found, inputs)


_Plane = list[Any]
"""A law by group: per group its row of (low, high) ends, one per decision; None for a group left out."""


def _section_checks(
    name: str, section: Mapping[str, Any], found: ObservedEnclosures, inputs: Mapping[str, Any]
) -> list[Check]:
    """The ratios, the global maximiser, the gaps and the sups of one section, from its law's enclosures."""
    population = inputs["population"]
    pop = recorded_array(population["probabilities"], "inputs.population.probabilities")
    labels = (population["groups"], inputs["kernel"]["decisions"])
    mass = [sum(row[a] for row in pop) for a in range(len(labels[0]))]
    local_planes = {  # Q[x, a, u] in the contexts with P(X = x) > 0
        population["contexts"][x]: [list(zip(lo, hi)) for lo, hi in zip(found.laws[0][x], found.laws[1][x])]
        for x in range(len(pop))
        if sum(pop[x]) > 0
    }
    global_planes = {None: _group_plane(pop, mass, found.laws)}  # P(u | a)
    pairless = len(labels[0]) < 2  # every metric 0 (ratio 1), no pair named
    undefined = not pairless and found.present < 2  # the metrics over groups: NaN, null in JSON
    glob = section["global"]
    out = [judge(f"{name}.local.ratio", section["local"]["ratio"], found.local, "estimate")]
    if undefined:
        out.append(equal(f"{name}.global.ratio", glob["ratio"], None, _UNDEFINED))
    else:
        out.append(judge(f"{name}.global.ratio", glob["ratio"], found.global_, "estimate"))
    e_plane = _group_plane(pop, mass, [[[[e] for e in row] for row in end] for end in found.ends])  # E[g | a]
    out.append(_named(f"{name}.global (its groups)", {**glob, "context": None, "decision": "E[g]"}, {None: e_plane},
                      (labels[0], ["E[g]"]), pairless or undefined))  # fmt: skip
    zero, one = Enclosure.point(Fraction(0)), Enclosure.point(Fraction(1))
    dp = None if undefined else zero if pairless else _max_tv(global_planes)
    eo = zero if pairless else _max_tv(local_planes)
    sup_local = one if pairless else _max_ratio(local_planes)
    sup_global = None if undefined else one if pairless else _max_ratio(global_planes)
    out += _metric(name, section, "demographic_parity", dp, global_planes, labels, pairless or undefined)
    out += _metric(name, section, "equalized_odds", eo, local_planes, labels, pairless)
    out += _metric(name, section, "sup_local", sup_local, local_planes, labels, pairless)
    out += _metric(name, section, "sup_global", sup_global, global_planes, labels, pairless or undefined)
    return out


def _metric(
    name: str,
    section: Mapping[str, Any],
    key: str,
    exact: Enclosure | None,
    planes: dict[Any, _Plane],
    labels: tuple[list[Any], list[Any]],
    no_pair: bool,
) -> list[Check]:
    """A gap (its value) or a sup (its value, the log of the ratio enclosed, and its ratio), the same in its details,
    and its maximiser; None for an undefined metric (null in JSON)."""
    detail, path = section["details"][key], f"{name}.details.{key}"
    sup = key.startswith("sup")
    out = []
    if exact is None:
        out += [equal(f"{name}.{key}", section[key], None, _UNDEFINED), equal(f"{path}.value", detail["value"], None)]
        if sup:
            out.append(equal(f"{path}.ratio", detail["ratio"], None))
    else:
        value = ln_of(exact) if sup else exact
        out += [
            judge(f"{name}.{key}", section[key], value, "estimate"),
            judge(f"{path}.value", detail["value"], value, "estimate"),
        ]
        if sup:
            out.append(judge(f"{path}.ratio", detail["ratio"], exact, "estimate"))
    what = "context, pair and decision" if sup else "context, pair and event"
    what = what if key in ("equalized_odds", "sup_local") else what.replace("context, ", "")
    out.append(_named(f"{path} (its {what})", detail, planes, labels, no_pair))
    return out


def _group_plane(pop: list[Any], mass: list[Fraction], ends: list[Any]) -> _Plane:
    """Σ_x P(x, a) T[x][a][u] / P(a) per group, at both ends of T (P(u | a) for the law); None where P(A = a) = 0."""
    plane: _Plane = []
    for a, m in enumerate(mass):
        if m == 0:
            plane.append(None)
            continue
        n = len(ends[0][0][a])
        rows = [
            [sum(pop[x][a] * end[x][a][u] for x in range(len(pop)) if pop[x][a]) / m for u in range(n)] for end in ends
        ]
        plane.append(list(zip(*rows)))
    return plane


def _max_tv(planes: dict[Any, _Plane]) -> Enclosure:
    """The largest TV = Σ_u (P_a(u) − P_b(u))⁺ over the planes and their ordered pairs of rows, enclosed (each term
    increases in P_a(u) and decreases in P_b(u))."""
    lo = hi = Fraction(0)
    for plane in planes.values():
        rows = [r for r in plane if r is not None]
        for i, ra in enumerate(rows):
            for j, rb in enumerate(rows):
                if i != j:
                    lo = max(lo, sum((max(Fraction(0), a[0] - b[1]) for a, b in zip(ra, rb)), Fraction(0)))
                    hi = max(hi, sum((max(Fraction(0), a[1] - b[0]) for a, b in zip(ra, rb)), Fraction(0)))
    return Enclosure(lo, hi)


def _max_ratio(planes: dict[Any, _Plane]) -> Enclosure:
    """The largest ratio max_a P_a(u) / min_a P_a(u) over the planes and decisions, enclosed (:func:`max_ratio`)."""
    columns = []
    for plane in planes.values():
        rows = [r for r in plane if r is not None]
        columns += [[r[u] for r in rows] for u in range(len(rows[0]))] if rows else []
    return max_ratio(columns)


def _named(check: str, detail: Mapping[str, Any], planes: dict[Any, _Plane], labels: tuple[list[Any], list[Any]],
           no_pair: bool) -> Check:  # fmt: skip
    """The detail's value at its named context (None: the plane over groups), pair and event (a gap: P(event | group)
    − P(event | other_group)) or decision (a ratio: P(decision | group) / P(decision | other_group), its log)."""
    groups, decisions = labels
    tv = "event" in detail
    picked = detail["event"] if tv else [detail["decision"]]
    names = [detail.get("context"), detail["group"], detail["other_group"], picked]
    if no_pair:
        return equal(check, names[1:3], [None, None], "no pair of groups to compare")
    where = f"at {names[0]!r}: {names[1]!r} over {names[2]!r}, {'event' if tv else 'decision'} {picked!r}"
    context = names[0] if not isinstance(names[0], list) else object()
    plane = planes.get(context)
    known = (plane is not None and names[1] in groups and names[2] in groups and isinstance(picked, list)
             and len(set(map(str, picked))) == len(picked) and all(u in decisions for u in picked))  # fmt: skip
    ra = rb = None
    if known:
        assert plane is not None
        ra, rb = plane[groups.index(names[1])], plane[groups.index(names[2])]
    if ra is None or rb is None:
        return equal(check, names, "labels of the inputs", f"no such cell: {where}")
    cols = [decisions.index(u) for u in picked]
    if tv:
        lo = sum((ra[u][0] - rb[u][1] for u in cols), Fraction(0))
        hi = sum((ra[u][1] - rb[u][0] for u in cols), Fraction(0))
        return judge(check, detail["value"], Enclosure(lo, hi), "estimate", where)
    u = cols[0]
    ratio = Enclosure(ratio_of(ra[u][0], rb[u][1]), ratio_of(ra[u][1], rb[u][0]))
    return judge(check, detail["value"], ln_of(ratio), "estimate", where)
