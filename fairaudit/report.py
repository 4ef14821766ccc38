"""Reports: one dictionary per result, rendered as JSON, text or Markdown; atomic writes.

The dictionaries follow the JSON contract of docs/design.md (keys that other tools
read); infinite values are the string ``"inf"``, NaN is ``null``, tuple labels
(product attributes) are joined with ``" & "``.
"""

from __future__ import annotations

import json
import math
import os
import re
import stat
import tempfile
import time
from collections.abc import Callable, Hashable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, SupportsFloat, TypeAlias

import numpy as np

from ._arrays import format_label
from ._errors import InputError

if TYPE_CHECKING:
    from .audit import Audit
    from .calibrate import Calibration
    from .certify import Certificate, Observed
    from .intervals import FairnessIntervals, Interval
    from .laws import Kernel, Population
    from .metrics import Fairness, SupFairness, TotalVariation
    from .plan import SamplePlan
    from .privacy import Mechanism
    from .worstcase import WorstCase, WorstModel

__all__ = ["certificate_dict", "audit_dict", "calibration_dict", "render", "write_atomic", "FORMATS", "plan_dict"]

FORMATS = ("text", "json", "markdown")

Report: TypeAlias = dict[str, Any]
"""A report dictionary: JSON-ready (str keys; str, numbers, bools, None, lists and dicts as values)."""


def _num(v: SupportsFloat | None) -> bool | int | float | str | None:
    if v is None:
        return None
    if isinstance(v, (bool, np.bool_)):
        return bool(v)
    if isinstance(v, (int, np.integer)):
        return int(v)
    f = float(v)
    if math.isnan(f):
        return None
    if math.isinf(f):
        return "inf" if f > 0 else "-inf"
    return f


def _label(v: Hashable | None) -> Hashable | None:
    if v is None:
        return None
    if isinstance(v, tuple):
        return format_label(v)
    if isinstance(v, np.generic):
        return v.item()
    return v


def _fairness(f: Fairness, interval: Interval | None = None) -> Report:
    d: Report = {"value": _num(f.value), "ratio": _num(f.ratio)}
    if f.kind == "local":
        d["context"] = _label(f.context)
    d.update(
        group=_label(f.group),
        other_group=_label(f.other_group),
        interval=None if interval is None else [_num(interval.lower), _num(interval.upper)],
    )
    return d


def _tv(t: TotalVariation) -> Report:
    return {
        "value": _num(t.value),
        "context": _label(t.context),
        "group": _label(t.group),
        "other_group": _label(t.other_group),
        "event": [_label(u) for u in t.event],
    }


def _sup(s: SupFairness) -> Report:
    return {
        "value": _num(s.value),
        "ratio": _num(s.ratio),
        "context": _label(s.context),
        "group": _label(s.group),
        "other_group": _label(s.other_group),
        "decision": _label(s.decision),
    }


def _interval(iv: Interval | None) -> Report | None:
    if iv is None:
        return None
    return {
        "lower": _num(iv.lower),
        "upper": _num(iv.upper),
        "estimate": _num(iv.estimate),
        "context": _label(iv.context),
        "group": _label(iv.group),
        "other_group": _label(iv.other_group),
    }


def intervals_dict(fi: FairnessIntervals) -> Report:
    """The JSON of a :class:`~fairaudit.intervals.FairnessIntervals`: method, level and one entry per metric."""
    out: Report = {
        "method": fi.method,
        "confidence": _num(fi.confidence),
        "sets": fi.n_sets,
        "filtered": fi.sensitive_mechanism is not None or fi.context_mechanism is not None,
        "notes": list(fi.notes),
    }
    if fi.method == "bayes":
        out.update(concentration=_num(fi.concentration), draws=fi.draws, seed=fi.seed)
    out.update({k: _interval(v) for k, v in fi.intervals().items()})
    return out


