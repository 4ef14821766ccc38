"""``fairaudit verify``: every certified number of a certificate re-derived from what the certificate records.

:func:`verify` reads a certificate (the JSON of ``fairaudit certify``, checked against its schema), recomputes the
SHA-256 of its ``inputs`` and re-derives, from those inputs alone and in exact rational arithmetic
(:mod:`~fairaudit.verification.enclosures`), each number it can: the mechanisms' ε, the paper, tight and corollary
bounds, the observed local and global g-fairness and their maximising context and groups, and the targets' verdicts.
A number **holds** when it lies on its certified side of the exact value (an upper bound at or above it) and within
:data:`TOLERANCE` of it (so that a number moved by 1e-9 fails); a measured value holds within the tolerance on either
side. Every number it does not re-derive is listed with the reason. It imports neither cvxpy, Clarabel nor scipy.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import TYPE_CHECKING, Any

from fairaudit.base.json_values import Report, canonical_digest, number
from fairaudit.base.outward import fraction_down, fraction_up
from fairaudit.verification.enclosures import (
    INF,
    Enclosure,
    RecordedMechanism,
    exact,
    exp_of,
    ln,
    ln_of,
    recorded_array,
)

if TYPE_CHECKING:
    from fairaudit.filter.filters import PrivacyFilter

__all__ = ["TOLERANCE", "Check", "Verification", "verify"]

TOLERANCE = 1e-12
"""How far (relative to max(1, |value|)) a recorded number may sit from its exact value on its allowed side."""

SIDES = ("upper", "lower", "estimate", "equal", "at most")
"""A check's side: an upper bound (≥ the exact value, within the tolerance), a lower bound, a measured value (either
side), an identity, or a value attained (≤ the exact maximum: a witness)."""


@dataclass(frozen=True, kw_only=True)
class Check:
    """One recorded number against its re-derived value.

    Attributes
    ----------
    name : str
        The number's JSON path (``bounds.tight``).
    reported : float or str or bool or None
        The recorded value.
    derived_low, derived_high : float
        The exact value's enclosure, rounded outward to floats (equal for an exact value).
    side : {"upper", "lower", "estimate", "equal", "at most"}
    holds : bool
    fails_by : float
        How far outside the allowed range the reported value is (0 when it holds).
    detail : str
        What was re-derived, or why it fails.
    """

    name: str
    reported: Any
    derived_low: float
    derived_high: float
    side: str
    holds: bool
    fails_by: float
    detail: str

    def to_dict(self) -> Report:
        """The report dictionary."""
        return {
            "name": self.name,
            "reported": self.reported,
            "derived": [number(self.derived_low), number(self.derived_high)],
            "side": self.side,
            "holds": self.holds,
            "fails_by": number(self.fails_by),
            "detail": self.detail,
        }

    def line(self) -> str:
        """One line: the name, the reported number and ``holds`` or ``fails by X``."""
        verdict = "holds" if self.holds else f"fails by {self.fails_by:.3g}"
        shown = self.reported if not isinstance(self.reported, float) else f"{self.reported!r}"
        return f"{self.name} = {shown}: {verdict}" + (f" ({self.detail})" if self.detail and not self.holds else "")


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

    def to_dict(self) -> Report:
        """The report dictionary: holds, the checks, what was not checked."""
        return {
            "source": self.source,
            "holds": self.holds,
            "checks": [c.to_dict() for c in self.checks],
            "not_checked": [{"name": n, "reason": r} for n, r in self.not_checked],
        }

    def lines(self) -> list[str]:
        """The text report: one line per check, then what was not re-derived, then the verdict."""
        out = [c.line() for c in self.checks]
        out += [f"{n}: not re-derived ({r})" for n, r in self.not_checked]
        n_fail = len(self.failures)
        out.append(
            f"{self.source}: all {len(self.checks)} checked numbers hold"
            if n_fail == 0
            else f"{self.source}: {n_fail} of {len(self.checks)} checked numbers fail"
        )
        return out


def _float(x: Fraction | float, upward: bool) -> float:
    """An exact value as a float on the stated side."""
    if isinstance(x, float):
        return x
    return fraction_up(x) if upward else fraction_down(x)


def _judge(name: str, reported: Any, derived: Enclosure, side: str, detail: str = "") -> Check:
    """The check of a reported number against the enclosure of its exact value, on ``side``."""
    low, high = _float(derived.lo, False), _float(derived.hi, True)
    value = exact(reported, name) if reported is not None else None
    if value is None:
        return Check(name=name, reported=reported, derived_low=low, derived_high=high, side=side, holds=False,
                     fails_by=math.inf, detail="no value recorded")  # fmt: skip
    scale = max(Fraction(1), abs(derived.hi)) if isinstance(derived.hi, Fraction) else Fraction(1)
    slack = Fraction(TOLERANCE) * scale
    if value == INF or derived.hi == INF:
        ok = value == INF and (derived.lo == INF or side == "upper")
        by = 0.0 if ok else math.inf
    else:
        allowed_low = derived.hi if side == "upper" else -INF if side == "at most" else derived.lo - slack
        allowed_high = derived.lo if side in ("lower", "at most") else derived.hi + slack
        if side == "equal":
            allowed_low, allowed_high = derived.lo, derived.hi
        below, above = allowed_low - value, value - allowed_high
        ok = below <= 0 and above <= 0
        by = 0.0 if ok else _float(max(below, above), True)
    return Check(name=name, reported=reported, derived_low=low, derived_high=high, side=side, holds=ok,
                 fails_by=by, detail=detail)  # fmt: skip


def _equal(name: str, reported: Any, expected: Any, detail: str = "") -> Check:
    """A recorded value that must equal the re-derived one exactly (a label, a verdict, a digest)."""
    ok = reported == expected
    return Check(name=name, reported=reported, derived_low=math.nan, derived_high=math.nan, side="equal", holds=ok,
                 fails_by=0.0 if ok else math.inf, detail=detail or f"expected {expected!r}")  # fmt: skip


def verify(
    certificate: Mapping[str, Any], *, privacy_filter: PrivacyFilter | None = None, source: str = "<certificate>"
) -> Verification:
    """Re-derive every number of a certificate that it can from the certificate's ``inputs``, exactly.

    Parameters
    ----------
    certificate : mapping
        A certificate's JSON, as ``fairaudit certify --format json`` writes it (format ``fairaudit-certificate``,
        ``format_version`` 1; checked against ``certificate.schema.json``).
    privacy_filter : PrivacyFilter, optional
        A deployed filter (:class:`fairaudit.PrivacyFilter`, e.g. read by ``PrivacyFilter.from_dict`` from
        ``fairaudit filter --parameters``): checked to be the certified mechanism on the sensitive attribute, or at
        least as private as it. Randomized response holds when the labels agree and the filter's exact ratio
        e^ε is ≤ e^ε of the certificate (a garbling of the certified mechanism, so every bound still holds); a
        matrix when its rows are the certificate's exactly; the identity for any filter on the same labels.
    source : str
        Its name in the report.

    Returns
    -------
    Verification
        One :class:`Check` per number re-derived (``holds`` or ``fails_by``), and the numbers not re-derived with
        the reason.

    Raises
    ------
    InputError
        When the certificate does not match its schema (the field named by its JSON path).

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
    >>> cert["bounds"]["tight"] += 1e-9
    >>> [c.name for c in verify(cert).failures]
    ['bounds.tight']
    """
    from fairaudit.verification.schema import check_certificate

    check_certificate(certificate)
    inputs = certificate["inputs"]
    checks: list[Check] = [
        _equal("inputs_sha256", certificate["inputs_sha256"], canonical_digest(inputs), "the SHA-256 of the inputs")
    ]
    skipped: list[tuple[str, str]] = []
    sensitive = RecordedMechanism.from_record(inputs["sensitive_mechanism"], "inputs.sensitive_mechanism")
    context = RecordedMechanism.from_record(inputs["context_mechanism"], "inputs.context_mechanism")
    eps_a = sensitive.epsilon_enclosure()
    privacy = certificate["privacy"]
    checks.append(_judge("privacy.sensitive.epsilon", privacy["sensitive"]["epsilon"], eps_a, "upper"))
    checks.append(
        _judge("privacy.context.epsilon", privacy["context"]["epsilon"], context.epsilon_enclosure(), "upper")
    )
    checks += _theorem_checks(certificate, sensitive, eps_a, skipped)
    checks += _black_box_checks(certificate, eps_a, skipped)
    checks += _observed_checks(certificate, sensitive, context, skipped)
    checks += _target_checks(certificate)
    if privacy_filter is not None:
        checks.append(_filter_check(sensitive, privacy_filter))
    skipped += [
        ("calibration", "the calibrated epsilon (not re-derived in format version 1)"),
        ("observed.intervals", "statistical intervals are estimates, not certified numbers"),
    ]
    return Verification(source=source, checks=tuple(checks), not_checked=tuple(skipped))


def _theorem_checks(
    cert: Mapping[str, Any], m: RecordedMechanism, eps_a: Enclosure, skipped: list[tuple[str, str]]
) -> list[Check]:
    """The paper, tight and corollary bounds, from the mechanism and the utility class."""
    u = cert["inputs"]["utility"]
    bounds, details = cert["bounds"], cert["bound_details"]
    out = [_judge("bounds.corollary", bounds["corollary"], eps_a, "upper")]
    tau = None if u["tau"] is None else exact(u["tau"], "inputs.utility.tau")
    lipschitz, gamma = exact(u["lipschitz"], "inputs.utility.lipschitz"), exact(u["gamma"], "inputs.utility.gamma")
    diameter = exact(u["diameter"], "inputs.utility.diameter")
    if bounds.get("paper") is None:
        return out
    if tau is None:  # L_A = 0 and pure DP: both forms are epsilon(M)
        out.append(_judge("bounds.paper", bounds["paper"], eps_a, "upper"))
        out.append(_judge("bounds.tight", bounds["tight"], eps_a, "upper"))
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
        out.append(_judge("bound_details.paper.delta", paper["delta"], delta, "upper"))
        recorded_delta = exact(paper["delta"], "bound_details.paper.delta")
        inner = 1 + (lipschitz * diameter + recorded_delta * gamma) / tau
        value = Enclosure(eps_star, eps_star) + ln(inner)
        out.append(_judge("bounds.paper", bounds["paper"], value, "upper", "at its recorded epsilon and delta"))
    if m.k > 64 and m.kind != "randomized_response":
        skipped.append(("bounds.tight", f"{m.k} groups: every pair's minimum is not re-derived beyond 64"))
        return out
    metric = u["metric"]
    tight, _, _ = m.tight_pair_log(lipschitz, gamma, tau, metric)  # type: ignore[arg-type]
    out.append(_judge("bounds.tight", bounds["tight"], tight, "upper", "max over pairs, exactly"))
    return out


def _law(kernel: Sequence[Any], sensitive: RecordedMechanism, context: RecordedMechanism, low: bool) -> list[Any]:
    """E-side law Q[x][a][u] = Σ M_X[x, x̃] M_A[a, ã] K[x̃, ã, u] at one end of the mechanisms' enclosures."""
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


