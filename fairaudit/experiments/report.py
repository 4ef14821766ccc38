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
import textwrap
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from fairaudit import InputError, number, write_atomic

from ._markdown import experiment_markdown, listed_order
from .harness import paper_queries_needed, table_queries_needed
from .slots import slot_names, true_prompts
from .vlm.tasks import UNPARSED

if TYPE_CHECKING:
    import pandas as pd
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from fairaudit import Calibration, Kernel

    from .analysis import ExperimentAnalysis, PointResult
    from .kernel import UnparsedMass
    from .paper_design import PaperDesignAnalysis
    from .slots import PositionSplit
    from .vlm.filter import PrivacyFilter
    from .vlm.tasks import DeliveryTask

__all__ = [
    "candidate_frame",
    "experiment_dict",
    "experiment_markdown",
    "experiment_spec",
    "kernel_frame",
    "plot_baseline",
    "plot_experiment_curve",
    "privacy_dict",
    "records_frame",
    "shown_kernel_frame",
    "write_report",
]


def _value_column(k: Kernel) -> tuple[str, npt.NDArray[np.float64]]:
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

    column, values = _value_column(kernel)
    n_ctx, n_pairs, n_dec = values.shape
    x, g, d = (a.ravel() for a in np.meshgrid(np.arange(n_ctx), np.arange(n_pairs), np.arange(n_dec), indexing="ij"))
    labels = np.asarray([[task.profile_label(p) for p in cell] for cell in kernel.groups], dtype=object)
    return pd.DataFrame(
        {
            task.context_name: np.asarray(kernel.contexts, dtype=object)[x],
            **{slot: labels[g, i] for i, slot in enumerate(slot_names(task))},
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
        *([f"unparsed = {j(UNPARSED)}"] if UNPARSED in t.outcomes else []),
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
        m = np.kron(ctx.matrix, np.eye(t.slots))
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
    x, g, d = np.nonzero(counts)
    reps = counts[x, g, d]
    x, g, d = np.repeat(x, reps), np.repeat(g, reps), np.repeat(d, reps)
    outcome = np.asarray(k.decisions, dtype=object)[d]
    if t.slots == 1:
        return pd.DataFrame(
            {
                t.context_name: np.asarray(k.contexts, dtype=object)[x],
                "profile": np.asarray(k.groups)[g],
                "outcome": outcome,
            }
        )
    ctx = np.asarray([c.rsplit(" @ ", 1) for c in k.contexts], dtype=object)
    shown = [s.split(" | ", 1) for s in k.groups]
    own = np.asarray([v[0] for v in shown], dtype=object)
    rest = np.asarray([v[1] for v in shown], dtype=object)
    return pd.DataFrame(
        {
            t.context_name: ctx[x, 0],
            "position": ctx[x, 1],
            "profile": own[g],
            "rival" if t.slots == 2 else "rivals": rest[g],
            "outcome": outcome,
        }
    )


def privacy_dict(task: DeliveryTask, f: PrivacyFilter, epsilon_candidate: float) -> dict[str, Any]:
    """The ``privacy`` of a point: the candidate's ε, the profile's, each attribute's ε and keep probability, δ = 0.

    ``attributes`` lists, per attribute, its number of values k, its keep
    probability p and its ε = ln(p (k − 1) / (1 − p)) (nats); ``split`` states
    how the budget is split over them (:data:`fairaudit.experiments.vlm.filter.SPLIT_RULE`).
    """
    from .vlm.filter import SPLIT_RULE

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
        "delta": 0.0,
        "context_mechanism": f.context_mechanism.name,
    }


def utility_dict(task: DeliveryTask) -> dict[str, Any]:
    """The ``utility`` of a report: g's name, its value per outcome, and ``unparsed``, the value an unparsed reply
    counts with ``source`` (``"given"``, or ``"default: expected g of a uniformly random reply"``) and ``rule``
    (how it was set, in words: :attr:`~fairaudit.experiments.vlm.tasks.DeliveryTask.unparsed_rule`)."""
    return {
        "name": task.utility_name,
        "values": dict(zip(task.outcomes, map(number, task.utility_values))),
        "unparsed": {
            "value": number(task.utility_values[-1]),
            "source": task.unparsed_source,
            "rule": task.unparsed_rule,
        },
    }


def observed_dicts(point: Any) -> dict[str, Any]:
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


def _point_dict(analysis: ExperimentAnalysis, p: PointResult) -> dict[str, Any]:
    return {
        "epsilon": number(p.epsilon),
        "privacy": privacy_dict(analysis.task, p.filter, p.mechanism.epsilon),
        "bounds": {
            "corollary": number(p.corollary),
            "black_box": number(p.black_box_local),
            "black_box_global": number(p.black_box_global),
            "unparsed_range": {name: r.to_dict() for name, r in p.bound_ranges.items()},
        },
        "observed": observed_dicts(p),
        "certified_local": number(p.black_box_local),
    }


def experiment_dict(analysis: ExperimentAnalysis, run: dict[str, Any] | None = None) -> dict[str, Any]:
    """The certificate JSON of an experiment.

    Keys: ``experiment``, ``model``, ``route`` (``"sampled"``: estimated
    from queries; ``"exact"``: the model's own law), ``positions``,
    ``samples``, ``queries`` (answered per design, unparsed, the mean
    unparsed share, and what each design needs), ``utility`` (g per
    outcome, and ``unparsed``: the value an unparsed reply counts, whether
    it was given or the default, and the rule: :func:`utility_dict`; and
    ``unparsed_range``, the [min g, max g] it is known within),
    ``unparsed_mass`` (the share of shown cells whose unparsed mass exceeds
    0.2, the largest, up to five such cells and the warning),
    ``confidence``, ``baseline`` (no filter: L, L̄ and the decision shares of
    the true profiles in both orders), ``position_split`` (the raw log ratio
    of the paper's order, its position and group parts and the share of it
    each explains, overall and per context: :class:`PositionSplit`),
    ``budgets`` (per target on L and on L̄: the candidate's ε that meets it
    for this model, white-box, and for any model, black-box, with the
    family's keep probability and whether the target can be met; this
    model's ε is met by the upper end of the unparsed range (``met_by``:
    ``"unparsed_upper_end"``), and ``stated_default`` beside it is the
    white-box answer under the stated unparsed utility with
    ``unparsed_upper``, the upper end of the unparsed range at its ε, and
    ``overturned_by_unparsed``, whether that exceeds the target),
    ``points`` (per requested ε: the
    privacy of the filter per attribute, profile and candidate; the
    corollary and black-box bounds on L and the black-box bound on L̄, with
    ``bounds.unparsed_range``: per bound its ``range`` over every utility of
    the unparsed reply in [min g, max g] and the ``reason``, equal ends
    unless the stated unparsed utility lies outside the other outcomes'
    range (:func:`fairaudit.experiments.analysis.bound_ranges`); the
    observed L and L̄ with their intervals). Every observed L and L̄ of the
    baseline and the points has ``unparsed_range`` ([lower, upper]: its exact
    range over every utility of the unparsed reply in [min g, max g], chosen
    per cell of the per-candidate kernel) and ``unparsed_range_ends`` (the
    context and groups of each end, and whether the lower end is exact:
    :func:`fairaudit.utility_range.fairness_range`). ``paper_design`` (the same from
    the paper's design, when run: L and L̄ with their intervals and unparsed ranges, per cell of its observed
    per-candidate law) and ``curve`` (the dense grid). Values in
    nats; +inf is ``"inf"``; NaN is ``null``.
    """
    a, t = analysis, analysis.task
    prompts, _ = true_prompts(t, "balanced")
    names = [", ".join(f"{o} = {t.profile_label(t.profiles[i])}" for o, i in zip(slot_names(t), p)) for p in prompts]
    shares = {
        ctx: {name: dict(zip(t.decisions, map(number, a.shares[i, j]))) for j, name in enumerate(names)}
        for i, ctx in enumerate(t.contexts)
    }
    curve = a.curve
    split = a.split
    out = {
        "experiment": t.name,
        "model": a.model,
        "route": a.route,
        "positions": a.positions,
        "samples": a.samples,
        "slots": t.slots,
        "candidates": [t.profile_label(c) for c in t.candidates],
        "context": t.context_name,
        "queries": {
            "table": a.table_queries,
            "paper": a.paper_queries,
            "unparsed": a.unparsed,
            "unparsed_share": number(a.unparsed_share),
            "table_design_needs": table_queries_needed(t, a.samples),
            "paper_design_needs_per_epsilon": paper_queries_needed(t, a.samples, 1, a.positions),
        },
        "utility": utility_dict(t)
        | {"unparsed_range": [number(a.baseline.unparsed_range.low), number(a.baseline.unparsed_range.high)]},
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
        "points": [_point_dict(a, p) for p in a.points],
        "paper_design": [
            {
                "epsilon": number(p.epsilon),
                "queries": p.queries,
                **observed_dicts(p),
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


def figure_class() -> type[Figure]:
    """matplotlib's :class:`~matplotlib.figure.Figure` (the figures are made without pyplot).

    Raises
    ------
    InputError
        When matplotlib is not installed: the run then writes its tables and report without figures.
    """
    try:
        from matplotlib.figure import Figure
    except ImportError:
        raise InputError(
            "path", "needs matplotlib, which is not installed: pip install 'fairness-certify[plot]'"
        ) from None
    return Figure


def plot_baseline(analysis: ExperimentAnalysis, path: str | Path) -> None:
    """Bar chart of the decisions without a filter: per context, in the paper's order and swapped (atomic PNG or SVG).

    See :func:`_baseline_figure`.
    """
    from fairaudit import save_figure

    save_figure(_baseline_figure(analysis), path)


def _baseline_figure(analysis: ExperimentAnalysis) -> Figure:
    """The figure of :func:`plot_baseline`.

    Per context two stacked bars of who gets the first option's outcome
    (chosen, served first): the paper's order plain, swapped hatched. The
    legends (who, and the order of each bar) sit right of the axes, so they
    hide no bar; the y axis is the share of queries on the sampled route and
    the model's probability on the exact one (``analysis.kernel.counts is None``).

    Parameters
    ----------
    analysis : ExperimentAnalysis

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.patches import Patch

    t = analysis.task
    if not _one_pair(t):
        return _outcome_figure(analysis)
    c1, c2 = (t.profile_label(c) for c in t.candidates)
    fig = figure_class()(figsize=(9.0, 3.8), layout="constrained")
    ax = fig.add_subplot()
    n = len(t.contexts)
    width = 0.38
    colors = ["tab:blue", "tab:orange", "0.7"]
    hatches = ("", "//")
    # who gets the outcome that option 1 gets (chosen / served first): candidate 1 or 2, per order
    for j, xs in enumerate((np.arange(n) - width / 2, np.arange(n) + width / 2)):
        s = analysis.shares[:, j, :]
        first, second = (s[:, 0], s[:, 1]) if j == 0 else (s[:, 1], s[:, 0])  # candidate 1's share, 2's
        bottoms = np.zeros(n)
        for vals, color in zip((first, second, s[:, 2]), colors):
            ax.bar(xs, vals, width * 0.95, bottom=bottoms, color=color, edgecolor="white", hatch=hatches[j])
            bottoms += vals
    verb = "chosen" if t.kind == "choice" else "served first"
    _baseline_axes(ax, analysis, f"who is {verb}")
    who = [Patch(facecolor=c, edgecolor="white", label=lab) for c, lab in zip(colors, (c1, c2, "unparsed"))]
    orders = [
        Patch(facecolor="0.55", edgecolor="white", hatch=hatches[j], label=f"{name}\n{t.options[0]} = {first}")
        for j, (name, first) in enumerate(((f"{listed_order(t.name)} (plain)", c1), ("swapped (hatched)", c2)))
    ]
    _side_legends(ax, (who, f"who is {verb}"), (orders, "order (bars)"))
    return fig


def _baseline_axes(ax: Axes, analysis: ExperimentAnalysis, what: str, sep: str = ": ") -> None:
    """The axes of a baseline figure: contexts on x, a share (sampled) or probability (exact) of ``what`` on y."""
    t = analysis.task
    ax.set_xticks(np.arange(len(t.contexts)), list(t.contexts), fontsize=8)
    ax.set_xlabel(t.context_name)
    measure = "share of queries" if analysis.kernel.counts is not None else "probability"
    ax.set_ylabel(f"{measure}{sep}{what}")
    ax.set_ylim(0, 1.0)
    ax.set_title(f"{t.name}, {analysis.model}: no privacy filter", fontsize=10)


def _side_legends(ax: Axes, upper: tuple[list, str], lower: tuple[list, str]) -> None:
    """Two legends (handles, title) right of the axes, top and bottom, so they hide no bar; patches large enough
    to show the hatching."""
    common: dict[str, Any] = dict(fontsize=8, title_fontsize=8, alignment="left", borderaxespad=0.0)
    common |= dict(handlelength=2.6, handleheight=1.6)
    ax.add_artist(ax.legend(handles=upper[0], title=upper[1], loc="upper left", bbox_to_anchor=(1.02, 1.0), **common))
    ax.legend(handles=lower[0], title=lower[1], loc="lower left", bbox_to_anchor=(1.02, 0.0), **common)


def _one_pair(t: DeliveryTask) -> bool:
    """Two candidates per prompt and one pair of them: the paper's design, drawn by order."""
    return t.slots == 2 and len(t.candidates) == 2


def _outcome_figure(analysis: ExperimentAnalysis) -> Figure:
    """Baseline of any design: per context, a stacked bar per candidate of its own outcomes without a filter.

    P(outcome | context, candidate), over the slots it takes and the rivals
    the population gives it (the baseline law, weighted by the population).
    """
    t = analysis.task
    law = analysis.baseline.law.probabilities  # [(x, slot), group, outcome]
    pop = analysis.population.probabilities  # [(x, slot), group]
    n_x, k, n_g = len(t.contexts), t.slots, len(t.candidates)
    w = pop.reshape(n_x, k, n_g)
    with np.errstate(invalid="ignore"):
        shares = np.einsum("xkgo,xkg->xgo", law.reshape(n_x, k, n_g, -1), w) / w.sum(1)[..., None]
    fig = figure_class()(figsize=(9.0, 3.8), layout="constrained")
    ax = fig.add_subplot()
    width = 0.8 / n_g
    from matplotlib import colormaps
    from matplotlib.patches import Patch

    n_o = len(t.outcomes)
    colors = [colormaps["viridis"](i / max(n_o - 2, 1)) for i in range(n_o - 1)] + ["0.7"]
    hatches = ["", "//", "\\\\", "..", "xx", "oo", "--", "++"]
    for j in range(n_g):
        xs = np.arange(n_x) - 0.4 + width * (j + 0.5)
        bottoms = np.zeros(n_x)
        for o in range(n_o):
            ax.bar(xs, shares[:, j, o], width * 0.92, bottom=bottoms, color=colors[o], edgecolor="white",
                   hatch=hatches[j % len(hatches)])  # fmt: skip
            bottoms += np.nan_to_num(shares[:, j, o])
    _baseline_axes(ax, analysis, "of each outcome", sep=" ")
    outcomes = [Patch(facecolor=c, edgecolor="white", label=o) for c, o in zip(colors, t.outcomes)]
    who = [
        Patch(facecolor="0.55", edgecolor="white", hatch=hatches[j % len(hatches)], label=t.profile_label(c))
        for j, c in enumerate(t.candidates)
    ]
    _side_legends(ax, (outcomes, "outcome"), (who, "candidate (bars, left to right)"))
    return fig


def plot_experiment_curve(analysis: ExperimentAnalysis, path: str | Path) -> None:
    """The fairness–privacy curve with confidence bands and the paper's design (atomic PNG or SVG).

    See :func:`_curve_figure`.
    """
    from fairaudit import save_figure

    save_figure(_curve_figure(analysis), path)


def _curve_figure(analysis: ExperimentAnalysis) -> Figure:
    """The figure of :func:`plot_experiment_curve`.

    The curve of :func:`fairaudit.plot.plot_curve` against the candidate's ε,
    with the keep probability of each attribute on a top axis
    (:func:`_keep_axis`); the confidence bands of the observed L (hatched,
    solid edge) and L̄ (shaded, dashed edge) at the requested ε; the
    black-box bound on L̄ there; and the paper's design, when run. +inf is
    drawn at the top edge (▲, labelled "+∞"). The legend sits below the axes.
    When the observed L and L̄ stay below 1/20 of the bounds' scale (a model far
    fairer than the worst case), a second panel shows them on their own scale.

    Parameters
    ----------
    analysis : ExperimentAnalysis

    Returns
    -------
    matplotlib.figure.Figure
    """
    from fairaudit import plot_curve

    zoom = _needs_zoom(analysis)
    fig = figure_class()(figsize=(12.0 if zoom else 8.0, 6.6), layout="constrained")
    if zoom:
        ax, side = fig.subplots(1, 2, width_ratios=(3, 2))
    else:
        ax = fig.add_subplot()
    top = _curve_top(analysis)
    keep = _keep_axis(analysis.task, analysis.positions)
    title = f"{analysis.task.name}: {analysis.model} (positions {analysis.positions})"
    plot_curve(analysis.curve, ax=ax, title=title, secondary_axis=keep, ymax=top)
    _draw_bands(analysis, ax, top)
    notes = _draw_design_points(analysis, ax)
    for note in notes:  # a legend entry without a mark: what could not be drawn
        ax.plot([], [], ls="none", label=note)[0].set_in_layout(False)
    ax.set_xlabel(
        "privacy budget ε of a candidate (nats; both profiles shown)"
        if _one_pair(analysis.task)
        else "privacy budget ε of a candidate (nats; all its prompt shows)"
    )
    ax.set_ylabel("local L and global L̄ (nats)")
    ax.get_legend().remove()
    handles, labels = ax.get_legend_handles_labels()
    labels = ["\n".join(textwrap.fill(part, 62, subsequent_indent="  ") for part in lab.split("\n")) for lab in labels]
    fig.legend(handles, labels, loc="outside lower center", ncols=2, fontsize=7, framealpha=0.9)
    if zoom:
        _zoom_observed(analysis, side)
    return fig


def _keep_axis(
    task: DeliveryTask, positions: str = "balanced"
) -> tuple[str, Callable[[Any], Any], Callable[[Any], Any]]:
    """The top axis of the curve: (label, ε ↦ keep p of each attribute, p ↦ ε), vectorised.

    The filter at the candidate's ε keeps every attribute of every profile
    with one probability p (:meth:`fairaudit.experiments.vlm.filter.PrivacyFilter.from_epsilon`):
    attribute i, with k_i values, at ε_i = ln(p (k_i − 1) / (1 − p)), the
    profile at ε_P = Σ_i ε_i (:func:`fairaudit.privacy.split_by_keep`; an
    attribute that p would keep less often than uniformly is shown uniformly).
    When ε = c ε_P for a constant c (2 for the paper's pair, whose profiles
    both count) and the k_i are equal, each attribute is at ε / d with d = c n,
    so p = 1 / (1 + (k − 1) e^{−ε/d}) and ε = d ln(p (k − 1) / (1 − p))
    (:func:`fairaudit.experiments.analysis.epsilon_from_keep`); otherwise the
    maps go through ε_P and the split.

    Parameters
    ----------
    task : DeliveryTask
    positions : {"balanced", "latin", "fixed"}

    Returns
    -------
    tuple of (str, callable, callable)
        The axis label, ε ↦ p and p ↦ ε, as ``secondary_axis`` of
        :func:`fairaudit.plot.plot_curve` takes them.

    Examples
    --------
    hr-delivery's three binary attributes (name, age, race), in both profiles:

    >>> from fairaudit.experiments.taskfile import HR_DELIVERY
    >>> label, forward, inverse = _keep_axis(HR_DELIVERY)
    >>> label
    'keep probability p of each attribute (6 shown, ε / 6 nats each)'
    >>> round(float(inverse(0.7)), 6), round(float(forward(inverse(0.7))), 12)    # 6 ln(7/3)
    (5.083787, 0.7)
    """
    from fairaudit import split_by_keep

    from .slots import epsilon_factor
    from .vlm.filter import profile_budget

    n = len(task.attributes)
    sizes = np.array([len(a.values) for a in task.attributes], dtype=float)
    factor = epsilon_factor(task, positions)
    shown = task.slots * n
    if factor is not None and np.all(sizes == sizes[0]):
        d = float(factor) * n
        k = sizes[0]
        each = f"{shown} shown, ε / {shown} nats each" if d == shown else f"ε / {d:g} nats each"

        def forward(e: Any) -> Any:
            with np.errstate(over="ignore"):
                return 1.0 / (1.0 + (k - 1) * np.exp(-np.asarray(e, dtype=float) / d))

        def inverse(p: Any) -> Any:
            q = np.clip(np.asarray(p, dtype=float), np.finfo(float).tiny, np.nextafter(1.0, 0.0))
            return d * np.log(q * (k - 1) / (1.0 - q))

        return f"keep probability p of each attribute ({each})", forward, inverse
    budget = profile_budget(task, positions)
    c = np.log(sizes - 1.0)

    def shared_keep(e: float) -> float:  # the one p of the split of the profile's ε_P (its active attributes')
        split = split_by_keep(max(budget(e), 0.0), sizes.astype(int).tolist())
        with np.errstate(over="ignore"):
            return float(np.min(1.0 / (1.0 + (sizes - 1.0) * np.exp(-split))))

    def candidate_at(p: float) -> float:
        q = min(max(p, np.finfo(float).tiny), np.nextafter(1.0, 0.0))
        profile = float(np.maximum(0.0, np.log(q / (1.0 - q)) + c).sum())
        return profile * float(factor) if factor is not None else _candidate_at(task, positions, profile)

    label = "keep probability p of each attribute (one p for all: ε = ln(p (k − 1) / (1 − p)) on k values)"
    return label, np.vectorize(shared_keep, otypes=[float]), np.vectorize(candidate_at, otypes=[float])


def _candidate_at(task: DeliveryTask, positions: str, profile_epsilon: float) -> float:
    """The candidate's ε when each profile is at ``profile_epsilon`` (nats)."""
    from .vlm.filter import PrivacyFilter

    if not np.isfinite(profile_epsilon):
        return float(profile_epsilon)
    return PrivacyFilter.from_epsilon(task, max(profile_epsilon, 0.0)).candidate_mechanism(positions).epsilon


def _curve_top(analysis: ExperimentAnalysis) -> float:
    """Top of the curve's y axis: 1.15 × the largest finite value drawn (curve, paper's design, L̄ bound), ≥ 0.1."""
    c = analysis.curve
    series = [c.black_box, c.paper, c.tight, c.corollary, c.observed_local, c.observed_global]
    series.append(np.array([p.black_box_global for p in analysis.points], dtype=float))
    series += [
        np.array([getattr(p, kind).value for p in analysis.paper], dtype=float)
        for kind in ("local_fairness", "global_fairness")
    ]
    values = np.concatenate([np.asarray(v, dtype=float).ravel() for v in series] + [np.zeros(1)])
    return max(1.15 * float(values[np.isfinite(values)].max()), 0.1)


def _draw_bands(analysis: ExperimentAnalysis, ax: Axes, top: float) -> None:
    """The confidence bands of the observed L̄ (shaded, dashed edge) and L (hatched over it, solid edge)."""
    pts = [p for p in analysis.points if p.intervals is not None]
    if not pts:
        return
    e = np.array([p.epsilon for p in pts])
    styles = (
        (
            "global_fairness",
            "L̄ (shaded, dashed edge)",
            dict(facecolor=(0.17, 0.63, 0.17, 0.16), edgecolor="tab:green", ls="--"),
        ),
        ("local_fairness", "L (hatched, solid edge)", dict(facecolor="none", edgecolor="0.3", hatch="////", ls="-")),
    )
    for kind, label, style in styles:
        lo = np.array([getattr(p.intervals, kind).lower for p in pts], dtype=float)
        hi = np.minimum(np.array([getattr(p.intervals, kind).upper for p in pts], dtype=float), top)
        ax.fill_between(e, lo, hi, lw=0.9, zorder=1, label=f"{analysis.confidence:g} band of observed {label}", **style)


def _draw_design_points(analysis: ExperimentAnalysis, ax: Axes) -> list[str]:
    """Markers at the requested ε: the black-box bound on L̄, and the paper's design's L and L̄.

    +inf is drawn at the top edge (▲ in the marker's colour); returns notes
    on the quantities that are undefined (NaN) at every ε.
    """
    from fairaudit import mark_infinite

    pts = analysis.points
    bb = np.array([p.black_box_global for p in pts], dtype=float)
    same = np.allclose(bb, [p.black_box_local for p in pts], rtol=1e-9, atol=1e-12, equal_nan=True)
    rows: list[tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], str, dict[str, Any]]] = [
        (
            np.array([p.epsilon for p in pts], dtype=float),
            bb,
            "black-box bound on L̄ (all models)" + (" = on L" if same else "") + ", at the requested ε",
            dict(marker="_", ms=14, mew=2.2, color="tab:blue", zorder=5, clip_on=False),
        )
    ]
    if analysis.paper:
        e = np.array([p.epsilon for p in analysis.paper], dtype=float)
        designs: tuple[tuple[str, str, dict[str, Any]], ...] = (
            ("local_fairness", "L", dict(marker="D", ms=5, mfc="none", color="tab:red", clip_on=False)),
            ("global_fairness", "L̄", dict(marker="s", ms=6, mfc="none", color="tab:brown", clip_on=False)),
        )
        for kind, name, style in designs:
            values = np.array([getattr(p, kind).value for p in analysis.paper], dtype=float)
            rows.append((e, values, f"observed {name}, paper's design (sampled through the filter)", style))
    notes = []
    for e, v, label, style in rows:
        if np.all(np.isnan(v)):
            why = "positions fixed: one candidate per context" if analysis.positions == "fixed" else "at every ε"
            notes.append(f"{label.split(' (')[0]}: undefined, not drawn ({why})")
            continue
        inf = np.isposinf(v)
        (line,) = ax.plot(e[~inf], v[~inf], ls="none", label=label + (" (+∞ at top)" if inf.any() else ""), **style)
        line.set_in_layout(bool((~inf).any()))  # an empty unclipped line would sit at the origin of the layout
        mark_infinite(ax, e[inf], style["color"])
    return notes


def _needs_zoom(analysis: ExperimentAnalysis) -> bool:
    """Whether the observed L and L̄ would lie flat against the bounds' scale (below 1/20 of it)."""
    c = analysis.curve
    seen = np.concatenate([c.observed_local, c.observed_global])
    seen = seen[np.isfinite(seen)]
    scale = np.concatenate([c.black_box, c.corollary])
    scale = scale[np.isfinite(scale)]
    # (not for rounding noise: a model fair to 1e-9 of the scale is drawn flat at 0)
    return bool(seen.size and scale.size and 1e-9 * scale.max() < seen.max() < scale.max() / 20)


def _zoom_observed(analysis: ExperimentAnalysis, ax: Axes) -> None:
    """The observed L and L̄ on their own scale, in a panel of their own (one line when they coincide)."""
    from matplotlib.ticker import MaxNLocator

    from fairaudit import mark_infinite

    c = analysis.curve
    same = np.allclose(c.observed_local, c.observed_global, rtol=1e-9, atol=1e-12, equal_nan=True)
    for values, color, ls, label in (
        (c.observed_local, "black", "-", "observed L (local)" + ("\n= observed L̄ (global)" if same else "")),
        (c.observed_global, "tab:green", "--", "observed L̄ (global)"),
    ):
        inf = np.isposinf(values)
        ax.plot(c.epsilon, np.where(inf, np.nan, values), color=color, lw=1.4, ls=ls, label=label)
        mark_infinite(ax, c.epsilon[inf], color)
        if same:
            break
    ax.set_ylim(bottom=0)
    ax.set_xlim(c.epsilon.min(), c.epsilon.max())
    label, forward, inverse = _keep_axis(analysis.task, analysis.positions)
    top_axis = ax.secondary_xaxis("top", functions=(forward, inverse))
    top_axis.set_xlabel(label.split(" (")[0], fontsize=8)
    top_axis.xaxis.set_major_locator(MaxNLocator(5, steps=[1, 2, 5, 10]))
    ax.set_title("observed only, on its own scale", fontsize=9, pad=30)
    ax.set_xlabel("ε of a candidate (nats)")
    ax.set_ylabel("local L and global L̄ (nats)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper left")


def write_json(path: str | Path, data: dict[str, Any]) -> None:
    """``data`` as indented JSON, atomically."""
    write_atomic(path, json.dumps(data, indent=2, ensure_ascii=False, allow_nan=False) + "\n", field="--out")


def write_frame(path: str | Path, frame: pd.DataFrame) -> None:
    """A DataFrame as CSV, atomically."""
    write_atomic(path, frame.to_csv(index=False), field="--out")


def write_report(analysis: ExperimentAnalysis | PaperDesignAnalysis, out: Path, run: dict[str, Any]) -> list[Path]:
    """The last step of a run: its files in ``out``, each written atomically (the module's list).

    A run of the paper's design alone writes its own (:func:`fairaudit.experiments.paper_design.write_paper_design`).
    The figures are skipped, with a note on stderr, when matplotlib is missing.
    """
    import sys

    from .analysis import ExperimentAnalysis

    if not isinstance(analysis, ExperimentAnalysis):
        from .paper_design import write_paper_design

        return write_paper_design(analysis, out, run)
    data = experiment_dict(analysis, run)
    steps: list[tuple[str, Callable[[Path], None]]] = [
        ("kernel.csv", lambda p: write_frame(p, kernel_frame(analysis))),
        ("candidates.csv", lambda p: write_frame(p, candidate_frame(analysis))),
        ("curve.csv", lambda p: analysis.curve.to_csv(p)),
        ("certificate.json", lambda p: write_json(p, data)),
        ("report.md", lambda p: write_atomic(p, experiment_markdown(data), field="out")),
    ]
    if analysis.route == "sampled":  # records are queries: the exact route has none
        steps.insert(2, ("records.csv", lambda p: write_frame(p, records_frame(analysis))))
    written = []
    for name, write in steps:
        write(out / name)
        written.append(out / name)
    for point in analysis.points:
        path = out / f"spec-eps-{point.epsilon:.4g}.toml"
        write_atomic(path, experiment_spec(analysis, point), field="out")
        written.append(path)
    try:
        plot_baseline(analysis, out / "baseline.png")
        plot_experiment_curve(analysis, out / "curve.png")
        written += [out / "baseline.png", out / "curve.png"]
    except InputError as exc:  # matplotlib missing: the tables and report are written
        print(f"fairaudit: figures skipped: {exc}", file=sys.stderr)
    return written
