"""One certificate from a spec: privacy, bounds, observed metrics, targets, assumptions.

:func:`certify` gathers, for the mechanism M_A (and M_X) of a spec:

* the privacy of each mechanism (pure ε in nats, δ = 0 at it, keep probability);
* the bounds on local g-fairness L that hold for *any* decision model behind
  the filter: ``paper`` and ``tight`` (main theorem; need τ), ``black_box``
  (the exact maxima of L and L̄ over every decision model, for the spec's
  utility and τ, with the worst model), ``corollary`` (ε, for g independent
  of the group);
* with a model in the spec: the observed metrics of the system *behind* the
  filter (the model's table composed with the mechanisms) and of the model
  on its own (``unfiltered``, as if it saw the true attributes);
* with a target: whether the best valid bound meets it, and the largest ε of
  the spec's mechanism family that would (the ``calibration``: black-box, and
  with a model also white-box; :func:`fairaudit.worstcase.calibration.calibrate`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

from fairaudit.base.errors import InputError, UnderflowError
from fairaudit.base.json_values import Report, canonical_digest, label, number
from fairaudit.base.outward import log_up, up
from fairaudit.base.progress import progress_shown
from fairaudit.certification.recorded_inputs import (
    CERTIFICATE_FORMAT,
    FORMAT_VERSION,
    certificate_inputs,
    member_proofs,
)
from fairaudit.certification.spec import Spec, load_spec
from fairaudit.data.counts import CountTable
from fairaudit.laws.composition import compose
from fairaudit.laws.independence import independence_factor
from fairaudit.laws.mechanisms import Mechanism
from fairaudit.laws.tables import Kernel, Law
from fairaudit.laws.utilities import UtilityClass
from fairaudit.metrics.assumptions import Assumption, check_assumptions
from fairaudit.metrics.bounds import Bound, corollary_bound, paper_bound, tight_bound
from fairaudit.metrics.observed import Observed, observe
from fairaudit.statistics.intervals import FairnessIntervals, IntervalOptions, fairness_intervals, interval_options
from fairaudit.worstcase.calibration import calibrate
from fairaudit.worstcase.calibration_result import Calibration
from fairaudit.worstcase.calibration_search import EPS_MAX
from fairaudit.worstcase.known_utility import worst_model
from fairaudit.worstcase.worst_cases import WorstModel

if TYPE_CHECKING:
    from fairaudit.certification.spec_schema import TargetSpec

__all__ = ["Certificate", "Observed", "TargetCheck", "certify", "observe"]

LARGEST_STEP = 1e-9
"""A calibration records its family's member at ε + LARGEST_STEP·max(1, ε) too (rounded up): that member misses the
target, which ``fairaudit verify`` re-derives, so ε is the largest that meets it to this relative step."""

TOLERANCE = 1e-9
"""The certificate's relative tightness contract, written as its ``tolerance``: every certified upper bound is sound
(at or above the exact value) and at most ``TOLERANCE``·max(1, |value|) above it (a lower bound as far below it; a
measured value within it on either side). ``fairaudit verify`` judges the certificate's numbers to it."""

DEFAULT_INTERVALS = IntervalOptions()
"""The intervals :func:`certify` makes unless told otherwise: 95%, by the method that suits the utility."""


@dataclass(frozen=True, kw_only=True)
class TargetCheck:
    """A fairness target and how the certificate and the observed value meet it.

    Attributes
    ----------
    kind : {"local", "global"}
    target : float
        nats.
    bound : float
        The best valid certified bound (+inf when none applies).
    met : bool
        ``bound <= target``: met for any decision model behind the filter.
    observed : float or None
        The observed value behind the filter, when the spec has a model.
    observed_met : bool or None
    reason : str
        Why the bound is what it is (which form, or why none applies).
    """

    kind: str
    target: float
    bound: float
    met: bool
    observed: float | None
    observed_met: bool | None
    reason: str

    def to_dict(self) -> Report:
        """The report dictionary: target, met, bound, observed, observed_met, reason."""
        return {
            "target": number(self.target),
            "met": self.met,
            "bound": number(self.bound),
            "observed": number(self.observed),
            "observed_met": self.observed_met,
            "reason": self.reason,
        }


