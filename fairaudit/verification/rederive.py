"""``fairaudit verify``: every certified number of a certificate re-derived from what the certificate records.

:func:`verify` reads a certificate (the JSON of ``fairaudit certify``, checked against its schema), recomputes the
SHA-256 of its ``inputs`` and re-derives, from those inputs alone and in exact rational arithmetic
(:mod:`~fairaudit.verification.enclosures`), each number it can: the mechanisms' ε, the paper, tight and corollary
bounds, every metric of the ``observed`` and ``unfiltered`` sections (L and L̄, L_dp and L_eo, the sups over g, their
ratios) with each maximiser (:mod:`~fairaudit.verification.observed_check`), and the targets' verdicts.
Each is a :class:`~fairaudit.verification.checks.Check`: it **holds** when it lies on its certified side of the exact
value (an upper bound at or above it) and within the certificate's stated ``tolerance`` of it (1e-9 as certify
writes it), relative to max(1, |value|), so that a number moved by 2e-9·max(1, |value|) fails; a measured value
holds within the tolerance on either side. Every number it does not re-derive is listed with the reason. It imports
neither cvxpy, Clarabel nor scipy.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

from fairaudit.verification.accounting import unaccounted
from fairaudit.verification.black_box_check import black_box_enclosures, pair_enclosure
from fairaudit.verification.calibration_check import calibration_checks
from fairaudit.verification.checks import Check, equal, judge, stated_tolerance
from fairaudit.verification.enclosures import (
    INDEPENDENCE,
    INF,
    Enclosure,
    RecordedMechanism,
    below_epsilon,
    exact,
    exp_of,
    independence,
    ln,
    ln_of,
)
from fairaudit.verification.observed_check import observed_checks
from fairaudit.verification.recorded_check import distribution_checks, recorded_checks
from fairaudit.verification.schema import CertificateError, check_certificate
from fairaudit.verification.verdict_check import verdict_checks

__all__ = ["Verification", "canonical_digest", "verify"]

TIGHT_GROUPS = 256
"""The most groups of a matrix whose tight bound is re-derived (every ordered pair's minimum over ε, exactly: 256
groups × 256 released values take about 2 s)."""


@dataclass(frozen=True, kw_only=True)
class Verification:
    """The result of :func:`verify`.

    Attributes
    ----------
    source : str
        Where the certificate came from (a path, or ``"<certificate>"``).
    checks : tuple of Check
    not_checked : tuple of (str, str)
        Numbers not re-derived, with the reason.
    holds : bool
        Every check holds.
    """

    source: str
    checks: tuple[Check, ...]
    not_checked: tuple[tuple[str, str], ...]

    @property
    def holds(self) -> bool:
        """True when every check holds."""
        return all(c.holds for c in self.checks)

    @property
    def failures(self) -> tuple[Check, ...]:
        """The checks that fail."""
        return tuple(c for c in self.checks if not c.holds)

    def to_dict(self) -> dict[str, Any]:
        """The report dictionary: holds, the checks, what was not checked."""
        return {
            "source": self.source,
            "holds": self.holds,
            "checks": [c.to_dict() for c in self.checks],
            "not_checked": [{"name": n, "reason": r} for n, r in self.not_checked],
        }

    def lines(self) -> list[str]:
        """The text report: one line per check, then what was not re-derived, then the verdict."""
        n_fail, n = len(self.failures), len(self.checks)
        verdict = f"all {n} checked numbers hold" if n_fail == 0 else f"{n_fail} of {n} checked numbers fail"
        skipped = [f"{name}: not re-derived ({reason})" for name, reason in self.not_checked]
        return [c.line() for c in self.checks] + skipped + [f"{self.source}: {verdict}"]


def verify(
    certificate: Mapping[str, Any], *, privacy_filter: Any = None, source: str = "<certificate>"
) -> Verification:
    """Re-derive every number of a certificate that it can from the certificate's ``inputs``, exactly.

    Parameters
    ----------
    certificate : mapping
        A certificate's JSON, as ``fairaudit certify --format json`` writes it (format ``fairaudit-certificate``,
        ``format_version`` 2; checked against ``certificate.schema.json``).
    privacy_filter : mapping, optional
        A deployed filter's parameters, the JSON ``fairaudit filter --parameters`` writes (docs/filter.md, "The
        JSON"), or an object whose ``to_dict()`` gives them (a :class:`fairaudit.PrivacyFilter`), read here exactly:
        checked to be the certified mechanism on the sensitive attribute, or at least as private as it. Randomized
        response holds when the labels agree and the filter's exact ratio e^ε = keep/move is ≤ e^ε of the
        certificate (a garbling of the certified mechanism, so every bound still holds); a matrix or a product when
        its rows are the certificate's exactly; the identity for any filter on the same labels.
    source : str
        Its name in the report.

    Returns
    -------
    Verification
        One :class:`Check` per number re-derived (``holds`` or ``fails_by``), judged to the ``tolerance`` the
        certificate states, and the numbers not re-derived with the reason.

    Raises
    ------
    CertificateError
        When the certificate does not match its schema (the field named by its JSON path), its ``tolerance``
        included (a number above 0 and at most 1e-6), or ``privacy_filter`` is not a filter's parameters.

    Examples
    --------
    >>> from fairaudit.certification.spec import parse_spec
    >>> from fairaudit.certification.certificate import certify
    >>> cert = certify(parse_spec('''
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
    ... decision = "yes"
    ... tau = 0.25
    ... ''')).to_dict()
    >>> verify(cert).holds
    True
    >>> cert["bounds"]["tight"] += 2e-9 * max(1.0, cert["bounds"]["tight"])  # twice the tolerance it states
    >>> cert["tolerance"], [c.name for c in verify(cert).failures]
    (1e-09, ['bound_details.tight.value', 'bounds.tight'])
    """
    check_certificate(certificate)
    with stated_tolerance(certificate["tolerance"]):  # every number is judged to it, and only during this verify
        return _rederived(certificate, privacy_filter, source)


def canonical_digest(value: Any) -> str:
    """SHA-256 (hex) of a JSON value's canonical text, as certify computes ``inputs_sha256`` (docs/certificates.md):
    keys sorted, no spaces, UTF-8, floats as ``repr``.

    Raises
    ------
    ValueError
        On NaN or an infinity (a certificate writes ``"inf"``).

    Examples
    --------
    >>> canonical_digest({"b": [0.1], "a": "inf"}) == hashlib.sha256(b'{"a":"inf","b":[0.1]}').hexdigest()
    True
    """
    text = json.dumps(value, sort_keys=True, separators=(",", ":"), ensure_ascii=False, allow_nan=False)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def _rederived(certificate: Mapping[str, Any], privacy_filter: Any, source: str) -> Verification:
    """:func:`verify`'s checks of a certificate that matches its schema, at the tolerance it states."""
    inputs = certificate["inputs"]
    checks: list[Check] = [
        equal("inputs_sha256", certificate["inputs_sha256"], canonical_digest(inputs), "the SHA-256 of the inputs")
    ]
    checks += distribution_checks(inputs)
    skipped: list[tuple[str, str]] = []
    sensitive = RecordedMechanism.from_record(inputs["sensitive_mechanism"], "inputs.sensitive_mechanism")
    context = RecordedMechanism.from_record(inputs["context_mechanism"], "inputs.context_mechanism")
    eps_a = sensitive.epsilon_enclosure()
    privacy = certificate["privacy"]
    checks.append(judge("privacy.sensitive.epsilon", privacy["sensitive"]["epsilon"], eps_a, "upper"))
    checks.append(judge("privacy.context.epsilon", privacy["context"]["epsilon"], context.epsilon_enclosure(), "upper"))
    checks += _theorem_checks(certificate, sensitive, eps_a, skipped)
    checks += _black_box_checks(certificate, eps_a, skipped)
    checks += observed_checks(certificate, sensitive, context, skipped)
    checks += _target_checks(certificate)
    if privacy_filter is not None:
        parameters = privacy_filter.to_dict() if hasattr(privacy_filter, "to_dict") else privacy_filter
        checks.append(_filter_check(sensitive, parameters))
    checks += calibration_checks(certificate, skipped)
    checks += recorded_checks(certificate, sensitive, context)
    checks += verdict_checks(certificate, skipped)
    skipped += unaccounted(certificate, checks, skipped)
    return Verification(source=source, checks=tuple(checks), not_checked=tuple(skipped))


