"""The default g of an unparsed reply is the expected g of a uniformly random reply, and the reports say so (issue 38).

The expected values come from enumerating the uniformly random replies in exact fractions: each slot of a choice,
each complete order of a ranking, each listed option of a decision about one person; never from the code's formula.
"""

from __future__ import annotations

import itertools
import json
from fractions import Fraction
from pathlib import Path

import pytest
from _cli import run

from fairaudit.experiments.taskfile import parse_task
from fairaudit.experiments.vlm.tasks import UNPARSED_DEFAULT

ROOT = Path(__file__).resolve().parents[2]

HEAD = """
[task]
candidates = {k}
decision = "{decision}"
[prompt]
user = "Pick from {{{{ candidates }}}}. Answer with the number."
[[attribute]]
name = "group"
values = ["A", "B"]
"""


def _task(k, decision, utility, *, partial=False):
    options = ", ".join(f'"{i}" = {i}' for i in range(1, k + 1))
    text = HEAD.format(k=k, decision=decision) + f"[decision]\noptions = {{ {options} }}\n"
    text += "partial = true\n" if partial else ""
    return parse_task(text + f"[utility]\n{utility}\n")


def _by_enumeration(replies, g_of_reply):
    """E[g] under the uniform law on ``replies``, in exact fractions."""
    return sum((Fraction(g_of_reply(r)) for r in replies), Fraction(0)) / len(replies)


@pytest.mark.parametrize("k", [2, 3, 5])
@pytest.mark.parametrize(("chosen", "other"), [(1.0, 0.0), (0.1, 0.7), (2.5, 1.0)])
def test_choice_of_k_counts_each_slot_with_probability_one_over_k(k, chosen, other):
    task = _task(k, "choose", f'values = {{ chosen = {chosen}, "not chosen" = {other} }}')
    for slot in range(k):  # the same for every slot: a uniformly random reply chooses `slot` 1 time in k
        expected = _by_enumeration(range(k), lambda u, slot=slot: chosen if u == slot else other)
        assert task.utility_values[-1] == float(expected)
    assert task.unparsed_source == UNPARSED_DEFAULT


def test_choose_one_of_three_is_one_third_not_one_half():
    task = _task(3, "choose", 'values = { chosen = 1, "not chosen" = 0 }')
    assert task.utility_values == (1.0, 0.0, float(Fraction(1, 3)))
    assert task.utility_values[-1] != 0.5  # the mean of the utility's values, the old default
    assert task.unparsed_rule == (
        "a uniformly random reply chooses each of the 3 candidates with probability 1/3: "
        "g = 1/3 g(chosen) + 2/3 g(not chosen)"
    )


@pytest.mark.parametrize(("k", "values"), [(2, [1.0, 3.0]), (3, [3.0, 1.0, 0.0]), (4, [0.3, 0.1, 0.7, 0.0])])
def test_ranking_gives_each_rank_with_probability_one_over_k(k, values):
    task = _task(k, "rank", f"values = {values}")
    orders = list(itertools.permutations(range(k)))  # every complete order, equally likely
    expected = _by_enumeration(orders, lambda order: values[order.index(0)])  # the rank of slot 1
    assert task.utility_values[-1] == float(expected)


def test_partial_ranking_default_is_over_complete_orders_never_unranked():
    # rank 1, rank 2, rank 3, unranked: a uniformly random reply orders all three, so "unranked" has probability 0
    values = [1.0, 0.0, 0.0, 5.0]
    task = _task(3, "rank", f"values = {values}", partial=True)
    assert task.outcomes == ("rank 1", "rank 2", "rank 3", "unranked", "unparsed")
    orders = list(itertools.permutations(range(3)))
    expected = _by_enumeration(orders, lambda order: values[order.index(1)])
    assert expected == Fraction(1, 3)
    assert task.utility_values[-1] == float(expected) != sum(values) / len(values)
    assert "never unranked" in task.unparsed_rule


def test_rank_values_rank_is_the_mean_rank():
    task = _task(4, "rank", 'values = "rank"')
    assert task.utility_values[-1] == float(_by_enumeration(list(itertools.permutations(range(4))),
                                                             lambda o: o.index(0) + 1)) == 2.5  # fmt: skip


def test_one_person_counts_each_listed_option_once():
    text = (
        HEAD.format(k=1, decision="choose")
        + '[decision]\noptions = { yes = "approved", sure = "approved", no = "denied" }\n'
        + "[utility]\nvalues = { approved = 1.0, denied = 0.0 }\n"
    )
    task = parse_task(text)
    g = {"yes": 1.0, "sure": 1.0, "no": 0.0}  # the outcome of each option, read off the file
    expected = _by_enumeration(list(g), g.get)
    assert expected == Fraction(2, 3)
    assert task.utility_values[-1] == float(expected)  # "approved", listed by two options, counts twice


def test_a_given_unparsed_value_is_kept_and_called_given():
    task = _task(3, "choose", 'values = { chosen = 1, "not chosen" = 0 }\nunparsed = 0.25')
    assert task.utility_values[-1] == 0.25 and task.unparsed_source == "given"
    assert task.unparsed_rule == "given ([utility] unparsed)"


CHOOSE_3 = (
    HEAD.format(k=3, decision="choose")
    + """
[decision]
options = { "1" = 1, "2" = 2, "3" = 3 }
[utility]
values = { chosen = 1.0, "not chosen" = 0.0 }
[filter]
keep = [0.8]
"""
)


@pytest.mark.slow
@pytest.mark.parametrize(
    ("extra", "value", "source"), [("", 1 / 3, UNPARSED_DEFAULT), ("unparsed = 0.25\n", 0.25, "given")]
)
def test_the_certificate_and_the_report_say_the_value_used_and_where_it_came_from(
    tmp_path, capsys, extra, value, source
):
    path = tmp_path / "choose3.toml"
    path.write_text(CHOOSE_3.replace('"not chosen" = 0.0 }\n', '"not chosen" = 0.0 }\n' + extra))
    out = tmp_path / "run"
    code, _, err = run(capsys, "experiment", path, "--samples", 1, "--no-images", "--no-progress", "--out", out)
    assert code == 0, err
    d = json.loads((out / "certificate.json").read_text())["utility"]
    assert d["unparsed"]["value"] == pytest.approx(value, abs=1e-15) and d["unparsed"]["source"] == source
    assert d["values"]["unparsed"] == d["unparsed"]["value"]
    md = (out / "report.md").read_text()
    if extra:
        assert "An unparsed reply counts g = 0.25 (given: `[utility] unparsed`)." in md
    else:
        assert d["unparsed"]["rule"].startswith("a uniformly random reply chooses each of the 3 candidates")
        assert f"An unparsed reply counts g = 0.3333 ({UNPARSED_DEFAULT}: {d['unparsed']['rule']})." in md