@dataclass(frozen=True, eq=False, kw_only=True)
class Certificate:
    """The result of :func:`certify`; repeats its spec.

    Attributes
    ----------
    spec : Spec
    paper, tight : Bound or None
        None when the spec gives no τ.
    black_box : WorstModel
        The exact maxima of L (``.local_fairness``) and L̄ (``.global_fairness``) over every
        decision model behind the filter, for the spec's utility and τ
        (:func:`fairaudit.worstcase.known_utility.worst_model`), with the worst kernels.
    corollary : Bound
    best : float
        The smallest bound on L whose assumptions are not violated, nats.
    best_form : str
    global_bound : float
        The bound on L̄ (equal to ``best`` when X ⊥ A holds; +inf otherwise).
    observed, unfiltered : Observed or None
    targets : dict of str to TargetCheck
    calibration : Calibration or None
        Black-box calibration of the spec's family for the targets (the
        smaller ε of the local one and, under X ⊥ A, the global one); None
        without a target or when skipped (see ``omitted``).
    calibration_white_box : Calibration or None
        With a model and a target: the largest ε of the family such that the
        model's own L (and L̄) stays within the targets on [0, ε].
    calibration_targets : tuple of str
        The targets (``"local"``, ``"global"``) the black-box calibration
        meets at its ε (every target of the spec unless one was left out, and
        then ``omitted["calibration"]`` says why).
    intervals, unfiltered_intervals : FairnessIntervals or None
        When the model comes from counts and ``intervals`` are asked for:
        simultaneous intervals for the observed metrics of the filtered law
        (the upper end of L is the white-box certificate at level 1 − α; a
        lower end above 0 is evidence of unfairness) and of the model on its
        own (:func:`fairaudit.statistics.intervals.fairness_intervals`).
    assumptions : tuple of (Assumption, tuple of str)
        Each hypothesis with the forms it concerns.
    certified : bool
        True when every target is met (and when there is no target).
    omitted : mapping of str to str
        Why a result is missing, by the name of its field: ``"black_box"``
        (no black-box bound: its value is NaN), ``"calibration"`` (a
        calibration, black-box or white-box, or one of its targets, was
        skipped) and ``"intervals"`` (no intervals). Absent when nothing was
        left out.
    """

    spec: Spec
    paper: Bound | None
    tight: Bound | None
    black_box: WorstModel
    corollary: Bound
    best: float
    best_form: str
    global_bound: float
    observed: Observed | None
    unfiltered: Observed | None
    targets: dict[str, TargetCheck]
    calibration: Calibration | None
    assumptions: tuple[tuple[Assumption, tuple[str, ...]], ...]
    certified: bool
    calibration_white_box: Calibration | None = None
    calibration_targets: tuple[str, ...] = ()
    intervals: FairnessIntervals | None = None
    unfiltered_intervals: FairnessIntervals | None = None
    omitted: Mapping[str, str] = field(default_factory=dict)

    def to_dict(self) -> Report:
        """The report dictionary (the JSON of ``fairaudit certify``; its contract is in docs/design.md)."""
        spec = self.spec
        out: Report = {
            "format": CERTIFICATE_FORMAT,
            "format_version": FORMAT_VERSION,
            "tolerance": TOLERANCE,
            "certified": bool(self.certified),
            "spec": spec.source,
            "title": spec.model.title,
            "sensitive": {"name": spec.model.sensitive.name, "values": [label(g) for g in spec.groups]},
            "context": {"name": spec.context_name, "values": [label(c) for c in spec.contexts]},
            "decision": {"name": spec.model.decision.name, "values": [label(d) for d in spec.decisions]},
            "privacy": {"sensitive": spec.sensitive_mechanism.to_dict(), "context": spec.context_mechanism.to_dict()},
            "utility": {
                "name": spec.utility.name,
                "gamma": number(spec.gamma),
                "lower": number(spec.lower),
                "tau": number(spec.tau),
                "lipschitz": number(spec.lipschitz),
                "diameter": number(spec.utility.diameter(spec.metric)),
                "depends_on_group": spec.utility.depends_on_group,
            },
            "population": spec.population.to_dict(),
            "bounds": {
                "paper": number(self.paper.value) if self.paper else None,
                "tight": number(self.tight.value) if self.tight else None,
                "black_box": number(self.black_box.local_fairness.value),
                "corollary": number(self.corollary.value),
                "best": number(self.best),
                "best_form": self.best_form,
                "global": number(self.global_bound),
            },
            "bound_details": {
                **{
                    name: b.to_dict()
                    for name, b in (("paper", self.paper), ("tight", self.tight), ("corollary", self.corollary))
                    if b is not None
                },
                "black_box": self.black_box.to_dict(self._black_box_reason()),
            },
            "assumptions": [
                {"name": a.name, "status": a.status, "detail": a.detail, "for": list(forms)}
                for a, forms in self.assumptions
            ],
        }
        if self.observed is not None:
            out["observed"] = self.observed.to_dict(self.intervals)
            if self.intervals is None:
                out["observed"]["intervals_reason"] = self.omitted.get("intervals", "")
        elif "observed" in self.omitted:
            out["observed_omitted"] = self.omitted["observed"]
        if self.unfiltered is not None:
            out["unfiltered"] = self.unfiltered.to_dict(self.unfiltered_intervals)
        if self.targets:
            out["targets"] = {k: t.to_dict() for k, t in self.targets.items()}
        if self.calibration is not None or self.calibration_white_box is not None or "calibration" in self.omitted:
            out["calibration"] = self._calibration_dict()
        inputs = certificate_inputs(spec, self._calibrated_members())
        out["inputs_sha256"] = canonical_digest(inputs)
        out["inputs"] = inputs
        return out

    def _black_box_reason(self) -> str:
        """``omitted["black_box"]`` when the black-box bound is missing, else what the bound is."""
        if "black_box" in self.omitted or math.isnan(self.black_box.local_fairness.value):
            return self.omitted.get("black_box", "")
        return _black_box_description(self.spec.tau, self.black_box)

    def _calibrated_members(self) -> dict[str, Mechanism | None] | None:
        """The family's member at each calibrated ε (what ``fairaudit verify`` re-derives the calibration from)."""
        family = self.spec.sensitive_family
        if family is None or (self.calibration is None and self.calibration_white_box is None):
            return None

        def member(c: Calibration | None, above: bool = False) -> Mechanism | None:
            if c is None or not c.feasible or math.isnan(c.epsilon):
                return None
            if not above:
                return family(c.epsilon)
            # just above ε: that member misses the target, so ε is the largest to LARGEST_STEP (none at the ends)
            return family(up(c.epsilon + LARGEST_STEP * max(1.0, c.epsilon))) if c.epsilon < EPS_MAX else None

        black, white = self.calibration, self.calibration_white_box
        return {
            "black_box": member(black),
            "white_box": member(white),
            "black_box_above": member(black, above=True),
            "white_box_above": member(white, above=True),
        }

    def _calibration_dict(self) -> Report:
        """``calibration`` with a target: the black-box one (or nulls and why), and ``white_box``."""
        reason = self.omitted.get("calibration", "")
        if self.calibration is not None:
            out = self.calibration.to_dict()
            out["targets"] = {k: number(self.targets[k].target) for k in self.calibration_targets if k in self.targets}
            if set(self.targets) - set(self.calibration_targets):
                out["left_out"] = reason or "not calibrated"
        else:
            out = {**dict.fromkeys(("epsilon", "keep_probability", "method", "bound")), "feasible": False}
            out["reason"] = reason or "no calibration"
        if self.calibration_white_box is not None:
            out["white_box"] = self.calibration_white_box.to_dict()
        proofs = member_proofs(self.spec, self.calibration, self._calibrated_members())
        if proofs:
            out["proofs"] = proofs
        return out


