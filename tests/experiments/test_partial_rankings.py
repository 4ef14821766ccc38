"""Partial rankings (`[decision] partial = true`): a reply that ranks some candidates ranks those, the others are
"unranked" (the Bloomberg study's rule), with hand values end to end."""

from __future__ import annotations

import itertools
import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from _cli import run

from fairaudit.base.errors import InputError
from fairaudit.experiments.analysis import analyse_kernel
from fairaudit.experiments.harness import decision_label
from fairaudit.experiments.slots import outcome_index
from fairaudit.experiments.taskfile import parse_task
from fairaudit.experiments.vlm.models import reply_text
from fairaudit.experiments.vlm.parse import parse_reply
from fairaudit.laws.tables import Kernel

RANKING = (Path(__file__).resolve().parents[2] / "examples" / "tasks" / "ranking.toml").read_text()
UTILITY = '[utility]\nvalues = "rank"\n'
PARTIAL = RANKING.replace(UTILITY, "[utility]\nvalues = [4, 2, 1, 0.5]   # rank 1, 2, 3, unranked\n").replace(
    '"3" = 3 }\n', '"3" = 3 }\npartial = true\n'
)


@pytest.fixture(scope="module")
def task():
    return parse_task(PARTIAL, "partial.toml", "partial")


def test_the_decisions_are_the_complete_orders_then_the_partial_ones(task):
    assert UTILITY in RANKING and task.partial
    assert task.outcomes == ("rank 1", "rank 2", "rank 3", "unranked", "unparsed")
    assert task.utility_values[:4] == (4.0, 2.0, 1.0, 0.5)
    assert len(task.decisions) == 6 + 6 + 3 + 1  # 3! complete, 3·2 of two, 3 of one, unparsed
    assert task.decisions[:6] == ("1 > 2 > 3", "1 > 3 > 2", "2 > 1 > 3", "2 > 3 > 1", "3 > 1 > 2", "3 > 2 > 1")
    assert task.decisions[6:] == ("1 > 2", "1 > 3", "2 > 1", "2 > 3", "3 > 1", "3 > 2", "1", "2", "3", "unparsed")
    # o_i(u): the rank of slot i (0 = first), 3 = unranked, 4 = unparsed; by hand
    o = outcome_index(task)
    assert o[:, task.decisions.index("3 > 1")].tolist() == [1, 3, 0]
    assert o[:, task.decisions.index("2")].tolist() == [3, 0, 3]
    assert o[:, task.decisions.index("2 > 3 > 1")].tolist() == [2, 0, 1]
    assert o[:, -1].tolist() == [4, 4, 4]
    # each decision's label is the label of the order read from its reply
    for d, label in enumerate(task.decisions[:-1]):
        parsed = parse_reply(reply_text(task, d), task.options, "order", partial=True)
        assert decision_label(task, parsed.choice, parsed.order) == label


def test_without_partial_a_reply_that_leaves_one_out_is_unparsed(task):
    complete = parse_task(RANKING, "ranking.toml", "ranking")
    assert not complete.partial and len(complete.decisions) == 7 and complete.partial_orders == ()
    assert not parse_reply("2, 3", complete.options, "order").ok
    assert decision_label(complete, 1, (1, 2)) == "unparsed"
    assert decision_label(task, 1, (1, 2)) == "2 > 3"


@pytest.mark.parametrize(
    ("reply", "order"),
    [
        ("1. Paul Wu\n2. Cara Kramer", (2, 0)),
        ("Cara Kramer is the strongest candidate.", (0,)),
        ("PAUL WU, JO LI, CARA KRAMER", (2, 1, 0)),
        ("Paul Wu, then Paul Wu again, then Jo Li", (2, 1)),
    ],
)
def test_names_found_rank_in_order_of_first_mention(reply, order):
    names = ("CARA KRAMER", "JO LI", "PAUL WU")
    r = parse_reply(reply, names, "order", named=True, partial=True)
    assert r.ok and r.order == order and r.choice == order[0]
    assert r.values == {names[i]: float(order.index(i) + 1) for i in sorted(order)}
    full = parse_reply(reply, names, "order", named=True)
    assert full.ok == (len(order) == 3)


@pytest.mark.parametrize(
    ("reply", "order"),
    [("2, 3", (1, 2)), ("3", (2,)), ("3 > 1", (2, 0)), ("1, 2, 3", (0, 1, 2)), ("2, 2", None), ("I cannot", None)],
)
def test_a_listed_partial_order(reply, order):
    r = parse_reply(reply, ("1", "2", "3"), "order", partial=True)
    assert r.order == order and r.ok == (order is not None)


def test_a_json_reply_still_needs_every_option():
    r = parse_reply('{"1": 1, "2": 2}', ("1", "2", "3"), "order", partial=True)
    assert not r.ok