def _theorem_checks(
    cert: Mapping[str, Any], m: RecordedMechanism, eps_a: Enclosure, skipped: list[tuple[str, str]]
) -> list[Check]:
    """The paper, tight and corollary bounds, from the mechanism and the utility class."""
    u = cert["inputs"]["utility"]
    bounds, details = cert["bounds"], cert["bound_details"]
    out = [judge("bounds.corollary", bounds["corollary"], eps_a, "upper")]
    for form in ("paper", "tight", "corollary"):  # (each a theorem_bound of the schema where present)
        if form in details:
            out.append(equal(f"bound_details.{form}.value", details[form]["value"], bounds[form], f"bounds.{form}"))
    corollary = details["corollary"]
    out.append(equal("bound_details.corollary.epsilon", corollary["epsilon"], bounds["corollary"], "the bound"))
    out.append(equal("bound_details.corollary.delta", corollary["delta"], 0.0, "the corollary is pure"))
    tau = None if u["tau"] is None else exact(u["tau"], "inputs.utility.tau")
    lipschitz, gamma, diameter = (exact(u[k], f"inputs.utility.{k}") for k in ("lipschitz", "gamma", "diameter"))
    if bounds["paper"] is None:
        return out
    if tau is None:  # L_A = 0 and pure DP: both forms are epsilon(M)
        out.append(judge("bounds.paper", bounds["paper"], eps_a, "upper"))
        if "paper" in details:
            out.append(equal("bound_details.paper.delta", details["paper"]["delta"], 0.0, "pure: the bound is epsilon"))
        out.append(judge("bounds.tight", bounds["tight"], eps_a, "upper"))
        return out
    if tau == INF or lipschitz == INF or gamma == INF:
        skipped.append(("bounds.paper", "an infinite class parameter"))
        return out
    paper = details["paper"]
    eps_star = exact(paper["epsilon"], "bound_details.paper.epsilon")
    if eps_star == INF:
        skipped.append(("bounds.paper", "its epsilon is infinite"))
    else:
        delta = m.largest_delta(eps_star)  # type: ignore[arg-type]
        out.append(judge("bound_details.paper.delta", paper["delta"], delta, "upper"))
        recorded_delta = exact(paper["delta"], "bound_details.paper.delta")
        value = Enclosure.point(eps_star) + ln(1 + (lipschitz * diameter + recorded_delta * gamma) / tau)
        out.append(judge("bounds.paper", bounds["paper"], value, "upper", "at its recorded epsilon and delta"))
    if m.k > TIGHT_GROUPS and m.kind != "randomized_response":
        skipped.append(("bounds.tight", f"{m.k} groups: every pair's minimum is not re-derived beyond {TIGHT_GROUPS}"))
        return out
    tight, _, _ = m.tight_pair_log(lipschitz, gamma, tau, u["metric"])  # type: ignore[arg-type]
    out.append(judge("bounds.tight", bounds["tight"], tight, "upper", "max over pairs, exactly"))
    return out