def _black_box_description(tau: float | None, worst: WorstModel) -> str:
    """What the black-box bound is, when there is one: the worst case, or an upper bound on it with a model's value."""
    floor = f", with E[g | x, a] >= {tau:g}" if tau is not None else ""
    unsettled = [c for c in (worst.local_fairness, worst.global_fairness) if not c.settled]
    if not unsettled:
        return "exact over every decision model behind the filter, for this utility" + floor
    attained = "; ".join(
        f"on {'L' if c.kind == 'local' else 'L-bar'} a model attains {c.witness:.6g} nats"
        if math.isfinite(c.witness)
        else f"on {'L' if c.kind == 'local' else 'L-bar'} no model attaining it was found"
        for c in unsettled
    )
    return (
        "an upper bound on the worst case over every decision model behind the filter, for this utility" + floor
        + f" (the programs' rounded coefficients leave a gap: {attained})"
    )  # fmt: skip


def _merge_assumptions(
    bounds: list[tuple[str, tuple[Assumption, ...]]],
) -> tuple[tuple[Assumption, tuple[str, ...]], ...]:
    merged: dict[tuple[str, str, str], tuple[Assumption, list[str]]] = {}
    for form, items in bounds:
        for a in items:
            key = (a.name, a.status, a.detail)
            merged.setdefault(key, (a, []))[1].append(form)
    return tuple((a, tuple(forms)) for a, forms in merged.values())


