"""discrim-eval's rows, lm-eval's score and the law, against hand calculations and a known linear model."""

from __future__ import annotations

import itertools
import json
import math
import warnings

import numpy as np
import pandas as pd
import pytest

import fairaudit as fa
from fairaudit import InputError
from fairaudit.experiments.discrim_eval import (
    DiscrimEvalRows,
    decision_law,
    lm_eval_score,
    mixed_effects,
    read_rows,
    score_means,
)

SAMPLE = "examples/discrim_eval/sample.jsonl"


def test_the_sample_reads_as_two_scenarios_of_eight_fills():
    rows = read_rows(SAMPLE)
    assert len(rows.prompts) == 16 and rows.scenarios.count("0") == 8 and rows.scenarios.count("1") == 8
    assert list(rows.attributes.columns) == ["age", "gender", "race"]
    assert len(set(rows.groups)) == 8 and rows.groups[1] == "20 & female & white"
    assert rows.prompts[0].startswith("The applicant is a 20-year-old black female")


def test_other_keys_are_mapped(tmp_path):
    path = tmp_path / "mine.jsonl"
    lines = [{"text": "Hire?", "job": "j1", "sex": "F"}, {"text": "Hire?", "job": "j1", "sex": "M"}]
    path.write_text("\n".join(json.dumps(r) for r in lines) + "\n\n", encoding="utf-8")
    rows = read_rows(path, {"prompt": "text", "scenario": "job", "attributes": "sex"})
    assert rows.groups == ("F", "M") and rows.scenarios == ("j1", "j1") and rows.prompts == ("Hire?", "Hire?")


@pytest.mark.parametrize(
    ("content", "message"),
    [
        ('{"filled_template": "q", "decision_question_id": 1, "age": 20, "gender": "f"}\n', "line 1 has no key 'race'"),
        ("[1, 2]\n", "line 1 is not a JSON object"),
        ('\n{"a": \n', "line 2 is not JSON"),
        ("\n\n", "has no rows"),
        (
            '{"filled_template": 3, "decision_question_id": 1, "age": 20, "gender": "f", "race": "w"}\n',
            "line 1: 'filled_template' must be text",
        ),
    ],
)
def test_bad_files_get_one_line_naming_the_line(tmp_path, content, message):
    path = tmp_path / "bad.jsonl"
    path.write_text(content, encoding="utf-8")
    with pytest.raises(InputError, match=f"^path: {message}"):
        read_rows(path)


def test_a_missing_file_is_named(tmp_path):
    with pytest.raises(InputError, match="^path: cannot be read"):
        read_rows(tmp_path / "nowhere.jsonl")


def test_lm_evals_score_by_hand():
    # row 1: yes 0.3 + Yes 0.3 against no 0.2 + No 0.1: ln(0.6 / 0.3) = ln 2; row 2: 0.05 + 0.15 vs 0.5 + 0.3
    logp = {
        "yes": np.log([0.3, 0.05]),
        "Yes": np.log([0.3, 0.15]),
        "no": np.log([0.2, 0.5]),
        "No": np.log([0.1, 0.3]),
    }
    assert lm_eval_score(logp) == pytest.approx([math.log(2), math.log(0.2 / 0.8)], rel=1e-12)
    with pytest.raises(InputError, match="^logprobs: needs the log-probability of 'No'"):
        lm_eval_score({k: v for k, v in logp.items() if k != "No"})


def test_means_per_attribute_value_and_group():
    rows = read_rows(SAMPLE)
    scores = np.where(rows.attributes["race"] == "black", -1.0, 1.0) + (rows.attributes["age"] == 60) * 0.5
    means = score_means(rows, scores)
    assert means["race"].to_dict() == {"black": pytest.approx(-0.75), "white": pytest.approx(1.25)}
    assert means["age"].to_dict() == {20: pytest.approx(0.0), 60: pytest.approx(0.5)}
    assert means["group"]["60 & male & white"] == pytest.approx(1.5)
    with pytest.raises(InputError, match="^scores:"):
        score_means(rows, scores[:3])


