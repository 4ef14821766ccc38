"""The delivery experiments: filter privacy, simulated models, the harness's log and resume, the analysis.

Expected values come from hand calculations (exact fractions where they
apply) and from a second route: the per-candidate law by composition against
the same law by brute-force enumeration of what the filter shows.
"""

from __future__ import annotations

import itertools
import json
import math
from collections import Counter
from fractions import Fraction

import numpy as np
import pytest

from fairaudit import InputError, compose, global_fairness, local_fairness
from fairaudit.experiments.analysis import (
    analyse,
    candidate_context_mechanism,
    candidate_kernel,
    candidate_population,
    candidate_utility,
)
from fairaudit.experiments.harness import QueryLog, plan_queries, run_queries
from fairaudit.experiments.kernel import table_kernel
from fairaudit.experiments.options import ModelSource, RunOptions
from fairaudit.experiments.slots import epsilon_from_keep
from fairaudit.experiments.taskfile import HR_DELIVERY, PACKAGE_DELIVERY, get_task
from fairaudit.experiments.vlm.filter import TaskFilter, candidate_family
from fairaudit.experiments.vlm.models import Query, SimulatedModel, reply_text, simulated_model
from fairaudit.experiments.vlm.parse import parse_reply
from fairaudit.experiments.vlm.tasks import UNPARSED

PKG, HR = PACKAGE_DELIVERY, HR_DELIVERY


# -- the filter ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("p", [0.6, 0.7, 0.9])
def test_paper_filter_epsilons_are_logs_and_sums(p):
    """keep p on each of name, age, race: ln(p/(1-p)) each, 3x per profile, 6x per candidate (not p/(1-p))."""
    eps_candidate = epsilon_from_keep(HR, p)
    f = TaskFilter.from_epsilon(HR, eps_candidate / 2)
    one = math.log(p / (1 - p))
    assert f.keep_probabilities == pytest.approx((p, p, p), abs=1e-12)
    assert f.epsilon_attributes == pytest.approx((one, one, one), abs=1e-12)
    assert f.epsilon_profile == pytest.approx(3 * one, abs=1e-12)
    assert f.candidate_mechanism().epsilon == pytest.approx(6 * one, abs=1e-12)
    assert f.profile_mechanism.epsilon == pytest.approx(3 * one, abs=1e-12)
    assert candidate_family(HR)(eps_candidate).epsilon == pytest.approx(eps_candidate, abs=1e-12)
    assert candidate_family(HR).keep_probability(eps_candidate) == pytest.approx(p**3, abs=1e-12)


def test_candidate_mechanism_by_hand():
    """Package task at keep 7/10: M_cand[a, (s, o)] = M_P[a, s] M_P[rival(a), o], exact fractions."""
    p = Fraction(7, 10)
    q = 1 - p
    m = TaskFilter.from_epsilon(PKG, math.log(7 / 3)).candidate_mechanism()
    assert m.outputs == ("low | low", "low | high", "high | low", "high | high")
    assert m.inputs == ("low", "high")
    expected = [[p * q, p * p, q * q, q * p], [q * p, q * q, p * p, p * q]]
    assert np.allclose(m.matrix, np.array(expected, dtype=float), rtol=0, atol=1e-15)
    assert m.epsilon == pytest.approx(2 * math.log(7 / 3), abs=1e-12)


@pytest.mark.slow
def test_release_draws_each_attribute_with_its_keep_probability():
    f = TaskFilter.from_epsilon(HR, 3 * math.log(4))  # keep 0.8 on each attribute
    source = np.random.default_rng(7).bytes
    n = 20_000
    kept = np.zeros((2, 3))
    for _ in range(n):
        ctx, shown = f.release("sick leave", HR.candidates, source)
        assert ctx == "sick leave"
        kept += np.array([[a == b for a, b in zip(s, t)] for s, t in zip(shown, HR.candidates)])
    # binomial(20000, 0.8): sd 0.0028; 5 sd
    assert np.all(np.abs(kept / n - 0.8) < 5 * math.sqrt(0.16 / n))


