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
from collections.abc import Callable, Mapping
from fractions import Fraction
from typing import Any

from fairaudit.verification.black_box_check import black_box_enclosures
from fairaudit.verification.checks import Check, judge, tolerance
from fairaudit.verification.class_check import lipschitz_class_enclosure
from fairaudit.verification.enclosures import (
    INDEPENDENCE,
    INF,
    Enclosure,
    RecordedMechanism,
    below_epsilon,
    exact,
    independence,
    ln,
    ln_of,
    recorded_array,
)
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
        worst = _on_l_bar if cal.get("kind") == "global" else _on_l
        out += _member_checks(cal, "calibration", members, "black_box", lambda r, k: worst(cert, cal, r, k), skipped)
    elif cal.get("epsilon") is not None:
        skipped.append(("calibration", "no member recorded at the calibrated epsilon"))
    else:
        skipped.append(("calibration", "no epsilon meets the target: it certifies no member (its reason says why)"))
    white = cal.get("white_box")
    if white is not None and members.get("white_box") is not None:
        observed = lambda r, k: _observed(cert, white, r, k)  # noqa: E731
        out += _member_checks(white, "calibration.white_box", members, "white_box", observed, skipped)
    elif white is not None and white.get("epsilon") is None:
        skipped.append(("calibration.white_box", "no epsilon meets the target: it certifies no member"))
    return out


Worst = Callable[[Mapping[str, Any], str], "tuple[Enclosure, str] | str"]
"""A member's value from its record and its key in ``inputs.calibration``, with what it is; or why not re-derived."""


def _member_checks(
    cal: Mapping[str, Any],
    where: str,
    members: Mapping[str, Any],
    key: str,
    worst: Worst,
    skipped: list[tuple[str, str]],
) -> list[Check]:
    """The member's ε (``members[key]``); its value (``worst``: the black box's worst case over every model, on L or
    L̄; the white box's observed L or L̄) at most the bound and the target (the white box's: within the tolerance of
    the bound, and meeting the target to its rounding); and the member recorded just above ε missing the target."""
    white = key == "white_box"
    m = RecordedMechanism.from_record(members[key], f"inputs.calibration.{key}")
    out = [judge(f"{where}.epsilon", cal["epsilon"], m.epsilon_enclosure(), "estimate", _PARAMETER)]
    found = worst(members[key], key)
    if isinstance(found, str):
        skipped += [(f"{where}.bound", found), (f"{where}.target", found)]
        return out
    value, basis = found
    detail = f"met by the exact {basis}" + (", to its rounding" if white else "")
    out.append(judge(f"{where}.bound", cal["bound"], value, "estimate" if white else "upper",
                     f"the exact {basis} at that epsilon"))  # fmt: skip
    out.append(judge(f"{where}.target", cal["target"], value, "met" if white else "at least", detail))
    name, above = f"{where}.epsilon is the largest", members.get(f"{key}_above")
    if above is None and cal["epsilon"] == "inf":
        return [*out, _none_above(name)]
    if above is None:
        skipped.append((name, "no member above the calibrated epsilon recorded"))
        return out
    eps_above = RecordedMechanism.from_record(above, f"inputs.calibration.{key}_above").epsilon_enclosure()
    found = worst(above, f"{key}_above")
    if isinstance(found, str):
        skipped.append((name, found))
        return out
    return [*out, _largest(name, cal["epsilon"], cal["target"], eps_above, found[0])]


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
    detail = "the member above misses the target: no larger epsilon meets it"
    if not ok:
        detail = "a larger epsilon meets the target too" if near else "the member above is not just above epsilon"
    return Check(name=name, reported=epsilon, derived_low=float(above.lo), derived_high=float(above.hi),
                 side="largest", holds=ok, fails_by=by, detail=detail)  # fmt: skip


def _none_above(name: str) -> Check:
    """ε = +inf is the largest: no ε lies above it (the bound and the target at +inf are checked beside it)."""
    return Check(name=name, reported="inf", derived_low=math.inf, derived_high=math.inf, side="largest", holds=True,
                 fails_by=0.0, detail="epsilon is +inf: no larger epsilon exists")  # fmt: skip


