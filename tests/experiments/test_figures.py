"""The experiment's figures, checked on the matplotlib objects: baseline.png and curve.png.

baseline.png: the legends hide no bar (for 1 to 8 contexts), the two orders have
legend entries (plain and hatched) and the tick labels are the contexts only;
the y axis says "probability" on the exact route and "share of queries" on the
sampled one. curve.png: a top axis of the keep probability of each attribute
whose ticks sit at the ε they map to (6 ln(7/3) at keep 0.7 for hr-delivery);
a y label naming L and L̄; both confidence bands visible; series equal
everywhere drawn once with one legend entry naming both; +inf drawn at the top
edge with ▲, a "+∞" label and a legend entry, for the bounds, the observed
values and the paper's design.

The analyses are exact (the simulated models' own kernels) or sampled from
counts made of them, on a coarse ε grid: each takes well under a second.
"""

from __future__ import annotations

import dataclasses
import functools
import itertools
import math
import re
import warnings
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

pytest.importorskip("matplotlib")

from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: E402
from matplotlib.legend import Legend  # noqa: E402
from matplotlib.patches import Rectangle  # noqa: E402

from fairaudit import UtilityClass
from fairaudit.experiments.analysis import analyse_kernel  # noqa: E402
from fairaudit.experiments.figures import (  # noqa: E402
    _baseline_figure,
    _curve_figure,
    _keep_axis,
    _needs_zoom,
    plot_baseline,
    plot_experiment_curve,
)
from fairaudit.experiments.slots import epsilon_from_keep  # noqa: E402
from fairaudit.experiments.taskfile import get_task  # noqa: E402
from fairaudit.experiments.vlm.filter import candidate_family  # noqa: E402
from fairaudit.experiments.vlm.models import simulated_model  # noqa: E402
from fairaudit.laws.tables import Kernel  # noqa: E402
from fairaudit.reports.figures import INFINITY_LABEL, coincide  # noqa: E402
from fairaudit.reports.plots import plot_curve  # noqa: E402

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def _task(name):
    """A shipped task by name."""
    return get_task(name)


@functools.cache
def _analysis(task_name, model, counts=None, positions="balanced", keeps=(0.6, 0.9)):
    """The analysis of a simulated model: exact (no counts) or from ``counts`` queries per cell (seeded)."""
    task = _task(task_name)
    k = len(task.profiles)
    p = simulated_model(task, model).probabilities.reshape(len(task.contexts), k * k, -1)
    pairs = [(a, b) for a in task.profiles for b in task.profiles]
    if counts is None:
        kernel = Kernel(p, task.contexts, pairs, task.decisions)
    else:
        drawn = np.random.default_rng(0).multinomial(counts, p / p.sum(axis=-1, keepdims=True))
        kernel = Kernel.from_counts(drawn, task.contexts, pairs, task.decisions)
    return analyse_kernel(
        task,
        kernel,
        model=model,
        epsilons=[epsilon_from_keep(task, q) for q in keeps],
        samples=counts or 0,
        positions=positions,
        grid=13,
        targets=(),
    )


def _drawn(fig):
    """Draw ``fig`` on an Agg canvas; return its renderer."""
    FigureCanvasAgg(fig)
    fig.canvas.draw()
    return fig.canvas.get_renderer()


def _legends(fig):
    """Every legend of the figure: its own and those of its axes (added as artists or not)."""
    out = list(fig.legends)
    for ax in fig.axes:
        out += [a for a in ax.get_children() if isinstance(a, Legend)]
    return out


def _one_line(text):
    return re.sub(r"\s*\n\s*", " ", text)


def _legend_texts(fig):
    """The legends' entries on one line each (long and merged entries are on several)."""
    return [_one_line(t.get_text()) for leg in _legends(fig) for t in leg.get_texts()]


# -- baseline.png ----------------------------------------------------------------------------------------------


class _ManyContexts:
    """A two-candidate choice task with ``n`` contexts (what the baseline figure reads of a task)."""

    name, kind, context_name, options, slots = "t", "choice", "document", ("HR1", "HR2"), 2
    candidates = (("Tom", 25, "Asian"), ("Mary", 55, "American"))

    def __init__(self, n):
        self.contexts = tuple(f"context {i}" for i in range(n))

    @staticmethod
    def profile_label(profile):
        return " & ".join(map(str, profile))