def _expected(law: list[Any], g: list[Any]) -> list[list[Fraction]]:
    """E[g | x, a] = Σ_u Q[x, a, u] g[x, a, u] (g one row over decisions, or a full table)."""
    flat = not isinstance(g[0], list)
    return [
        [sum(q * (g[u] if flat else g[x][a][u]) for u, q in enumerate(cell)) for a, cell in enumerate(plane)]
        for x, plane in enumerate(law)
    ]


def _ratio(top: Fraction, bottom: Fraction) -> Fraction | float:
    """top/bottom with 0/0 = 1 and c/0 = +inf."""
    if bottom == 0:
        return Fraction(1) if top == 0 else INF
    return top / bottom


def _observed_checks(
    cert: Mapping[str, Any], sensitive: RecordedMechanism, context: RecordedMechanism, skipped: list[tuple[str, str]]
) -> list[Check]:
    """The observed local and global g-fairness behind the filter, and their maximising context and groups."""
    inputs = cert["inputs"]
    if inputs["kernel"] is None or "observed" not in cert:
        return []
    kernel = recorded_array(inputs["kernel"]["probabilities"], "inputs.kernel.probabilities")
    if any(v is None for plane in kernel for cell in plane for v in cell):
        skipped.append(("observed", "the kernel has empty cells"))
        return []
    if sensitive.kind == "matrix" and len(sensitive.outputs) * sensitive.k > 10**6:
        skipped.append(("observed", "the mechanism's matrix is too large to compose exactly"))
        return []
    g = recorded_array(inputs["utility"]["values"], "inputs.utility.values")
    pop = recorded_array(inputs["population"]["probabilities"], "inputs.population.probabilities")
    contexts, groups = inputs["population"]["contexts"], inputs["population"]["groups"]
    ends = [_expected(_law(kernel, sensitive, context, low), g) for low in (True, False)]
    live = [x for x in range(len(pop)) if sum(pop[x]) > 0]
    out: list[Check] = []
    obs = cert["observed"]
    local = obs["local"]
    best = _max_ratio([[(e_lo, e_hi) for e_lo, e_hi in zip(ends[0][x], ends[1][x])] for x in live])
    out.append(_judge("observed.local.value", local["value"], ln_of(best[0]), "estimate"))
    named = _named_ratio(ends, contexts.index(local["context"]) if local["context"] in contexts else None,
                         groups, local["group"], local["other_group"])  # fmt: skip
    out.append(_judge("observed.local (its context and groups)", local["value"], ln_of(named), "estimate",
                      f"the ratio at {local['context']!r}: {local['group']!r} over {local['other_group']!r}"))  # fmt: skip
    # global: E[g | a] = Σ_x P(x, a) E[g | x, a] / P(a)
    by_group = []
    for a in range(len(groups)):
        mass = sum(pop[x][a] for x in range(len(pop)))
        if mass == 0:
            continue
        lo = sum(pop[x][a] * ends[0][x][a] for x in range(len(pop))) / mass
        hi = sum(pop[x][a] * ends[1][x][a] for x in range(len(pop))) / mass
        by_group.append((lo, hi))
    glob = obs["global"]
    out.append(_judge("observed.global.value", glob["value"], ln_of(_max_ratio([by_group])[0]), "estimate"))
    return out


