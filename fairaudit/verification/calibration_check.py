"""The calibrated ε re-derived: the family's member at that ε, recorded in ``inputs.calibration``, meets the target.

A calibration claims that the member of the spec's family at its ε meets the target: for the black-box calibration,
the worst local g-fairness over every decision model and every utility of the class ([lower, γ], E[g | x, a] ≥ τ,
free of the group) is at most the target (on L̄: that worst case plus ln F when X and A are independent to 1e-9, F the
population's departure from independence; otherwise the exact worst L̄ over every model for the recorded utility);
for the white-box calibration, the observed L (or L̄) of the recorded
model behind that member is. Each is re-derived exactly from the recorded member: its ε (at most the calibration's),
its worst case by the exact programs of :mod:`~fairaudit.verification.black_box_check` (one context, the class's
box [lower, γ]: a utility free of the group enters only through h = Σ_u K g(u) ∈ [lower, γ], and the context
mechanism drops out, ``proofs/black_box.md`` §1 and §6), its observed L by
:mod:`~fairaudit.verification.observed_check`. That ε is the *largest* such, to a relative step of 1e-9, is
re-derived from the member recorded just above it (``inputs.calibration.black_box_above``): it misses the target.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from fractions import Fraction
from typing import Any

from fairaudit.verification.black_box_check import black_box_enclosures
from fairaudit.verification.checks import Check, judge, tolerance
from fairaudit.verification.class_check import lipschitz_class_enclosure
from fairaudit.verification.enclosures import INF, Enclosure, RecordedMechanism, exact, ln, ln_of, recorded_array
from fairaudit.verification.observed_check import observed_enclosures

__all__ = ["calibration_checks"]

_PARAMETER = "the family's parameter: the member's exact epsilon, to the tolerance"
"""What ``calibration.epsilon`` is checked as. It is the family's parameter ε; a product's member is built from
floating-point components (ε split, each matrix rounded), so its exact ε may differ from ε in the last digits: the
member, recorded exactly, is what the bound and the target are re-derived for."""


def calibration_checks(cert: Mapping[str, Any], skipped: list[tuple[str, str]]) -> list[Check]:
    """The black-box and white-box calibrations of a certificate, re-derived from their recorded members.

    Parameters
    ----------
    cert : mapping
        A certificate (checked against its schema).
    skipped : list of (str, str)
        Appended to: what is not re-derived, and why.

    Returns
    -------
    list of Check
        Per calibration: ``calibration.epsilon`` (the member's exact ε, to the tolerance), ``calibration.bound`` (≥ the member's
        exact worst case; for the white box, within the tolerance of the member's exact L),
        ``calibration.target`` (≥ that exact value: the target is met) and ``calibration.epsilon is the largest``
        (the member recorded just above ε misses the target).

    Notes
    -----
    The black-box worst case over the class is ``proofs/black_box.md`` §1 and §5; why each verdict is sound,
    ``proofs/verification.md`` §4b.

    Examples
    --------
    Binary randomized response keeping 0.7, utilities in [0.5, 1]: the worst ratio is 17/13 (``proofs/black_box.md``
    §3), so the target ln(17/13) is met at ε = ln(7/3).

    >>> import json
    >>> from fairaudit.certification.certificate import certify
    >>> from fairaudit.certification.spec import parse_spec
    >>> spec = parse_spec('''
    ... [sensitive]
    ... name = "office"
    ... values = ["HR_1", "HR_2"]
    ... [decision]
    ... name = "chosen"
    ... values = ["yes", "no"]
    ... [privacy.sensitive]
    ... mechanism = "randomized_response"
    ... keep = 0.7
    ... [utility]
    ... kind = "table"
    ... values = [1.0, 0.5]
    ... [target]
    ... local = 0.26826398659467937
    ... ''')
    >>> cert = json.loads(json.dumps(certify(spec).to_dict()))
    >>> [c.line() for c in calibration_checks(cert, [])]
    ['calibration.epsilon = 0.8472978603872036: holds', 'calibration.bound = 0.26826398659467937: holds', 'calibration.target = 0.26826398659467937: holds', 'calibration.epsilon is the largest = 0.8472978603872036: holds']
    """
    cal = cert.get("calibration")
    if cal is None:
        return []
    members = cert["inputs"].get("calibration")
    if members is None:
        skipped.append(("calibration", "the certificate records no calibrated mechanism"))
        return []
    out: list[Check] = []
    if cal.get("epsilon") is not None and members.get("black_box") is not None:
        out += _black_box(cert, cal, members["black_box"], skipped)
    elif cal.get("epsilon") is not None:
        skipped.append(("calibration", "no member recorded at the calibrated epsilon"))
    else:
        skipped.append(("calibration", "no epsilon meets the target: it certifies no member (its reason says why)"))
    white = cal.get("white_box")
    if white is not None and members.get("white_box") is not None:
        out += _white_box(cert, white, members["white_box"], skipped)
    elif white is not None and white.get("epsilon") is None:
        skipped.append(("calibration.white_box", "no epsilon meets the target: it certifies no member"))
    return out


def _member(record: Mapping[str, Any], field: str) -> tuple[RecordedMechanism, Enclosure]:
    m = RecordedMechanism.from_record(record, field)
    return m, m.epsilon_enclosure()


def _black_box(
    cert: Mapping[str, Any], cal: Mapping[str, Any], record: Mapping[str, Any], skipped: list[tuple[str, str]]
) -> list[Check]:
    """The member's ε, and its worst case over every model (on L, or on L̄), at most the bound and the target."""
    m, eps = _member(record, "inputs.calibration.black_box")
    out = [judge("calibration.epsilon", cal["epsilon"], eps, "estimate", _PARAMETER)]
    proofs = cal.get("proofs") or {}
    worst = (
        _on_l_bar(cert, cal, record, m, eps, proofs.get("black_box"))
        if cal.get("kind") == "global"
        else _on_l(cert, cal, record, m, eps, proofs.get("black_box"))
    )
    if isinstance(worst, str):
        skipped += [("calibration.bound", worst), ("calibration.target", worst)]
        return out
    value, basis = worst
    out.append(judge("calibration.bound", cal["bound"], value, "upper", f"the exact {basis} at that epsilon"))
    out.append(judge("calibration.target", cal["target"], value, "at least", f"met by the exact {basis}"))
    above = cert["inputs"]["calibration"].get("black_box_above")
    if above is None and cal["epsilon"] == "inf":
        return [*out, _none_above(LARGEST)]
    if above is None:
        skipped.append((LARGEST, "no member above the calibrated epsilon recorded"))
        return out
    m_above, eps_above = _member(above, "inputs.calibration.black_box_above")
    worst_above = (
        _on_l_bar(cert, cal, above, m_above, eps_above, proofs.get("black_box_above"))
        if cal.get("kind") == "global"
        else _on_l(cert, cal, above, m_above, eps_above, proofs.get("black_box_above"))
    )
    if isinstance(worst_above, str):
        skipped.append((LARGEST, worst_above))
        return out
    out.append(_largest(LARGEST, cal["epsilon"], cal["target"], eps_above, worst_above[0]))
    return out


LARGEST = "calibration.epsilon is the largest"
"""The check that the member just above the calibrated ε misses the target."""

STEP = 2e-9
"""How far above ε (relative to max(1, ε)) the member above may lie: certify records it at ε + 1e-9·max(1, ε)."""


def _largest(name: str, epsilon: Any, target: Any, eps_above: Enclosure, above: Enclosure) -> Check:
    """ε is the largest that meets the target, to the step: the member above has ε' in (ε, ε + :data:`STEP`·max(1, ε)] and
    misses the target (the lower end of its exact value is not below the target by more than the certificate's
    tolerance, :func:`~fairaudit.verification.checks.tolerance`; monotone in ε along the family,
    ``proofs/calibration.md`` §3, so no ε'' ≥ ε' meets it)."""
    eps, goal = exact(epsilon, "calibration.epsilon"), exact(target, "calibration.target")
    if not (isinstance(eps, Fraction) and isinstance(goal, Fraction)):  # +inf: every epsilon meets, none is above
        near = meets = False
    else:
        slack = tolerance() * max(Fraction(1), abs(goal))
        near = eps < eps_above.lo and eps_above.hi <= eps + Fraction(STEP) * max(Fraction(1), eps)
        meets = above.lo != INF and above.lo < goal - slack  # (its lower end: the value may be as low)
    ok = near and not meets
    by = 0.0 if ok else math.inf if not near else float(goal - above.lo)
    detail = (
        "the member above misses the target: no larger epsilon meets it"
        if ok
        else "the member above is not just above epsilon"
        if not near
        else "a larger epsilon meets the target too"
    )
    return Check(name=name, reported=epsilon, derived_low=float(above.lo), derived_high=float(above.hi),
                 side="largest", holds=ok, fails_by=by, detail=detail)  # fmt: skip


def _none_above(name: str) -> Check:
    """ε = +inf is the largest: no ε lies above it (the bound and the target at +inf are checked beside it)."""
    return Check(name=name, reported="inf", derived_low=math.inf, derived_high=math.inf, side="largest", holds=True,
                 fails_by=0.0, detail="epsilon is +inf: no larger epsilon exists")  # fmt: skip


def _on_l(
    cert: Mapping[str, Any],
    cal: Mapping[str, Any],
    record: Mapping[str, Any],
    m: RecordedMechanism,
    eps: Enclosure,
    proof: Mapping[str, Any] | None = None,
) -> tuple[Enclosure, str] | str:
    """ln of the member's worst local ratio over the calibration's class (one context, the box [lower, γ], τ; with
    L_A > 0 the utilities Lipschitz in the group, d the recorded metric), with what it is; or why it is not
    re-derived. ``proof``: the member's recorded black box (``calibration.proofs``), its programs' proofs."""
    lower, gamma = cal.get("lower") or 0.0, cal.get("gamma")
    lipschitz = exact(cal.get("lipschitz") or 0.0, "calibration.lipschitz")
    if lipschitz:
        metric = cert["inputs"]["utility"]["metric"]
        tau = cal.get("tau")
        ratio = lipschitz_class_enclosure(
            m,
            Fraction(exact(lower, "calibration.lower")),
            Fraction(exact(gamma, "calibration.gamma")),
            None if tau is None else Fraction(exact(tau, "calibration.tau")),
            Fraction(lipschitz),
            None if metric is None else recorded_array(metric, "inputs.utility.metric"),
            proof,
        )
        return ratio if isinstance(ratio, str) else (ln_of(ratio), "worst case over the Lipschitz class")
    the_class = {
        "sensitive_mechanism": record,
        "context_mechanism": {"inputs": ["x"], "outputs": ["x"], "kind": "identity"},
        "utility": {"values": [gamma, lower], "tau": cal.get("tau")},
        "population": {"contexts": ["x"], "groups": record["inputs"], "probabilities": [[1.0] * m.k]},
    }
    worst = black_box_enclosures(the_class, proof)
    if worst.local is None:
        return worst.reason
    logs = ln_of(worst.local)
    return Enclosure(logs.lo, min(logs.hi, eps.hi)), "worst case"  # under pure ε-DP no ratio exceeds e^ε


def _on_l_bar(
    cert: Mapping[str, Any],
    cal: Mapping[str, Any],
    record: Mapping[str, Any],
    m: RecordedMechanism,
    eps: Enclosure,
    proof: Mapping[str, Any] | None = None,
) -> tuple[Enclosure, str] | str:
    """ln of the member's worst L̄ as certify bounds it, with what it is; or why it is not re-derived.

    With X and A independent to 1e-9 (max |P(x, a) − P(x) P(a)|, the rule certify applies) L̄ ≤ L + ln F, F = max r /
    min r over r(x, a) = P(x, a)/(P(x) P(a)) (1 when independent exactly; ``proofs/black_box.md`` §6); otherwise
    the exact worst L̄ over every model for the recorded utility, τ, population and context mechanism, behind the
    member."""
    pop = recorded_array(cert["inputs"]["population"]["probabilities"], "inputs.population.probabilities")
    p_x, p_a = [sum(row) for row in pop], [sum(col) for col in zip(*pop)]
    deviation = max(abs(pop[x][a] - p_x[x] * p_a[a]) for x in range(len(p_x)) for a in range(len(p_a)))
    if deviation > Fraction(1e-9):
        worst = black_box_enclosures({**cert["inputs"], "sensitive_mechanism": record}, proof)
        return worst.reason if worst.global_ is None else (ln_of(worst.global_), "worst case on L-bar")
    on_l = _on_l(cert, cal, record, m, eps, proof)
    if isinstance(on_l, str):
        return on_l
    r = [pop[x][a] / (p_x[x] * p_a[a]) for x in range(len(p_x)) if p_x[x] for a in range(len(p_a)) if p_a[a]]
    if max(r) == min(r):
        return on_l[0], "worst case on L (L-bar <= L: X and A independent)"
    if min(r) == 0:  # a cell P(x, a) = 0 with P(x) P(a) > 0 (within 1e-9 of independence): F = +inf
        return Enclosure.point(INF), "worst case on L plus ln F, F = +inf (a cell P(x, a) = 0 with P(x) P(a) > 0)"
    return on_l[0] + ln(max(r) / min(r)), "worst case on L plus ln F (X and A independent within rounding)"


def _white_box(
    cert: Mapping[str, Any], cal: Mapping[str, Any], record: Mapping[str, Any], skipped: list[tuple[str, str]]
) -> list[Check]:
    """The member's ε, and the observed L (or L̄) of the recorded model behind it, the bound and at most the target."""
    m, eps = _member(record, "inputs.calibration.white_box")
    out = [judge("calibration.white_box.epsilon", cal["epsilon"], eps, "estimate", _PARAMETER)]
    context = RecordedMechanism.from_record(cert["inputs"]["context_mechanism"], "inputs.context_mechanism")
    found = observed_enclosures(cert["inputs"], m, context)
    if isinstance(found, str):
        skipped += [("calibration.white_box.bound", found), ("calibration.white_box.target", found)]
        return out
    value = ln_of(found.local if cal.get("kind") == "local" else found.global_)
    out.append(judge("calibration.white_box.bound", cal["bound"], value, "estimate", "the exact L at that epsilon"))
    out.append(
        judge("calibration.white_box.target", cal["target"], value, "met", "met by the exact L, to its rounding")
    )
    name = "calibration.white_box.epsilon is the largest"
    above = cert["inputs"]["calibration"].get("white_box_above")
    if above is None and cal["epsilon"] == "inf":
        return [*out, _none_above(name)]
    if above is None:
        skipped.append((name, "no member above the calibrated epsilon recorded"))
        return out
    m_above, eps_above = _member(above, "inputs.calibration.white_box_above")
    found_above = observed_enclosures(cert["inputs"], m_above, context)
    if isinstance(found_above, str):
        skipped.append((name, found_above))
        return out
    value_above = ln_of(found_above.local if cal.get("kind") == "local" else found_above.global_)
    out.append(_largest(name, cal["epsilon"], cal["target"], eps_above, value_above))
    return out