@pytest.mark.parametrize("n", [1, 3, 8])
def test_baseline_legends_hide_no_bar_and_fit_in_the_figure(n):
    rng = np.random.default_rng(n)
    shares = rng.dirichlet([5.0, 1.0, 0.1], size=(n, 2))
    shares[-1] = [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0]]  # the last pair of bars full height, where a legend would sit
    analysis = SimpleNamespace(task=_ManyContexts(n), model="m", shares=shares, kernel=SimpleNamespace(counts=None))
    fig = _baseline_figure(analysis)
    renderer = _drawn(fig)
    ax = fig.axes[0]
    bars = [p for p in ax.patches if isinstance(p, Rectangle) and p.get_height() > 0]
    assert len(bars) >= 2 * n
    legends = _legends(fig)
    assert legends
    page = fig.bbox
    for legend in legends:
        box = legend.get_window_extent(renderer)
        assert page.x0 <= box.x0 and box.x1 <= page.x1 and page.y0 <= box.y0 and box.y1 <= page.y1
        for bar in bars:
            assert not box.overlaps(bar.get_window_extent(renderer)), legend.get_title().get_text()


def test_baseline_legend_names_both_orders_plain_and_hatched():
    a = _analysis("hr-delivery", "prefers-mary")
    fig = _baseline_figure(a)
    ax = fig.axes[0]
    order = next(leg for leg in _legends(fig) if leg.get_title().get_text().startswith("order"))
    texts = [t.get_text() for t in order.get_texts()]
    assert texts[0].startswith("paper's order") and "HR1 = Tom & 25 & Asian" in texts[0]
    assert texts[1].startswith("swapped") and "HR1 = Mary & 55 & American" in texts[1]
    plain, hatched = order.legend_handles
    assert not plain.get_hatch() and hatched.get_hatch() == "//"
    # the bars carry the same hatching: plain for the paper's order, "//" for swapped
    assert {p.get_hatch() or "" for p in ax.patches} == {"", "//"}
    # the key is in the legend, not squeezed under the first tick
    assert [t.get_text() for t in ax.get_xticklabels()] == list(a.task.contexts)
    who = next(leg for leg in _legends(fig) if leg.get_title().get_text() == "who is chosen")
    assert [t.get_text() for t in who.get_texts()] == ["Tom & 25 & Asian", "Mary & 55 & American", "unparsed"]


@pytest.mark.parametrize(
    ("counts", "label"),
    [(None, "probability: who is chosen"), (20, "share of queries: who is chosen")],
)
def test_baseline_y_label_follows_the_route(counts, label):
    a = _analysis("hr-delivery", "prefers-mary", counts=counts)
    assert (a.kernel.counts is None) == (counts is None)
    assert _baseline_figure(a).axes[0].get_ylabel() == label


def test_package_baseline_says_served_first():
    a = _analysis("package-delivery", "position-biased")
    assert _baseline_figure(a).axes[0].get_ylabel() == "probability: who is served first"


# -- the keep-probability axis ---------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["hr-delivery", "package-delivery"])
def test_keep_axis_inverts_exactly_and_matches_the_plotted_filter(name):
    task = _task(name)
    label, forward, inverse = _keep_axis(task)
    assert label.startswith("keep probability p of each attribute")
    keeps = np.linspace(0.5, 0.995, 23)
    np.testing.assert_allclose(forward(inverse(keeps)), keeps, rtol=0, atol=1e-12)
    eps = np.linspace(0.0, 20.0, 41)
    np.testing.assert_allclose(inverse(forward(eps)), eps, rtol=1e-12, atol=1e-12)
    # the inverse is epsilon_from_keep (the same keep on every attribute of both profiles) ...
    for q in (0.5, 0.6, 0.7, 0.8, 0.9):
        assert float(inverse(q)) == pytest.approx(epsilon_from_keep(task, q), rel=1e-12, abs=1e-12)
    # ... and the forward map is the keep probability of the family on the curve's x axis
    family = candidate_family(task)
    for e in (0.0, 1.0, 5.0, 13.0):
        assert float(forward(e)) ** len(task.attributes) == pytest.approx(family.keep_probability(e), rel=1e-12)