def _max_ratio(planes: list[list[tuple[Fraction, Fraction]]]) -> tuple[Enclosure]:
    """max over planes of max_a E / min_a E, enclosed from each E's (low, high) ends."""
    lo: Fraction | float = Fraction(1)
    hi: Fraction | float = Fraction(1)
    for plane in planes:
        if len(plane) < 2:
            continue
        lo = max(lo, _ratio(max(e[0] for e in plane), min(e[1] for e in plane)))
        hi = max(hi, _ratio(max(e[1] for e in plane), min(e[0] for e in plane)))
    return (Enclosure(lo, hi),)


def _named_ratio(ends: list[Any], x: int | None, groups: list[Any], group: Any, other: Any) -> Enclosure:
    """E[g | x, group] / E[g | x, other], enclosed; the empty enclosure [+inf, −inf] when a label is unknown."""
    if x is None or group not in groups or other not in groups:
        return Enclosure(INF, -INF)
    a, b = groups.index(group), groups.index(other)
    return Enclosure(_ratio(ends[0][x][a], ends[1][x][b]), _ratio(ends[1][x][a], ends[0][x][b]))


def _target_checks(cert: Mapping[str, Any]) -> list[Check]:
    """Each target's bound is the certificate's bound, and its verdicts follow from the numbers."""
    out: list[Check] = []
    bounds = cert["bounds"]
    if bounds.get("best_form") not in (None, "none"):
        out.append(_equal("bounds.best", bounds["best"], bounds[bounds["best_form"]], f"bounds.{bounds['best_form']}"))
    for kind, t in (cert.get("targets") or {}).items():
        expected = bounds["best"] if kind == "local" else bounds["global"]
        out.append(_equal(f"targets.{kind}.bound", t["bound"], expected))
        goal, bound = exact(t["target"], f"targets.{kind}.target"), exact(t["bound"], f"targets.{kind}.bound")
        out.append(_equal(f"targets.{kind}.met", t["met"], bound <= goal))
        if t.get("observed") is not None and "observed" in cert:
            out.append(_equal(f"targets.{kind}.observed", t["observed"], cert["observed"][kind]["value"]))
        if t.get("observed") is not None:
            out.append(
                _equal(f"targets.{kind}.observed_met", t["observed_met"], exact(t["observed"], "observed") <= goal)
            )
    return out


