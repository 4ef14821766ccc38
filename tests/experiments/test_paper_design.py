"""The paper's design alone (`--design paper`): the true prompts without a filter for the baseline and through the
filter at each ε, no kernel; the bounds in closed form where the mechanism is too large to build. Checked against a
second route each: the matrix's worst model, the paper points of `--design both`, `fairaudit audit` of the records,
and hand values."""

from __future__ import annotations

import itertools
import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from _cli import run

from fairaudit import UtilityClass
from fairaudit.base.errors import InputError
from fairaudit.base.json_values import number
from fairaudit.experiments.analysis import candidate_context_mechanism, candidate_utility
from fairaudit.experiments.harness import plan_queries
from fairaudit.experiments.kernel import true_cell_counts
from fairaudit.experiments.options import ModelSource, RunOptions
from fairaudit.experiments.paper_design import paper_design_bounds
from fairaudit.experiments.run import run_experiment
from fairaudit.experiments.slots import candidate_population, epsilon_from_keep
from fairaudit.experiments.taskfile import HR_DELIVERY, PACKAGE_DELIVERY, load_task, parse_task
from fairaudit.experiments.vlm.models import RuleModel, SimulatedModel, simulated_model, simulated_models
from fairaudit.worstcase.known_utility import worst_model

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "tasks"
RESUMES = EXAMPLES / "resume-ranking.toml"
RANKING = (
    (EXAMPLES / "ranking.toml")
    .read_text()
    .replace('[utility]\nvalues = "rank"\n', "[utility]\nvalues = [1, 0, 0]   # ranked first or not\nunparsed = 0\n")
)


def _latin(positions: str = "latin"):
    return parse_task(RANKING.replace('positions = "balanced"', f'positions = "{positions}"'), "r.toml", "ranking")


def _matrix_bounds(task, eps, positions, context_epsilon=None):
    """The corollary and worst-case values from M_cand's matrix (the route the closed forms replace)."""
    b = paper_design_bounds(task, eps, positions, context_epsilon=context_epsilon)
    mech = b.filter.candidate_mechanism(positions)
    wm = worst_model(
        mech,
        candidate_utility(task),
        context_mechanism=candidate_context_mechanism(task, context_epsilon),
        population=candidate_population(task, positions),
    )
    return b, mech.epsilon, wm.local_fairness.value, wm.global_fairness.value


@pytest.mark.parametrize(
    ("task", "positions"),
    [(HR_DELIVERY, "balanced"), (HR_DELIVERY, "latin"), (_latin(), "latin"), (_latin(), "balanced")],
    ids=["hr-balanced", "hr-latin", "ranking-latin", "ranking-balanced"],
)
@pytest.mark.parametrize("eps", [0.3, 1.7, 6.0])
def test_the_closed_form_bounds_equal_the_worst_model_over_the_matrix(task, positions, eps):
    b, corollary, local, global_ = _matrix_bounds(task, eps, positions, context_epsilon=0.8)
    assert candidate_utility(task).lower == 0
    assert b.corollary == pytest.approx(corollary, rel=1e-12, abs=1e-12)
    assert b.corollary == pytest.approx(eps, rel=1e-9)  # the candidate's ε is the one asked for
    assert b.black_box_local == pytest.approx(local, rel=1e-9)
    assert b.black_box_global == pytest.approx(global_, rel=1e-9)
    # the ranking task's balanced population is a mixture: no closed form, the matrix is used
    assert b.closed_form == (positions == "latin" or task is HR_DELIVERY)


def test_a_floor_or_the_listed_order_takes_the_matrix():
    b = paper_design_bounds(PACKAGE_DELIVERY, 2.0)  # waiting time >= 1: tau is set
    assert not b.closed_form
    mech = b.filter.candidate_mechanism("balanced")
    assert b.corollary == mech.epsilon
    fixed = paper_design_bounds(HR_DELIVERY, 2.0, "fixed")
    assert not fixed.closed_form and fixed.black_box_global == math.inf  # the slot reveals the group


@pytest.mark.slow
def test_the_bounds_of_eight_candidates_need_no_matrix():
    task = load_task(RESUMES)
    for eps in (0.5, 1.0, 2.0):
        b = paper_design_bounds(task, eps, "latin")
        assert b.closed_form and b.corollary == b.black_box_local == b.black_box_global == pytest.approx(eps)
        assert b.filter.epsilon_profile == pytest.approx(eps / 8)  # a Latin square: views differ in all 8 slots
    with pytest.raises(InputError, match=r"^task.candidates: a candidate's view has 8\^8"):
        paper_design_bounds(task, 1.0, "balanced")


