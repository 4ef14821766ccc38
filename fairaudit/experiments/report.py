"""What an experiment writes: tables, the certificate JSON, the figures and a Markdown report.

Files in the run's folder (each written atomically):

* ``kernel.csv``: the model's kernel on shown cells with counts (the table
  design): the context, the profile shown as each option, the decision, the
  count. It is also the input of ``--kernel`` (a simulated model of it).
* ``candidates.csv``: the per-candidate kernel with counts (context @
  position, ``own | rival`` shown, outcome, count).
* ``records.csv``: the same as one record per query and candidate, for
  ``fairaudit audit records.csv --sensitive profile --context document,position
  --outcome outcome --positive chosen`` (the model without a filter).
* ``spec-eps-<ε>.toml``: :func:`experiment_spec`, one per requested ε, for
  ``fairaudit certify``.
* ``certificate.json``: :func:`experiment_dict`.
* ``curve.csv``: the dense fairness–privacy curve.
* ``baseline.png``: decision shares without a filter, per context and order.
* ``curve.png``: observed L and L̄ with their confidence bands, the bounds,
  and the paper's design when it was run.
* ``report.md``: :func:`experiment_markdown`.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .._io import write_atomic
from .._json import Report, number
from ._markdown import experiment_markdown

if TYPE_CHECKING:
    import pandas as pd

    from .._arrays import FloatArray
    from ..calibrate import Calibration
    from ..laws import Kernel
    from .analysis import ExperimentAnalysis, PointResult, PositionSplit
    from .vlm.tasks import DeliveryTask

__all__ = [
    "candidate_frame",
    "experiment_dict",
    "experiment_markdown",
    "experiment_spec",
    "kernel_frame",
    "plot_baseline",
    "plot_experiment_curve",
    "records_frame",
    "shown_kernel_frame",
]


def _value_column(k: Kernel) -> tuple[str, FloatArray]:
    """``("count", counts)`` on the sampled route, ``("probability", probabilities)`` on the exact one."""
    if k.counts is not None:
        return "count", k.counts
    return "probability", k.probabilities


def kernel_frame(analysis: ExperimentAnalysis) -> pd.DataFrame:
    """The model's kernel on shown cells as a long table: context, option columns, decision, count.

    On the exact route the last column is ``probability`` (the model's own
    P(decision | cell)) instead of ``count``; both are read by ``--kernel``.
    """
    return shown_kernel_frame(analysis.task, analysis.kernel)


def shown_kernel_frame(task: DeliveryTask, kernel: Kernel) -> pd.DataFrame:
    """A kernel on shown cells as the long table of ``kernel.csv``, read back by ``--kernel``.

    Parameters
    ----------
    task : DeliveryTask
    kernel : Kernel
        Shape (n_contexts, n_profiles², n_decisions), the layout of
        :func:`fairaudit.experiments.harness.table_kernel` (groups: the shown
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

    column, values = _value_column(kernel)
    n_ctx, n_pairs, n_dec = values.shape
    x, g, d = (a.ravel() for a in np.meshgrid(np.arange(n_ctx), np.arange(n_pairs), np.arange(n_dec), indexing="ij"))
    labels = [(task.profile_label(p1), task.profile_label(p2)) for p1, p2 in kernel.groups]
    return pd.DataFrame(
        {
            task.context_name: np.asarray(kernel.contexts, dtype=object)[x],
            task.options[0]: [labels[i][0] for i in g],
            task.options[1]: [labels[i][1] for i in g],
            "decision": np.asarray(kernel.decisions, dtype=object)[d],
            column: values.ravel().astype(int) if column == "count" else values.ravel(),
        }
    )


def candidate_frame(analysis: ExperimentAnalysis) -> pd.DataFrame:
    """The per-candidate kernel as a long table: context, shown, outcome, count (probability on the exact route)."""
    import pandas as pd

    k = analysis.candidate_kernel
    column, values = _value_column(k)
    n_ctx, n_g, n_d = values.shape
    x, g, d = (a.ravel() for a in np.meshgrid(np.arange(n_ctx), np.arange(n_g), np.arange(n_d), indexing="ij"))
    return pd.DataFrame(
        {
            "context": np.asarray(k.contexts, dtype=object)[x],
            "profile": np.asarray(k.groups, dtype=object)[g],
            "outcome": np.asarray(k.decisions, dtype=object)[d],
            column: values.ravel().astype(int) if column == "count" else values.ravel(),
        }
    )


def experiment_spec(analysis: ExperimentAnalysis, point: PointResult) -> str:
    """A ``fairaudit certify`` spec (TOML) of the per-candidate experiment at one ε.

    ``[sensitive]`` the two candidates' profiles; ``[context]`` item @
    position; ``[privacy.sensitive]`` the matrix M_cand of that ε, with its
    outputs (``own | rival``); ``[privacy.context]`` M_X ⊗ I; ``[population]``
    the run's positions; ``[model]`` ``candidates.csv`` (counts, or
    probabilities on the exact route);
    ``[utility]`` the task's g. ``fairaudit certify`` of it repeats the
    experiment's certificate at that ε. Values are written with ``json.dumps``
    (TOML's strings, arrays and floats accept them).
    """
    a, t = analysis, analysis.task
    j = json.dumps
    rows = ",\n  ".join(j([float(v) for v in r]) for r in point.mechanism.matrix)
    ctx = point.filter.context_mechanism
    lines = [
        f"# {t.name}: {a.model}; the candidate's ε = {point.epsilon:.6g} nats "
        f"(keep p = {', '.join(f'{q:.6g}' for q in point.filter.keep_probabilities)} per attribute)",
        f"title = {j(f'{t.name}: {a.model}, per candidate, epsilon = {point.epsilon:.6g}')}",
        "",
        "[sensitive]",
        'name = "profile"',
        f"values = {j(list(a.population.groups))}",
        "",
        "[context]",
        'name = "context"',
        f"values = {j(list(a.population.contexts))}",
        "",
        "[decision]",
        'name = "outcome"',
        f"values = {j(list(t.outcomes))}",
        "",
        "[population]",
        "probabilities = [\n  " + ",\n  ".join(j(r) for r in a.population.probabilities.tolist()) + "\n]",
        "",
        "[privacy.sensitive]",
        'mechanism = "matrix"',
        f"name = {j(point.mechanism.name)}",
        f"outputs = {j(list(point.mechanism.outputs))}",
        f"rows = [\n  {rows}\n]",
        "",
    ]
    if ctx.epsilon != float("inf"):
        m = np.kron(ctx.matrix, np.eye(len(t.options)))
        lines += [
            "[privacy.context]",
            'mechanism = "matrix"',
            f"name = {j(ctx.name)}",
            "rows = [\n  " + ",\n  ".join(j(r) for r in m.tolist()) + "\n]",
            "",
        ]
    lines += [
        "[model]",
        'table = "candidates.csv"',
        'count_column = "count"' if a.candidate_kernel.counts is not None else 'probability_column = "probability"',
        "",
        "[utility]",
        'kind = "table"',
        f"values = {j([float(v) for v in t.utility_values])}",
    ]
    if a.tau is not None:
        lines.append(f"tau = {j(float(a.tau))}")
    return "\n".join(lines) + "\n"


def records_frame(analysis: ExperimentAnalysis) -> pd.DataFrame:
    """Per-candidate records of the table design, one row per query and candidate, for ``fairaudit audit``.

    Columns: the context name, ``position`` (the option), ``profile`` (the
    candidate's shown profile), ``rival`` (the other's) and ``outcome``; the
    profiles are the ones shown to the model, so an audit of this file is the
    model's own fairness without a filter, against a rival drawn uniformly.
    """
    import pandas as pd

    t, k = analysis.task, analysis.candidate_kernel
    assert k.counts is not None  # (estimated from counts)
    counts = k.counts.astype(int)
    x, g, d = np.nonzero(counts)
    reps = counts[x, g, d]
    x, g, d = np.repeat(x, reps), np.repeat(g, reps), np.repeat(d, reps)
    ctx = np.asarray([c.rsplit(" @ ", 1) for c in k.contexts], dtype=object)
    shown = np.asarray([s.split(" | ") for s in k.groups], dtype=object)
    return pd.DataFrame(
        {
            t.context_name: ctx[x, 0],
            "position": ctx[x, 1],
            "profile": shown[g, 0],
            "rival": shown[g, 1],
            "outcome": np.asarray(k.decisions, dtype=object)[d],
        }
    )


def _point_dict(analysis: ExperimentAnalysis, p: PointResult) -> Report:
    f = p.filter
    return {
        "epsilon": number(p.epsilon),
        "privacy": {
            "epsilon_candidate": number(p.mechanism.epsilon),
            "epsilon_profile": number(f.epsilon_profile),
            "epsilon_per_attribute": {
                a.name: number(e) for a, e in zip(analysis.task.attributes, f.epsilon_attributes)
            },
            "keep_probability_per_attribute": {
                a.name: number(q) for a, q in zip(analysis.task.attributes, f.keep_probabilities)
            },
            "delta": 0.0,
            "context_mechanism": f.context_mechanism.name,
        },
        "bounds": {
            "corollary": number(p.corollary),
            "black_box": number(p.black_box_local),
            "black_box_global": number(p.black_box_global),
        },
        "observed": {
            "local": p.local.to_dict(None if p.intervals is None else p.intervals.local),
            "global": p.global_.to_dict(None if p.intervals is None else p.intervals.global_),
        },
        "certified_local": number(p.black_box_local),
    }


def experiment_dict(analysis: ExperimentAnalysis, run: Report | None = None) -> Report:
    """The certificate JSON of an experiment.

    Keys: ``experiment``, ``model``, ``route`` (``"sampled"``: estimated
    from queries; ``"exact"``: the model's own law), ``positions``,
    ``samples``, ``queries`` (answered per design, unparsed, the mean
    unparsed share, and what each design needs), ``utility``,
    ``confidence``, ``baseline`` (no filter: L, L̄ and the decision shares of
    the true profiles in both orders), ``position_split`` (the raw log ratio
    of the paper's order, its position and group parts and the share of it
    each explains, overall and per context: :class:`PositionSplit`),
    ``budgets`` (per target on L and on L̄: the candidate's ε that meets it
    for this model, white-box, and for any model, black-box, with the
    family's keep probability and whether the target can be met),
    ``points`` (per requested ε: the
    privacy of the filter per attribute, profile and candidate; the
    corollary and black-box bounds on L and the black-box bound on L̄; the
    observed L and L̄ with their intervals), ``paper_design`` (the same from
    the paper's design, when run) and ``curve`` (the dense grid). Values in
    nats; +inf is ``"inf"``; NaN is ``null``.
    """
    a, t = analysis, analysis.task
    shares = {}
    c1, c2 = (t.profile_label(c) for c in t.candidates)
    for i, ctx in enumerate(t.contexts):
        shares[ctx] = {
            f"{t.options[0]} = {c1}, {t.options[1]} = {c2}": dict(zip(t.decisions, map(number, a.shares[i, 0]))),
            f"{t.options[0]} = {c2}, {t.options[1]} = {c1}": dict(zip(t.decisions, map(number, a.shares[i, 1]))),
        }
    curve = a.curve
    split = a.split
    out = {
        "experiment": t.name,
        "model": a.model,
        "route": a.route,
        "positions": a.positions,
        "samples": a.samples,
        "candidates": [c1, c2],
        "context": t.context_name,
        "queries": {
            "table": a.table_queries,
            "paper": a.paper_queries,
            "unparsed": a.unparsed,
            "unparsed_share": number(a.unparsed_share),
            "table_design_needs": len(t.contexts) * len(t.profiles) ** 2 * a.samples,
            "paper_design_needs_per_epsilon": len(t.contexts) * (2 if a.positions == "balanced" else 1) * a.samples,
        },
        "utility": {"name": t.utility_name, "values": dict(zip(t.outcomes, map(number, t.utility_values)))},
        "tau": number(a.tau),
        "confidence": number(a.confidence),
        "baseline": {
            "local": a.baseline.local.to_dict(None if a.baseline.intervals is None else a.baseline.intervals.local),
            "global": a.baseline.global_.to_dict(
                None if a.baseline.intervals is None else a.baseline.intervals.global_
            ),
            "shares": shares,
        },
        "position_split": None if split is None else _split_dict(split),
        "budgets": [
            {
                "target": number(b.target),
                "kind": b.kind,
                "this_model": _budget(b.this_model),
                "any_model": _budget(b.any_model),
            }
            for b in a.budgets
        ],
        "points": [_point_dict(a, p) for p in a.points],
        "paper_design": [
            {
                "epsilon": number(p.epsilon),
                "queries": p.queries,
                "local": p.local.to_dict(None if p.intervals is None else p.intervals.local),
                "global": p.global_.to_dict(None if p.intervals is None else p.intervals.global_),
            }
            for p in a.paper
        ],
        "curve": {
            k: [number(v) for v in getattr(curve, k)]
            for k in (
                "epsilon",
                "keep_probability",
                "paper",
                "tight",
                "black_box",
                "corollary",
                "observed_local",
                "observed_global",
            )
        },
    }
    if run:
        out["run"] = run
    return out


def _budget(c: Calibration) -> Report:
    return {
        "epsilon": number(c.epsilon),
        "keep_probability": number(c.keep_probability),
        "feasible": c.feasible,
        "bound": number(c.bound),
        "reason": c.reason,
    }


def _split_dict(split: PositionSplit) -> Report:
    position, group = split.explained()
    return {
        "raw": number(split.overall_raw),
        "position": number(split.overall_position),
        "group": number(split.overall_group),
        "explained": {"position": number(position), "group": number(group)},
        "per_context": {
            c: {"raw": number(r), "position": number(q), "group": number(g)}
            for c, r, q, g in zip(split.contexts, split.raw, split.position, split.group)
        },
    }


def plot_baseline(analysis: ExperimentAnalysis, path: str | Path) -> None:
    """Bar chart of the decisions without a filter: per context, in the paper's order and swapped (atomic)."""
    from ..plot import load_matplotlib, save_figure

    Figure = load_matplotlib()
    t = analysis.task
    c1, c2 = (t.profile_label(c) for c in t.candidates)
    fig = Figure(figsize=(7.5, 3.8), layout="constrained")
    ax = fig.add_subplot()
    n = len(t.contexts)
    width = 0.38
    colors = ["tab:blue", "tab:orange", "0.7"]
    # who gets the outcome that option 1 gets (chosen / served first): candidate 1 or 2, per order
    for j, (order, xs) in enumerate(
        (("paper's order", np.arange(n) - width / 2), ("swapped", np.arange(n) + width / 2))
    ):
        s = analysis.shares[:, j, :]
        first = s[:, 0] if j == 0 else s[:, 1]  # candidate 1's share
        second = s[:, 1] if j == 0 else s[:, 0]
        unp = s[:, 2]
        bottoms = np.zeros(n)
        for k, (vals, lab) in enumerate(((first, c1), (second, c2), (unp, "unparsed"))):
            ax.bar(
                xs,
                vals,
                width * 0.95,
                bottom=bottoms,
                color=colors[k],
                edgecolor="white",
                label=lab if j == 0 else None,
                hatch="" if j == 0 else "//",
            )
            bottoms += vals
    verb = "chosen" if t.kind == "choice" else "served first"
    ax.set_xticks(
        np.arange(n),
        [
            f"{c}\n(left: {c1.split(' & ')[0]} as {t.options[0]}; right: swapped)" if i == 0 else c
            for i, c in enumerate(t.contexts)
        ],
        fontsize=8,
    )
    ax.set_ylabel(f"share of queries: who is {verb}")
    ax.set_ylim(0, 1.0)
    ax.set_title(f"{t.name}, {analysis.model}: no privacy filter", fontsize=10)
    ax.legend(fontsize=8, loc="upper right", framealpha=0.9)
    save_figure(fig, path)


def plot_experiment_curve(analysis: ExperimentAnalysis, path: str | Path) -> None:
    """The fairness–privacy curve with confidence bands and the paper's design (atomic PNG or SVG).

    When the observed L and L̄ stay below 1/20 of the bounds' scale (a model far
    fairer than the worst case), a second panel shows them on their own scale.
    """
    from ..plot import load_matplotlib, plot_curve, save_figure

    Figure = load_matplotlib()
    zoom = _needs_zoom(analysis)
    fig = Figure(figsize=(11.0 if zoom else 7.5, 4.8), layout="constrained")
    if zoom:
        ax, side = fig.subplots(1, 2, width_ratios=(3, 2))
    else:
        ax = fig.add_subplot()
    plot_curve(analysis.curve, ax=ax, title=f"{analysis.task.name}: {analysis.model} (positions {analysis.positions})")
    pts = [p for p in analysis.points if p.intervals is not None]
    if pts:
        top = ax.get_ylim()[1]
        e = np.array([p.epsilon for p in pts])
        for attr, color, label in (("local", "black", "L"), ("global_", "tab:green", "L̄")):
            lo = np.array([getattr(p.intervals, attr).lower for p in pts])
            hi = np.array([min(getattr(p.intervals, attr).upper, top) for p in pts])
            ax.fill_between(
                e, lo, hi, color=color, alpha=0.12, lw=0, label=f"{analysis.confidence:g} band of observed {label}"
            )
    if analysis.paper:
        e = np.array([p.epsilon for p in analysis.paper])
        v = np.array([p.local.value for p in analysis.paper])
        top = ax.get_ylim()[1]
        ax.plot(
            e,
            np.minimum(v, top),
            ls="none",
            marker="D",
            ms=5,
            mfc="none",
            color="tab:red",
            label="observed L, paper's design (sampled through the filter)",
        )
    ax.set_xlabel("privacy budget ε of a candidate (nats; both profiles shown)")
    ax.legend(loc="upper left", fontsize=7, framealpha=0.9)
    if zoom:
        _zoom_observed(analysis, side)
    save_figure(fig, path)


def _needs_zoom(analysis: ExperimentAnalysis) -> bool:
    """Whether the observed L and L̄ would lie flat against the bounds' scale (below 1/20 of it)."""
    c = analysis.curve
    seen = np.concatenate([c.observed_local, c.observed_global])
    seen = seen[np.isfinite(seen)]
    scale = np.concatenate([c.black_box, c.corollary])
    scale = scale[np.isfinite(scale)]
    return bool(seen.size and scale.size and 0 < seen.max() < scale.max() / 20)


def _zoom_observed(analysis: ExperimentAnalysis, ax: Any) -> None:
    """The observed L and L̄ on their own scale, in a panel of their own."""
    c = analysis.curve
    ax.plot(c.epsilon, c.observed_local, color="black", lw=1.4, label="observed L (local)")
    ax.plot(c.epsilon, c.observed_global, color="tab:green", lw=1.4, ls="--", label="observed L̄ (global)")
    ax.set_ylim(bottom=0)
    ax.set_xlim(c.epsilon.min(), c.epsilon.max())
    ax.set_title("observed only, on its own scale", fontsize=9)
    ax.set_xlabel("ε of a candidate (nats)")
    ax.set_ylabel("nats")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper left")


def write_json(path: str | Path, data: Report) -> None:
    """``data`` as indented JSON, atomically."""
    write_atomic(path, json.dumps(data, indent=2, ensure_ascii=False, allow_nan=False) + "\n", field="--out")


def write_frame(path: str | Path, frame: pd.DataFrame) -> None:
    """A DataFrame as CSV, atomically."""
    write_atomic(path, frame.to_csv(index=False), field="--out")
