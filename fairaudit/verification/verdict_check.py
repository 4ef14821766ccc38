"""The verdicts a certificate states, re-derived from its numbers: ``certified``, the best valid bound, each
assumption's status that its inputs decide, each form's ``holds``, X ⊥ A, whether g depends on the group, and whether
a calibration is feasible.

Each verdict is the one certify reaches by its own rule (``fairaudit.certification.certificate``,
``fairaudit.metrics.assumptions``, ``Population.independence``), applied to the numbers verify reads or re-derives:
a flipped verdict fails, naming its field (``proofs/verification.md`` §1: a verdict holds iff it equals the one
re-derived). The targets' ``met`` and ``observed_met`` are re-derived with their bounds
(``rederive._target_checks``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from fractions import Fraction
from typing import Any

from fairaudit.verification.checks import Check, equal
from fairaudit.verification.enclosures import INDEPENDENCE, exact, group_free, independence, recorded_array

__all__ = ["FORMS", "verdict_checks"]

FORMS = ("black_box", "tight", "corollary", "paper")
"""The bounds on L in the order certify prefers them on a tie (``_best_bound``: the tighter form first)."""

EDGE = Fraction(1, 2**40)
"""certify evaluates that deviation in floats: within this relative distance of :data:`INDEPENDENCE` either verdict
is accepted."""

GLOBAL_ONLY = "X independent of A"
"""The one assumption that concerns only L̄ ≤ L (its scope is ``global``): it voids no bound on L."""


def verdict_checks(cert: Mapping[str, Any], skipped: list[tuple[str, str]]) -> list[Check]:
    """Every verdict of a certificate that its numbers decide, re-derived by certify's rule.

    Parameters
    ----------
    cert : mapping
        A certificate (checked against its schema).
    skipped : list of (str, str)
        Appended to: the verdicts not re-derived, with the reason.

    Returns
    -------
    list of Check
        ``certified`` (every target's bound at most its target; true without a target), ``bounds.best_form`` (the
        smallest bound whose assumptions hold, ties to the tighter form), ``assumptions[i].status`` (where the inputs
        decide it), ``bound_details.<form>.holds`` (no assumption of the form on L violated),
        ``population.independent``, ``utility.depends_on_group`` and ``calibration[.white_box].feasible``.

    Examples
    --------
    ``certified`` is every target's bound at most its target (certify's ``bound <= goal``):

    >>> _certified({"certified": True, "targets": {"local": {"target": 0.5, "bound": 0.6}}}).line()
    'certified = True: fails (not every target is met: targets.local.bound 0.6 > target 0.5)'
    """
    assumptions, population = cert["assumptions"], cert["population"]
    out = [_certified(cert), *_assumption_checks(cert, assumptions, skipped), *_holds_checks(cert, assumptions)]
    out.append(_best_form(cert, assumptions))
    expected = _pick(population["independent"], _independent(cert))
    why = "max |P(x, a) - P(x) P(a)| of inputs.population <= 1e-9"
    if population["source"] == "assumed":
        expected, why = "assumed", "an assumed population is never checked"
    out.append(equal("population.independent", population["independent"], expected, why))
    dep = not group_free(cert["inputs"]["utility"]["values"])
    why = "inputs.utility.values over the groups"
    out.append(equal("utility.depends_on_group", cert["utility"]["depends_on_group"], dep, why))
    calibration = cert.get("calibration") or {}
    for where, section in (("calibration", calibration), ("calibration.white_box", calibration.get("white_box"))):
        if isinstance(section, Mapping) and "feasible" in section:
            found = section.get("epsilon") is not None
            why = "an epsilon meets the target" if found else "no epsilon recorded: none meets the target"
            out.append(equal(f"{where}.feasible", section["feasible"], found, why))
    return out


def _certified(cert: Mapping[str, Any]) -> Check:
    """``certified``: every target met, its bound at most the target (certify's ``bound <= goal``)."""
    missed = []
    for kind, t in (cert.get("targets") or {}).items():
        bound, goal = exact(t["bound"], f"targets.{kind}.bound"), exact(t["target"], f"targets.{kind}.target")
        if not bound <= goal:
            missed.append(f"targets.{kind}.bound {t['bound']} > target {t['target']}")
    why = "not every target is met: " + "; ".join(missed) if missed else "every target is met (or none is set)"
    return equal("certified", cert.get("certified"), not missed, why)


def _violates(a: Mapping[str, Any], form: str) -> bool:
    """Whether an assumption, as recorded, voids ``form``'s bound on L (violated, for that form, not global-only)."""
    return a.get("status") == "violated" and a.get("name") != GLOBAL_ONLY and form in (a.get("for") or ())


def _valid(cert: Mapping[str, Any], form: str, assumptions: Sequence[Mapping[str, Any]]) -> bool:
    """Whether certify counts ``form`` among the bounds on L: given, no assumption of it violated, and for the black
    box both worst cases certified (certify leaves out a worst case that is the solver's word only)."""
    if cert["bounds"].get(form) is None or any(_violates(a, form) for a in assumptions):
        return False
    if form != "black_box":
        return True
    detail = cert["bound_details"]["black_box"]  # (a worst case of the schema: certified is a boolean)
    return detail["certified"] and detail["global"]["certified"]


def _best_form(cert: Mapping[str, Any], assumptions: Sequence[Mapping[str, Any]]) -> Check:
    """``bounds.best_form``: the smallest valid bound on L, ties to the tighter form; ``none`` when none is valid."""
    bounds = cert["bounds"]
    valid = [form for form in FORMS if _valid(cert, form, assumptions)]
    best = min(valid, key=lambda f: exact(bounds[f], f"bounds.{f}"), default="none")
    why = "the smallest bound whose assumptions hold, of " + (", ".join(valid) or "none")
    return equal("bounds.best_form", bounds["best_form"], best, why)


def _holds_checks(cert: Mapping[str, Any], assumptions: Sequence[Mapping[str, Any]]) -> list[Check]:
    """``bound_details.<form>.holds``: no assumption of the form on L violated (``Bound.holds``)."""
    out = []
    for form, detail in cert["bound_details"].items():
        if "holds" in detail:  # (each form's theorem_bound; the black box's worst case has none)
            expected = not any(_violates(a, form) for a in assumptions)
            why = "no assumption of the form on L is violated" if expected else "an assumption of the form is violated"
            out.append(equal(f"bound_details.{form}.holds", detail["holds"], expected, why))
    return out


def _independent(cert: Mapping[str, Any]) -> tuple[bool, ...]:
    """The verdicts X ⊥ A may take: (True,) or (False,), both within :data:`EDGE` of the threshold."""
    dev = max(map(max, independence(cert["inputs"]["population"]["probabilities"])[0]))
    if dev <= INDEPENDENCE * (1 - EDGE):
        return (True,)
    return (False,) if dev > INDEPENDENCE * (1 + EDGE) else (True, False)


def _pick(reported: Any, allowed: Sequence[Any]) -> Any:
    """The reported verdict where it is one of those allowed, else the first allowed (to report)."""
    return reported if reported in allowed else allowed[0]


def _assumption_checks(
    cert: Mapping[str, Any], assumptions: Sequence[Mapping[str, Any]], skipped: list[tuple[str, str]]
) -> list[Check]:
    """Each assumption's status where the inputs decide it (``metrics.assumptions``, ``corollary_bound``)."""
    out = []
    utility = cert["inputs"]["utility"]
    for i, a in enumerate(assumptions):
        name, where, status = a.get("name"), f"assumptions[{i}].status", a.get("status")
        if name == "M_A is differentially private":  # a finite mechanism's exact privacy profile is computed
            out.append(equal(where, status, "checked", "the exact privacy profile of the recorded mechanism"))
        elif name == GLOBAL_ONLY:
            source = cert["population"]["source"]
            allowed = ["violated" if not ind else "assumed" if source == "assumed" else "checked"
                       for ind in _independent(cert)]  # fmt: skip
            why = "max |P(x, a) - P(x) P(a)| of inputs.population against 1e-9, and population.source"
            out.append(equal(where, status, _pick(status, allowed), why))
        elif name == "g <= gamma":  # certify's rule, in its floats: max g <= gamma + 1e-12
            largest = max(_flat(recorded_array(utility["values"], "inputs.utility.values")))
            ceiling = float(utility["gamma"]) + 1e-12  # ("inf" reads as +inf)
            ok = ceiling == float("inf") or largest <= Fraction(ceiling)
            out.append(equal(where, status, "checked" if ok else "violated", "max inputs.utility.values <= gamma"))
        elif name == "g independent of the group":
            dep = not group_free(utility["values"])
            out.append(equal(where, status, "violated" if dep else "checked", "inputs.utility.values over the groups"))
        else:
            why = f"{name!r} is {status!r}: the inputs do not decide it (a vow, or the observed model)"
            skipped.append((where, why))
    return out


def _flat(values: Any) -> list[Any]:
    """The entries of nested lists, in order."""
    return [v for inner in values for v in _flat(inner)] if isinstance(values, list) else [values]