@pytest.mark.parametrize("task", [HR_DELIVERY, PACKAGE_DELIVERY, _latin()], ids=["hr", "package", "ranking"])
def test_a_rule_model_replies_as_the_table_model_does(task):
    queries = plan_queries(task, "paper", 3, 7, epsilons=[math.inf, 1.0], positions="balanced")
    for name, rule in simulated_models(task).items():
        table = simulated_model(task, name)
        assert isinstance(table, SimulatedModel)
        lazy = RuleModel(task, rule, name)
        for q in queries:
            assert lazy.reply(q).text == table.reply(q).text


def test_fair_ranks_every_order_evenly():
    task = _latin()
    p = simulated_model(task, "fair").probabilities
    n = len(task.orders)
    assert n == 6 and np.allclose(p[..., :n], 1 / 6) and np.all(p[..., n:] == 0)


@pytest.mark.slow
def test_keep_maps_to_the_candidates_epsilon_of_the_runs_positions(tmp_path):
    task = _latin()
    latin, balanced = epsilon_from_keep(task, 0.6, "latin"), epsilon_from_keep(task, 0.6, "balanced")
    assert latin == pytest.approx(3 * math.log(0.6 * 2 / 0.4))  # two views differ in all 3 slots, at ln 3 each
    assert latin != pytest.approx(balanced)
    path = tmp_path / "latin.toml"
    path.write_text(RANKING.replace('positions = "balanced"', 'positions = "latin"'))
    done = run_experiment(
        str(path), tmp_path / "run", ModelSource(simulated="fair"),
        RunOptions(samples=1, keeps=[0.6], images=False, targets=[], confidence=None), progress=False,
    )  # fmt: skip
    assert done.analysis.points[0].epsilon == pytest.approx(latin)
    assert done.analysis.points[0].filter.keep_probabilities == pytest.approx((0.6,))


@pytest.fixture(scope="module")
def hr_runs(tmp_path_factory):
    """hr-delivery with one seed: the paper's design alone, and beside the table design."""
    tmp = tmp_path_factory.mktemp("hr")
    source = ModelSource(simulated="prefers-mary")
    runs = {}
    for design in ("paper", "both"):
        options = RunOptions(samples=12, keeps=[0.6, 0.8], design=design, images=False, targets=[], seed=3)
        runs[design] = run_experiment("hr-delivery", tmp / design, source, options, progress=False)
    return runs


@pytest.mark.slow
def test_the_paper_design_alone_observes_what_design_both_observes(hr_runs):
    alone, both = hr_runs["paper"].analysis, hr_runs["both"].analysis
    assert [p.epsilon for p in alone.points] == [p.epsilon for p in both.paper]
    for a, b in zip(alone.points, both.paper):
        assert a.queries == b.queries == 3 * 2 * 12  # documents x both orders x samples
        assert a.local_fairness.value == b.local_fairness.value and a.global_fairness.value == b.global_fairness.value
        assert tuple(a.intervals.local_fairness) == tuple(b.intervals.local_fairness)
    for a, b in zip(alone.points, both.points):  # the bounds: closed form against the table design's matrix
        assert a.bounds.black_box_local == pytest.approx(b.black_box_local, rel=1e-12)
        assert a.bounds.black_box_global == pytest.approx(b.black_box_global, rel=1e-12)
        assert a.bounds.corollary == pytest.approx(b.corollary, rel=1e-12)