def certify(
    spec: Spec | str | Path, *, intervals: IntervalOptions | None = DEFAULT_INTERVALS, progress: bool = False
) -> Certificate:
    """Build the certificate of a spec (a :class:`~fairaudit.certification.spec.Spec` or a path).

    Parameters
    ----------
    spec : Spec, str or Path
    intervals : IntervalOptions or None
        Simultaneous intervals for the observed metrics when the spec's model
        comes from counts (records, or a table with a count column): their
        level, method and Bayesian settings
        (:func:`fairaudit.statistics.intervals.fairness_intervals`); default
        ``IntervalOptions()`` (95%, "auto"); None for none.
    progress : bool
        Progress bars on stderr for the long steps (the worst cases' pair searches, the intervals behind a filter),
        where tqdm is installed and stderr is a terminal (:func:`fairaudit.base.progress.progress_shown`), each
        cleared when its step ends (a search's shown once it has run half a second). Default False; ``fairaudit
        certify`` shows them unless ``--no-progress``.

    Raises
    ------
    InputError
        On any invalid spec or model table (one line naming the field), or
        ``intervals`` that is not an :class:`~fairaudit.statistics.intervals.IntervalOptions`.

    Examples
    --------
    >>> from fairaudit.certification.spec import parse_spec
    >>> c = certify(parse_spec('''
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
    ... [target]
    ... local = 1.0
    ... '''))
    >>> round(c.black_box.local_fairness.value, 6), c.certified, c.best_form
    (0.847298, True, 'black_box')
    """
    with progress_shown(progress):
        return _build(spec, intervals)