def test_the_law_and_its_fairness_by_hand():
    # scenario 0: white fills say yes with 0.6, black ones 0.3, no 0.3 each; scenario 1: yes 0.5, no 0.5 for all.
    # L = ln(0.6 / 0.3) = ln 2 in scenario 0; with the unparsed mass (0.1, 0.4) anywhere in [0, 1] the upper end
    # is ln(0.7 / 0.3)
    rows = read_rows(SAMPLE)
    first = np.array([s == "0" for s in rows.scenarios])
    white = (rows.attributes["race"] == "white").to_numpy()
    yes = np.where(first, np.where(white, 0.6, 0.3), 0.5)
    no = np.where(first, 0.3, 0.5)
    law = decision_law(rows, yes, no)
    g = fa.indicator("yes", law.decisions)
    local = fa.local_fairness(law, g)
    assert local.value == pytest.approx(math.log(2), rel=1e-12) and local.context == "0"
    assert "white" in str(local.group) and "black" in str(local.other_group)
    assert law.probabilities[0, 0].tolist() == pytest.approx([0.3, 0.3, 0.4])
    span = fa.fairness_range(law, g)
    assert span.local_fairness.upper == pytest.approx(math.log(0.7 / 0.3), rel=1e-9)


def test_the_law_refuses_masses_that_are_not_probabilities():
    rows = read_rows(SAMPLE)
    with pytest.raises(InputError, match="^yes: plus no must not exceed 1"):
        decision_law(rows, [0.7] * 16, [0.4] * 16)
    with pytest.raises(InputError, match="^no: must be probabilities"):
        decision_law(rows, [0.5] * 16, [-0.1] * 16)
    with pytest.raises(InputError, match="^yes: must have one probability per row"):
        decision_law(rows, [0.5] * 3, [0.1] * 3)


def test_mixed_effects_recover_a_known_linear_model():
    pytest.importorskip("statsmodels")
    # 12 scenarios x 2 ages x 2 genders x 3 races; score = 0.5 [black] + 0.2 [asian] - 0.3 [female] + 0.1 age_c
    # + a scenario offset + small noise: the fixed effects come back within 0.02
    rng = np.random.default_rng(82)
    fills = list(itertools.product(range(12), (20, 60), ("female", "male"), ("white", "black", "asian")))
    attributes = pd.DataFrame([f[1:] for f in fills], columns=["age", "gender", "race"])
    rows = DiscrimEvalRows(tuple("q" for _ in fills), tuple(str(f[0]) for f in fills), attributes, "made up")
    age_c = (attributes["age"] - attributes["age"].mean()) / attributes["age"].std()
    offset = rng.normal(0, 0.5, 12)[[f[0] for f in fills]]
    score = (
        0.5 * (attributes["race"] == "black")
        + 0.2 * (attributes["race"] == "asian")
        - 0.3 * (attributes["gender"] == "female")
        + 0.1 * age_c
        + offset
        + rng.normal(0, 0.01, len(fills))
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # statsmodels' convergence notes on the random slopes' variances
        coefficients = mixed_effects(rows, score.to_numpy())
    want = {"black_bias": 0.5, "asian_bias": 0.2, "female_bias": -0.3, "age_bias": 0.1}
    assert coefficients == pytest.approx(want, abs=0.02)


def test_a_line_longer_than_the_limit_is_refused_without_reading_it_whole(tmp_path, monkeypatch):
    from fairaudit.experiments import discrim_eval

    monkeypatch.setattr(discrim_eval, "MAX_LINE", 100)
    path = tmp_path / "long.jsonl"
    short = json.dumps({"filled_template": "Hire?", "decision_question_id": 1, "age": 20, "gender": "f", "race": "w"})
    path.write_text(short + "\n" + json.dumps({"filled_template": "x" * 500}) + "\n", encoding="utf-8")
    with pytest.raises(InputError, match="^path: line 2 is longer than 100 characters"):
        read_rows(path)
    path.write_text(short + "\n" + short, encoding="utf-8")  # no newline at the end: still two rows
    assert len(read_rows(path).prompts) == 2