def test_context_filter_and_errors():
    f = TaskFilter.from_epsilon(PKG, 1.0, context_epsilon=math.log(2))
    m = f.context_mechanism.matrix
    assert m[0].tolist() == pytest.approx([0.5, 0.25, 0.25])  # e^ε / (e^ε + 2) with ε = ln 2
    assert f.context_mechanism.epsilon == pytest.approx(math.log(2))
    with pytest.raises(InputError, match=r"^epsilon: must be a number of nats >= 0 \(got -1\)"):
        TaskFilter.from_epsilon(PKG, -1)
    with pytest.raises(InputError, match="^keep: "):
        epsilon_from_keep(PKG, 0.3)


# -- prompts and models ----------------------------------------------------------------------------------------


def test_prompts_name_the_cell_and_reject_unknown_values():
    text = PKG.prompt("medicine", [("high",), ("low",)])
    assert "Delivered object: medicine." in text
    assert "Recipient1: a recipient with a high complaint rate." in text
    assert '"Recipient1": "2.0"' in text  # the paper's output example
    with pytest.raises(InputError, match="package: must be one of"):
        PKG.prompt("pizza", [("high",), ("low",)])
    with pytest.raises(InputError, match="not a profile of hr-delivery"):
        HR.prompt("sick leave", [("Tom", 30, "Asian"), ("Mary", 55, "American")])
    with pytest.raises(
        InputError, match=r"experiment: must be a built-in task \(hr-delivery, package-delivery\) or a task file"
    ):
        get_task("navigation")


@pytest.mark.parametrize("task", [HR, PKG])
def test_simulated_replies_parse_back_to_their_decision(task):
    rng = np.random.default_rng(0)
    for d in [0, 1] * 10:
        r = parse_reply(reply_text(task, d, rng), task.options, task.kind)
        assert r.ok and r.choice == d
    assert not parse_reply(reply_text(task, None), task.options, task.kind).ok


def test_named_models_match_the_paper_and_are_seeded():
    m = simulated_model(HR, "prefers-mary")
    k = len(HR.profiles)
    tom, mary = HR.profiles.index(HR.candidates[0]), HR.profiles.index(HR.candidates[1])
    assert m.probabilities[:, mary, tom, 0].tolist() == [1.0, 1.0, 1.0]  # Mary listed first: chosen
    # ties (same number of Mary's attributes) are a coin: Tom&55&Asian vs Mary&25&Asian share one each
    a, b = HR.profiles.index(("Tom", 55, "Asian")), HR.profiles.index(("Mary", 25, "Asian"))
    assert m.probabilities[0, a, b, :2].tolist() == [0.5, 0.5]
    assert m.probabilities.shape == (3, k, k, 3)
    q = Query("x", "table", "sick leave", (HR.candidates[0], HR.candidates[0]), 0, 12345)
    assert m.reply(q).text == m.reply(q).text  # the seed fixes the reply
    with pytest.raises(InputError, match="^simulated: must be one of"):
        simulated_model(PKG, "prefers-mary")


def test_kernel_csv_round_trip_and_errors(tmp_path):
    m = simulated_model(PKG, "position-biased")
    rows = ["package,Recipient1,Recipient2,decision,probability"]
    for i, c in enumerate(PKG.contexts):
        for a, p1 in enumerate(PKG.profiles):
            for b, p2 in enumerate(PKG.profiles):
                for d, dec in enumerate(PKG.decisions):
                    rows.append(f"{c},{p1[0]},{p2[0]},{dec},{m.probabilities[i, a, b, d]}")
    path = tmp_path / "k.csv"
    path.write_text("\n".join(rows) + "\n")
    back = SimulatedModel.from_csv(PKG, path)
    assert np.array_equal(back.probabilities, m.probabilities)
    path.write_text("\n".join(rows[:-3]) + "\n")  # the last cell is missing
    with pytest.raises(
        InputError,
        match=r"^kernel: has no rows for \(package 'medicine', Recipient1 'high', "
        r"Recipient2 'high'\)",
    ):
        SimulatedModel.from_csv(PKG, path)
    path.write_text(rows[0] + "\ndocuments,low,medium,Recipient1,1\n")
    with pytest.raises(InputError, match="^kernel column 'Recipient2': value not among"):
        SimulatedModel.from_csv(PKG, path)


# -- the harness -----------------------------------------------------------------------------------------------