def _build(spec: Spec | str | Path, intervals: IntervalOptions | None) -> Certificate:
    """:func:`certify`'s work, inside its progress block."""
    if not isinstance(spec, Spec):
        spec = load_spec(spec)
    interval_options(intervals)
    kernel: Kernel | None = spec.kernel()
    observed, unfiltered, observed_reason = _observations(spec, kernel)
    obs_law = observed.law if observed is not None else None
    mech, tau = spec.sensitive_mechanism, spec.tau
    paper, tight = _theorem_bounds(spec, obs_law)
    forms = [] if paper is None or tight is None else [("paper", paper.assumptions), ("tight", tight.assumptions)]
    black_box = worst_model(
        mech, spec.utility, context_mechanism=spec.context_mechanism, population=spec.population, tau=tau
    )
    bb_assumptions = check_assumptions(
        mech, utility_class=UtilityClass(tau=tau), utility=spec.utility, population=spec.population, law=obs_law
    )
    forms.append(("black_box", bb_assumptions))
    corollary = corollary_bound(mech, utility=spec.utility, population=spec.population, law=obs_law)
    forms.append(("corollary", corollary.assumptions))
    omitted: dict[str, str] = {"observed": observed_reason} if observed_reason else {}
    if math.isnan(black_box.local_fairness.value):
        omitted["black_box"] = black_box.local_fairness.reason
    else:
        for case in (black_box.local_fairness, black_box.global_fairness):
            if not case.certified:  # the solver's word only (proofs/linear_fractional.md §6): never a certified bound
                omitted["black_box"] = f"the {case.kind} worst case is not certified: {case.reason}"
    bb_holds = not any(a.status == "violated" and a.scope != "global" for a in bb_assumptions)
    bb_ok = bb_holds and "black_box" not in omitted
    best, best_form = _best_bound(black_box if bb_ok else None, tight, corollary, paper)
    independent = spec.population.independence().independent
    factor = independence_factor(spec.population.probabilities) if independent else math.inf
    global_bound, global_why = _global_bound(black_box if bb_ok else None, best, best_form, factor)

    t = spec.model.target
    targets = (
        {} if t is None else _target_checks(t, observed, (best, f"best bound: {best_form}"), (global_bound, global_why))
    )
    calibration, calibration_white, calibration_reason, calibration_targets = (
        (None, None, "", ()) if t is None else _calibrations(spec, kernel, t, independent)
    )
    if calibration_reason:
        omitted["calibration"] = calibration_reason
    made, unfiltered_intervals, intervals_reason = _intervals(spec, kernel, intervals)
    if intervals_reason:
        omitted["intervals"] = intervals_reason
    return Certificate(
        spec=spec,
        paper=paper,
        tight=tight,
        black_box=black_box,
        corollary=corollary,
        best=best,
        best_form=best_form,
        global_bound=global_bound,
        observed=observed,
        unfiltered=unfiltered,
        targets=targets,
        calibration=calibration,
        assumptions=_merge_assumptions(forms),
        certified=all(c.met for c in targets.values()),
        calibration_white_box=calibration_white,
        calibration_targets=calibration_targets,
        intervals=made,
        unfiltered_intervals=unfiltered_intervals,
        omitted=omitted,
    )


def _observations(spec: Spec, kernel: Kernel | None) -> tuple[Observed | None, Observed | None, str]:
    """The observed metrics behind the filter and, where the model reads the true labels, of the model on its own;
    and why the first are left out ("" when they are not): a law behind the filter that floating point cannot hold."""
    if kernel is None:
        return None, None, ""
    mech = spec.sensitive_mechanism
    observed, why = None, ""
    try:
        observed = observe(compose(kernel, mech, spec.context_mechanism), spec.utility, spec.population)
    except UnderflowError as exc:
        why = f"{exc.field}: {exc.problem} (at {exc.value})"
    except InputError as exc:
        raise exc.under(f"{spec.source}: {exc.field}", keep_own=False) from None
    filtered = not (mech.is_identity and spec.context_mechanism.is_identity)
    if filtered and spec.sees_inputs:  # the model on its own: only where it reads the true labels
        return observed, observe(Law.from_kernel(kernel), spec.utility, spec.population), why
    return observed, None, why