def _on_l(
    cert: Mapping[str, Any], cal: Mapping[str, Any], record: Mapping[str, Any], key: str
) -> tuple[Enclosure, str] | str:
    """ln of the member's worst local ratio over the calibration's class (one context, the box [lower, γ], τ; with
    L_A > 0 the utilities Lipschitz in the group, d the recorded metric), with what it is; or why it is not
    re-derived. The member is ``record``, ``inputs.calibration.<key>``; its recorded black box (``calibration.proofs``
    under ``key``) holds its programs' proofs."""
    m = RecordedMechanism.from_record(record, f"inputs.calibration.{key}")
    proof = (cal.get("proofs") or {}).get(key)
    lower, gamma = cal.get("lower") or 0.0, cal.get("gamma")
    lipschitz = exact(cal.get("lipschitz") or 0.0, "calibration.lipschitz")
    if lipschitz:
        metric, tau = cert["inputs"]["utility"]["metric"], cal.get("tau")
        low, high = (Fraction(exact(v, f"calibration.{k}")) for k, v in (("lower", lower), ("gamma", gamma)))
        box = (low, high, None if tau is None else Fraction(exact(tau, "calibration.tau")), Fraction(lipschitz))
        metric = None if metric is None else recorded_array(metric, "inputs.utility.metric")
        ratio = lipschitz_class_enclosure(m, *box, metric, proof)
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
    return below_epsilon(worst.local, m.epsilon_enclosure()), "worst case"


def _on_l_bar(
    cert: Mapping[str, Any], cal: Mapping[str, Any], record: Mapping[str, Any], key: str
) -> tuple[Enclosure, str] | str:
    """ln of the member's worst L̄ as certify bounds it, with what it is; or why it is not re-derived.

    With X and A independent to 1e-9 (max |P(x, a) − P(x) P(a)|, the rule certify applies) L̄ ≤ L + ln F, F = max r /
    min r over r(x, a) = P(x, a)/(P(x) P(a)) (1 when independent exactly; ``proofs/black_box.md`` §6); otherwise
    the exact worst L̄ over every model for the recorded utility, τ, population and context mechanism, behind the
    member."""
    deviation, spread = independence(cert["inputs"]["population"]["probabilities"])
    if max(map(max, deviation)) > INDEPENDENCE:
        worst = black_box_enclosures(
            {**cert["inputs"], "sensitive_mechanism": record}, (cal.get("proofs") or {}).get(key)
        )
        return worst.reason if worst.global_ is None else (ln_of(worst.global_), "worst case on L-bar")
    on_l = _on_l(cert, cal, record, key)
    if isinstance(on_l, str):
        return on_l
    if spread == 1:
        return on_l[0], "worst case on L (L-bar <= L: X and A independent)"
    if spread == INF:  # a cell P(x, a) = 0 with P(x) P(a) > 0 (within 1e-9 of independence): F = +inf
        return Enclosure.point(INF), "worst case on L plus ln F, F = +inf (a cell P(x, a) = 0 with P(x) P(a) > 0)"
    return on_l[0] + ln(spread), "worst case on L plus ln F (X and A independent within rounding)"


def _observed(
    cert: Mapping[str, Any], cal: Mapping[str, Any], record: Mapping[str, Any], key: str
) -> tuple[Enclosure, str] | str:
    """ln of the observed L (or L̄) of the recorded model behind the member ``record`` (``inputs.calibration.<key>``)."""
    m = RecordedMechanism.from_record(record, f"inputs.calibration.{key}")
    context = RecordedMechanism.from_record(cert["inputs"]["context_mechanism"], "inputs.context_mechanism")
    found = observed_enclosures(cert["inputs"], m, context)
    return (
        found if isinstance(found, str) else (ln_of(found.local if cal.get("kind") == "local" else found.global_), "L")
    )