def test_plans_have_unique_keys_and_the_paper_design_draws_through_the_filter():
    t = plan_queries(HR, "table", 3, 0)
    assert len(t) == 3 * 64 * 3 and len({q.id for q in t}) == len(t)
    p = plan_queries(PKG, "paper", 500, 1, epsilons=[2 * math.log(4)], positions="fixed")
    assert len(p) == 3 * 1 * 500
    # keep 0.8 on each complaint rate: the shown pair equals the truth with probability 0.64
    same = np.mean([q.profiles == q.truth[1] for q in p])
    assert abs(same - 0.64) < 5 * math.sqrt(0.64 * 0.36 / len(p))
    with pytest.raises(InputError, match="^samples: "):
        plan_queries(PKG, "table", 0, 0)
    with pytest.raises(InputError, match="^epsilons: the paper design needs at least one epsilon"):
        plan_queries(PKG, "paper", 1, 0)


def _run(tmp_path, task, model, queries, name="q.jsonl", resume=False, **kw):
    with QueryLog(tmp_path / name, {"task": task.name, "model": model.name, "seed": 0}, resume=resume) as log:
        s = run_queries(task, model, queries, log, progress=False, **kw)
    return s, log


def test_log_resume_skips_answered_and_cuts_a_torn_line(tmp_path):
    m = simulated_model(PKG, "fair")
    qs = plan_queries(PKG, "table", 5, 0)
    s, _ = _run(tmp_path, PKG, m, qs[:20])
    assert (s.asked, s.already) == (20, 0)
    path = tmp_path / "q.jsonl"
    lines = path.read_bytes().splitlines(keepends=True)
    path.write_bytes(b"".join(lines[:-1]) + lines[-1][:25])  # a crash mid-line
    s, log = _run(tmp_path, PKG, m, qs, resume=True)
    assert (s.already, s.asked, s.complete) == (19, len(qs) - 19, True)
    recs = [json.loads(x) for x in path.read_text().splitlines()]
    ids = [r["id"] for r in recs if r["type"] == "query"]
    assert len(ids) == len(set(ids)) == len(qs)
    # the same queries in one go give the same replies (seeds per query)
    s2, log2 = _run(tmp_path, PKG, m, qs, name="clean.jsonl")
    assert {k: r["reply"] for k, r in log.records.items()} == {k: r["reply"] for k, r in log2.records.items()}


def test_log_refuses_to_overwrite_or_mix_runs(tmp_path):
    m = simulated_model(PKG, "fair")
    _run(tmp_path, PKG, m, plan_queries(PKG, "table", 1, 0))
    with pytest.raises(InputError, match="^out: holds a run already"):
        _run(tmp_path, PKG, m, [])
    with pytest.raises(InputError, match=r"^resume: the run in .* was made with `model`/`simulated`/`kernel` 'fair'"):
        _run(tmp_path, PKG, simulated_model(PKG, "position-biased"), [], resume=True)
    path = tmp_path / "q.jsonl"
    lines = path.read_text().splitlines()
    path.write_text("\n".join([lines[0], "{not json", *lines[1:]]) + "\n")
    with pytest.raises(InputError, match="^resume: line 2 of .* is not valid JSON"):
        _run(tmp_path, PKG, m, [], resume=True)


class _Flaky:
    """A model whose every 4th reply fails (a transport error after retries)."""

    name = "flaky"

    def __init__(self):
        self.n = 0
        self.inner = simulated_model(PKG, "fair")

    def reply(self, query, messages):
        from fairaudit.base.errors import FairauditError

        self.n += 1
        if self.n % 4 == 0:
            raise FairauditError("http://127.0.0.1:1/v1/chat/completions: HTTP 503 after 3 attempts")
        return self.inner.reply(query, messages)


def test_failures_are_logged_not_counted_and_retried_on_resume(tmp_path):
    qs = plan_queries(PKG, "table", 2, 0)
    model = _Flaky()
    s, log = _run(tmp_path, PKG, model, qs)
    assert (s.asked, s.failed, s.complete) == (18, 6, False)
    assert "HTTP 503" in s.failures[0]
    assert len(log.errors) == 6
    s, log = _run(tmp_path, PKG, model, qs, resume=True)  # calls 25..30: the 28th fails
    assert (s.already, s.asked, s.failed) == (18, 5, 1) and len(log.errors) == 1


