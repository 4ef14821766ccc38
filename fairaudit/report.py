"""Reports: one dictionary per result, rendered as JSON, text or Markdown.

The dictionaries follow the JSON contract of docs/design.md (keys that other tools
read); infinite values are the string ``"inf"``, NaN is ``null``, tuple labels
(product attributes) are joined with ``" & "``. :func:`render` turns one into
the text of a report through the formats of ``fairaudit._format`` (one module
per format). :func:`write_atomic` (from ``fairaudit._io``) is re-exported here.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from ._errors import InputError
from ._format import FORMATTERS
from ._format._values import Report, fairness_dict, label, number
from ._io import STALE_SECONDS, write_atomic

if TYPE_CHECKING:
    from .audit import Audit
    from .calibrate import Calibration
    from .certify import Certificate, Observed
    from .intervals import FairnessIntervals, Interval
    from .laws import Kernel, Population
    from .metrics import SupFairness, TotalVariation
    from .plan import SamplePlan
    from .privacy import Mechanism
    from .worstcase import WorstCase, WorstModel

__all__ = [
    "certificate_dict",
    "audit_dict",
    "calibration_dict",
    "render",
    "write_atomic",
    "FORMATS",
    "plan_dict",
    "intervals_dict",
    "population_dict",
    "Report",
    "STALE_SECONDS",
]

#: The report formats, the choices of ``--format``.
FORMATS = tuple(FORMATTERS)


def _tv(t: TotalVariation) -> Report:
    return {
        "value": number(t.value),
        "context": label(t.context),
        "group": label(t.group),
        "other_group": label(t.other_group),
        "event": [label(u) for u in t.event],
    }


def _sup(s: SupFairness) -> Report:
    return {
        "value": number(s.value),
        "ratio": number(s.ratio),
        "context": label(s.context),
        "group": label(s.group),
        "other_group": label(s.other_group),
        "decision": label(s.decision),
    }


def _interval(iv: Interval | None) -> Report | None:
    if iv is None:
        return None
    return {
        "lower": number(iv.lower),
        "upper": number(iv.upper),
        "estimate": number(iv.estimate),
        "context": label(iv.context),
        "group": label(iv.group),
        "other_group": label(iv.other_group),
    }


def intervals_dict(fi: FairnessIntervals) -> Report:
    """The JSON of a :class:`~fairaudit.intervals.FairnessIntervals`: method, level and one entry per metric."""
    out: Report = {
        "method": fi.method,
        "confidence": number(fi.confidence),
        "sets": fi.n_sets,
        "filtered": fi.sensitive_mechanism is not None or fi.context_mechanism is not None,
        "notes": list(fi.notes),
    }
    if fi.method == "bayes":
        out.update(concentration=number(fi.concentration), draws=fi.draws, seed=fi.seed)
    out.update({k: _interval(v) for k, v in fi.intervals().items()})
    return out


def _observed(o: Observed, intervals: FairnessIntervals | None = None) -> Report:
    excluded = list(dict.fromkeys(o.local.excluded + o.global_.excluded))
    out: Report = {
        "local": fairness_dict(o.local, None if intervals is None else intervals.local),
        "global": fairness_dict(o.global_, None if intervals is None else intervals.global_),
        "demographic_parity": number(o.demographic_parity.value),
        "equalized_odds": number(o.equalized_odds.value),
        "sup_local": number(o.sup_local.value),
        "sup_global": number(o.sup_global.value),
        "details": {
            "demographic_parity": _tv(o.demographic_parity),
            "equalized_odds": _tv(o.equalized_odds),
            "sup_local": _sup(o.sup_local),
            "sup_global": _sup(o.sup_global),
        },
        "excluded": excluded,
    }
    if intervals is not None:
        out["intervals"] = intervals_dict(intervals)
    return out


def population_dict(p: Population) -> Report:
    """``population`` of a certificate or an audit: where P(X, A) comes from and whether X ⊥ A holds in it.

    ``source`` is ``"given"``, ``"records"`` or ``"assumed"``; ``independent`` is
    ``"assumed"`` for an assumed population (never checked), else a bool with
    ``max_deviation`` = max |P(x, a) − P(x) P(a)| at ``context``, ``group``.
    """
    ind = p.independence()
    out: Report = {"source": p.source, "description": p.describe(), "records": number(p.records)}
    out["independent"] = "assumed" if p.source == "assumed" else bool(ind.independent)
    out.update(max_deviation=number(ind.max_deviation), context=label(ind.context), group=label(ind.group))
    return out


def _mechanism(m: Mechanism) -> Report:
    eps = m.epsilon
    return {
        "mechanism": m.name,
        "epsilon": number(eps),
        "delta": 0.0 if math.isfinite(eps) else None,
        "keep_probability": number(m.keep_probability),
        "inputs": len(m.inputs),
        "outputs": len(m.outputs),
    }


def calibration_dict(c: Calibration) -> Report:
    """The ``calibrate`` JSON of a :class:`~fairaudit.calibrate.Calibration`.

    Contract keys: ``epsilon`` (``"inf"`` when every ε meets the target,
    ``null`` when none does), ``keep_probability``, ``method``, ``bound``;
    then ``feasible``, ``reason``, ``target``, ``kind``, ``mechanism`` (the
    family member's name, or the family's when infeasible), ``family`` and the
    inputs ``groups``, ``gamma``, ``lower``, ``tau`` (``null`` when not given),
    ``delta``, ``lipschitz``, ``diameter``.
    """
    return {
        "epsilon": number(c.epsilon),
        "keep_probability": number(c.keep_probability),
        "method": c.method,
        "bound": number(c.bound),
        "feasible": bool(c.feasible),
        "reason": c.reason,
        "target": number(c.target),
        "kind": c.kind,
        "mechanism": c.mechanism.name if c.mechanism is not None else c.family,
        "family": c.family,
        "groups": c.groups,
        "gamma": number(c.gamma),
        "lower": number(c.lower),
        "tau": number(c.tau),
        "delta": number(c.delta),
        "lipschitz": number(c.lipschitz),
        "diameter": number(c.diameter),
    }


def _certificate_calibration(cert: Certificate) -> Report:
    """``calibration`` of a certificate with a target: the black-box one (or nulls and why), and ``white_box``."""
    if cert.calibration is not None:
        out = calibration_dict(cert.calibration)
        out["targets"] = {k: number(cert.targets[k].target) for k in cert.calibration_targets if k in cert.targets}
        if set(cert.targets) - set(cert.calibration_targets):
            out["left_out"] = cert.calibration_reason or "not calibrated"
    else:
        out = {
            "epsilon": None,
            "keep_probability": None,
            "method": None,
            "bound": None,
            "feasible": False,
            "reason": getattr(cert, "calibration_reason", "") or "no calibration",
        }
    white = getattr(cert, "calibration_white_box", None)
    if white is not None:
        out["white_box"] = calibration_dict(white)
    return out


def _worst_case(w: WorstCase) -> Report:
    d: Report = {"value": number(w.value), "ratio": number(w.ratio)}
    if w.kind == "local":
        d["context"] = label(w.context)
    d.update(
        group=label(w.group),
        other_group=label(w.other_group),
        method=w.method,
        status=w.status,
        programs_solved=int(w.programs_solved),
    )
    if w.reason:
        d["reason"] = w.reason
    return d


def _kernel_dict(k: Kernel) -> dict[str, dict[str, dict[str, float]]]:
    """{released context: {released group: {decision: probability}}} of a kernel."""
    p = np.round(k.probabilities, 12) + 0.0
    return {
        str(label(x)): {
            str(label(a)): {str(label(u)): float(p[i, j, m]) for m, u in enumerate(k.decisions)}
            for j, a in enumerate(k.groups)
        }
        for i, x in enumerate(k.contexts)
    }


def _worst_model(wm: WorstModel, reason: str) -> Report:
    """``bound_details.black_box``: the exact worst cases for L and L-bar and the worst decision model for L."""
    out = _worst_case(wm.local)
    out["reason"] = reason
    out["global"] = _worst_case(wm.global_)
    out["worst_model"] = None if wm.local.kernel is None else _kernel_dict(wm.local.kernel)
    return out


def certificate_dict(cert: Certificate) -> Report:
    """The ``certify`` JSON (docs/design.md contract) of a :class:`~fairaudit.certify.Certificate`."""
    spec = cert.spec
    bounds = {
        "paper": number(cert.paper.value) if cert.paper else None,
        "tight": number(cert.tight.value) if cert.tight else None,
        "black_box": number(cert.black_box.local.value),
        "corollary": number(cert.corollary.value),
        "best": number(cert.best),
        "best_form": cert.best_form,
        "global": number(cert.global_bound),
    }
    details: Report = {}
    for name, b in (("paper", cert.paper), ("tight", cert.tight), ("corollary", cert.corollary)):
        if b is not None:
            details[name] = {
                "value": number(b.value),
                "epsilon": number(b.epsilon),
                "delta": number(b.delta),
                "group": label(b.group),
                "other_group": label(b.other_group),
                "holds": b.holds,
            }
    details["black_box"] = _worst_model(cert.black_box, cert.black_box_reason)
    out: Report = {
        "certified": bool(cert.certified),
        "spec": spec.source,
        "title": spec.model.title,
        "sensitive": {"name": spec.model.sensitive.name, "values": [label(g) for g in spec.groups]},
        "context": {"name": spec.context_name, "values": [label(c) for c in spec.contexts]},
        "decision": {"name": spec.model.decision.name, "values": [label(d) for d in spec.decisions]},
        "privacy": {"sensitive": _mechanism(spec.sensitive_mechanism), "context": _mechanism(spec.context_mechanism)},
        "utility": {
            "name": spec.utility.name,
            "gamma": number(spec.gamma),
            "lower": number(spec.lower),
            "tau": number(spec.tau),
            "lipschitz": number(spec.lipschitz),
            "diameter": number(spec.utility.diameter(spec.metric)),
            "depends_on_group": spec.utility.depends_on_group,
        },
        "population": population_dict(spec.population),
        "bounds": bounds,
        "bound_details": details,
        "assumptions": [
            {"name": a.name, "status": a.status, "detail": a.detail, "for": list(forms)}
            for a, forms in cert.assumptions
        ],
    }
    if cert.observed is not None:
        out["observed"] = _observed(cert.observed, cert.intervals)
        if cert.intervals is None:
            out["observed"]["intervals_reason"] = cert.intervals_reason
    if cert.unfiltered is not None:
        out["unfiltered"] = _observed(cert.unfiltered, cert.unfiltered_intervals)
    if cert.targets:
        out["targets"] = {
            k: {
                "target": number(t.target),
                "met": t.met,
                "bound": number(t.bound),
                "observed": number(t.observed),
                "observed_met": t.observed_met,
                "reason": t.reason,
            }
            for k, t in cert.targets.items()
        }
    if (
        cert.calibration is not None
        or getattr(cert, "calibration_white_box", None) is not None
        or bool(getattr(cert, "calibration_reason", ""))
    ):
        out["calibration"] = _certificate_calibration(cert)
    return out


def audit_dict(a: Audit) -> Report:
    """The ``audit`` JSON (docs/design.md contract) of an :class:`~fairaudit.audit.Audit`."""
    t = a.table
    e = a.observed.local.expected_utility
    cells = t.cell_counts
    iv = a.intervals
    out: Report = {
        "n": t.n,
        "sensitive": list(t.sensitive_columns),
        "outcome": t.outcome_column,
        "context_columns": list(t.context_columns),
        "utility": {"name": a.utility.name, "gamma": number(a.utility.gamma), "lower": number(a.utility.lower)},
        "groups": [{"label": label(g), "n": int(n)} for g, n in zip(t.groups, t.group_counts)],
        "contexts": [{"label": label(c), "n": int(n)} for c, n in zip(t.contexts, t.context_counts)],
        "cells": [
            {
                "context": label(c),
                "group": label(g),
                "n": int(cells[i, j]),
                "expected_utility": number(e[i, j]),
                **({} if iv is None else {"interval": [number(iv.cell_lower[i, j]), number(iv.cell_upper[i, j])]}),
            }
            for i, c in enumerate(t.contexts)
            for j, g in enumerate(t.groups)
        ],
        "decisions": [label(d) for d in t.decisions],
        "population": population_dict(a.population),
        "confidence": number(a.confidence),
        "interval_method": iv.method if iv is not None else None,
    }
    out.update(_observed(a.observed, iv))
    return out


def plan_dict(plans: Sequence[SamplePlan]) -> Report:
    """The ``plan`` JSON of one or more :class:`~fairaudit.plan.SamplePlan` (same inputs, one per method).

    Keys: ``target``, ``confidence``, ``power``, ``kind``, ``groups``,
    ``contexts``, ``base_rate``, ``disparity``, ``epsilon`` (``null`` without
    a filter), ``seed``, ``max_n``, ``true_value`` (L or L̄ of the assumed law),
    ``feasible`` (every plan found an n) and ``plans``: one entry per method
    with ``method``, ``n_per_cell``, ``n_total`` (``null`` when infeasible),
    ``achieved_power``, ``expected_upper`` (median upper end, nats),
    ``datasets``, ``reason`` (``""`` when feasible).
    """
    first = plans[0]
    return {
        "target": number(first.target),
        "confidence": number(first.confidence),
        "power": number(first.power),
        "kind": first.kind,
        "groups": first.groups,
        "contexts": first.contexts,
        "base_rate": number(first.base_rate),
        "disparity": number(first.disparity),
        "epsilon": number(first.epsilon),
        "seed": first.seed,
        "max_n": first.max_n,
        "true_value": number(first.true_value),
        "feasible": all(p.feasible for p in plans),
        "plans": [
            {
                "method": p.method,
                "n_per_cell": p.n_per_cell,
                "n_total": p.n_total,
                "achieved_power": number(p.achieved_power),
                "expected_upper": number(p.expected_upper),
                "datasets": p.datasets,
                "reason": p.reason,
            }
            for p in plans
        ],
    }


def render(data: Report, kind: str, fmt: str) -> str:
    """Render a report dictionary.

    Parameters
    ----------
    data : dict
        From :func:`certificate_dict`, :func:`audit_dict`, :func:`calibration_dict` or :func:`plan_dict`.
    kind : {"certify", "audit", "calibrate", "plan"}
    fmt : {"text", "json", "markdown"}
        One of :data:`FORMATS`.

    Raises
    ------
    InputError
        On an unknown format (naming ``format``).

    Examples
    --------
    >>> print(render({"epsilon": "inf"}, "calibrate", "json"), end="")
    {
      "epsilon": "inf"
    }
    >>> render({}, "audit", "html")
    Traceback (most recent call last):
    ...
    fairaudit._errors.InputError: format: must be one of text, json, markdown (got 'html')
    """
    formatter = FORMATTERS.get(fmt)
    if formatter is None:
        raise InputError("format", f"must be one of {', '.join(FORMATS)}", fmt)
    return formatter.render(data, kind)
