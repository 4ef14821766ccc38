"""The observed and unfiltered sections re-derived exactly from the recorded kernel.

For the law behind the recorded mechanisms (``observed``) and the kernel on its own (``unfiltered``, identity
mechanisms), composed at both ends of the mechanisms' enclosures (randomized response's rows hold e^ε, irrational):
L and L̄ and their ratios e^L and e^L̄, the total-variation gaps L_dp and L_eo and the sups over g of L and L̄
(:mod:`fairaudit.metrics.parity`, :mod:`fairaudit.metrics.sup_fairness`), each with its maximiser. Every entry of the
law lies between its two ends, and each metric is monotone in the entries it reads, so each is enclosed by evaluating
it at the right end of each entry (``proofs/verification.md`` §2b).
"""

from __future__ import annotations

import itertools
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
    "max_ratio",
    "observed_checks",
    "observed_enclosures",
    "ratio_of",
]

_UNDEFINED = "fewer than two groups with P(A = a) > 0"


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
    by_a = [_through(sensitive, plane, low) for plane in kernel]  # Σ_ã M_A[a, ã] K[x̃, ã, u], by released context
    if context.kind == "identity":
        return by_a
    n_a, n_u = len(by_a[0]), len(by_a[0][0])
    by_x = _through(context, [[v for row in plane for v in row] for plane in by_a], low)
    return [[row[a * n_u : (a + 1) * n_u] for a in range(n_a)] for row in by_x]


def _through(m: RecordedMechanism, rows: Sequence[Sequence[Fraction]], low: bool) -> list[list[Fraction]]:
    """Σ_ĩ M[i, ĩ] rows[ĩ] for each input i of M, at the low or the high end of M's enclosure (randomized response:
    p rows[i] + q (S − rows[i]), S the sum of the rows)."""
    exact_rows = m.matrix_rows()
    if exact_rows is None:
        p, q = (e.lo if low else e.hi for e in m.rr_rows())
        total = [sum(column) for column in zip(*rows)]
        return [[p * c + q * (t - c) for c, t in zip(row, total)] for row in rows]
    n = len(rows[0])
    return [[sum((w * rows[j][u] for j, w in enumerate(ws) if w), Fraction(0)) for u in range(n)] for ws in exact_rows]


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


_Plane = list[Any]
"""A law by group: per group its row of (low, high) ends, one per decision; None for a group left out."""


@dataclass(frozen=True)
class ObservedEnclosures:
    """The observed L and L̄ behind a mechanism, as enclosed ratios (not logarithms), and the planes they are read from.

    Each plane maps a context's label (None for the plane over groups) to a row per group, None for a group left out:
    a (low, high) pair per decision of the law Q (``"law"``: Q[x, a, u] in each live context; ``"law by group"``:
    P(u | a)), or one pair, E[g] (``"utility"``: E[g | x, a] in each live context; ``"utility by group"``: E[g | a]).
    """

    local: Enclosure  # max over live x of max_a E[g | x, a] / min_a E[g | x, a]
    global_: Enclosure  # max_a E[g | a] / min_a E[g | a], E[g | a] = Σ_x P(x, a) E[g | x, a] / P(a)
    present: int  # the groups with P(A = a) > 0: L̄ is undefined with fewer than two
    planes: dict[str, dict[Any, _Plane]]