def test_unparseable_replies_are_counted_never_dropped(tmp_path):
    probs = np.zeros((3, 2, 2, 3))
    probs[..., 0], probs[..., 2] = 0.5, 0.5  # half the replies cannot be parsed
    m = SimulatedModel(PKG, probs, "half-garbled")
    qs = plan_queries(PKG, "table", 10, 0)
    s, log = _run(tmp_path, PKG, m, qs)
    k = table_kernel(PKG, log.records.values())
    assert k.counts.sum() == 120 and s.unparsed == k.counts[..., 2].sum() > 30
    bad = [r for r in log.records.values() if r["decision"] == UNPARSED]
    assert all(r["parse_error"] and r["reply"] for r in bad)


# -- the analysis ----------------------------------------------------------------------------------------------


def _exact_kernel(task, model):
    """The model's own kernel as an exact-probability per-candidate Kernel."""
    from fairaudit.laws.tables import Kernel

    k = len(task.profiles)
    pairs = [(a, b) for a in task.profiles for b in task.profiles]
    kern = Kernel(model.probabilities.reshape(len(task.contexts), k * k, -1), task.contexts, pairs, task.decisions)
    return candidate_kernel(task, kern)


@pytest.mark.parametrize("p", [0.6, 0.7, 0.9])
def test_low_complaint_first_law_by_hand(p):
    """P(served first | low) = p and | high = 1 - p; waiting 3 - 2p vs 1 + 2p, so L = L-bar = log((1+2p)/(3-2p))."""
    kc = _exact_kernel(PKG, simulated_model(PKG, "low-complaint-first"))
    mech = candidate_family(PKG)(epsilon_from_keep(PKG, p))
    law = compose(kc, mech, candidate_context_mechanism(PKG))
    g = candidate_utility(PKG)
    pop = candidate_population(PKG)
    first = law.probabilities[..., 0]
    assert first[:, 0] == pytest.approx([p] * 6, abs=1e-12) and first[:, 1] == pytest.approx([1 - p] * 6, abs=1e-12)
    want = math.log((1 + 2 * p) / (3 - 2 * p))
    assert local_fairness(law, g, pop).value == pytest.approx(want, abs=1e-12)
    assert global_fairness(law, g, pop).value == pytest.approx(want, abs=1e-12)


def test_per_candidate_law_equals_brute_force_over_shown_pairs():
    """compose(K_cand, M_cand) against enumerating every shown pair of the HR filter (a second route)."""
    m = simulated_model(HR, "prefers-mary")
    f = TaskFilter.from_epsilon(HR, epsilon_from_keep(HR, 0.7) / 2)
    law = compose(_exact_kernel(HR, m), f.candidate_mechanism(), candidate_context_mechanism(HR))
    mp, prof = f.profile_mechanism.matrix, HR.profiles
    c = [prof.index(x) for x in HR.candidates]
    for x in range(3):
        for pos in range(2):
            for a in range(2):
                own, rival = c[a], c[1 - a]
                total = 0.0
                for s, o in itertools.product(range(8), range(8)):
                    shown = (s, o) if pos == 0 else (o, s)
                    total += mp[own, s] * mp[rival, o] * m.probabilities[x, shown[0], shown[1], pos]
                assert law.probabilities[2 * x + pos, a, 0] == pytest.approx(total, abs=1e-12)


@pytest.mark.slow
def test_black_box_certificates_by_hand():
    """Package, keep 7/10, g in [1, 3]: the worst model waits 3 only on 'low | high', 99/59; HR: epsilon (attained)."""
    recs = _records(PKG, "low-complaint-first", 4)
    a = analyse(PKG, recs, model="m", samples=4, epsilons=[epsilon_from_keep(PKG, 0.7)], confidence=None)
    assert a.points[0].black_box_local == pytest.approx(math.log(Fraction(99, 59)), abs=1e-9)
    assert a.tau == 1.0
    eps = epsilon_from_keep(HR, 0.7)
    h = analyse(HR, _records(HR, "prefers-mary", 1), model="m", samples=1, epsilons=[eps], confidence=None)
    assert h.points[0].black_box_local == pytest.approx(eps, abs=1e-9)
    assert h.points[0].corollary == pytest.approx(eps, abs=1e-12)
    fixed = analyse(
        HR, _records(HR, "prefers-mary", 1), model="m", samples=1, epsilons=[eps], confidence=None, positions="fixed"
    )
    assert fixed.points[0].black_box_global == math.inf  # a model that picks by position: L-bar unbounded