def _theorem_bounds(spec: Spec, law: Law | None) -> tuple[Bound | None, Bound | None]:
    """The paper and tight bounds of the main theorem, or (None, None) when they need a τ the spec does not give."""
    mech, tau = spec.sensitive_mechanism, spec.tau
    # without tau the extra term must be 0 (L_A = 0, g free of the group, pure DP): then paper = tight = epsilon(M)
    if tau is None and not (spec.lipschitz == 0 and not spec.utility.depends_on_group and math.isfinite(mech.epsilon)):
        return None, None
    paper, tight = (
        form(mech, utility_class=spec.utility_class, utility=spec.utility, population=spec.population, law=law)
        for form in (paper_bound, tight_bound)
    )
    return paper, tight


def _best_bound(
    black_box: WorstModel | None, tight: Bound | None, corollary: Bound, paper: Bound | None
) -> tuple[float, str]:
    """The smallest bound on L that holds, and its form (``black_box`` None when it does not apply)."""
    candidates = [(black_box.local_fairness.value, "black_box")] if black_box is not None else []
    for form, b in (("tight", tight), ("corollary", corollary), ("paper", paper)):  # ties go to the tighter form
        if b is not None and b.holds:
            candidates.append((b.value, form))
    return min(candidates, default=(math.inf, "none"), key=lambda t: t[0])


def _global_bound(black_box: WorstModel | None, best: float, best_form: str, factor: float) -> tuple[float, str]:
    """The bound on L-bar and why: the exact black-box one, or L's best bound when X and A are independent.

    ``factor`` is :func:`~fairaudit.laws.independence.independence_factor` of the population (+inf when X and A are
    not independent): L-bar <= L + ln factor, so L's best bound holds for a population independent within rounding
    once ln factor is added (0 when X and A are exactly independent).
    """
    independent = math.isfinite(factor)
    bound = math.inf
    if independent:
        bound = best if factor == 1.0 else up(best + log_up(factor))
    if black_box is not None and not math.isnan(black_box.global_fairness.value):  # exact, X independent of A or not
        bound = min(bound, black_box.global_fairness.value)
    if black_box is not None and bound == black_box.global_fairness.value:
        return bound, "black-box bound on L-bar (exact over every model)"
    if independent and factor != 1.0:
        return (
            bound,
            f"best bound: {best_form} + ln {factor:.17g} (L-bar <= L + ln F: X and A independent within rounding)",
        )
    if independent:
        return bound, f"best bound: {best_form} (L-bar <= L since X and A are independent)"
    return bound, "X and A are not independent in the population and no black-box bound applies"


def _target_checks(
    t: TargetSpec, observed: Observed | None, local: tuple[float, str], global_: tuple[float, str]
) -> dict[str, TargetCheck]:
    """Each target of the spec against its (bound, reason) and the observed value."""
    targets: dict[str, TargetCheck] = {}
    for kind, goal, (bound, reason) in (("local", t.local, local), ("global", t.global_, global_)):
        if goal is None:
            continue
        obs = None if observed is None else getattr(observed, f"{kind}_fairness").value
        targets[kind] = TargetCheck(
            kind=kind,
            target=goal,
            bound=bound,
            met=bound <= goal,
            observed=obs,
            observed_met=None if obs is None else bool(obs <= goal),
            reason=reason,
        )
    return targets