def _target_checks(cert: Mapping[str, Any]) -> list[Check]:
    """Each target's bound is the certificate's bound, and its verdicts follow from the numbers."""
    bounds, form = cert["bounds"], cert["bounds"]["best_form"]
    expected, why = ("inf", "no form gives a bound: +inf") if form == "none" else (bounds[form], f"bounds.{form}")
    out = [equal("bounds.best", bounds["best"], expected, why)]
    for kind, t in (cert.get("targets") or {}).items():
        expected = bounds["best"] if kind == "local" else bounds["global"]
        out.append(equal(f"targets.{kind}.bound", t["bound"], expected))
        goal, bound = exact(t["target"], f"targets.{kind}.target"), exact(t["bound"], f"targets.{kind}.bound")
        out.append(equal(f"targets.{kind}.met", t["met"], bound <= goal))
        if t.get("observed") is not None:
            if "observed" in cert:
                out.append(equal(f"targets.{kind}.observed", t["observed"], cert["observed"][kind]["value"]))
            met = exact(t["observed"], "observed") <= goal
            out.append(equal(f"targets.{kind}.observed_met", t["observed_met"], met))
    return out


def _filter_check(m: RecordedMechanism, parameters: Mapping[str, Any]) -> Check:
    """The deployed filter (its parameters) is the certified mechanism on the sensitive attribute, or a garbling of it;
    the ε the parameters record is only shown (what is judged is read from their rows)."""
    kind, inputs, outputs, den, rows = _filter_rows(parameters, "privacy_filter")

    def verdict(holds: bool, detail: str) -> Check:
        return Check(name="filter", reported=parameters.get("epsilon"), derived_low=math.nan, derived_high=math.nan,
                     side="equal", holds=holds, fails_by=0.0 if holds else math.nan, detail=detail)  # fmt: skip

    labels = [_label(v) for v in inputs]
    if labels != list(m.inputs) or [_label(v) for v in outputs] != list(m.outputs):
        return verdict(False, f"the filter's values {labels} are not the certificate's {list(m.inputs)}")
    if m.kind == "identity":
        return verdict(True, "any filter is a garbling of the identity")
    if m.kind == "randomized_response":
        if kind != "randomized_response":
            return verdict(False, f"the filter is a {kind}; the certificate's mechanism is randomized response")
        low, high = sorted((int(parameters["keep"]), int(parameters["move"])))
        ratio = Fraction(1) if len(inputs) < 2 else INF if low == 0 else Fraction(high, low)  # e^epsilon, exactly
        t = m.t()  # (the schema's epsilon >= 0: e^epsilon's lower end is at least 1 unclamped too)
        if ratio <= t.lo:
            return verdict(True, "the filter's exact e^epsilon is at most the certificate's")
        why = "exceeds" if ratio > t.hi else "cannot be shown to be at most"
        return verdict(False, f"the filter's exact e^epsilon {why} the certificate's")
    if tuple(tuple(Fraction(n, den) for n in row) for row in rows) == m.matrix_rows():
        return verdict(True, "the filter's rows are the certificate's, exactly")
    return verdict(False, "the filter's rows are not the certificate's matrix")