def _records(task, name, n, seed=0):
    m = simulated_model(task, name)
    recs = []
    for q in plan_queries(task, "table", n, seed):
        d = parse_reply(m.reply(q).text, task.options, task.kind)
        recs.append(
            {
                "design": "table",
                "status": "ok",
                "context": q.context,
                "profiles": [list(x) for x in q.profiles],
                "decision": task.options[d.choice] if d.ok else UNPARSED,
            }
        )
    return recs


@pytest.mark.slow
def test_intervals_cover_the_exact_law_and_positions_change_only_l_bar():
    """400 queries per cell: the 95% band covers the exact L; fixed positions leave L alone and void L-bar's bound."""
    p = 0.8
    eps = epsilon_from_keep(PKG, p)
    want = math.log((1 + 2 * p) / (3 - 2 * p))
    recs = _records(PKG, "low-complaint-first", 400)
    bal = analyse(PKG, recs, model="m", samples=400, epsilons=[eps])
    iv = bal.points[0].intervals
    assert (
        iv.local_fairness.lower <= want <= iv.local_fairness.upper
        and iv.local_fairness.upper - iv.local_fairness.lower < 0.4
    )
    assert bal.points[0].black_box_global < math.inf
    fixed = analyse(PKG, recs, model="m", samples=400, epsilons=[eps], positions="fixed", confidence=None)
    assert fixed.points[0].local_fairness.value == pytest.approx(bal.points[0].local_fairness.value, abs=1e-12)
    # the position reveals the group: the worst model serves by position, L-bar reaches log(gamma / lower)
    assert fixed.points[0].black_box_global == pytest.approx(math.log(3), abs=1e-9)


def test_position_bias_is_not_group_bias_when_balanced():
    """A first-listed bias (0.82) is unfair by position only: balanced L-bar is 0, the paper's fixed order is not."""
    m = simulated_model(PKG, "position-biased")
    kc = _exact_kernel(PKG, m)
    law = compose(kc, candidate_family(PKG)(5.0), candidate_context_mechanism(PKG))
    g = candidate_utility(PKG)
    assert global_fairness(law, g, candidate_population(PKG, "balanced")).value == pytest.approx(0.0, abs=1e-12)
    w1, w2 = 0.82 * 1 + 0.18 * 3, 0.18 * 1 + 0.82 * 3  # waiting time at position 1 and 2
    fixed = global_fairness(law, g, candidate_population(PKG, "fixed")).value
    assert fixed == pytest.approx(math.log(w2 / w1), abs=1e-12)


def test_paper_design_counts_follow_the_truth(tmp_path):
    m = simulated_model(PKG, "low-complaint-first")
    eps = epsilon_from_keep(PKG, 0.9)
    qs = plan_queries(PKG, "paper", 50, 3, epsilons=[eps])
    _, log = _run(tmp_path, PKG, m, qs)
    recs = list(log.records.values())
    cells = Counter((r["truth"]["context"], tuple(map(tuple, r["truth"]["profiles"]))) for r in recs)
    assert len(recs) == 300 and len(cells) == 6 and set(cells.values()) == {50}  # 3 packages x 2 orders x 50
    # the low-complaint recipient is served first about p = 0.9 of the time in both orders
    served = [r["truth"]["profiles"][PKG.options.index(r["decision"])] for r in recs if r["decision"] != UNPARSED]
    low_first = served.count(["low"]) / 300
    assert abs(low_first - 0.9) < 5 * math.sqrt(0.09 / 300)


def test_analysis_refuses_an_incomplete_table():
    recs = _records(PKG, "fair", 1)[:-1]
    with pytest.raises(
        InputError,
        match=r"table design: shown cell \(package 'medicine', Recipient1 'high', "
        r"Recipient2 'high'\) has no answered query",
    ):
        analyse(PKG, recs, model="m", samples=1, epsilons=[1.0])