def test_keep_axis_hand_value_for_hr_delivery():
    """Three binary attributes on each of two profiles: keep 0.7 is ε = 6 ln(7/3) = 5.083787... nats."""
    _, forward, inverse = _keep_axis(_task("hr-delivery"))
    assert float(inverse(0.7)) == pytest.approx(6 * math.log(7 / 3), rel=1e-12)
    assert float(inverse(0.7)) == pytest.approx(5.083787162323221, abs=1e-12)
    assert float(forward(6 * math.log(7 / 3))) == pytest.approx(0.7, abs=1e-12)


def test_keep_axis_with_attributes_of_different_sizes_is_the_shared_keep_probability():
    from fairaudit.experiments.taskfile import parse_task

    text = (Path(__file__).resolve().parents[2] / "examples" / "tasks" / "shortlist.toml").read_text()
    task = parse_task(text.replace('values = ["engineering", "sales"]', 'values = ["engineering", "sales", "hr"]'))
    label, forward, inverse = _keep_axis(task)  # one pair differing in both attributes, own and rival
    assert label.startswith("keep probability p of each attribute")
    # by hand: keep 0.6 is ln 1.5 on the name (2 values) and ln 3 on the department (3), both profiles shown
    assert float(inverse(0.6)) == pytest.approx(2 * (math.log(1.5) + math.log(3)), rel=1e-12)
    assert float(forward(2 * math.log(4.5))) == pytest.approx(0.6, abs=1e-12)
    for q in (0.5, 0.7, 0.9):
        assert float(inverse(q)) == pytest.approx(epsilon_from_keep(task, q), rel=1e-12)
        assert float(forward(inverse(q))) == pytest.approx(q, abs=1e-12)
    # below the name's floor 1/2 the department alone carries the profile's ln 1.5: p = 1.5 / (1.5 + 2) on it
    p = float(forward(2 * math.log(1.5)))
    assert p == pytest.approx(1.5 / (1.5 + 2), abs=1e-12)


# -- curve.png -------------------------------------------------------------------------------------------------


def _secondary(ax):
    (sec,) = [c for c in ax.child_axes if c.get_xlabel()]
    return sec


def test_curve_has_a_top_axis_of_the_keep_probability_at_the_right_epsilon():
    a = _analysis("hr-delivery", "prefers-mary")
    fig = _curve_figure(a)
    _drawn(fig)
    ax = fig.axes[0]
    sec = _secondary(ax)
    assert sec.get_xlabel().startswith("keep probability p of each attribute")
    _, forward, inverse = _keep_axis(a.task)
    lo, hi = ax.get_xlim()
    ticks = [t for t in sec.get_xticks() if forward(lo) <= t <= forward(hi)]
    assert len(ticks) >= 3
    for t in ticks:  # a tick at keep t sits at the ε that keep gives
        x = sec.transData.transform((t, 0.0))[0]
        eps = ax.transData.inverted().transform((x, 0.0))[0]
        assert eps == pytest.approx(float(inverse(t)), rel=1e-6, abs=1e-6)
    np.testing.assert_allclose(forward(inverse(np.array(ticks))), ticks, atol=1e-12)
    assert 0.7 in np.round(ticks, 12)


@pytest.mark.parametrize("counts", [None, 20])
def test_curve_y_label_names_l_and_l_bar(counts):
    fig = _curve_figure(_analysis("hr-delivery", "prefers-mary", counts=counts))
    label = fig.axes[0].get_ylabel()
    assert "L̄" in label and "local L" in label


def test_both_confidence_bands_are_visible():
    a = _analysis("hr-delivery", "prefers-mary", counts=20)
    ax = _curve_figure(a).axes[0]
    bands = {c.get_label(): c for c in ax.collections if "band of observed" in c.get_label()}
    (local,) = [c for k, c in bands.items() if "observed L " in k]
    (global_,) = [c for k, c in bands.items() if "observed L̄" in k]
    # L on top of L̄, hatched with a see-through face and a solid edge; L̄ shaded with a dashed edge
    assert ax.collections.index(local) > ax.collections.index(global_) and local.get_zorder() >= global_.get_zorder()
    assert local.get_hatch() and np.all(local.get_facecolor()[:, 3] == 0) and local.get_linewidth()[0] > 0
    assert np.all(global_.get_facecolor()[:, 3] > 0) and np.all(global_.get_edgecolor()[:, 3] > 0)
    assert not global_.get_hatch()


def _curves(ax):
    return [ln for ln in ax.lines if not ln.get_label().startswith("_") and len(ln.get_xdata()) > 1]