def _filter_rows(data: Any, where: str) -> tuple[str, list[Any], list[Any], int, list[list[int]]]:
    """A filter's parameters (docs/filter.md, "The JSON") read exactly: its kind, inputs and outputs (JSON labels, a
    product's the lists of its components'), its denominator and its integer rows (randomized response's from keep
    and move, a product's the Kronecker product of its components'), each row checked to be a distribution over the
    denominator.

    Raises
    ------
    CertificateError
        Naming ``where`` (``privacy_filter.components[1]``) when a field is missing or malformed, or a row is not
        whole numbers ≥ 0 summing to the denominator.
    """
    try:
        kind = data["mechanism"]
        if kind == "product":
            parts = [_filter_rows(c, f"{where}.components[{i}]") for i, c in enumerate(data["components"])]
            inputs = [list(t) for t in itertools.product(*(p[1] for p in parts))]
            outputs = [list(t) for t in itertools.product(*(p[2] for p in parts))]
            tables = itertools.product(*(p[4] for p in parts))
            rows = [[math.prod(x) for x in itertools.product(*row)] for row in tables]
            return kind, inputs, outputs, math.prod(p[3] for p in parts), rows
        den = int(data["denominator"])
        if kind == "randomized_response":
            inputs = outputs = list(data["values"])
            keep, move, k = int(data["keep"]), int(data["move"]), len(inputs)
            rows = [[keep if o == a else move for o in range(k)] for a in range(k)]
        else:
            inputs, outputs = list(data["inputs"]), list(data["outputs"])
            rows = [list(map(int, r)) for r in data["rows"]]
    except CertificateError:
        raise
    except (KeyError, TypeError, ValueError) as exc:
        raise CertificateError(where, f"is not a filter's parameters (filter --parameters): {exc!r}") from None
    valid = kind in ("matrix", "randomized_response") and len(rows) == len(inputs) and all(
        len(r) == len(outputs) and min(r, default=0) >= 0 and sum(r) == den for r in rows)  # fmt: skip
    if not valid or den <= 0:
        raise CertificateError(where, "must have rows of whole numbers >= 0 summing to its denominator", den)
    return kind, inputs, outputs, den, rows


def _label(value: Any, inner: bool = False) -> Any:
    """A filter's JSON label as a certificate writes it: a list (a tuple of labels) its parts joined with " & ", a part
    that is text with spaces around it quoted (fairaudit's ``format_label``).

    >>> _label(["f", [" x", 1]]), _label(" x")
    ("f & ' x' & 1", ' x')
    """
    if isinstance(value, list):
        return " & ".join(_label(v, True) for v in value)
    if not inner:
        return value
    text = str(value)
    return repr(text) if isinstance(value, str) and (not text or text != text.strip()) else text


