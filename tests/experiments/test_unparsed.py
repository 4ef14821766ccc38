"""An experiment's L and L̄ over the unparsed reply's utility, and the warning on large unparsed mass.

The HR task (Tom = profile 0, Mary = profile 7, g = 1 for chosen, 0 for not chosen and, as given, unparsed;
range [0, 1]). Without a filter each candidate's view is its own pair, so every group's expected utility
spans its own interval: L's range is per context [max(1, max lo / min hi), max hi / lo'] (closed form, by hand
below), and L̄'s the same over the sums of the six contexts' ends (P(x | a) uniform).
"""

from __future__ import annotations

import dataclasses
import itertools
import math

import numpy as np
import pytest

from fairaudit import UtilityClass
from fairaudit.experiments._markdown import experiment_markdown
from fairaudit.experiments.analysis import analyse_kernel
from fairaudit.experiments.report import experiment_dict
from fairaudit.experiments.taskfile import HR_DELIVERY as T
from fairaudit.laws.tables import Kernel


def _kernel() -> Kernel:
    p = np.tile([0.45, 0.3, 0.25], (3, 64, 1))  # unparsed 0.25 > 0.2 in every cell but two
    p[0, 0 * 8 + 7] = [0.3, 0.5, 0.2]  # maternity leave, (Tom, Mary)
    p[0, 7 * 8 + 0] = [0.7, 0.2, 0.1]  # maternity leave, (Mary, Tom)
    p[2, 0] = [0.05, 0.05, 0.9]  # sick leave, (Tom, Tom): the largest unparsed mass
    groups = list(itertools.product(T.profiles, repeat=2))
    return Kernel(p, T.contexts, groups, T.decisions)


@pytest.fixture(scope="module")
def analysis():
    return analyse_kernel(T, _kernel(), model="m", epsilons=[1.0], targets=[0.5, 1.0])


@pytest.mark.slow
def test_baseline_range_by_hand(analysis):
    r = analysis.baseline.unparsed_range
    # maternity @ HR2: Tom [0.2, 0.3] (chosen if HR2 in (Mary, Tom)), Mary [0.5, 0.7] (HR2 in (Tom, Mary)):
    # lower 0.5/0.3, upper 0.7/0.2; every other context is below both (maternity @ HR1: 0.7/0.5, 0.8/0.3).
    assert math.exp(r.local_fairness.lower) == pytest.approx(5 / 3, rel=1e-8)
    assert math.exp(r.local_fairness.upper) == pytest.approx(3.5, rel=1e-12)
    assert r.local_fairness.upper_context == r.local_fairness.lower_context == "maternity leave @ HR2"
    assert r.local_fairness.upper_group == "Mary & 55 & American"
    assert math.exp(r.local_fairness.value) == pytest.approx(2.5, rel=1e-12)  # unparsed = 0: 0.5/0.2
    assert r.local_fairness.value == analysis.baseline.local_fairness.value  # the stated value is unchanged
    # L̄: Tom's ends sum to 2.0 and 3.3, Mary's to 2.7 and 4.0 (over six contexts, each 1/6)
    assert math.exp(r.global_fairness.upper) == pytest.approx(4.0 / 2.0, rel=1e-12)
    assert math.exp(r.global_fairness.lower) == pytest.approx(1.0, abs=1e-8)


def test_certificate_and_report_carry_the_range_and_the_warning(analysis):
    d = experiment_dict(analysis)
    assert d["baseline"]["local"]["unparsed_range"] == pytest.approx([math.log(5 / 3), math.log(3.5)], rel=1e-8)
    ends = d["baseline"]["local"]["unparsed_range_ends"]
    assert ends["upper"] == {"context": "maternity leave @ HR2", "group": "Mary & 55 & American",
                             "other_group": "Tom & 25 & Asian"}  # fmt: skip
    point = d["points"][0]["observed"]
    assert point["local"]["unparsed_range"][0] <= point["local"]["value"] <= point["local"]["unparsed_range"][1]
    assert d["utility"]["unparsed_range"] == [0.0, 1.0]
    m = d["unparsed_mass"]
    assert m["share_above"] == pytest.approx(190 / 192) and m["largest"] == pytest.approx(0.9)
    assert m["cells"][0] == {"context": "sick leave", "shown": "HR1 = Tom & 25 & Asian, HR2 = Tom & 25 & Asian",
                             "mass": pytest.approx(0.9)}  # fmt: skip
    md = experiment_markdown(d)
    assert "**Warning:** 99.0% of the shown cells put more than 0.2" in md
    assert "L in [0.5108, 1.253]" in md
    for b in d["budgets"]:  # a target is met only by the upper end; the stated default's answer beside it
        this = b["this_model"]
        assert this["met_by"] == "unparsed_upper_end"
        stated = this["stated_default"]
        if stated["feasible"]:
            assert stated["overturned_by_unparsed"] == (stated["unparsed_upper"] > b["target"])
    # No filter is needed for L̄ ≤ 1 (its upper end at ε = inf is ln 2 by hand above), but L ≤ 1 holds without a
    # filter only under the stated utility: the upper end there is ln 3.5 > 1.
    flags = {(b.target, b.kind): (b.stated_default.epsilon, b.unparsed_upper, b.overturned) for b in analysis.budgets}
    assert flags[(1.0, "global")] == (math.inf, pytest.approx(math.log(2.0)), False)
    assert flags[(1.0, "local")] == (math.inf, pytest.approx(math.log(3.5)), True)
    eps = {(b.target, b.kind): b.this_model.epsilon for b in analysis.budgets}
    assert eps[(1.0, "global")] == math.inf
    assert "| 1 | L | {} | ∞ | 1.253 **not met** | 1 |".format(f"{eps[(1.0, 'local')]:.4g}") in md
    assert "| 1 | L̄ | ∞ | ∞ | 0.6931 | 1 |" in md