@pytest.mark.parametrize(
    ("task", "model", "merged"),
    [
        ("hr-delivery", "prefers-mary", "black-box bound (all models, exact) = ε (corollary, g independent of a)"),
        ("package-delivery", "low-complaint-first", "paper bound (main theorem) = tight bound (its proof, per pair)"),
        ("hr-delivery", "fair", "observed L (local) = observed L̄ (global)"),
    ],
)
def test_coinciding_series_are_drawn_once_with_one_entry_naming_both(task, model, merged):
    a = _analysis(task, model)
    fig = _curve_figure(a)
    ax = fig.axes[0]
    assert merged in [_one_line(ln.get_label()) for ln in ax.lines]
    assert merged in _legend_texts(fig)
    for one, two in itertools.combinations(_curves(ax), 2):  # no labelled line hides under another
        same_x = np.array_equal(one.get_xdata(), two.get_xdata())
        assert not (same_x and coincide(one.get_ydata(), two.get_ydata())), (one.get_label(), two.get_label())


def test_plot_curve_merges_coinciding_bounds_only_when_equal_everywhere():
    from fairaudit.certification.curves import privacy_curve
    from fairaudit.laws.families import randomized_response_family

    curve = privacy_curve(family=randomized_response_family(["a", "b"]), utility_class=UtilityClass(tau=0.2))
    labels = [t.get_text() for t in plot_curve(curve).axes[0].get_legend().get_texts()]
    assert "paper bound (main theorem)\n= tight bound (its proof, per pair)" in labels
    apart = dataclasses.replace(curve, tight=curve.tight * 0.9)
    labels = [t.get_text() for t in plot_curve(apart).axes[0].get_legend().get_texts()]
    assert "paper bound (main theorem)" in labels and "tight bound (its proof, per pair)" in labels


def test_a_curve_whose_series_all_coincide_keeps_a_legend_that_fits(tmp_path):
    """Four bounds on one line and the observed values on it (``fairaudit certify`` of a model at the bound)."""
    from fairaudit.certification.curves import privacy_curve
    from fairaudit.laws.families import randomized_response_family

    c = privacy_curve(family=randomized_response_family(["a", "b"]), utility_class=UtilityClass(tau=0.2))
    e = c.corollary
    curve = dataclasses.replace(c, paper=e, tight=e, black_box=e, observed_local=e, observed_global=e)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # e.g. "constrained_layout not applied": a legend too wide for the figure
        fig = plot_curve(curve, tmp_path / "c.png")
    ax = fig.axes[0]
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert labels == [
        "black-box bound (all models, exact)\n= paper bound (main theorem)\n= tight bound (its proof, per pair)"
        "\n= ε (corollary, g independent of a)",
        "observed L (local)\n= observed L̄ (global)",
    ]
    renderer = _drawn(fig)
    assert ax.get_legend().get_window_extent(renderer).width < ax.get_window_extent(renderer).width


def _infinity_marks(ax, color=None):
    """The ▲ marks of +inf values on ``ax`` (of one colour, if given)."""
    import matplotlib.colors as mcolors

    return [
        ln
        for ln in ax.lines
        if ln.get_marker() == "^"
        and len(ln.get_xdata())
        and (color is None or mcolors.same_color(ln.get_color(), color))
    ]


def _assert_visible_at_the_top(fig, marks):
    renderer = _drawn(fig)
    ax = fig.axes[0]
    frame = ax.get_window_extent(renderer)
    for mark in marks:
        assert not mark.get_clip_on()
        box = mark.get_window_extent(renderer)
        assert frame.x0 - 8 <= box.x0 and box.x1 <= frame.x1 + 8  # whole, within the frame (a marker's width)
        assert box.y0 >= frame.y1 - 12 and box.y1 <= frame.y1 + 0.5  # just inside the top edge
    texts = [t for t in ax.texts if t.get_text() == "+∞"]
    assert len(texts) == 1
    box = texts[0].get_window_extent(renderer)
    assert fig.bbox.x0 <= box.x0 and box.x1 <= fig.bbox.x1  # in the figure, not cut off
    assert any(INFINITY_LABEL in t for t in _legend_texts(fig))