def _witness_checks(
    where: str,
    detail: Mapping[str, Any],
    ratio: Enclosure,
    value: Enclosure,
    eps: Enclosure | None,
    skipped: list[tuple[str, str]] | None,
) -> list[Check]:
    """A worst case's ratio (e^value, an upper end, at most e^ε where ``eps``, ε(M_A), is given), its witness (a model
    attains it: at most the exact value) and the gap (at least the value less the witness). With ``skipped`` (the
    upper end rests on recorded duals, the lower end on the recorded witness point), a witness above the lower end is listed there, not failed: the point recorded
    does not attain it exactly, which does not show that no model does."""
    out = []
    if skipped is not None and detail.get("witness") is not None and value.lo != INF:
        witness = exact(detail["witness"], f"{where}.witness")
        if witness != INF and witness > value.lo:
            skipped.append((f"{where}.witness", "the recorded witness point does not attain it exactly"))
            detail = {k: v for k, v in detail.items() if k != "witness"}
    if detail.get("ratio") is not None:
        top: Fraction | float = ratio.hi
        if eps is not None and eps.hi != INF:  # under pure epsilon-DP no ratio exceeds e^epsilon
            top = min(top, exp_of(eps.hi).hi)  # type: ignore[arg-type, assignment]
        bottom: Fraction | float = min(ratio.lo, top)
        out.append(judge(f"{where}.ratio", detail["ratio"], Enclosure(bottom, top), "upper", "e^value"))
    if detail.get("witness") is not None:
        out.append(judge(f"{where}.witness", detail["witness"], value, "at most", "a model attains it"))
        if detail.get("gap") is not None and detail.get("value") not in (None, "inf"):
            difference = exact(detail["value"], f"{where}.value") - exact(detail["witness"], f"{where}.witness")
            out.append(judge(f"{where}.gap", detail["gap"], Enclosure.point(difference), "upper", "value - witness"))
    return out


def _global_from_best(cert: Mapping[str, Any]) -> Check:
    """``bounds.global`` from L's best bound: L-bar <= L + ln F, F = max r / min r with r(x, a) = P(x, a)/(P(x) P(a))
    over P(x) > 0 and P(a) > 0 (1 when X and A are independent exactly; ``proofs/black_box.md`` §6). The bound
    holds whatever F; certify gives it for X and A independent to 1e-9 (:data:`~fairaudit.verification.enclosures.INDEPENDENCE`, its
    ``Population.independence`` rule evaluated in floats: within 2^-40 relative of it, either reading is accepted), and
    +inf beyond."""
    bounds, (deviation, spread) = cert["bounds"], independence(cert["inputs"]["population"]["probabilities"])
    if spread == 1:
        return equal("bounds.global", bounds["global"], bounds["best"], "the best bound on L")
    if spread == INF:
        return equal("bounds.global", bounds["global"], "inf", "X and A dependent: no bound from L")
    if bounds["global"] == "inf" and max(map(max, deviation)) >= INDEPENDENCE * (1 - Fraction(1, 2**40)):
        return equal(
            "bounds.global", "inf", "inf", "X and A dependent beyond 1e-9: certify bounds L-bar from L no more"
        )
    best = exact(bounds["best"], "bounds.best")
    return judge("bounds.global", bounds["global"], Enclosure.point(best) + ln(spread), "upper",
                 "the best bound on L + ln F (X and A independent within rounding)")  # fmt: skip


PAIR_TOLERANCE = 1e-8
"""How far (relative to max(1, |value|)) below a worst case the pair a certificate names may reach: the search keeps
the earlier of two pairs whose solved values lie within the solver's 1e-9, so the pair named is a maximiser to that
accuracy, not to the last digit (the value is an upper end over every pair all the same)."""