def _filter_check(m: RecordedMechanism, f: PrivacyFilter) -> Check:
    """The deployed filter is the certified mechanism on the sensitive attribute, or a garbling of it."""
    from fairaudit.base.json_values import label

    name = "filter"
    labels = [label(v) for v in f.inputs]
    ratio = f.ratio
    eps_f = number(f.epsilon)
    if labels != list(m.inputs) or [label(v) for v in f.outputs] != list(m.outputs):
        return _equal(name, labels, list(m.inputs), "the filter's values are not the certificate's")
    if m.kind == "identity":
        return _equal(name, eps_f, eps_f, "any filter is a garbling of the identity")
    if m.kind == "randomized_response":
        if f.kind != "randomized_response":
            return _equal(name, f.kind, "randomized_response", "the certificate's mechanism is randomized response")
        eps = m.epsilon
        if eps == INF or ratio <= exp_of(eps).lo:  # type: ignore[arg-type]
            return _equal(name, eps_f, eps_f, "the filter's exact e^epsilon is at most the certificate's")
        over = ratio > exp_of(eps).hi  # type: ignore[arg-type]
        why = "exceeds" if over else "cannot be shown to be at most"
        return _equal(name, eps_f, number(eps), f"the filter's exact e^epsilon {why} the certificate's")
    rows = m.matrix_rows()
    exact_rows = tuple(tuple(Fraction(n, f.denominator) for n in row) for row in f.numerator_rows())
    if exact_rows == rows:
        return _equal(name, eps_f, eps_f, "the filter's rows are the certificate's, exactly")
    return _equal(name, "rows differ", "the certificate's rows", "the filter's rows are not the certificate's matrix")