def test_the_baseline_is_the_true_prompts_counted_by_hand(hr_runs):
    run_ = hr_runs["paper"]
    a = run_.analysis
    # prefers-mary picks whoever is shown as Mary: without a filter, Mary always; by hand E[g] = 1 and 0
    tom, mary = (HR_DELIVERY.profile_label(c) for c in HR_DELIVERY.candidates)
    e = a.baseline.local_fairness.expected_utility
    assert np.all(e[:, a.population.groups.index(mary)] == 1) and np.all(e[:, a.population.groups.index(tom)] == 0)
    assert a.baseline.local_fairness.value == math.inf and a.baseline.local_fairness.group == mary
    # the baseline's counts from the log, record by record
    lines = (run_.out / "queries.jsonl").read_text().splitlines()
    assert json.loads(lines[0])["design"] == "paper"
    records = [json.loads(x) for x in lines[1:]]  # strict JSON: no Infinity
    base = [r for r in records if r["epsilon"] == "inf"]
    assert len(base) == a.baseline.queries == 72 and all(r["id"].startswith("paper|inf|") for r in base)
    assert all(r["profiles"] == r["truth"]["profiles"] for r in base)  # no filter: shown as they are
    c = true_cell_counts(HR_DELIVERY, base).reshape(a.baseline.counts.shape)
    assert np.array_equal(c, a.baseline.counts)


def test_the_certificate_and_the_records_csv_agree_with_an_audit(hr_runs, capsys):
    out = hr_runs["paper"].out
    cert = json.loads((out / "certificate.json").read_text())
    assert cert["route"] == "sampled" and cert["design"] == "paper"
    assert cert["baseline"]["local"]["value"] == "inf"
    p = cert["points"][0]
    assert p["epsilon"] == pytest.approx(epsilon_from_keep(HR_DELIVERY, 0.6))
    assert p["bounds"]["black_box"] == pytest.approx(p["epsilon"]) and p["bounds"]["closed_form"] is True
    assert p["observed"]["local"]["value"] == hr_runs["paper"].analysis.points[0].local_fairness.value
    counts = pd.read_csv(out / "candidates.csv")
    assert set(counts.columns) == {"epsilon", "document", "position", "profile", "outcome", "count"}
    per_eps = counts.groupby("epsilon")["count"].sum()
    assert per_eps.index.tolist() == pytest.approx([p["epsilon"], cert["points"][1]["epsilon"], math.inf])
    assert per_eps.tolist() == [144, 144, 144]  # 72 queries x 2 candidates at each
    records = pd.read_csv(out / "records.csv")
    assert len(records) == 2 * 72  # one per query and candidate
    code, stdout, _ = run(
        capsys, "audit", out / "records.csv", "--sensitive", "profile", "--context", "document,position",
        "--outcome", "outcome", "--positive", "chosen", "--format", "json",
    )  # fmt: skip
    assert code == 0
    audit = json.loads(stdout)
    assert audit["local"]["value"] == "inf" and audit["global"]["value"] == "inf"
    assert (out / "report.md").read_text().startswith("# hr-delivery: prefers-mary")
    assert (out / "curve.png").stat().st_size > 10_000


@pytest.mark.slow
def test_eight_candidates_ranked_run_on_the_paper_design(tmp_path, capsys):
    out = tmp_path / "run"
    code, stdout, err = run(
        capsys, "experiment", RESUMES, "--design", "paper", "--samples", "2", "--epsilon", "1",
        "--out", out, "--no-progress",
    )  # fmt: skip
    assert code == 0, err
    assert "128 of 128 queries answered" in err  # 4 jobs x 8 orders x 2 samples x (baseline + one ε)
    assert stdout.startswith("# resume-ranking: prefers-first")
    cert = json.loads((out / "certificate.json").read_text())
    (p,) = cert["points"]
    assert p["epsilon"] == 1.0 and p["bounds"]["black_box"] == pytest.approx(1.0)
    assert p["privacy"]["epsilon_profile"] == pytest.approx(1 / 8)
    # prefers-first ranks the first candidate's group first, always, without a filter: E[g] is 1 for it, 0 otherwise
    first = cert["candidates"][0]
    assert cert["baseline"]["local"]["group"] == first and cert["baseline"]["local"]["value"] == "inf"
    records = pd.read_csv(out / "records.csv")
    assert len(records) == 64 * 8
    ranked_first = records[records.outcome == "rank 1"]
    assert (ranked_first.profile == first).all() and len(ranked_first) == 64


@pytest.mark.slow
def test_the_paper_design_is_refused_where_it_cannot_run(tmp_path, capsys):
    code, _, err = run(
        capsys, "experiment", RESUMES, "--design", "paper", "--positions", "balanced", "--samples", "1",
        "--out", tmp_path / "b", "--no-progress",
    )  # fmt: skip
    assert code == 2 and err.startswith("fairaudit: error: task.candidates: a candidate's view has 8^8")
    assert "positions = 'latin'" in err and len(err.splitlines()) == 1
    assert not (tmp_path / "b").exists()
    with pytest.raises(InputError, match="^design: the paper's design samples"):
        run_experiment(
            "hr-delivery", tmp_path / "e", ModelSource(endpoint="http://127.0.0.1:9/v1", model="m", exact=True),
            RunOptions(design="paper"), progress=False,
        )  # fmt: skip
    assert not (tmp_path / "e").exists()