def _by_grid(analysis, target, kind, end="upper"):
    """The largest ε with the upper end ≤ target at every smaller ε: fairness_range's upper end (tested against LPs
    in tests/metrics/test_utility_range.py) on a grid of 0.1 up to 30 nats, its first crossing bisected by hand; with
    ``end="value"`` the same for the value under the stated utility."""
    from fairaudit.experiments.vlm.filter import candidate_family
    from fairaudit.metrics.utility_range import fairness_range

    family = candidate_family(T)

    def upper(e):
        r = fairness_range(
            analysis.candidate_kernel, analysis.utility, -1, sensitive_mechanism=family(e),
            population=analysis.population, lower_end=False,
        )  # fmt: skip
        return getattr(r.local_fairness if kind == "local" else r.global_fairness, end)

    grid = np.linspace(0.0, 30.0, 301)
    first = next((i for i, e in enumerate(grid) if upper(e) > target), None)
    if first is None:
        return math.inf
    lo, hi = grid[first - 1], grid[first]
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if upper(mid) <= target else (lo, mid)
    return lo


@pytest.mark.slow
def test_budgets_are_met_by_the_upper_end(analysis):
    budgets = {(b.target, b.kind): b for b in analysis.budgets}
    for key in [(0.5, "local"), (0.5, "global"), (1.0, "local")]:
        b = budgets[key]
        want = _by_grid(analysis, *key)
        assert 1.0 < want < 20.0  # a finite ε, which the stated default exceeds
        assert b.this_model.epsilon == pytest.approx(want, rel=1e-8)
        assert b.this_model.bound == pytest.approx(key[0], rel=1e-9) and "upper end of" in b.this_model.reason
        assert b.stated_default.epsilon == pytest.approx(_by_grid(analysis, *key, end="value"), rel=1e-8)
        assert b.stated_default.epsilon > want * 1.3 and b.overturned


@pytest.mark.slow
def test_without_unparsed_mass_the_budget_is_the_stated_one():
    p = _kernel().probabilities.copy()
    p[..., 1] += p[..., 2]  # every unparsed reply read as "not chosen"
    p[..., 2] = 0.0
    k = Kernel(p, T.contexts, list(itertools.product(T.profiles, repeat=2)), T.decisions)
    a = analyse_kernel(T, k, model="m", epsilons=[1.0], targets=[0.1, 0.5])
    for b in a.budgets:
        on_upper_end = b.this_model.to_dict()
        assert on_upper_end.pop("unparsed")["decision"] == "unparsed"  # it says what it was calibrated on
        assert on_upper_end == b.stated_default.to_dict() and not b.overturned
    assert any(math.isfinite(b.this_model.epsilon) for b in a.budgets)
    md = experiment_markdown(experiment_dict(a))
    for b in a.budgets:
        e = "∞" if math.isinf(b.this_model.epsilon) else f"{b.this_model.epsilon:.4g}"
        assert f"| {b.target:g} | {'L' if b.kind == 'local' else 'L̄'} | {e} | {e} |" in md