def _maximiser(
    name: str, where: Mapping[str, Any], local: bool, inputs: Any, recorded: Any, eps: Enclosure | None, skip: list[Any]
) -> list[Check]:
    """The black box's named context and pair (``where``: its context and groups, or L̄'s groups) attain its worst case
    (to :data:`PAIR_TOLERANCE`): a swapped pair fails, judged by the named pair's own worst case from ``inputs`` and the
    ``recorded`` black box (:func:`~fairaudit.verification.black_box_check.pair_enclosure`): on L at the named context
    (``local``), or on L̄. ``eps``, where given, is ε(M_A), at most which a pair's reach is, as for the values
    (:func:`~fairaudit.verification.enclosures.below_epsilon`: beyond ε = 10^6 the upper end is solved at the
    identity, where a pair's ratio may be c/0). Where a recorded dual (or the relaxation) gives the pair's upper end, a
    pair whose upper end reaches the value but whose lower end (the recorded point's) does not is listed in
    ``skip``: its upper end does not show that it attains the value."""
    context, group, other = where.get("context") if local else None, where.get("group"), where.get("other_group")
    labels = " vs ".join(str(v) for v in ((context,) if local else ()) + (group, other))
    value = exact(where["value"], name)
    if where.get("certified") is False:  # (an inexact solve's value: its pair need only reach its witness)
        if where.get("witness") is None:
            skip.append((name, "the value is not certified and no witness is recorded"))
            return []
        value = exact(where["witness"], name)
    ratio, from_duals = pair_enclosure(inputs, recorded, group, other, context)
    reach = None if ratio is None else below_epsilon(ratio, eps).hi
    if reach is None:
        ok = False
    elif value == INF or reach == INF:
        ok = reach == value
    else:
        v = Fraction(value)
        enough = v - Fraction(PAIR_TOLERANCE) * max(Fraction(1), abs(v))
        ok = Fraction(reach) >= enough
        if ok and from_duals and ratio is not None and ln_of(ratio).lo < enough:
            skip.append((name, "its program is bounded by a recorded dual; the recorded point does not reach"))
            return []
    why = "its exact worst case reaches the value" if ok else "the named pair does not reach the value"
    return [equal(name, labels, labels if ok else "a pair that reaches the value", why)]


def _black_box_checks(cert: Mapping[str, Any], eps_a: Enclosure, skipped: list[tuple[str, str]]) -> list[Check]:
    """The black-box worst cases on L and L̄, re-derived by exact programs, and the witness below them."""
    bounds, detail = cert["bounds"], cert["bound_details"]["black_box"]
    if bounds["black_box"] is None:
        skipped += [
            (n, "the certificate gives no black-box bound") for n in ("bounds.black_box", "bound_details.black_box")
        ]
        return [] if bounds.get("global") is None else [_global_from_best(cert)]  # L-bar from L, or +inf
    worst = black_box_enclosures(cert["inputs"], detail)
    if worst.local is None:
        skipped += [(n, worst.reason) for n in ("bounds.black_box", "bounds.global", "bound_details.black_box")]
        return []
    eps = eps_a if worst.group_free else None  # (L <= epsilon(M_A) for a utility free of the group)
    local = below_epsilon(worst.local, eps)
    out = [
        judge("bounds.black_box", bounds["black_box"], local, "upper", "the exact worst case over every model"),
        equal("bound_details.black_box.value", detail["value"], bounds["black_box"]),
    ]
    evidence = skipped if worst.from_duals else None
    out += _witness_checks("bound_details.black_box", detail, worst.local, local, eps, evidence)
    glob, inputs = detail.get("global") or {}, cert["inputs"]
    out += _maximiser("bound_details.black_box (its context and groups)", detail, True, inputs, detail, eps, skipped)
    eps_bar = eps if worst.independent else None  # (and L-bar <= epsilon(M_A) too where X and A are independent)
    if worst.global_ is not None and glob.get("value") is not None and glob.get("group") is not None:
        out += _maximiser("bound_details.black_box.global (its groups)", glob, False, inputs, detail, eps_bar, skipped)
    if worst.global_ is None:
        skipped += [("bounds.global", worst.reason), ("bound_details.black_box.global", worst.reason)]
    elif glob.get("value") is not None:
        on_l_bar = below_epsilon(worst.global_, eps_bar)
        if glob.get("certified") is False:  # (an inexact solve's: certify gives no bound from it, bounds.global)
            why = f"not certified by certify (solver status {glob.get('solver_status')}): its witness is checked"
            skipped += [("bound_details.black_box.global.value", why), ("bound_details.black_box.global.ratio", why)]
            glob = {k: v for k, v in glob.items() if k != "ratio"}
        else:
            out.append(judge("bound_details.black_box.global.value", glob["value"], on_l_bar, "upper"))
        out += _witness_checks("bound_details.black_box.global", glob, worst.global_, on_l_bar, eps_bar, evidence)
        if bounds["global"] == glob["value"]:
            out.append(equal("bounds.global", bounds["global"], glob["value"], "the black-box bound on L-bar"))
        elif bounds["global"] == "inf":  # no bound on L-bar (a black box whose assumptions fail, X and A dependent)
            out.append(equal("bounds.global", bounds["global"], "inf", "no bound: +inf bounds every value"))
        else:  # L-bar <= L + ln F when X and A are independent (within rounding: F > 1): the best bound on L
            out.append(_global_from_best(cert))
    return out