def observed_enclosures(
    inputs: Mapping[str, Any], sensitive: RecordedMechanism, context: RecordedMechanism
) -> ObservedEnclosures | str:
    """The observed L and L̄ of the recorded kernel behind ``sensitive`` and ``context``, enclosed; or why not.

    Parameters
    ----------
    inputs : mapping
        A certificate's ``inputs`` (its kernel, utility and population, with its contexts' labels, are used; its
        mechanisms are not).
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
    ...           "population": {"contexts": ["x"], "probabilities": [[0.5, 0.5]]}}
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
    utilities = [[[[e] for e in row] for row in expected_utility(law, g)] for law in laws]  # E[g] as one decision
    contexts, planes = inputs["population"]["contexts"], {}
    for name, ends in (("law", laws), ("utility", utilities)):
        planes[name] = {contexts[x]: [list(zip(lo, hi)) for lo, hi in zip(ends[0][x], ends[1][x])]
                        for x in range(len(pop)) if sum(pop[x]) > 0}  # fmt: skip
        planes[f"{name} by group"] = {None: _group_plane(pop, ends)}
    present = sum(row is not None for row in planes["utility by group"][None])
    return ObservedEnclosures(max_ratio(planes["utility"]), max_ratio(planes["utility by group"]), present, planes)


def observed_checks(
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
        Appended to: what is not re-derived, and why.

    Returns
    -------
    list of Check
        For each section present, as measured values (side "estimate": within the tolerance of the exact value):
        ``local.value`` and ``global.value`` (nats; L̄ null with fewer than two groups present), ``local.ratio``
        and ``global.ratio``; the ratio E[g | x, group] / E[g | x, other_group] at the local maximiser; the ratio E[g | group] / E[g | other_group] at the global maximiser; ``demographic_parity``,
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
    >>> checks = observed_checks({"inputs": inputs, "observed": observed}, m, x, [])
    >>> len(checks), all(c.holds for c in checks)
    (20, True)
    >>> observed["details"]["demographic_parity"]["group"] = "b"  # a swapped pair: -1/2
    >>> [c.name for c in observed_checks({"inputs": inputs, "observed": observed}, m, x, []) if not c.holds]
    ['observed.details.demographic_parity (its pair and event)']
    """
    inputs = cert["inputs"]
    if inputs["kernel"] is None:
        return []
    if "observed" not in cert and "observed_omitted" in cert:
        skipped.append(("observed", f"left out by certify: {cert['observed_omitted']}"))
    population = inputs["population"]
    sections = [("observed", sensitive, context)]
    if inputs["kernel"]["groups"] != population["groups"] or inputs["kernel"]["contexts"] != population["contexts"]:
        if "unfiltered" in cert:
            skipped.append(("unfiltered", "the model's labels are not the population's"))
    else:
        sections.append(("unfiltered", _identity(population["groups"]), _identity(population["contexts"])))
    out: list[Check] = []
    for name, m_a, m_x in sections:
        found = observed_enclosures(inputs, m_a, m_x) if name in cert else None
        if isinstance(found, str):
            skipped.append((name, found))
        elif found is not None:
            out += _section_checks(name, cert[name], found, inputs)
    return out


def max_ratio(planes: dict[Any, _Plane]) -> Enclosure:
    """max over the planes and their decisions of max_a E / min_a E (:func:`ratio_of`), enclosed from each E's (low,
    high) ends.

    Parameters
    ----------
    planes : dict of label to list
        Per plane (a context, or None for the plane over groups), a row per group of (Fraction, Fraction) pairs, the
        enclosure of each decision's quantity E ≥ 0 (one pair for E[g]); None for a group left out. A decision with
        fewer than two groups is left out.

    Returns
    -------
    Enclosure
        The largest ratio: its low end from the low ends of the tops and the high ends of the bottoms, its high
        end the other way round (the ratio increases in the top and decreases in the bottom; 1 when no decision has
        two groups).

    Examples
    --------
    >>> F = Fraction
    >>> max_ratio({"x": [[(F(1), F(2))], [(F(4), F(4))], None], "y": [[(F(1), F(1))]]})
    Enclosure(lo=Fraction(2, 1), hi=Fraction(4, 1))
    """
    columns = [c for plane in planes.values() for c in zip(*(row for row in plane if row is not None)) if len(c) >= 2]

    def ratio(column: Sequence[Any], end: int) -> Fraction | float:  # the low (end 0) or the high (1) end
        return ratio_of(max(e[end] for e in column), min(e[1 - end] for e in column))

    return Enclosure(*(max([Fraction(1), *(ratio(c, end) for c in columns)]) for end in (0, 1)))


def _identity(labels: list[Any]) -> RecordedMechanism:
    """The identity on ``labels``."""
    return RecordedMechanism.from_record({"inputs": labels, "outputs": labels, "kind": "identity"}, "identity")