def _observed(o: Observed, intervals: FairnessIntervals | None = None) -> Report:
    excluded = list(dict.fromkeys(o.local.excluded + o.global_.excluded))
    out: Report = {
        "local": _fairness(o.local, None if intervals is None else intervals.local),
        "global": _fairness(o.global_, None if intervals is None else intervals.global_),
        "demographic_parity": _num(o.demographic_parity.value),
        "equalized_odds": _num(o.equalized_odds.value),
        "sup_local": _num(o.sup_local.value),
        "sup_global": _num(o.sup_global.value),
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
    out: Report = {"source": p.source, "description": p.describe(), "records": _num(p.records)}
    out["independent"] = "assumed" if p.source == "assumed" else bool(ind.independent)
    out.update(max_deviation=_num(ind.max_deviation), context=_label(ind.context), group=_label(ind.group))
    return out


def _population_line(d: Report) -> str:
    """The reports' population line."""
    p = d["population"]
    if p["independent"] == "assumed":
        return f"population P(X, A): {p['description']}"
    state = "independent" if p["independent"] else "dependent"
    return (
        f"population P(X, A): {p['description']}; X and A {state} in it (max |P(x,a) - P(x)P(a)| = "
        f"{_fmt(p['max_deviation'], 3)} at context {_fmt(p['context'])}, group {_fmt(p['group'])})"
    )


def _mechanism(m: Mechanism) -> Report:
    eps = m.epsilon
    return {
        "mechanism": m.name,
        "epsilon": _num(eps),
        "delta": 0.0 if math.isfinite(eps) else None,
        "keep_probability": _num(m.keep_probability),
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
        "epsilon": _num(c.epsilon),
        "keep_probability": _num(c.keep_probability),
        "method": c.method,
        "bound": _num(c.bound),
        "feasible": bool(c.feasible),
        "reason": c.reason,
        "target": _num(c.target),
        "kind": c.kind,
        "mechanism": c.mechanism.name if c.mechanism is not None else c.family,
        "family": c.family,
        "groups": c.groups,
        "gamma": _num(c.gamma),
        "lower": _num(c.lower),
        "tau": _num(c.tau),
        "delta": _num(c.delta),
        "lipschitz": _num(c.lipschitz),
        "diameter": _num(c.diameter),
    }


def _certificate_calibration(cert: Certificate) -> Report:
    """``calibration`` of a certificate with a target: the black-box one (or nulls and why), and ``white_box``."""
    if cert.calibration is not None:
        out = calibration_dict(cert.calibration)
        out["targets"] = {k: _num(cert.targets[k].target) for k in cert.calibration_targets if k in cert.targets}
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
    d: Report = {"value": _num(w.value), "ratio": _num(w.ratio)}
    if w.kind == "local":
        d["context"] = _label(w.context)
    d.update(
        group=_label(w.group),
        other_group=_label(w.other_group),
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
        str(_label(x)): {
            str(_label(a)): {str(_label(u)): float(p[i, j, m]) for m, u in enumerate(k.decisions)}
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
        "paper": _num(cert.paper.value) if cert.paper else None,
        "tight": _num(cert.tight.value) if cert.tight else None,
        "black_box": _num(cert.black_box.local.value),
        "corollary": _num(cert.corollary.value),
        "best": _num(cert.best),
        "best_form": cert.best_form,
        "global": _num(cert.global_bound),
    }
    details: Report = {}
    for name, b in (("paper", cert.paper), ("tight", cert.tight), ("corollary", cert.corollary)):
        if b is not None:
            details[name] = {
                "value": _num(b.value),
                "epsilon": _num(b.epsilon),
                "delta": _num(b.delta),
                "group": _label(b.group),
                "other_group": _label(b.other_group),
                "holds": b.holds,
            }
    details["black_box"] = _worst_model(cert.black_box, cert.black_box_reason)
    out: Report = {
        "certified": bool(cert.certified),
        "spec": spec.source,
        "title": spec.model.title,
        "sensitive": {"name": spec.model.sensitive.name, "values": [_label(g) for g in spec.groups]},
        "context": {"name": spec.context_name, "values": [_label(c) for c in spec.contexts]},
        "decision": {"name": spec.model.decision.name, "values": [_label(d) for d in spec.decisions]},
        "privacy": {"sensitive": _mechanism(spec.sensitive_mechanism), "context": _mechanism(spec.context_mechanism)},
        "utility": {
            "name": spec.utility.name,
            "gamma": _num(spec.gamma),
            "lower": _num(spec.lower),
            "tau": _num(spec.tau),
            "lipschitz": _num(spec.lipschitz),
            "diameter": _num(spec.utility.diameter(spec.metric)),
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
                "target": _num(t.target),
                "met": t.met,
                "bound": _num(t.bound),
                "observed": _num(t.observed),
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
        "utility": {"name": a.utility.name, "gamma": _num(a.utility.gamma), "lower": _num(a.utility.lower)},
        "groups": [{"label": _label(g), "n": int(n)} for g, n in zip(t.groups, t.group_counts)],
        "contexts": [{"label": _label(c), "n": int(n)} for c, n in zip(t.contexts, t.context_counts)],
        "cells": [
            {
                "context": _label(c),
                "group": _label(g),
                "n": int(cells[i, j]),
                "expected_utility": _num(e[i, j]),
                **({} if iv is None else {"interval": [_num(iv.cell_lower[i, j]), _num(iv.cell_upper[i, j])]}),
            }
            for i, c in enumerate(t.contexts)
            for j, g in enumerate(t.groups)
        ],
        "decisions": [_label(d) for d in t.decisions],
        "population": population_dict(a.population),
        "confidence": _num(a.confidence),
        "interval_method": iv.method if iv is not None else None,
    }
    out.update(_observed(a.observed, iv))
    return out


# -- rendering ---------------------------------------------------------------------------------------


def _fmt(v: object, digits: int = 6) -> str:
    if v is None:
        return "n/a"
    if isinstance(v, str):
        return v
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, int):
        return str(v)
    return f"{v:.{digits}g}"


def _nats(v: object) -> str:
    return "n/a" if v is None else ("inf" if v == "inf" else f"{_fmt(v)} nats")


def _pair(d: Report) -> str:
    where = f" in context {d['context']!s}" if d.get("context") is not None else ""
    if d.get("group") is None:
        return ""
    return f" ({d['group']} vs {d['other_group']}{where})"


def _iv(o: Report, key: str) -> str:
    iv = (o.get("intervals") or {}).get(key)
    return f"  interval [{_fmt(iv['lower'])}, {_fmt(iv['upper'])}]" if iv else ""


def _observed_lines(o: Report, head: str) -> list[str]:
    lines = [head]
    for key, name in (("local", "local g-fairness L"), ("global", "global g-fairness L-bar")):
        f = o[key]
        lines.append(f"  {name:<28} {_nats(f['value']):<18} ratio {_fmt(f['ratio'])}{_pair(f)}{_iv(o, key)}")
    det = o["details"]
    lines.append(
        f"  {'demographic parity gap':<28} {_fmt(o['demographic_parity']):<18}{_pair(det['demographic_parity'])}"
        f"{_iv(o, 'demographic_parity')}"
    )
    lines.append(
        f"  {'equalized odds gap':<28} {_fmt(o['equalized_odds']):<18}{_pair(det['equalized_odds'])}"
        f"{_iv(o, 'equalized_odds')}"
    )
    s = det["sup_local"]
    lines.append(
        f"  {'sup over g of L':<28} {_nats(o['sup_local']):<18} decision {s['decision']}{_pair(s)}{_iv(o, 'sup_local')}"
    )
    s = det["sup_global"]
    lines.append(
        f"  {'sup over g of L-bar':<28} {_nats(o['sup_global']):<18} decision {s['decision']}{_pair(s)}"
        f"{_iv(o, 'sup_global')}"
    )
    for note in (o.get("intervals") or {}).get("notes", []):
        lines.append(f"  intervals: {note}")
    for note in o.get("excluded", [])[:10]:
        lines.append(f"  excluded: {note}")
    if len(o.get("excluded", [])) > 10:
        lines.append(f"  ... and {len(o['excluded']) - 10} more exclusions")
    return lines


def _goal(kind: str, target: object) -> str:
    """'the local target 0.5 nats on L' (or on L-bar for the global one)."""
    return f"the {kind} target {_nats(target)} on {'L' if kind == 'local' else 'L-bar'}"


def _certificate_text(d: Report) -> str:
    lines = [f"fairaudit certificate: {d['title'] or d['spec']}"]
    ps = d["privacy"]["sensitive"]
    lines.append(
        f"privacy of {d['sensitive']['name']}: {ps['mechanism']}, epsilon = {_nats(ps['epsilon'])}, delta = "
        f"{_fmt(ps['delta'])}, keep probability {_fmt(ps['keep_probability'])}"
    )
    pc = d["privacy"]["context"]
    lines.append(f"privacy of {d['context']['name']}: {pc['mechanism']}, epsilon = {_nats(pc['epsilon'])}")
    u = d["utility"]
    lines.append(
        f"utility: {u['name']}, range [{_fmt(u['lower'])}, {_fmt(u['gamma'])}], tau = {_fmt(u['tau'])}, "
        f"L_A = {_fmt(u['lipschitz'])}"
    )
    lines.append(_population_line(d))
    lines.append("bounds on L for any decision model behind the filter:")
    det = d["bound_details"]
    for key, name in (
        ("paper", "paper (main theorem)"),
        ("tight", "tight (its proof, per pair)"),
        ("black_box", "black-box (exact worst case)"),
        ("corollary", "corollary (epsilon)"),
    ):
        v = d["bounds"][key]
        extra = ""
        if key in ("paper", "tight") and key in det:
            extra = f" at epsilon = {_fmt(det[key]['epsilon'])}, delta = {_fmt(det[key]['delta'])}"
        if key == "black_box":
            bb = det["black_box"]
            extra = (
                f" ({bb['reason']})"
                if bb.get("value") is None
                else f" ({_fmt(bb['group'])} over {_fmt(bb['other_group'])}; on L-bar {_nats(bb['global']['value'])})"
            )
        if key in ("paper", "tight") and v is None:
            extra = " (needs utility.tau)"
        if key in det and det[key].get("holds") is False:
            extra += " (does not apply: an assumption is violated)"
        lines.append(f"  {name:<30} {_nats(v)}{extra}")
    lines.append(f"  best valid bound: {_nats(d['bounds']['best'])} ({d['bounds']['best_form']})")
    if "observed" in d:
        lines += _observed_lines(d["observed"], "observed, the model behind the filter:")
        iv = d["observed"].get("intervals")
        if iv and iv.get("local"):
            lines.append(
                f"  from counts, simultaneous {_fmt(iv['confidence'])} ({iv['method']}): white-box certificate "
                f"L <= {_nats(iv['local']['upper'])}; evidence of unfairness L >= {_nats(iv['local']['lower'])}"
            )
    if "unfiltered" in d:
        lines += _observed_lines(d["unfiltered"], "observed, the model without the filter:")
    if "targets" in d:
        for k, t in d["targets"].items():
            obs = f"; observed {_nats(t['observed'])}" if t["observed"] is not None else ""
            lines.append(
                f"target {k}: {_nats(t['target'])} -> {'MET' if t['met'] else 'NOT MET'} "
                f"(bound {_nats(t['bound'])}{obs}; {t['reason']})"
            )
    if "calibration" in d:
        c = d["calibration"]
        if c["method"] is None:
            lines.append(f"calibration: skipped ({c['reason']})")
        elif c["feasible"]:
            goals = " and ".join(_goal(k, v) for k, v in c.get("targets", {}).items()) or _goal(c["kind"], c["target"])
            lines.append(
                f"calibration: {c.get('family') or 'randomized response'} with epsilon <= {_nats(c['epsilon'])} "
                f"(keep probability {_fmt(c['keep_probability'])}) would meet {goals} for any model ({c['method']})"
            )
            if "left_out" in c:
                lines.append(f"calibration leaves out a target: {c['left_out']}")
        else:
            lines.append(
                f"calibration: no epsilon meets {_goal(c['kind'], c['target'])} for any model ({c['method']}): "
                f"{c['reason']}"
            )
        w = c.get("white_box")
        if w is not None and w["feasible"]:
            lines.append(
                f"calibration for this model: epsilon <= {_nats(w['epsilon'])} (keep probability "
                f"{_fmt(w['keep_probability'])}) keeps its {_measure(w)} <= {_nats(w['target'])} (white_box)"
            )
        elif w is not None:
            lines.append(f"calibration for this model: no epsilon (white_box): {w['reason']}")
    lines.append("assumptions:")
    for a in d["assumptions"]:
        lines.append(f"  [{a['status']}] {a['name']}: {a['detail']} (for {', '.join(a['for'])})")
    lines.append(f"certified: {'yes' if d['certified'] else 'no'}")
    return "\n".join(lines) + "\n"


def _audit_text(d: Report) -> str:
    ctx = ", ".join(d["context_columns"]) or "none"
    lines = [
        f"fairaudit audit: {d['n']} records; sensitive {', '.join(d['sensitive'])}; outcome {d['outcome']}; "
        f"context {ctx}",
        f"utility: {d['utility']['name']}",
    ]
    lines.append("records per group: " + ", ".join(f"{g['label']} {g['n']}" for g in d["groups"]))
    if len(d["contexts"]) > 1:
        lines.append(
            "records per context: "
            + ", ".join(f"{c['label']} {c['n']}" for c in d["contexts"][:30])
            + (" ..." if len(d["contexts"]) > 30 else "")
        )
    lines.append(_population_line(d))
    if d["confidence"] is not None:
        lines.append(f"intervals: simultaneous {_fmt(d['confidence'])} ({d['interval_method']})")
    lines += _observed_lines(d, "metrics:")
    return "\n".join(lines) + "\n"


def _measure(d: Report) -> str:
    return "L-bar" if d.get("kind") == "global" else "L"


def _calibration_text(d: Report) -> str:
    if not d["feasible"]:
        low = f"the model's {_measure(d)} at epsilon = 0" if d["method"] == "white_box" else "smallest certified bound"
        return (
            f"no epsilon of {d['family']} meets {_measure(d)} <= {_nats(d['target'])}\n"
            f"method: {d['method']}; {low}: {_nats(d['bound'])}\n"
            f"reason: {d['reason']}\n"
        )
    there = f"the model's {_measure(d)} there" if d["method"] == "white_box" else "certified bound there"
    return (
        f"largest epsilon of {d['family']} meeting {_measure(d)} <= {_nats(d['target'])}: {_nats(d['epsilon'])}\n"
        f"keep probability (the price): {_fmt(d['keep_probability'])}\n"
        f"method: {d['method']}; {there}: {_nats(d['bound'])}\n"
        f"reason: {d['reason']}\n"
    )


def _md_table(rows: Sequence[tuple[object, ...]], head: tuple[str, ...]) -> list[str]:
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    out += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return out


def _observed_md(o: Report) -> list[str]:
    rows: list[tuple[str, ...]] = [
        ("local g-fairness L", _nats(o["local"]["value"]), _pair(o["local"]).strip(" ()")),
        ("global g-fairness L-bar", _nats(o["global"]["value"]), _pair(o["global"]).strip(" ()")),
        (
            "demographic parity gap",
            _fmt(o["demographic_parity"]),
            _pair(o["details"]["demographic_parity"]).strip(" ()"),
        ),
        ("equalized odds gap", _fmt(o["equalized_odds"]), _pair(o["details"]["equalized_odds"]).strip(" ()")),
        ("sup over g of L", _nats(o["sup_local"]), _pair(o["details"]["sup_local"]).strip(" ()")),
        ("sup over g of L-bar", _nats(o["sup_global"]), _pair(o["details"]["sup_global"]).strip(" ()")),
    ]
    if o.get("intervals"):
        iv = o["intervals"]
        rows = [
            r + (f"[{_fmt(iv[k]['lower'])}, {_fmt(iv[k]['upper'])}]" if iv.get(k) else "n/a",)
            for r, k in zip(
                rows, ("local", "global", "demographic_parity", "equalized_odds", "sup_local", "sup_global")
            )
        ]
        head = ("metric", "value", "where", f"simultaneous {_fmt(iv['confidence'])} interval ({iv['method']})")
        return _md_table(rows, head)
    return _md_table(rows, ("metric", "value", "where"))


def _certificate_md(d: Report) -> str:
    lines = [f"# fairaudit certificate: {d['title'] or d['spec']}", ""]
    ps = d["privacy"]["sensitive"]
    lines.append(
        f"Privacy of **{d['sensitive']['name']}**: {ps['mechanism']}, ε = {_nats(ps['epsilon'])}, "
        f"keep probability {_fmt(ps['keep_probability'])}."
    )
    lines += ["", f"Population P(X, A): {_population_line(d).removeprefix('population P(X, A): ')}."]
    lines += ["", "## Bounds on L for any decision model", ""]
    rows = [(k, _nats(d["bounds"][k])) for k in ("paper", "tight", "black_box", "corollary")]
    lines += _md_table(rows, ("bound", "value"))
    lines += ["", f"Best valid bound: **{_nats(d['bounds']['best'])}** ({d['bounds']['best_form']})."]
    for key, head in (("observed", "Observed behind the filter"), ("unfiltered", "Observed without the filter")):
        if key in d:
            lines += ["", f"## {head}", ""] + _observed_md(d[key])
    if "targets" in d:
        lines += ["", "## Targets", ""]
        lines += _md_table(
            [
                (k, _nats(t["target"]), _nats(t["bound"]), "met" if t["met"] else "NOT met")
                for k, t in d["targets"].items()
            ],
            ("target", "value", "bound", "result"),
        )
    if "calibration" in d:
        c = d["calibration"]
        if c["method"] is None:
            lines += ["", f"Calibration: skipped ({c['reason']})."]
        elif c["feasible"]:
            goals = " and ".join(_goal(k, v) for k, v in c.get("targets", {}).items()) or _goal(c["kind"], c["target"])
            lines += [
                "",
                f"Calibration: ε ≤ {_nats(c['epsilon'])} (keep probability {_fmt(c['keep_probability'])}) "
                f"would meet {goals} for any model ({c['method']}).",
            ]
            if "left_out" in c:
                lines += ["", f"Calibration leaves out a target: {c['left_out']}."]
        else:
            lines += [
                "",
                f"Calibration: no ε meets {_goal(c['kind'], c['target'])} for any model ({c['method']}): "
                f"{c['reason']}.",
            ]
        w = c.get("white_box")
        if w is not None:
            lines += [
                "",
                f"Calibration for this model (white_box): ε ≤ {_nats(w['epsilon'])} (keep probability "
                f"{_fmt(w['keep_probability'])})."
                if w["feasible"]
                else f"Calibration for this model (white_box): no ε: {w['reason']}.",
            ]
    lines += ["", "## Assumptions", ""]
    lines += _md_table(
        [(a["name"], a["status"], a["detail"], ", ".join(a["for"])) for a in d["assumptions"]],
        ("assumption", "status", "detail", "for"),
    )
    lines += ["", f"**Certified: {'yes' if d['certified'] else 'no'}**", ""]
    return "\n".join(lines)


def _audit_md(d: Report) -> str:
    lines = [
        f"# fairaudit audit: {d['n']} records",
        "",
        f"Sensitive: {', '.join(d['sensitive'])}; outcome: {d['outcome']}; utility: `{d['utility']['name']}`.",
        "",
    ]
    lines += _md_table([(g["label"], g["n"]) for g in d["groups"]], ("group", "records"))
    lines += ["", f"Population P(X, A): {_population_line(d).removeprefix('population P(X, A): ')}.", ""]
    lines += _observed_md(d) + [""]
    return "\n".join(lines)


def render(data: Report, kind: str, fmt: str) -> str:
    """Render a report dictionary.

    Parameters
    ----------
    data : dict
        From :func:`certificate_dict`, :func:`audit_dict`, :func:`calibration_dict` or :func:`plan_dict`.
    kind : {"certify", "audit", "calibrate", "plan"}
    fmt : {"text", "json", "markdown"}

    Raises
    ------
    InputError
        On an unknown format.
    """
    if fmt == "json":
        return json.dumps(data, indent=2, ensure_ascii=False, allow_nan=False) + "\n"
    if fmt not in FORMATS:
        raise InputError("--format", f"must be one of {', '.join(FORMATS)}", fmt)
    table: dict[tuple[str, str], Callable[[Report], str]] = {
        ("certify", "text"): _certificate_text,
        ("certify", "markdown"): _certificate_md,
        ("audit", "text"): _audit_text,
        ("audit", "markdown"): _audit_md,
        ("calibrate", "text"): _calibration_text,
        ("calibrate", "markdown"): lambda d: "# fairaudit calibration\n\n```\n" + _calibration_text(d) + "```\n",
        ("plan", "text"): _plan_text,
        ("plan", "markdown"): _plan_md,
    }
    return table[(kind, fmt)](data)


def write_atomic(
    path: str | os.PathLike[str], content: str | bytes | Callable[[str], object], *, field: str = "--output"
) -> None:
    """Write ``content`` to ``path`` atomically: a temporary file in the same folder, then rename.

    An existing file is replaced only once the new one is complete; on any
    error it is left untouched and the temporary file removed. The file gets
    the usual permissions (0666 less the umask).

    The temporary file is ``.NAME.XXXXXXXX.tmpSUFFIX`` next to ``NAME``
    (``tempfile.mkstemp``). A writer killed before its rename (SIGKILL, power
    loss) leaves it behind; each write first removes the leftovers of *the
    same* target: regular files in that folder whose name is exactly that
    pattern for ``NAME`` and that are older than :data:`STALE_SECONDS` (a
    live writer's file is younger: it is written as soon as it is made).
    No other file is touched.

    Parameters
    ----------
    path : str or os.PathLike
    content : str, bytes or callable
        Text (UTF-8), bytes, or a function that writes the file given the
        temporary path (for example a matplotlib ``savefig``).
    field : str
        The option named in errors (``--output``, ``--plot``, ...).

    Raises
    ------
    InputError
        If the folder does not exist or cannot be written, or ``path`` is a folder.
    """
    p = Path(path)
    folder = p.parent if str(p.parent) else Path(".")
    if not folder.is_dir():
        raise InputError(field, "folder does not exist", str(folder))
    if p.is_dir():
        raise InputError(field, "is a directory", str(p))
    _remove_stale_temporaries(folder, p)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.", suffix=".tmp" + p.suffix, dir=folder)
    except OSError as exc:
        raise InputError(field, f"cannot write there ({exc.strerror})", str(path)) from None
    try:
        if callable(content):
            os.close(fd)
            content(tmp)
        else:
            data = content.encode("utf-8") if isinstance(content, str) else bytes(content)
            with os.fdopen(fd, "wb") as fh:
                fh.write(data)
                fh.flush()
                os.fsync(fh.fileno())
        mask = os.umask(0)
        os.umask(mask)
        os.chmod(tmp, 0o666 & ~mask)  # mkstemp makes 0600; a report gets the usual permissions
        os.replace(tmp, p)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


STALE_SECONDS = 60.0
"""Age (by modification time) after which :func:`write_atomic` removes a temporary file left by a killed writer."""


def _remove_stale_temporaries(folder: Path, target: Path) -> None:
    """Remove the temporary files that killed writers of ``target`` left in ``folder`` (best effort)."""
    pattern = re.compile(re.escape(f".{target.name}.") + r"[a-z0-9_]{8}" + re.escape(".tmp" + target.suffix))
    now = time.time()
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return
    for entry in entries:
        if not pattern.fullmatch(entry.name):
            continue
        try:
            info = entry.stat(follow_symlinks=False)
            if stat.S_ISREG(info.st_mode) and now - info.st_mtime > STALE_SECONDS:
                os.unlink(entry.path)
        except OSError:
            pass  # gone already, or not ours to remove


# -- sample-size plans (fairaudit plan) -----------------------------------------------------------------


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
        "target": _num(first.target),
        "confidence": _num(first.confidence),
        "power": _num(first.power),
        "kind": first.kind,
        "groups": first.groups,
        "contexts": first.contexts,
        "base_rate": _num(first.base_rate),
        "disparity": _num(first.disparity),
        "epsilon": _num(first.epsilon),
        "seed": first.seed,
        "max_n": first.max_n,
        "true_value": _num(first.true_value),
        "feasible": all(p.feasible for p in plans),
        "plans": [
            {
                "method": p.method,
                "n_per_cell": p.n_per_cell,
                "n_total": p.n_total,
                "achieved_power": _num(p.achieved_power),
                "expected_upper": _num(p.expected_upper),
                "datasets": p.datasets,
                "reason": p.reason,
            }
            for p in plans
        ],
    }


def _plan_head(d: Report) -> list[str]:
    name = "L-bar" if d["kind"] == "global" else "L"
    ctx = f"{d['contexts']} context{'s' if d['contexts'] != 1 else ''}"
    filt = (
        f"queried behind {d['groups']}-ary randomized response at epsilon = {_nats(d['epsilon'])}"
        if d["epsilon"] is not None
        else "no privacy filter"
    )
    return [
        f"queries per cell to certify {name} <= {_nats(d['target'])} at confidence {_fmt(d['confidence'])} "
        f"with power {_fmt(d['power'])}",
        f"model: {d['groups']} groups x {ctx}, E[g] = {_fmt(d['base_rate'])}, group 0 times "
        f"exp({_fmt(d['disparity'])}); {filt}; true {name} = {_nats(d['true_value'])}",
    ]


def _plan_rows(d: Report) -> list[tuple[str, ...]]:
    def upper(v: object) -> str:
        return "n/a" if v is None else ("inf" if v == "inf" else f"{_fmt(v, 4)} nats")

    return [
        (
            p["method"],
            _fmt(p["n_per_cell"]),
            _fmt(p["n_total"]),
            _fmt(p["achieved_power"], 3),
            upper(p["expected_upper"]),
            str(p["datasets"]),
        )
        for p in d["plans"]
    ]


_PLAN_HEAD = ("method", "n per cell", "n total", "power", "median upper end", "datasets")


def _plan_text(d: Report) -> str:
    rows = [_PLAN_HEAD] + _plan_rows(d)
    widths = [max(len(r[i]) for r in rows) for i in range(len(_PLAN_HEAD))]
    lines = _plan_head(d)
    lines += ["  " + "  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip() for r in rows]
    lines += [f"{p['method']}: {p['reason']}" for p in d["plans"] if p["reason"]]
    return "\n".join(lines) + "\n"


def _plan_md(d: Report) -> str:
    head = _plan_head(d)
    lines = ["# fairaudit plan", "", head[0] + ".", "", head[1] + ".", ""]
    lines += _md_table(_plan_rows(d), _PLAN_HEAD)
    lines += [""] + [f"* {p['method']}: {p['reason']}" for p in d["plans"] if p["reason"]]
    return "\n".join(lines).rstrip("\n") + "\n"
