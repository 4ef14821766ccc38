"""The paper's design alone (`--design paper`): the true prompts without a filter for the baseline and through the
filter at each ε, no kernel; the bounds in closed form where the mechanism is too large to build. Checked against a
second route each: the matrix's worst model, the paper points of `--design both`, `fairaudit audit` of the records,
and hand values."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from _cli import run

from fairaudit._errors import InputError
from fairaudit.experiments.analysis import candidate_context_mechanism, candidate_utility, epsilon_from_keep
from fairaudit.experiments.harness import plan_queries, true_cell_counts
from fairaudit.experiments.options import ModelSource, RunOptions
from fairaudit.experiments.paper_design import paper_design_bounds
from fairaudit.experiments.run import run_experiment
from fairaudit.experiments.slots import candidate_population
from fairaudit.experiments.taskfile import HR_DELIVERY, PACKAGE_DELIVERY, load_task, parse_task
from fairaudit.experiments.vlm.models import RuleModel, SimulatedModel, simulated_model, simulated_models
from fairaudit.worstcase import worst_model

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "tasks"
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