@pytest.mark.parametrize(
    ("edit", "field"),
    [
        (lambda t: t.replace('decision = "rank"', 'decision = "choose"'), "decision.partial"),
        (lambda t: t.replace("candidates = 3", "candidates = 2"), "decision.partial"),
        (lambda t: t.replace("values = [4, 2, 1, 0.5]", 'values = "rank"'), "utility.values"),
        (lambda t: t.replace("values = [4, 2, 1, 0.5]", "values = [4, 2, 1]"), "utility.values"),
    ],
)
def test_refusals_name_the_field(edit, field):
    with pytest.raises(InputError) as e:
        parse_task(edit(PARTIAL), "partial.toml", "partial")
    assert field in str(e.value)


def _half_partial(task):
    """Ranks the candidate shown as Emily Walsh first; then, half the time, the two others in either order, half the
    time no one else. Cells without exactly one Emily: every complete order alike."""
    n = len(task.profiles)
    p = np.zeros((len(task.contexts), *([n] * 3), len(task.decisions)))
    for cell in itertools.product(range(n), repeat=3):
        emily = [s for s in range(3) if cell[s] == 0]
        if len(emily) != 1:
            p[(slice(None), *cell, slice(0, 6))] = 1 / 6
            continue
        s = emily[0]
        for order in task.orders:
            if order[0] == s:
                p[(slice(None), *cell, task.orders.index(order))] = 0.25
        p[(slice(None), *cell, task.decisions.index(task.options[s]))] = 0.5
    return p


@pytest.mark.slow
def test_the_law_of_a_model_that_often_names_one_by_hand(task):
    """Emily: rank 1 always, g = 4. The others: half the time rank 2 or 3 (g 2 or 1, 1.5 on average), half the time
    unranked (g 0.5): E[g] = 1. L = ln(4 / 1) = ln 4, in each role."""
    p = _half_partial(task)
    kernel = Kernel(p.reshape(len(task.contexts), 27, -1), task.contexts, list(range(27)), task.decisions)
    a = analyse_kernel(task, kernel, model="m", epsilons=[1.0], confidence=None)
    assert a.baseline.local_fairness.value == pytest.approx(math.log(4), abs=1e-12)
    np.testing.assert_allclose(a.split.expected_utility[:, 0], 4.0, atol=1e-12)
    np.testing.assert_allclose(a.split.expected_utility[:, 1:], 1.0, atol=1e-12)


@pytest.mark.slow
def test_partial_rankings_end_to_end_on_the_sampled_route(task, tmp_path, capsys):
    """The same model as a kernel CSV: its replies name one candidate half the time, and each is read as a partial
    ranking (none unparsed); the baseline's interval covers ln 4."""
    path = tmp_path / "partial.toml"
    path.write_text(PARTIAL)
    p = _half_partial(task)
    rows = [
        {"role": x, **{o: task.profile_label(task.profiles[c]) for o, c in zip(task.options, cell)}, "decision": d,
         "probability": p[(i, *cell, j)]}
        for i, x in enumerate(task.contexts)
        for cell in itertools.product(range(3), repeat=3)
        for j, d in enumerate(task.decisions)
    ]  # fmt: skip
    pd.DataFrame(rows).to_csv(tmp_path / "kernel.csv", index=False)
    out = tmp_path / "run"
    code, _, err = run(
        capsys, "experiment", path, "--kernel", tmp_path / "kernel.csv", "--samples", "40", "--keep", "0.8",
        "--out", out, "--no-progress",
    )  # fmt: skip
    assert code == 0, err
    cert = json.loads((out / "certificate.json").read_text())
    assert cert["queries"]["unparsed"] == 0
    records = pd.read_csv(out / "records.csv")
    shares = records.outcome.value_counts(normalize=True)
    assert set(shares.index) == {"rank 1", "rank 2", "rank 3", "unranked"}
    low, high = cert["baseline"]["local"]["interval"]
    assert low <= math.log(4) <= high
    kernel = pd.read_csv(out / "kernel.csv")
    assert set(kernel.decision) == set(task.decisions)


@pytest.mark.parametrize(
    "flag", [["--local-model", "smollm2"], ["--sampled-twin", "--endpoint", "http://127.0.0.1:9/v1", "--model", "m"]]
)
def test_the_exact_routes_refuse_partial_rankings_in_one_line(tmp_path, capsys, flag):
    path = tmp_path / "partial.toml"
    path.write_text(PARTIAL)
    code, out, err = run(capsys, "experiment", path, *flag, "--out", tmp_path / "r", "--no-progress")
    assert code == 2 and out == "" and len(err.strip().splitlines()) == 1
    assert "partial rankings" in err and not (tmp_path / "r").exists()
