"""The figures of an experiment: ``baseline.png`` (decision shares without a filter) and ``curve.png`` (the
fairness–privacy curve with its bands, bounds and the paper's design)."""

from __future__ import annotations

import textwrap
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from fairaudit import optional_modules

from ._markdown import listed_order

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from .analysis import ExperimentAnalysis
    from .vlm.tasks import DeliveryTask

__all__ = ["figure_class", "plot_baseline", "plot_experiment_curve"]


def figure_class() -> type[Figure]:
    """matplotlib's :class:`~matplotlib.figure.Figure` (the figures are made without pyplot).

    Raises
    ------
    InputError
        When matplotlib is not installed: the run then writes its tables and report without figures.
    """
    problem = "needs matplotlib, which is not installed: pip install 'fairness-certify[plot]'"
    figure: type[Figure] = optional_modules("path", problem, "matplotlib.figure")[0].Figure
    return figure


def plot_baseline(analysis: ExperimentAnalysis, path: str | Path) -> None:
    """Bar chart of the decisions without a filter: per context, in the paper's order and swapped (atomic PNG or SVG).

    See :func:`_baseline_figure`.
    """
    from fairaudit import save_figure

    save_figure(_baseline_figure(analysis), path)


def _baseline_figure(analysis: ExperimentAnalysis) -> Figure:
    """The figure of :func:`plot_baseline`: per context two stacked bars of who gets the first option's outcome,
    the paper's order plain, swapped hatched; the share of queries (sampled) or the model's probability (exact).
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
        _stack(ax, xs, (first, second, s[:, 2]), width * 0.95, colors, hatches[j])
    verb = "chosen" if t.kind == "choice" else "served first"
    _baseline_axes(ax, analysis, f"who is {verb}")
    who = [Patch(facecolor=c, edgecolor="white", label=lab) for c, lab in zip(colors, (c1, c2, "unparsed"))]
    orders = [
        Patch(facecolor="0.55", edgecolor="white", hatch=hatches[j], label=f"{name}\n{t.options[0]} = {first}")
        for j, (name, first) in enumerate(((f"{listed_order(t.name)} (plain)", c1), ("swapped (hatched)", c2)))
    ]
    _side_legends(ax, (who, f"who is {verb}"), (orders, "order (bars)"))
    return fig


def _stack(ax: Axes, xs: np.ndarray, parts: Any, width: float, colors: list, hatch: str) -> None:
    """Bars at ``xs``, each a stack of ``parts`` (one array over ``xs`` per colour, bottom first; NaN: no bar)."""
    bottoms = np.zeros(len(xs))
    for values, color in zip(parts, colors):
        ax.bar(xs, values, width, bottom=bottoms, color=color, edgecolor="white", hatch=hatch)
        bottoms += np.nan_to_num(values)


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
        _stack(ax, xs, shares[:, j, :].T, width * 0.92, colors, hatches[j % len(hatches)])
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
    """The figure of :func:`plot_experiment_curve`: the curve of :func:`fairaudit.plot_curve` against the candidate's ε,
    the keep probability on a top axis (:func:`_keep_axis`), the confidence bands of L (hatched) and L̄ (shaded) at
    the requested ε, the black-box bound on L̄ there, and the paper's design when run; +inf at the top edge. When the
    observed L and L̄ stay below 1/20 of the bounds' scale, a second panel shows them on their own scale.
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
    shown = "both profiles shown" if _one_pair(analysis.task) else "all its prompt shows"
    ax.set_xlabel(f"privacy budget ε of a candidate (nats; {shown})")
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
    """The top axis of the curve: (label, ε ↦ keep p of each attribute, p ↦ ε), vectorised, as ``secondary_axis``
    of :func:`fairaudit.plot_curve` takes them.

    When ε = c ε_P for a constant c and the attributes have k values each, each attribute is at ε / d with d = c n,
    so p = 1 / (1 + (k − 1) e^{−ε/d}); otherwise the maps go through ε_P and the split by keep probability.

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
    from .vlm.filter import TaskFilter, profile_budget

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

    def candidate_at(p: float) -> float:  # the candidate's ε when each profile is at the ε_P of keep p (NaN: NaN)
        q = min(max(p, np.finfo(float).tiny), np.nextafter(1.0, 0.0))
        profile = float(np.maximum(0.0, np.log(q / (1.0 - q)) + c).sum())  # >= 0, finite unless p is NaN
        if factor is not None:
            return profile * float(factor)
        if np.isnan(profile):
            return profile
        return TaskFilter.from_epsilon(task, profile).candidate_mechanism(positions).epsilon

    label = "keep probability p of each attribute (one p for all: ε = ln(p (k − 1) / (1 − p)) on k values)"
    return label, np.vectorize(shared_keep, otypes=[float]), np.vectorize(candidate_at, otypes=[float])


def _curve_top(analysis: ExperimentAnalysis) -> float:
    """Top of the curve's y axis: 1.15 × the largest finite value drawn (curve, paper's design, L̄ bound), ≥ 0.1."""
    c = analysis.curve
    paper = [f.value for p in analysis.paper for f in (p.local_fairness, p.global_fairness)]
    series = [c.black_box, c.paper, c.tight, c.corollary, c.observed_local, c.observed_global, paper]
    series.append([p.black_box_global for p in analysis.points])
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