@pytest.mark.slow
def test_the_command_warns_on_stderr(tmp_path, capsys):
    from _cli import run

    from fairaudit.experiments.report import shown_kernel_frame

    p = np.tile([0.05, 0.05, 0.9], (3, 64, 1))  # a model that almost never gives a reply the parser reads
    kernel = Kernel(p, T.contexts, list(itertools.product(T.profiles, repeat=2)), T.decisions)
    shown_kernel_frame(T, kernel).to_csv(tmp_path / "kernel.csv", index=False)
    code, _, err = run(
        capsys, "experiment", "hr-delivery", "--kernel", tmp_path / "kernel.csv", "--samples", "4", "--no-images",
        "--keep", "0.7", "--target", "0.5", "--out", tmp_path / "run", "--no-progress",
    )  # fmt: skip
    assert code == 0, err
    (line,) = [x for x in err.splitlines() if x.startswith("fairaudit: warning: ")]
    share = float(line.split("fairaudit: warning: ")[1].split("%")[0]) / 100
    # a cell's counted share is k/4 with k ~ Bin(4, 0.9) unparsed replies: above 0.2 unless k = 0 (P = 1e-4)
    assert share > 0.9 and "of the shown cells put more than 0.2 of their mass on unparsed replies" in line
    report = (tmp_path / "run" / "report.md").read_text()
    assert "**Warning:**" in report


def test_certified_bounds_do_not_depend_on_the_unparsed_utility_here(analysis):
    # HR: g = 1 chosen, 0 not chosen, 0 unparsed: every unparsed utility in [0, 1] keeps g's range [0, 1], and the
    # black-box bounds depend on g only through it (and tau); the corollary is epsilon of the filter.
    d = experiment_dict(analysis)
    for p, point in zip(analysis.points, d["points"]):
        b = point["bounds"]
        for name in ("corollary", "black_box", "black_box_global"):
            assert b["unparsed_range"][name]["range"] == [b[name], b[name]]
        assert b["corollary"] == pytest.approx(p.epsilon, rel=1e-12)
        assert b["black_box"] == pytest.approx(p.epsilon, rel=1e-12)  # g in {0, 1}: the worst model's L is ε
        assert "lies within the other outcomes' [0, 1]" in b["unparsed_range"]["black_box"]["reason"]
    md = experiment_markdown(d)
    assert (
        "Certified bounds over the unparsed reply's utility: the corollary is ε of the filter, and the black-box "
        "bounds depend on g only through [min g, max g] = [0, 1] and tau, and the stated unparsed utility 0 lies "
        "within the other outcomes' [0, 1], so no utility of an unparsed reply in [min g, max g] changes them: each "
        "range is one value."
    ) in md


def test_an_unparsed_utility_beyond_the_others_widens_the_black_box_bounds():
    # Package delivery with unparsed stated 5 (waiting times 1 and 3): g's range is [1, 5] as stated, [1, 3] for an
    # unparsed utility within [1, 3]. The bounds' ends by a second route: black_box_bound on the class [lower, gamma]
    # (tau = 1 = min g, as the run uses), and worst_model with the class's two-decision extreme for L-bar.
    from fairaudit.experiments.taskfile import PACKAGE_DELIVERY
    from fairaudit.laws.utilities import from_table
    from fairaudit.worstcase.black_box import black_box_bound
    from fairaudit.worstcase.known_utility import worst_model

    task = dataclasses.replace(PACKAGE_DELIVERY, utility_values=(1.0, 3.0, 5.0))
    p = np.tile([0.5, 0.3, 0.2], (3, 4, 1))
    kernel = Kernel(p, task.contexts, list(itertools.product(task.profiles, repeat=2)), task.decisions)
    a = analyse_kernel(task, kernel, model="m", epsilons=[1.0, 2.0], targets=())
    assert a.tau == 1.0
    for point in a.points:
        r, m = point.bound_ranges, point.mechanism
        assert (r["corollary"].lower, r["corollary"].upper) == (point.corollary, point.corollary)
        for lower, gamma, end in ((1.0, 5.0, "upper"), (1.0, 3.0, "lower")):
            local = black_box_bound(
                m, utility_class=UtilityClass(lower=lower, gamma=gamma, tau=1.0), population=a.population
            ).value
            extreme = from_table([gamma, lower], ["high", "low"])
            glob = worst_model(m, extreme, population=a.population, tau=1.0).global_fairness.value
            assert getattr(r["black_box"], end) == pytest.approx(local, rel=1e-9)
            assert getattr(r["black_box_global"], end) == pytest.approx(glob, rel=1e-9)
        assert r["black_box"].upper == point.black_box_local and r["black_box"].lower < 0.9 * r["black_box"].upper
        assert "lies outside the other outcomes' [1, 3]" in r["black_box"].reason
    d = experiment_dict(a)
    b = d["points"][0]["bounds"]
    md = experiment_markdown(d)
    lo, hi = b["unparsed_range"]["black_box"]["range"]
    assert f"| {b['black_box']:.4g} [{lo:.4g}, {hi:.4g}] | 1 |" in md
    assert "(in the bounds' columns)." in md