def test_infinite_black_box_bound_on_l_bar_is_marked_at_the_top_edge():
    """Positions fixed on hr-delivery (g in [0, 1]): no filter on the profiles bounds L̄, its black-box bound is +inf."""
    a = _analysis("hr-delivery", "prefers-mary", positions="fixed")
    assert all(math.isinf(p.black_box_global) for p in a.points)
    fig = _curve_figure(a)
    marks = _infinity_marks(fig.axes[0], "tab:blue")
    assert marks and sorted(np.concatenate([m.get_xdata() for m in marks])) == [p.epsilon for p in a.points]
    _assert_visible_at_the_top(fig, marks)
    assert any("black-box bound on L̄" in t and "+∞ at top" in t for t in _legend_texts(fig))


def test_infinite_paper_design_values_are_marked_at_the_top_edge():
    a = _analysis("hr-delivery", "prefers-mary")
    value = SimpleNamespace
    paper = (
        SimpleNamespace(epsilon=a.points[0].epsilon, local_fairness=value(value=0.5), global_fairness=value(value=0.2)),
        SimpleNamespace(
            epsilon=a.points[1].epsilon, local_fairness=value(value=math.inf), global_fairness=value(value=math.inf)
        ),
    )
    fig = _curve_figure(dataclasses.replace(a, paper=paper))
    ax = fig.axes[0]
    for color in ("tab:red", "tab:brown"):
        marks = _infinity_marks(ax, color)
        assert [m.get_xdata().tolist() for m in marks] == [[a.points[1].epsilon]]
        _assert_visible_at_the_top(fig, marks)
    finite = [ln for ln in ax.lines if ln.get_marker() == "D" and len(ln.get_xdata())]
    assert [ln.get_ydata().tolist() for ln in finite] == [[0.5]]
    assert ax.get_ylim()[1] > 0.5


def test_infinite_observed_values_and_bounds_of_a_curve_are_marked_at_the_top_edge():
    from fairaudit.certification.curves import privacy_curve
    from fairaudit.laws.families import randomized_response_family

    curve = privacy_curve(family=randomized_response_family(["a", "b"]), utility_class=UtilityClass(tau=0.2))
    tail = np.arange(len(curve.epsilon)) >= len(curve.epsilon) - 3
    curve = dataclasses.replace(
        curve,
        black_box=np.where(tail, np.inf, curve.black_box),
        observed_local=np.where(tail, np.inf, 0.1 * curve.epsilon),
    )
    fig = plot_curve(curve)
    ax = fig.axes[0]
    for color, label in (("tab:blue", "black-box bound"), ("black", "observed L")):
        marks = _infinity_marks(ax, color)
        assert marks and np.array_equal(marks[0].get_xdata(), curve.epsilon[tail])
        _assert_visible_at_the_top(fig, marks)
        assert any(t.startswith(label) and "+∞ at top" in t for t in _legend_texts(fig))


def test_a_model_fair_up_to_rounding_gets_no_zoom_panel():
    exact = _analysis("package-delivery", "position-biased")
    assert 0 < np.nanmax(exact.curve.observed_local) < 1e-12  # rounding noise, not a disparity
    assert not _needs_zoom(exact) and len(_curve_figure(exact).axes) == 1
    sampled = _analysis("package-delivery", "position-biased", counts=200)
    assert _needs_zoom(sampled)
    fig = _curve_figure(sampled)
    side = [ax for ax in fig.axes if ax.get_title().startswith("observed only")]
    assert len(side) == 1 and _secondary(side[0]).get_xlabel().startswith("keep probability")


@pytest.mark.slow
def test_the_figures_are_written_as_png(tmp_path):
    a = _analysis("package-delivery", "low-complaint-first", counts=20)
    plot_baseline(a, tmp_path / "baseline.png")
    plot_experiment_curve(a, tmp_path / "curve.png")
    for name in ("baseline.png", "curve.png"):
        assert (tmp_path / name).read_bytes()[:8] == PNG_MAGIC


@pytest.mark.parametrize("positions", ["fixed", "balanced"])
def test_curve_axes_fill_the_figure_above_the_legend(positions):
    """No empty band between the axes and the legend below them (an unclipped empty line once reserved one)."""
    fig = _curve_figure(_analysis("hr-delivery", "prefers-mary", positions=positions))
    renderer = _drawn(fig)
    ax_bottom = fig.axes[0].get_tightbbox(renderer).y0
    legend_top = fig.legends[0].get_window_extent(renderer).y1
    assert 0 <= ax_bottom - legend_top < 0.05 * fig.bbox.height