def _section_checks(
    name: str, section: Mapping[str, Any], found: ObservedEnclosures, inputs: Mapping[str, Any]
) -> list[Check]:
    """The ratios, the maximisers, the gaps and the sups of one section, from its law's enclosures."""
    groups, planes = inputs["population"]["groups"], found.planes
    pairless = len(groups) < 2  # every metric 0 (ratio 1), no pair named
    undefined = not pairless and found.present < 2  # the metrics over groups: NaN, null in JSON
    local, glob, by_e = section["local"], section["global"], (groups, ["E[g]"])
    out = [
        judge(f"{name}.local.value", local["value"], ln_of(found.local), "estimate"),
        judge(f"{name}.local.ratio", local["ratio"], found.local, "estimate"),
        _named(f"{name}.local (its context and groups)", {**local, "decision": "E[g]"}, planes["utility"], by_e,
               False),
        # no pair of groups present: the metrics leave L-bar undefined (NaN, null in JSON)
        _number(f"{name}.global.value", glob["value"], None if found.present < 2 else ln_of(found.global_)),
        _number(f"{name}.global.ratio", glob["ratio"], None if undefined else found.global_),
        _named(f"{name}.global (its groups)", {**glob, "context": None, "decision": "E[g]"},
               planes["utility by group"], by_e, pairless or undefined),
    ]  # fmt: skip
    for key in ("demographic_parity", "equalized_odds", "sup_local", "sup_global"):  # each gap and sup, its detail
        sup, by_group = key.startswith("sup"), key in ("demographic_parity", "sup_global")
        plane = planes["law by group" if by_group else "law"]  # P(u | a), or Q[x, a, u] in the live contexts
        no_pair = pairless or (undefined and by_group)
        ratio = Enclosure.point(Fraction(int(sup))) if pairless else (max_ratio if sup else _max_tv)(plane)
        value = None if undefined and by_group else ln_of(ratio) if sup else ratio  # (a sup's value: ln of its ratio)
        detail, path = section["details"][key], f"{name}.details.{key}"
        out += [_number(f"{name}.{key}", section[key], value), _number(f"{path}.value", detail["value"], value, "")]
        if sup:
            out.append(_number(f"{path}.ratio", detail["ratio"], None if value is None else ratio, ""))
        what = ("context, " if not by_group else "") + ("pair and decision" if sup else "pair and event")
        labels = (groups, inputs["kernel"]["decisions"])
        out.append(_named(f"{path} (its {what})", detail, plane, labels, no_pair))
    return out


def _number(name: str, reported: Any, value: Enclosure | None, undefined: str = _UNDEFINED) -> Check:
    """A measured number within the tolerance of its exact ``value``; null where the metric is undefined (None)."""
    return equal(name, reported, None, undefined) if value is None else judge(name, reported, value, "estimate")


def _group_plane(pop: list[Any], ends: list[Any]) -> _Plane:
    """Σ_x P(x, a) ``T[x][a][u]`` / P(a) per group, at both ends of T (P(u | a) for the law); None where P(A = a) = 0."""

    def mean(end: list[Any], a: int, mass: Fraction) -> list[Fraction]:
        weighted = [[p[a] * v for v in plane[a]] for p, plane in zip(pop, end) if p[a]]
        return [sum(column) / mass for column in zip(*weighted)]

    masses = [sum(column) for column in zip(*pop)]
    return [list(zip(*(mean(end, a, m) for end in ends))) if m else None for a, m in enumerate(masses)]


def _max_tv(planes: dict[Any, _Plane]) -> Enclosure:
    """The largest TV = Σ_u (P_a(u) − P_b(u))⁺ over the planes and their ordered pairs of rows, enclosed (each term
    increases in P_a(u) and decreases in P_b(u): its low end from P_a's low ends and P_b's high ends)."""
    pairs = [
        pair for plane in planes.values() for pair in itertools.permutations([r for r in plane if r is not None], 2)
    ]

    def tv(ra: list[Any], rb: list[Any], end: int) -> Fraction:
        return sum((max(Fraction(0), a[end] - b[1 - end]) for a, b in zip(ra, rb)), Fraction(0))

    return Enclosure(*(max((tv(ra, rb, end) for ra, rb in pairs), default=Fraction(0)) for end in (0, 1)))


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
    plane = planes.get(names[0]) or []  # (the schema types each label, the event a list of them)
    known = (names[1] in groups and names[2] in groups
             and len(set(map(str, picked))) == len(picked) and all(u in decisions for u in picked))  # fmt: skip
    ra, rb = (plane[groups.index(names[1])], plane[groups.index(names[2])]) if known and plane else (None, None)
    if ra is None or rb is None:
        return equal(check, names, "labels of the inputs", f"no such cell: {where}")
    cols = [decisions.index(u) for u in picked]
    if tv:  # P(event | group) − P(event | other_group), at its low (end 0) and its high (1) end
        value = Enclosure(*(sum((ra[u][end] - rb[u][1 - end] for u in cols), Fraction(0)) for end in (0, 1)))
    else:  # ln of P(decision | group) / P(decision | other_group)
        value = ln_of(Enclosure(*(ratio_of(ra[cols[0]][end], rb[cols[0]][1 - end]) for end in (0, 1))))
    return judge(check, detail["value"], value, "estimate", where)