def test_position_split_by_hand_with_three_contexts():
    """Package delivery, g = 1 first, 3 second, 2 unparsed; shares per context in the paper's order and swapped.

    Contexts 0 and 1: low first is served first 0.9, high first 0.6, so m(low, 1) = 0.9 + 0.1 * 3 = 1.2,
    m(high, 2) = 0.1 + 0.9 * 3 = 2.8, m(high, 1) = 0.6 + 0.4 * 3 = 1.8, m(low, 2) = 0.4 + 0.6 * 3 = 2.2.
    Context 2: 0.5 first, 0.3 second, 0.2 unparsed in both orders: m(., 1) = 0.5 + 0.9 + 0.4 = 1.8 and
    m(., 2) = 0.3 + 1.5 + 0.4 = 2.2 for both candidates (pure position).
    """
    from fairaudit.experiments.slots import expected_utility, position_split
    from fairaudit.experiments.taskfile import PACKAGE_DELIVERY

    mixed = [[0.9, 0.1, 0.0], [0.6, 0.4, 0.0]]
    pure = [[0.5, 0.3, 0.2], [0.5, 0.3, 0.2]]
    probs = np.full((3, 4, 3), 1 / 3)  # shown cells (low, low), (low, high), (high, low), (high, high)
    probs[:, 1], probs[:, 2] = np.array([mixed, mixed, pure]).transpose(1, 0, 2)
    m = expected_utility(PACKAGE_DELIVERY, probs, np.asarray(PACKAGE_DELIVERY.utility_values))
    s = position_split(PACKAGE_DELIVERY, m)
    ln = math.log
    expected = {
        "raw": ln(1.2 / 2.8),
        "group": 0.5 * (ln(1.2 / 1.8) + ln(2.2 / 2.8)),
        "position": 0.5 * (ln(1.2 / 2.2) + ln(1.8 / 2.8)),
    }
    for name, value in expected.items():
        np.testing.assert_allclose(getattr(s, name)[:2], value, rtol=0, atol=1e-12)
    np.testing.assert_allclose([s.raw[2], s.position[2], s.group[2]], [ln(1.8 / 2.2), ln(1.8 / 2.2), 0], atol=1e-12)
    # overall: m averaged over the three contexts first
    m11, m22, m21, m12 = (2 * 1.2 + 1.8) / 3, (2 * 2.8 + 2.2) / 3, (2 * 1.8 + 1.8) / 3, (2 * 2.2 + 2.2) / 3
    assert s.overall_raw == pytest.approx(ln(m11 / m22), abs=1e-12)
    assert s.overall_group == pytest.approx(0.5 * (ln(m11 / m21) + ln(m12 / m22)), abs=1e-12)
    assert s.overall_position == pytest.approx(0.5 * (ln(m11 / m12) + ln(m21 / m22)), abs=1e-12)
    position, group = s.explained()
    assert position + group == pytest.approx(1.0, abs=1e-12) and position == pytest.approx(
        s.overall_position / s.overall_raw
    )
    np.testing.assert_allclose(s.expected_utility[0], [[1.2, 2.2], [1.8, 2.8]], atol=1e-12)  # [candidate, position]


# -- run_experiment: source and options ---------------------------------------------------------------------


@pytest.mark.slow
def test_run_experiment_takes_a_source_and_options(tmp_path):
    from fairaudit.experiments.run import ModelSource, RunOptions, run_experiment

    source, options = ModelSource(simulated="position-biased"), RunOptions(samples=2, keeps=[0.7], images=False)
    done = run_experiment("package-delivery", tmp_path / "run", source, options, progress=False)
    assert done.analysis is not None
    assert (done.summary.planned, done.analysis.model) == (24, "position-biased")


@pytest.mark.parametrize(
    "make, message",
    [
        (lambda: ModelSource(simulated="fair", endpoint="http://x/v1"), "^endpoint: give only one of"),
        (lambda: ModelSource(endpoint="http://x/v1"), "^model: is needed with `endpoint`"),
        (lambda: ModelSource(model="gpt"), "^model: goes with `endpoint`"),
        (lambda: RunOptions(design="kernel"), "^design: must be one of table, both, paper"),
        (lambda: RunOptions(epsilons=[1.0], keeps=[0.7]), "^keeps: give `epsilons` or `keeps`, not both"),
        (lambda: RunOptions(epsilons=[-1.0]), r"^epsilons: must be finite and >= 0 \(nats\)"),
        (lambda: RunOptions(targets=[math.inf]), "^targets: "),
        (lambda: RunOptions(samples=0), "^samples: must be a whole number >= 1"),
        (lambda: RunOptions(concurrency=0), "^concurrency: "),
    ],
)
def test_sources_and_options_name_the_bad_field(make, message):
    with pytest.raises(InputError, match=message):
        make()