def test_a_floor_on_eight_candidates_is_refused_naming_the_utility():
    task = load_task(RESUMES)
    with pytest.raises(InputError, match=r"^utility: the black-box bound with a floor tau needs .* 8\^8 = 16,777,216"):
        paper_design_bounds(task, 1.0, "latin", tau=0.1)


# --------------------------------------------------------------------------- the unparsed reply's utility


def _unparsed_kernel():
    """hr-delivery's model on shown pairs: a quarter of the replies unparsed (0.1 to 0.2 in two cells)."""
    import itertools

    from fairaudit.laws.tables import Kernel

    p = np.tile([0.45, 0.3, 0.25], (3, 64, 1))
    p[0, 0 * 8 + 7] = [0.3, 0.5, 0.2]  # maternity leave, (Tom, Mary)
    p[0, 7 * 8 + 0] = [0.7, 0.2, 0.1]  # maternity leave, (Mary, Tom)
    return Kernel(
        p, HR_DELIVERY.contexts, list(itertools.product(HR_DELIVERY.profiles, repeat=2)), HR_DELIVERY.decisions
    )


@pytest.fixture(scope="module")
def unparsed_run(tmp_path_factory):
    """hr-delivery, the paper's design alone, on a kernel table that replies unparsed (g stated 0, within [0, 1])."""
    from fairaudit.experiments.report import shown_kernel_frame

    tmp = tmp_path_factory.mktemp("unparsed")
    shown_kernel_frame(HR_DELIVERY, _unparsed_kernel()).to_csv(tmp / "kernel.csv", index=False)
    options = RunOptions(samples=20, keeps=[0.7], design="paper", images=False, targets=[], seed=1)
    return run_experiment("hr-delivery", tmp / "run", ModelSource(kernel=tmp / "kernel.csv"), options, progress=False)


def _by_hand(out: Path, eps: str, task=HR_DELIVERY, positions="balanced"):
    """L's and L̄'s ranges from candidates.csv alone, in ratios: the upper ends by enumerating every vertex of the
    box (each cell's unparsed utility at 0 or 1: the maximum of each pair's linear-fractional program is at a vertex,
    proofs/unparsed.md §2), the lower ends by the closed forms of disjoint boxes (§3: no mechanism between the
    cells and the groups, since the filter is in the queries)."""
    frame = pd.read_csv(out / "candidates.csv", keep_default_na=False)
    frame = frame[frame["epsilon"].astype(str) == eps]
    table = frame.pivot_table(index=["document", "position", "profile"], columns="outcome", values="count",
                              aggfunc="sum", fill_value=0)  # fmt: skip
    n = table.sum(axis=1).to_numpy(float)
    known = table["chosen"].to_numpy(float) / n  # g = 1 chosen, 0 not chosen
    mass = table["unparsed"].to_numpy(float) / n
    cells = table.index.to_frame(index=False)
    contexts = (cells["document"] + " @ " + cells["position"]).to_numpy()
    groups = cells["profile"].to_numpy()
    pop = candidate_population(task, positions)
    w = np.array([  # P(x | a) of the run's population, per cell
        pop.context_given_group()[pop.contexts.index(x), pop.groups.index(a)] for x, a in zip(contexts, groups)
    ])  # fmt: skip
    lo, hi = known, known + mass
    vertices = np.array(list(itertools.product([0.0, 1.0], repeat=len(n))))  # 2^12
    e = known + vertices * mass  # (vertices, cells)
    up_local, up_global, low_local = 0.0, 0.0, 1.0
    for x in np.unique(contexts):
        a, b = (
            np.flatnonzero((contexts == x) & (groups == groups[0])),
            np.flatnonzero((contexts == x) & (groups != groups[0])),
        )
        ea, eb = e[:, a[0]], e[:, b[0]]
        up_local = max(up_local, np.max(np.maximum(ea / eb, eb / ea)))
        low_local = max(low_local, max(lo[a[0]], lo[b[0]]) / min(hi[a[0]], hi[b[0]]))
    first = groups == groups[0]
    mean = np.stack([(e * w)[:, first].sum(1), (e * w)[:, ~first].sum(1)])  # E[g | a] per vertex
    up_global = np.max(np.maximum(mean[0] / mean[1], mean[1] / mean[0]))
    m_lo, m_hi = [(w * lo)[first].sum(), (w * lo)[~first].sum()], [(w * hi)[first].sum(), (w * hi)[~first].sum()]
    low_global = max(1.0, max(m_lo) / min(m_hi))
    return (low_local, up_local), (low_global, up_global)