def _below_epsilon(ratio: Enclosure, eps: Enclosure) -> Enclosure:
    """ln of a worst ratio, enclosed, its upper end at most ε(M_A): under pure ε-DP no model's ratio exceeds e^ε
    (post-processing), which decides the ties where the worst case is ε itself."""
    logs = ln_of(ratio)
    return Enclosure(logs.lo, min(logs.hi, eps.hi))


def _black_box_checks(cert: Mapping[str, Any], eps_a: Enclosure, skipped: list[tuple[str, str]]) -> list[Check]:
    """The black-box worst cases on L and L̄, re-derived by exact programs, and the witness below them."""
    from fairaudit.verification.black_box_check import black_box_enclosures

    bounds, detail = cert["bounds"], cert["bound_details"]["black_box"]
    if bounds["black_box"] is None:
        skipped.append(("bounds.black_box", "the certificate gives no black-box bound"))
        return []
    worst = black_box_enclosures(cert["inputs"])
    if worst.local is None:
        skipped.append(("bounds.black_box", worst.reason))
        skipped.append(("bounds.global", worst.reason))
        return []
    local = _below_epsilon(worst.local, eps_a)
    out = [
        _judge("bounds.black_box", bounds["black_box"], local, "upper", "the exact worst case over every model"),
        _equal("bound_details.black_box.value", detail["value"], bounds["black_box"]),
    ]
    if detail.get("witness") is not None:
        out.append(_judge("bound_details.black_box.witness", detail["witness"], local, "at most", "a model attains it"))
    glob = detail.get("global") or {}
    if worst.global_ is None:
        skipped.append(("bounds.global", worst.reason))
    elif glob.get("value") is not None:
        on_l_bar = _below_epsilon(worst.global_, eps_a) if worst.independent else ln_of(worst.global_)
        out.append(_judge("bound_details.black_box.global.value", glob["value"], on_l_bar, "upper"))
        if bounds["global"] == glob["value"]:
            out.append(_equal("bounds.global", bounds["global"], glob["value"], "the black-box bound on L-bar"))
        else:  # L-bar <= L when X and A are independent: the best bound on L
            out.append(_equal("bounds.global", bounds["global"], bounds["best"], "the best bound on L"))
    return out
