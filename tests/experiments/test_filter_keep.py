"""A keep probability is applied per attribute (issue 38, defect 1).

A keep probability p on an attribute with k values is k-ary randomized
response at ε = ln(p (k − 1) / (1 − p)), whatever the other attributes' sizes;
a total ε is split by one shared keep probability (proofs/privacy.md,
Proposition 6). Expected values are hand formulas and exact fractions.
"""

from __future__ import annotations

import json
import math
from fractions import Fraction

import numpy as np
import pytest
from _cli import run

from fairaudit import InputError
from fairaudit.experiments.options import ModelSource, RunOptions
from fairaudit.experiments.run import run_experiment
from fairaudit.experiments.slots import epsilon_factor, epsilon_from_keep
from fairaudit.experiments.taskfile import parse_task
from fairaudit.experiments.vlm.filter import SPLIT_RULE, TaskFilter, candidate_family

LOAN = """
title = "Loan"
[task]
candidates = 1
decision = "choose"
[prompt]
system = "You review loan applications. Answer with one word: yes or no."
user = '''Applicant aged {{ c1.age }}, {{ c1.gender }}, {{ c1.race }}. Loan: {{ context }}. Approve? yes or no.'''
[context]
name = "loan"
values = ["10,000 dollars", "50,000 dollars"]
[[attribute]]
name = "age"
values = ["25-34", "45-54", "55-64"]
[[attribute]]
name = "gender"
values = ["female", "male"]
[[attribute]]
name = "race"
values = ["Asian", "Black", "white"]
[decision]
options = { yes = "approved", no = "denied" }
[utility]
values = { approved = 1.0, denied = 0.0 }
[filter]
keep = [0.6]
"""

SIZES = {"age": 3, "gender": 2, "race": 3}


def _rr(keep: Fraction, k: int) -> np.ndarray:
    """k-ary randomized response keeping with ``keep``, in exact fractions (as floats)."""
    off = (1 - keep) / (k - 1)
    return np.array([[float(keep if i == j else off) for j in range(k)] for i in range(k)])


def test_keep_06_gives_each_attribute_its_own_epsilon():
    task = parse_task(LOAN)
    want = {a: math.log(0.6 * (k - 1) / 0.4) for a, k in SIZES.items()}  # ln 3, ln 1.5, ln 3
    eps = epsilon_from_keep(task, 0.6)
    assert eps == pytest.approx(sum(want.values()), rel=1e-15)
    f = TaskFilter.from_epsilon(task, eps)
    assert f.epsilon_attributes == pytest.approx(tuple(want.values()), rel=1e-13)
    assert f.epsilon_attributes[1] == pytest.approx(math.log(0.6 / 0.4), rel=1e-13)  # gender 0.405, not 0.868
    for m, k in zip(f.attribute_mechanisms, SIZES.values()):
        np.testing.assert_allclose(m.matrix, _rr(Fraction(3, 5), k), rtol=0, atol=1e-14)
    assert f.keep_probabilities == pytest.approx((0.6, 0.6, 0.6), abs=1e-14)
    # the candidate family on the curve carries the same filter at that ε
    assert candidate_family(task)(eps).epsilon == pytest.approx(eps, rel=1e-13)
    assert candidate_family(task).keep_probability(eps) == pytest.approx(0.6**3, rel=1e-13)


def test_a_pair_differing_in_one_attribute_has_no_constant_factor_and_still_keeps_p():
    # two candidates that differ only in the name (2 values), not the department (3): a candidate's ε is
    # 2 ε_name, so with the shared-keep split ε_P is no constant multiple of it (root finding)
    text = LOAN.replace(
        "candidates = 1",
        'candidates = 2\npopulation = [[["25-34", "female", "Asian"], '
        '["25-34", "male", "Asian"]]]\npositions = "fixed"',
    )
    text = text.replace('options = { yes = "approved", no = "denied" }', "options = { A = 1, B = 2 }")
    text = text.replace("values = { approved = 1.0, denied = 0.0 }", 'values = { chosen = 1.0, "not chosen" = 0.0 }')
    text = text.replace("{{ c1.age }}, {{ c1.gender }}, {{ c1.race }}", "A: {{ c1 }}; B: {{ c2 }}")
    task = parse_task(text)
    assert epsilon_factor(task, "fixed") is None
    eps = epsilon_from_keep(task, 0.7, "fixed")
    assert eps == pytest.approx(2 * math.log(7 / 3), rel=1e-13)  # own and rival name, by hand
    member = candidate_family(task, "fixed")(eps)
    assert member.epsilon == pytest.approx(eps, rel=1e-9)