def test_the_certificate_gives_the_observed_values_range_over_the_unparsed_utility(unparsed_run):
    a, out = unparsed_run.analysis, unparsed_run.out
    cert = json.loads((out / "certificate.json").read_text())
    assert cert["queries"]["unparsed"] > 0 and cert["utility"]["unparsed_range"] == [0.0, 1.0]
    for p, d, eps in [(a.baseline, cert["baseline"], "inf")] + [
        (p, d["observed"], str(d["epsilon"])) for p, d in zip(a.points, cert["points"])
    ]:
        for kind, by_hand in zip(("local", "global"), _by_hand(out, eps)):
            rng = getattr(p.unparsed_range, f"{kind}_fairness")
            # the range's stated value is the observed value the certificate reports
            assert rng.value == getattr(p, f"{kind}_fairness").value
            assert rng.value == pytest.approx(d[kind]["value"], abs=1e-12)
            lower, upper = d[kind]["unparsed_range"]
            assert math.exp(upper) == pytest.approx(by_hand[1], rel=1e-12)
            assert math.exp(lower) == pytest.approx(by_hand[0], rel=1e-8)
            assert lower < d[kind]["value"] < upper  # a quarter of the replies unparsed: a range, not a point
            assert d[kind]["unparsed_range_ends"]["exact"] is True
        up = d["local"]["unparsed_range_ends"]["upper"]
        assert set(up) == {"context", "group", "other_group"} and up["context"] in a.population.contexts


def test_the_report_shows_the_ranges_of_the_paper_design(unparsed_run):
    cert = json.loads((unparsed_run.out / "certificate.json").read_text())
    md = (unparsed_run.out / "report.md").read_text()
    b, p = cert["baseline"], cert["points"][0]
    (bl, bu), (gl, gu) = b["local"]["unparsed_range"], b["global"]["unparsed_range"]
    assert f"Over the unparsed reply's utility: L in [{bl:.4g}, {bu:.4g}], L̄ in [{gl:.4g}, {gu:.4g}] nats." in md
    (pl, pu), (ql, qu) = p["observed"]["local"]["unparsed_range"], p["observed"]["global"]["unparsed_range"]
    assert f"| [{pl:.4g}, {pu:.4g}] | " in md and f"| [{ql:.4g}, {qu:.4g}] | " in md
    assert "chosen independently for every cell of the per-candidate law observed at that ε" in md


def test_without_unparsed_replies_each_range_is_the_value(hr_runs):
    a = hr_runs["paper"].analysis
    cert = json.loads((hr_runs["paper"].out / "certificate.json").read_text())
    assert cert["queries"]["unparsed"] == 0
    for d in [cert["baseline"]] + [p["observed"] for p in cert["points"]]:
        for kind in ("local", "global"):
            value = d[kind]["value"]  # a number, or "inf" (JSON's +inf): compared as itself
            want = [value] * 2 if isinstance(value, str) else pytest.approx([value] * 2, rel=1e-9)
            assert d[kind]["unparsed_range"] == want
    assert cert["baseline"]["local"]["unparsed_range"] == ["inf", "inf"]  # prefers-mary: Tom's E[g] is 0
    assert a.points[0].unparsed_range.local_fairness.value == a.points[0].local_fairness.value


