"""What an experiment writes: tables, the certificate JSON, the figures and a Markdown report (the last step of a
run, :func:`write_report`).

The files are docs/experiments.md's "The files": ``kernel.csv`` (also the input of ``--kernel``),
``candidates.csv``, ``records.csv`` (sampled route), ``spec-eps-<ε>.toml`` (:func:`experiment_spec`),
``certificate.json`` (:func:`experiment_dict`), ``curve.csv``, ``baseline.png``, ``curve.png`` and ``report.md``.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from fairaudit import InputError, number, write_atomic

from ._markdown import experiment_markdown
from .harness import paper_queries_needed, table_queries_needed
from .slots import slot_names, true_prompts, view_mixtures
from .vlm.tasks import UNPARSED

if TYPE_CHECKING:
    import pandas as pd

    from fairaudit import Calibration, Kernel, UtilityRange

    from .analysis import ExperimentAnalysis, Observed, PointResult, RunAnalysis
    from .kernel import UnparsedMass
    from .slots import PositionSplit
    from .vlm.filter import TaskFilter
    from .vlm.tasks import DeliveryTask

__all__ = [
    "candidate_frame",
    "experiment_dict",
    "experiment_markdown",
    "experiment_spec",
    "head_dict",
    "observed_dicts",
    "point_dict",
    "privacy_dict",
    "records_frame",
    "shown_kernel_frame",
    "utility_dict",
    "write_files",
    "write_frame",
    "write_json",
    "write_report",
]


def _cells(k: Kernel) -> tuple[npt.NDArray[np.intp], npt.NDArray[np.intp], npt.NDArray[np.intp], dict[str, Any]]:
    """The (x, g, d) of every cell of ``k`` in table order, and its column of values: ``count`` (integers) on the
    sampled route, ``probability`` on the exact one."""
    value = (
        {"count": k.counts.ravel().astype(int)} if k.counts is not None else {"probability": k.probabilities.ravel()}
    )
    x, g, d = (a.ravel() for a in np.indices(k.probabilities.shape))
    return x, g, d, value


def shown_kernel_frame(task: DeliveryTask, kernel: Kernel) -> pd.DataFrame:
    """A kernel on shown cells as the long table of ``kernel.csv``, read back by ``--kernel``.

    Parameters
    ----------
    task : DeliveryTask
    kernel : Kernel
        Shape (n_contexts, n_profiles^k, n_decisions), the layout of
        :func:`fairaudit.experiments.kernel.table_kernel` (groups: the shown
        pairs, row-major), with counts (sampled) or without (exact).

    Returns
    -------
    pandas.DataFrame
        One row per context, shown pair and decision: the task's context
        name, the two options (the profile shown as each), ``decision``, and
        ``count`` (integers) or ``probability``
        (:meth:`fairaudit.experiments.vlm.models.SimulatedModel.from_csv` reads both).
    """
    import pandas as pd

    x, g, d, value = _cells(kernel)
    labels = np.asarray([[task.profile_label(p) for p in cell] for cell in kernel.groups], dtype=object)
    return pd.DataFrame(
        {
            task.context_name: np.asarray(kernel.contexts, dtype=object)[x],
            **{slot: labels[g, i] for i, slot in enumerate(slot_names(task))},
            "decision": np.asarray(kernel.decisions, dtype=object)[d],
            **value,
        }
    )


def candidate_frame(analysis: ExperimentAnalysis) -> pd.DataFrame:
    """The per-candidate kernel as a long table: context, shown, outcome, count (probability on the exact route)."""
    import pandas as pd

    k = analysis.candidate_kernel
    x, g, d, value = _cells(k)
    return pd.DataFrame(
        {
            "context": np.asarray(k.contexts, dtype=object)[x],
            "profile": np.asarray(k.groups, dtype=object)[g],
            "outcome": np.asarray(k.decisions, dtype=object)[d],
            **value,
        }
    )


def experiment_spec(analysis: ExperimentAnalysis, point: PointResult) -> str:
    """A ``fairaudit certify`` spec (TOML) of the per-candidate experiment at one ε.

    ``[sensitive]`` the two candidates' profiles; ``[context]`` item @
    position; ``[privacy.sensitive]`` the matrix M_cand of that ε, with its
    outputs (``own | rival``), and ``[privacy.family]`` its family (:func:`_family_lines`: ``fairaudit calibrate
    --spec`` moves along it); ``[privacy.context]`` M_X ⊗ I; ``[population]``
    the run's positions; ``[model]`` ``candidates.csv`` (counts, or
    probabilities on the exact route);
    ``[utility]`` the task's g; ``[decision] unparsed`` names the outcome of
    replies read as no option (its g is a stated default), so that
    ``fairaudit calibrate`` of it calibrates on the upper end over that
    utility. ``fairaudit certify`` of it repeats the experiment's certificate
    at that ε (under the stated default; the ranges are the experiment's
    ``unparsed_range``). Values are written with ``json.dumps`` (TOML's
    strings, arrays and floats accept them).
    """
    a, t = analysis, analysis.task
    j = json.dumps
    ctx = point.filter.context_mechanism
    model = (
        {"count_column": "count"} if a.candidate_kernel.counts is not None else {"probability_column": "probability"}
    )
    lines = [
        f"# {t.name}: {a.model}; the candidate's ε = {point.epsilon:.6g} nats "
        f"(keep p = {', '.join(f'{q:.6g}' for q in point.filter.keep_probabilities)} per attribute)",
        f"title = {j(f'{t.name}: {a.model}, per candidate, epsilon = {point.epsilon:.6g}')}",
        "",
        *_toml("sensitive", name="profile", values=list(a.population.groups)),
        *_toml("context", name="context", values=list(a.population.contexts)),
        *_toml(
            "decision", name="outcome", values=list(t.outcomes), unparsed=UNPARSED if UNPARSED in t.outcomes else None
        ),
        *_toml("population", probabilities=a.population.probabilities),
        *_toml(
            "privacy.sensitive",
            mechanism="matrix",
            name=point.mechanism.name,
            outputs=list(point.mechanism.outputs),
            rows=point.mechanism.matrix,
        ),
        *_family_lines(a, point),
    ]
    if ctx.epsilon != float("inf"):
        lines += _toml("privacy.context", mechanism="matrix", name=ctx.name, rows=np.kron(ctx.matrix, np.eye(t.slots)))
    lines += _toml("model", table="candidates.csv", **model)
    tau = None if a.tau is None else float(a.tau)
    lines += _toml("utility", kind="table", values=[float(v) for v in t.utility_values], tau=tau)
    return "\n".join(lines)


def _toml(header: str, /, **keys: Any) -> list[str]:
    """The lines of TOML table ``header``: the header, ``key = value`` per keyword whose value is not None, a blank
    line. Values are written with ``json.dumps`` (TOML's strings, arrays and floats accept them); a 2-D array one
    row a line."""

    def value(v: Any) -> str:
        if isinstance(v, np.ndarray):
            return "[\n  " + ",\n  ".join(json.dumps(row) for row in v.tolist()) + "\n]"
        return json.dumps(v)

    return [f"[{header}]", *(f"{k} = {value(v)}" for k, v in keys.items() if v is not None), ""]


def _family_lines(analysis: ExperimentAnalysis, point: PointResult) -> list[str]:
    """``[privacy.family]`` of :func:`experiment_spec`: M_cand as a product of randomized responses on the rows of
    the true views the candidates are shown with (``inputs``: the one view of each, in a point-mass design; else
    ``mixtures``: each candidate's views weighted by how often the design shows them), so that ``fairaudit
    calibrate --spec`` moves along it.

    The product has one component per slot (the candidate's own first, then its rivals' in the order of its view)
    and attribute, randomized response at the point's ε of that attribute: calibration splits ε in their
    proportion, which is the experiment's split (one keep probability on every attribute) where the attributes
    have equally many values.
    """
    t = analysis.task
    mixtures = view_mixtures(t, analysis.positions)
    j = json.dumps
    eps = [e if np.isfinite(e) else "inf" for e in point.filter.epsilon_attributes]
    component = ", ".join(
        f'{{mechanism = "randomized_response", values = {j(list(a.values))}, epsilon = {e}}}'
        for a, e in zip(t.attributes, eps)
    )

    def row(view: tuple[int, ...]) -> list:
        return [v for i in view for v in t.profiles[i]]

    groups = [mixtures[t.profiles.index(tuple(c))] for c in t.candidates]
    if all(len(views) == 1 for views in groups):
        rows = f"inputs = {j([row(next(iter(views))) for views in groups])}"
    else:
        mixed = (
            "[" + ", ".join(f"{{weight = {j(w)}, input = {j(row(v))}}}" for v, w in m.items()) + "]" for m in groups
        )
        rows = "mixtures = [\n  " + ",\n  ".join(mixed) + "\n]"
    return [
        "[privacy.family]",
        f"name = {j(point.mechanism.name)}",
        "components = [\n  " + ",\n  ".join([component] * t.slots) + "\n]",
        rows,
        "",
    ]


def records_frame(analysis: ExperimentAnalysis) -> pd.DataFrame:
    """Per-candidate records of the table design, one row per query and candidate, for ``fairaudit audit``.

    Columns: the context name, ``position`` (the option), ``profile`` (the
    candidate's shown profile), ``rival`` (the other's; ``rivals`` for k ≥ 3,
    from the next slot on, joined by ``" | "``) and ``outcome``; one candidate
    per prompt has no ``position`` nor rival. The profiles are the ones shown
    to the model, so an audit of this file is the model's own fairness
    without a filter, against rivals drawn uniformly.
    """
    import pandas as pd

    t, k = analysis.task, analysis.candidate_kernel
    assert k.counts is not None  # (estimated from counts)
    counts = k.counts.astype(int)
    x, g, d = np.repeat(np.indices(counts.shape).reshape(3, -1), counts.ravel(), axis=1)  # each cell count times
    many = t.slots > 1  # one candidate per prompt: no position, no rival
    ctx = np.asarray([c.rsplit(" @ ", 1) if many else (c, "") for c in k.contexts], dtype=object)
    shown = np.asarray([s.split(" | ", 1) if many else (s, "") for s in k.groups], dtype=object)
    return pd.DataFrame(
        {
            t.context_name: ctx[x, 0],
            **({"position": ctx[x, 1]} if many else {}),
            "profile": shown[g, 0],
            **({"rival" if t.slots == 2 else "rivals": shown[g, 1]} if many else {}),
            "outcome": np.asarray(k.decisions, dtype=object)[d],
        }
    )


def privacy_dict(task: DeliveryTask, f: TaskFilter, epsilon_candidate: float) -> dict[str, Any]:
    """The ``privacy`` of a point: the candidate's ε, the profile's, each attribute's ε and keep probability, δ = 0.

    ``attributes`` lists, per attribute, its number of values k, its keep
    probability p and its ε = ln(p (k − 1) / (1 − p)) (nats); ``split`` states
    how the budget is split over them (:data:`fairaudit.experiments.vlm.filter.SPLIT_RULE`), and ``release`` how
    the paper design draws what the model is shown (:data:`fairaudit.experiments.vlm.filter.RELEASE_RULE`).
    """
    from .vlm.filter import RELEASE_RULE, SPLIT_RULE

    return {
        "epsilon_candidate": number(epsilon_candidate),
        "epsilon_profile": number(f.epsilon_profile),
        "epsilon_per_attribute": {a.name: number(e) for a, e in zip(task.attributes, f.epsilon_attributes)},
        "keep_probability_per_attribute": {a.name: number(q) for a, q in zip(task.attributes, f.keep_probabilities)},
        "attributes": [
            {"name": a.name, "values": len(a.values), "keep_probability": number(q), "epsilon": number(e)}
            for a, q, e in zip(task.attributes, f.keep_probabilities, f.epsilon_attributes)
        ],
        "split": SPLIT_RULE,
        "release": RELEASE_RULE,
        "delta": 0.0,
        "context_mechanism": f.context_mechanism.name,
    }


def head_dict(analysis: RunAnalysis) -> dict[str, Any]:
    """The keys both designs' certificates begin with: the task, the model, the route, the positions, the samples,
    the slots, the candidates and the context's name.

    Parameters
    ----------
    analysis : RunAnalysis
        Either design's analysis (the task file's or the paper's).

    Returns
    -------
    dict
        ``experiment``, ``model``, ``route``, ``positions``, ``samples``, ``slots``, ``candidates`` (labels) and
        ``context``, in that order (``docs/experiments.md`` "The files").
    """
    a, t = analysis, analysis.task
    return {
        "experiment": t.name,
        "model": a.model,
        "route": a.route,
        "positions": a.positions,
        "samples": a.samples,
        "slots": t.slots,
        "candidates": [t.profile_label(c) for c in t.candidates],
        "context": t.context_name,
    }


def utility_dict(task: DeliveryTask, unparsed_range: UtilityRange) -> dict[str, Any]:
    """The ``utility`` of a report: g's name, its value per outcome, ``unparsed``, the value an unparsed reply
    counts with ``source`` (``"given"``, or ``"default: expected g of a uniformly random reply"``) and ``rule``
    (how it was set, in words: :attr:`~fairaudit.experiments.vlm.tasks.DeliveryTask.unparsed_rule`), and
    ``unparsed_range``, the ends of ``unparsed_range`` (the baseline's)."""
    return {
        "name": task.utility_name,
        "values": dict(zip(task.outcomes, map(number, task.utility_values))),
        "unparsed": {
            "value": number(task.utility_values[-1]),
            "source": task.unparsed_source,
            "rule": task.unparsed_rule,
        },
        "unparsed_range": [number(unparsed_range.low), number(unparsed_range.high)],
    }


def observed_dicts(point: Observed) -> dict[str, Any]:
    """``{"local": ..., "global": ...}``: a point's observed L and L̄ (both designs' certificates).

    ``point`` has ``local_fairness``, ``global_fairness``, ``intervals`` (or None) and ``unparsed_range``
    (:class:`~fairaudit.experiments.analysis.PointResult`, the paper design's points). Each is a dictionary with
    ``unparsed_range`` (its range over the unparsed reply's utility) and ``unparsed_range_ends`` (exactness, and
    the context and groups of each end).
    """
    out: dict[str, Any] = {}
    for kind in ("local", "global"):
        d = getattr(point, f"{kind}_fairness").to_dict(
            None if point.intervals is None else getattr(point.intervals, f"{kind}_fairness")
        )
        ends = getattr(point.unparsed_range, f"{kind}_fairness").to_dict()
        d["unparsed_range"] = ends.pop("range")
        d["unparsed_range_ends"] = ends
        out[kind] = d
    return out


def point_dict(
    task: DeliveryTask, p: Any, bounds: Any, queries: int | None = None, closed_form: bool | None = None
) -> dict[str, Any]:
    """One ε of a certificate (both designs): its privacy, its bounds with their unparsed ranges, what was observed.

    ``p`` is a point (:class:`~fairaudit.experiments.analysis.PointResult`, the paper design's points) and ``bounds``
    what holds for any model (``filter``, ``corollary``, ``black_box_local``, ``black_box_global``: the point itself,
    or the paper design's :class:`~fairaudit.experiments.paper_design.DesignBounds`); ``queries`` and
    ``closed_form`` are written when given.
    """
    closed = {} if closed_form is None else {"closed_form": closed_form}
    return {
        "epsilon": number(p.epsilon),
        **({} if queries is None else {"queries": queries}),
        "privacy": privacy_dict(task, bounds.filter, bounds.corollary),
        "bounds": {
            "corollary": number(bounds.corollary),
            "black_box": number(bounds.black_box_local),
            "black_box_global": number(bounds.black_box_global),
            **closed,
            "unparsed_range": {name: r.to_dict() for name, r in p.bound_ranges.items()},
        },
        "observed": observed_dicts(p),
        "certified_local": number(bounds.black_box_local),
    }


def experiment_dict(analysis: ExperimentAnalysis, run: dict[str, Any] | None = None) -> dict[str, Any]:
    """The certificate JSON of an experiment: docs/experiments.md, "The files", lists its keys. Values in nats; +inf is ``"inf"``;
    NaN is ``null``.
    """
    a, t = analysis, analysis.task
    prompts, _ = true_prompts(t, "balanced")
    names = [", ".join(f"{o} = {t.profile_label(t.profiles[i])}" for o, i in zip(slot_names(t), p)) for p in prompts]
    shares = {
        ctx: {name: dict(zip(t.decisions, map(number, a.shares[i, j]))) for j, name in enumerate(names)}
        for i, ctx in enumerate(t.contexts)
    }
    split = a.split
    out = head_dict(a) | {
        "queries": {
            "table": a.table_queries,
            "paper": a.paper_queries,
            "unparsed": a.unparsed,
            "unparsed_share": number(a.unparsed_share),
            "table_design_needs": table_queries_needed(t, a.samples),
            "paper_design_needs_per_epsilon": paper_queries_needed(t, a.samples, 1, a.positions),
        },
        "utility": utility_dict(t, a.baseline.unparsed_range),
        "unparsed_mass": None if a.unparsed_mass is None else _mass_dict(a.unparsed_mass),
        "tau": number(a.tau),
        "confidence": number(a.confidence),
        "baseline": {
            **observed_dicts(a.baseline),
            "shares": shares,
        },
        "position_split": None if split is None else _split_dict(split),
        "budgets": [
            {
                "target": number(b.target),
                "kind": b.kind,
                "this_model": _budget(b.this_model)
                | {
                    "met_by": "unparsed_upper_end",
                    "stated_default": _budget(b.stated_default)
                    | {"unparsed_upper": number(b.unparsed_upper), "overturned_by_unparsed": b.overturned},
                },
                "any_model": _budget(b.any_model),
            }
            for b in a.budgets
        ],
        "points": [point_dict(t, p, p) for p in a.points],
        "paper_design": [
            {
                "epsilon": number(p.epsilon),
                "queries": p.queries,
                **observed_dicts(p),
            }
            for p in a.paper
        ],
        # the curve's first eight columns (curve.csv's: ε to observed L̄), each named without "_nats"
        "curve": {
            str(column).removesuffix("_nats"): [number(v) for v in values]
            for column, values in a.curve.to_frame().iloc[:, :8].items()
        },
    }
    if run:
        out["run"] = run
    return out


def _mass_dict(m: UnparsedMass) -> dict[str, Any]:
    return {
        "threshold": number(m.threshold),
        "share_above": number(m.share),
        "largest": number(m.largest),
        "cells": [{"context": c, "shown": shown, "mass": number(v)} for c, shown, v in m.cells],
        "warning": m.warning,
    }


def _budget(c: Calibration) -> dict[str, Any]:
    return {
        "epsilon": number(c.epsilon),
        "keep_probability": number(c.keep_probability),
        "feasible": c.feasible,
        "bound": number(c.bound),
        "reason": c.reason,
    }


def _split_dict(split: PositionSplit) -> dict[str, Any]:
    position, group = split.explained()
    return {
        "pair": list(split.pair),
        "raw": number(split.overall_raw),
        "position": number(split.overall_position),
        "group": number(split.overall_group),
        "interaction": number(split.overall_interaction),
        "explained": {"position": number(position), "group": number(group)},
        "per_context": {
            c: {"raw": number(r), "position": number(q), "group": number(g), "interaction": number(i)}
            for c, r, q, g, i in zip(split.contexts, split.raw, split.position, split.group, split.interaction)
        },
    }


def write_json(path: str | Path, data: dict[str, Any]) -> None:
    """``data`` as indented JSON, atomically."""
    write_atomic(path, json.dumps(data, indent=2, ensure_ascii=False, allow_nan=False) + "\n", field="--out")


def write_frame(path: str | Path, frame: pd.DataFrame) -> None:
    """A DataFrame as CSV, atomically."""
    write_atomic(path, frame.to_csv(index=False), field="--out")


def write_files(
    out: Path, steps: Sequence[tuple[str, Callable[[Path], None]]], plot: Callable[[], list[Path]]
) -> list[Path]:
    """Write each ``(name, write)`` of ``steps`` to ``out / name``, then the figures ``plot`` draws; the figures are
    skipped, with a note on stderr, when matplotlib is missing.

    Parameters
    ----------
    out : Path
        The run's folder.
    steps : sequence of (str, callable)
        Each file's name and the function that writes it given its path (atomically, as every writer does).
    plot : callable
        Draws the figures into ``out`` and returns their paths; an ``InputError`` (matplotlib missing) skips them.

    Returns
    -------
    list of Path
        The files written, in order.
    """
    import sys

    for name, write in steps:
        write(out / name)
    written = [out / name for name, _ in steps]
    try:
        written += plot()
    except InputError as exc:  # matplotlib missing: the tables and report are written
        print(f"fairaudit: figures skipped: {exc}", file=sys.stderr)
    return written


def write_report(analysis: ExperimentAnalysis, out: Path, run: dict[str, Any]) -> list[Path]:
    """The last step of a run: its files in ``out``, each written atomically (the module's list); the figures are
    skipped, with a note on stderr, when matplotlib is missing."""
    from .figures import plot_baseline, plot_experiment_curve

    data = experiment_dict(analysis, run)
    steps: list[tuple[str, Callable[[Path], None]]] = [
        ("kernel.csv", lambda p: write_frame(p, shown_kernel_frame(analysis.task, analysis.kernel))),
        ("candidates.csv", lambda p: write_frame(p, candidate_frame(analysis))),
        ("curve.csv", lambda p: analysis.curve.to_csv(p)),
        ("certificate.json", lambda p: write_json(p, data)),
        ("report.md", lambda p: write_atomic(p, experiment_markdown(data), field="out")),
    ]
    if analysis.route == "sampled":  # records are queries: the exact route has none
        steps.insert(2, ("records.csv", lambda p: write_frame(p, records_frame(analysis))))
    for point in analysis.points:
        spec = partial(write_atomic, content=experiment_spec(analysis, point), field="out")
        steps.append((f"spec-eps-{point.epsilon:.4g}.toml", spec))

    def plot() -> list[Path]:
        plot_baseline(analysis, out / "baseline.png")
        plot_experiment_curve(analysis, out / "curve.png")
        return [out / "baseline.png", out / "curve.png"]

    return write_files(out, steps, plot)