def _intervals(
    spec: Spec, kernel: Kernel | None, options: IntervalOptions | None
) -> tuple[FairnessIntervals | None, FairnessIntervals | None, str]:
    """Intervals for the observed metrics when the model comes from counts: (filtered, unfiltered, reason)."""
    if options is None:
        return None, None, "no confidence level asked for"
    if kernel is None:
        return None, None, "the spec has no model"
    if kernel.counts is None:
        return None, None, "the model is a table of probabilities, not counts: no sampling uncertainty to report"
    table = spec.weighted_table or CountTable(  # weighted records: intervals on Kish's effective counts
        kernel.counts,
        kernel.contexts,
        kernel.groups,
        kernel.decisions,
        () if spec.model.context is None else (spec.model.context.name,),
        (spec.model.sensitive.name,),
        spec.model.decision.name,
    )
    # The records' own population is estimated from the same records: without a filter the intervals then pool
    # each group's records (population None), exactly as `fairaudit audit` does; behind a filter it is held fixed.
    pop = spec.population
    own_pop = None if pop.source == "records" else pop
    identity = spec.sensitive_mechanism.is_identity and spec.context_mechanism.is_identity
    try:
        filtered_iv = fairness_intervals(
            table,
            spec.utility,
            options,
            sensitive_mechanism=spec.sensitive_mechanism,
            context_mechanism=spec.context_mechanism,
            population=own_pop if identity else pop,
        )
        own = None
        if not identity and spec.sees_inputs:
            own = fairness_intervals(table, spec.utility, options, population=own_pop)
    except InputError as exc:
        if exc.field == "method":  # (clopper-pearson asked for a utility that is not 0/1)
            raise
        return None, None, f"no intervals: {exc.field} {exc.problem}"
    return filtered_iv, own, ""


def _tightest(results: list[Calibration]) -> Calibration | None:
    """The calibration meeting every target: an infeasible one if any, else the smallest ε."""
    if not results:
        return None
    bad = [c for c in results if not c.feasible]
    return bad[0] if bad else min(results, key=lambda c: c.epsilon)


def _calibrations(
    spec: Spec, kernel: Kernel | None, t: TargetSpec, independent: bool
) -> tuple[Calibration | None, Calibration | None, str, tuple[str, ...]]:
    """Calibrate the spec's family for its targets: black-box (and white-box with a model), why one is skipped,
    and the targets the black-box one covers.

    Black-box: ``calibrate(method="black_box")`` with the spec's family, τ, L_A,
    metric and [lower, γ], for the local target and for the global one (under
    X ⊥ A through L̄ ≤ L; otherwise the exact worst case on L̄ over every model
    for the spec's utility and population, as ``worst_model`` gives it to the
    certificate); the smaller ε. White-box: the same targets on the model's
    exact L and L̄ (no independence needed). The reason names any target left out.
    """
    family = spec.sensitive_family
    if family is None:
        return None, None, "fewer than 2 groups: nothing to calibrate", ()
    goals = [(kind, v) for kind, v in (("local", t.local), ("global", t.global_)) if v is not None]
    if not goals:
        return None, None, "", ()
    black: list[Calibration] = []
    reason = ""
    if spec.utility.depends_on_group and spec.model.utility.lipschitz is None:
        reason = "the utility depends on the group and the spec gives no utility.lipschitz for the black-box class"
    else:
        for kind, goal in goals:
            dependent = kind == "global" and not independent  # the exact worst case on L-bar, for this utility
            try:
                black.append(
                    calibrate(
                        goal,
                        kind=kind,
                        method="black_box",
                        utility_class=replace(spec.utility_class, diameter=None),
                        utility=spec.utility if dependent else None,
                        context_mechanism=spec.context_mechanism if dependent else None,
                        family=family,
                        population=spec.population,
                    )
                )
            except InputError as exc:
                reason = f"black-box calibration not available: {exc}"
                black = []
                break
    white: list[Calibration] = []
    if kernel is not None and not spec.sees_inputs:
        reason = (reason + "; " if reason else "") + (
            "white-box calibration needs a model indexed by the groups: the spec's mechanism releases other values"
        )
    elif kernel is not None:
        white = [
            calibrate(
                goal,
                kind=kind,
                method="white_box",
                utility_class=UtilityClass(gamma=spec.gamma, lower=spec.lower),
                kernel=kernel,
                utility=spec.utility,
                context_mechanism=spec.context_mechanism,
                family=family,
                population=spec.population,
            )
            for kind, goal in goals
        ]
    return _tightest(black), _tightest(white), reason, tuple(c.kind for c in black)