def test_the_paper_design_states_its_bounds_ranges(unparsed_run):
    # g = 1 chosen, 0 not chosen and unparsed: the stated unparsed utility lies within the other outcomes' [0, 1],
    # so no utility of an unparsed reply changes the bounds (proofs/unparsed.md §6): each range is one value
    cert = json.loads((unparsed_run.out / "certificate.json").read_text())
    for p in cert["points"]:
        b = p["bounds"]
        for name in ("corollary", "black_box", "black_box_global"):
            assert b["unparsed_range"][name]["range"] == [b[name], b[name]]
        assert "lies within the other outcomes' [0, 1]" in b["unparsed_range"]["black_box"]["reason"]
    assert (
        "Certified bounds over the unparsed reply's utility: the corollary is ε of the filter"
        in (unparsed_run.out / "report.md").read_text()
    )


def test_an_unparsed_utility_below_the_others_widens_the_paper_designs_black_box_bounds(unparsed_run):
    # g = 1 chosen, 3 not chosen, unparsed stated 0: [min g, max g] = [0, 3] as stated (the closed form: the bound
    # is epsilon), [1, 3] for an unparsed utility within the others'. That end by a second route: black_box_bound on
    # the class [1, 3] with the candidate's mechanism from its matrix, and worst_model with the class's extreme.
    import dataclasses

    from fairaudit.experiments.paper_design import analyse_paper_design
    from fairaudit.laws.utilities import from_table
    from fairaudit.worstcase.black_box import black_box_bound

    task = dataclasses.replace(HR_DELIVERY, utility_values=(1.0, 3.0, 0.0))
    records = [json.loads(x) for x in (unparsed_run.out / "queries.jsonl").read_text().splitlines()[1:]]
    eps = [p.epsilon for p in unparsed_run.analysis.points]
    a = analyse_paper_design(task, records, model="m", samples=20, epsilons=eps, confidence=None)
    assert a.tau is None
    for p in a.points:
        r = p.bound_ranges
        assert (r["corollary"].lower, r["corollary"].upper) == (p.bounds.corollary, p.bounds.corollary)
        assert r["black_box"].upper == p.bounds.black_box_local == pytest.approx(p.epsilon)
        m = p.bounds.filter.candidate_mechanism("balanced")
        pop = candidate_population(task, "balanced")
        local = black_box_bound(m, utility_class=UtilityClass(lower=1.0, gamma=3.0), population=pop).value
        glob = worst_model(m, from_table([3.0, 1.0], ["high", "low"]), population=pop).global_fairness.value
        assert r["black_box"].lower == pytest.approx(local, rel=1e-9) and r["black_box"].lower < 0.9 * p.epsilon
        assert r["black_box_global"].lower == pytest.approx(glob, rel=1e-9)
        assert "lies outside the other outcomes' [1, 3]" in r["black_box"].reason
        # the observed values' ranges: unparsed in [0, 3] per cell
        assert p.unparsed_range.low == 0.0 and p.unparsed_range.high == 3.0


def test_a_bounds_lower_end_that_needs_too_large_a_mechanism_is_left_out_with_the_reason():
    import dataclasses

    from fairaudit.experiments.paper_design import _bound_ranges

    task = load_task(RESUMES)
    values = (2.0,) + (1.0,) * (len(task.outcomes) - 2) + (0.0,)  # ranked first 2, any other rank 1, unparsed 0
    task = dataclasses.replace(task, utility_values=values)
    b = paper_design_bounds(task, 1.0, "latin")
    assert b.closed_form and b.black_box_local == pytest.approx(1.0)  # as stated: min g = 0, epsilon itself
    r = _bound_ranges(task, 1.0, "latin", None, None, b)
    assert r["black_box"].upper == b.black_box_local and math.isnan(r["black_box"].lower)
    assert "; the lower end is not computed (utility: the black-box bound with a utility whose smallest value is 1" in (
        r["black_box"].reason
    )
    assert r["corollary"].lower == r["corollary"].upper == b.corollary


def test_design_both_gives_the_paper_points_ranges_too(hr_runs):
    alone, both = hr_runs["paper"], hr_runs["both"]
    cert = json.loads((both.out / "certificate.json").read_text())
    for a, d in zip(alone.analysis.points, cert["paper_design"]):
        for kind in ("local", "global"):
            rng = getattr(a.unparsed_range, f"{kind}_fairness")
            assert d[kind]["unparsed_range"] == [number(rng.lower), number(rng.upper)]  # (JSON round-trips floats)
            assert d[kind]["unparsed_range_ends"]["exact"] is True
    assert (
        "| ε candidate | queries | observed L | L, unparsed range | observed L̄ | L̄, unparsed range |"
        in (both.out / "report.md").read_text()
    )