@pytest.mark.slow
def test_the_report_lists_p_k_and_epsilon_per_attribute_and_the_asked_filter(tmp_path):
    spec = tmp_path / "loan.toml"
    spec.write_text(LOAN)
    done = run_experiment(
        spec, tmp_path / "run", ModelSource(simulated="fair"), RunOptions(samples=1, targets=[]), progress=False
    )
    cert = json.loads((done.out / "certificate.json").read_text())
    assert cert["run"]["filter"] == {"keep": [0.6], "split": SPLIT_RULE}
    (point,) = cert["points"]
    rows = {a["name"]: a for a in point["privacy"]["attributes"]}
    for name, k in SIZES.items():
        assert rows[name]["values"] == k
        assert rows[name]["keep_probability"] == pytest.approx(0.6, abs=1e-13)
        assert rows[name]["epsilon"] == pytest.approx(math.log(0.6 * (k - 1) / 0.4), rel=1e-13)
    assert point["privacy"]["epsilon_profile"] == pytest.approx(2 * math.log(3) + math.log(1.5), rel=1e-13)
    assert point["privacy"]["split"] == SPLIT_RULE
    md = (done.out / "report.md").read_text()
    assert "Asked: keep p = 0.6 on every attribute." in md
    assert "| gender | 2 | 0.6 | 0.405465 |" in md and "| age | 3 | 0.6 | 1.09861 |" in md


@pytest.mark.slow
def test_a_total_epsilon_is_split_by_the_stated_rule(tmp_path):
    spec = tmp_path / "loan.toml"
    spec.write_text(LOAN)
    total = math.log(4) + math.log(2) + math.log(4)  # keep 2/3 on each: e^ε_i = (2/3)(k − 1)/(1/3)
    done = run_experiment(
        spec,
        tmp_path / "run",
        ModelSource(simulated="fair"),
        RunOptions(samples=1, epsilons=[total], targets=[]),
        progress=False,
    )
    cert = json.loads((done.out / "certificate.json").read_text())
    assert cert["run"]["filter"]["epsilon"] == [pytest.approx(total)]
    rows = cert["points"][0]["privacy"]["attributes"]
    assert [r["keep_probability"] for r in rows] == pytest.approx([2 / 3] * 3, abs=1e-13)
    assert [r["epsilon"] for r in rows] == pytest.approx([math.log(4), math.log(2), math.log(4)], rel=1e-13)
    assert "Split rule: one keep probability p on every attribute" in (done.out / "report.md").read_text()


def test_a_keep_below_one_over_k_names_the_task_files_field_or_the_flag(tmp_path, capsys):
    with pytest.raises(InputError) as e:
        parse_task(LOAN.replace("keep = [0.6]", "keep = [0.6, 0.4]"))
    assert e.value.field.endswith("filter.keep[1]") and "'gender'" in str(e.value) and "0.5" in str(e.value)
    spec = tmp_path / "loan.toml"
    spec.write_text(LOAN.replace("keep = [0.6]", "keep = [0.4]"))
    code, _, err = run(capsys, "experiment", spec, "--simulated", "fair", "--out", tmp_path / "r")
    assert code == 2 and "filter.keep[0]" in err and "--keep" not in err
    spec.write_text(LOAN)
    code, _, err = run(capsys, "experiment", spec, "--simulated", "fair", "--keep", "0.4", "--out", tmp_path / "r")
    assert code == 2 and err.startswith("fairaudit: error: --keep:") and "'gender' has k = 2" in err
    assert not (tmp_path / "r").exists()
