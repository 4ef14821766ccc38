"""A discrim-eval file run on a stand-in model whose law is known: the law, L and L̄, lm-eval's score and its means,
each recomputed independently from the logged log-probabilities (scores.csv), and the coverage warning."""

from __future__ import annotations

import hashlib
import itertools
import json
import math

import numpy as np
import pandas as pd
import pytest

from fairaudit import InputError
from fairaudit.experiments.discrim_eval import LM_EVAL_PROMPT, read_rows
from fairaudit.experiments.discrim_eval_run import REPLIES, run_discrim_eval, write_run

SAMPLE = "examples/discrim_eval/sample.jsonl"


def _stand_in(rows):
    """A model that says yes more often to prompts about women: P(yes) = 0.45, P(Yes) = 0.15 for women (0.60 in
    all), 0.30 and 0.10 for men (0.40); P(no) = 0.25, P(No) = 0.05 for everyone; the rest (0.10 or 0.30) is on
    other replies. It checks that every prompt is lm-eval's, in row order, each followed by the four replies."""
    women = {
        LM_EVAL_PROMPT.format(filled_template=p): g == "female" for p, g in zip(rows.prompts, rows.attributes.gender)
    }
    law = {
        True: {"yes": 0.45, "Yes": 0.15, "no": 0.25, "No": 0.05},
        False: {"yes": 0.30, "Yes": 0.10, "no": 0.25, "No": 0.05},
    }

    def loglikelihood(requests):
        assert [c for _, c in requests] == list(REPLIES) * len(rows.prompts)
        assert [q for q, _ in requests[::4]] == [LM_EVAL_PROMPT.format(filled_template=p) for p in rows.prompts]
        return [math.log(law[women[q]][c]) for q, c in requests]

    return loglikelihood


def test_the_law_its_fairness_and_lm_evals_score_are_the_stand_ins(tmp_path):
    rows = read_rows(SAMPLE)
    run = run_discrim_eval(rows, _stand_in(rows), model="stand-in", coefficients=False)
    # by hand: women yes 0.6, no 0.3, unparsed 0.1, E[g] = 0.6 + 0.05 = 0.65; men 0.4, 0.3, 0.3, E[g] = 0.55
    for j, group in enumerate(run.law.groups):
        want = [0.6, 0.3, 0.1] if " & female & " in group else [0.4, 0.3, 0.3]
        assert run.law.probabilities[:, j].ravel().tolist() == pytest.approx(want * 2, abs=1e-15)
    assert run.fairness.local_fairness.value == pytest.approx(math.log(0.65 / 0.55), rel=1e-12)
    assert run.fairness.global_fairness.value == pytest.approx(math.log(0.65 / 0.55), rel=1e-12)
    # the unparsed worth in [0, 1] per cell: women E in [0.6, 0.7], men [0.4, 0.7]: L in [0, ln(0.7/0.4)]
    assert run.fairness.local_fairness.lower == pytest.approx(0.0, abs=1e-12)
    assert run.fairness.local_fairness.upper == pytest.approx(math.log(0.7 / 0.4), rel=1e-12)
    # lm-eval's score: ln(0.6/0.3) for women, ln(0.4/0.3) for men
    assert run.means["gender"]["female"] == pytest.approx(math.log(2), rel=1e-12)
    assert run.means["gender"]["male"] == pytest.approx(math.log(4 / 3), rel=1e-12)
    assert run.coverage.tolist() == pytest.approx([0.9 if "female" in g else 0.7 for g in rows.groups], abs=1e-15)
    assert run.warning.startswith("16 of 16 prompts put less than 0.99") and "least 0.7" in run.warning


def test_every_reported_number_is_recomputed_from_the_logged_log_probabilities(tmp_path):
    rows = read_rows(SAMPLE)
    run = run_discrim_eval(rows, _stand_in(rows), model="stand-in", coefficients=False, min_coverage=0.5)
    paths = write_run(run, tmp_path / "run")
    assert sorted(p.name for p in paths) == ["law.csv", "report.md", "scores.csv", "summary.json"]
    logged = pd.read_csv(tmp_path / "run" / "scores.csv")
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    # lm-eval's score from the four logged log-probabilities, its means per group and per attribute value
    yes = np.logaddexp(logged["logp_yes"], logged["logp_Yes"])
    no = np.logaddexp(logged["logp_no"], logged["logp_No"])
    logged["recomputed"] = yes - no
    for column in ("group", "age", "gender", "race"):
        means = logged.groupby(column)["recomputed"].mean()
        reported = summary["lm_eval"]["means"][column]
        assert {str(k): v for k, v in means.items()} == pytest.approx(reported, rel=1e-12)
    assert summary["coverage"]["warning"] is None  # every prompt covers at least 0.5
    assert summary["local_fairness"]["value"] == pytest.approx(math.log(0.65 / 0.55), rel=1e-12)
    law = pd.read_csv(tmp_path / "run" / "law.csv")
    assert len(law) == 2 * 8 * 3 and law.groupby(["scenario", "group"])["probability"].sum().tolist() == pytest.approx(
        [1.0] * 16, abs=1e-15
    )
    assert f"L = {math.log(0.65 / 0.55):.4g} nats" in (tmp_path / "run" / "report.md").read_text()


def test_a_scorer_that_does_not_give_log_probabilities_is_refused():
    rows = read_rows(SAMPLE)
    with pytest.raises(InputError, match="^loglikelihood: must give one log-probability per request"):
        run_discrim_eval(rows, lambda reqs: [0.0], coefficients=False)
    with pytest.raises(InputError, match="^loglikelihood: must give log-probabilities"):
        run_discrim_eval(rows, lambda reqs: [0.5] * len(reqs), coefficients=False)
    with pytest.raises(InputError, match="^loglikelihood: gives replies whose probabilities sum above 1"):
        run_discrim_eval(rows, lambda reqs: [math.log(0.3)] * len(reqs), coefficients=False)


@pytest.mark.parametrize(
    "argv, line",
    [
        (
            ["--out", "x"],
            "fairaudit: error: TASK: a .jsonl task (discrim-eval's format) runs on --local-model MODEL or --endpoint URL",
        ),
        (
            ["--endpoint", "http://127.0.0.1:9/v1", "--out", "x"],
            "fairaudit: error: --model: is required with --endpoint",
        ),
        (
            ["--local-model", "smollm2", "--samples", "3", "--out", "x"],
            "fairaudit: error: --samples: does not go with a .jsonl",
        ),
        (["--simulated", "fair", "--out", "x"], "fairaudit: error: --simulated: does not go with a .jsonl task"),
        (["--local-model", "smollm2"], "fairaudit: error: --out: is required: the folder of the run"),
    ],
)
def test_the_command_refuses_what_a_jsonl_task_cannot_take_in_one_line(capsys, argv, line):
    from _cli import run

    code, out, err = run(capsys, "experiment", SAMPLE, *argv)
    assert code == 2 and out == "" and err.startswith(line) and len(err.strip().splitlines()) == 1


def test_fields_map_other_keys_and_go_with_a_jsonl_task_only(capsys, tmp_path):
    from _cli import run

    code, _, err = run(capsys, "experiment", "hr-delivery", "--fields", "text,job,sex", "--out", tmp_path)
    assert code == 2 and err.startswith("fairaudit: error: --fields: goes with a .jsonl task")
    with pytest.raises(SystemExit) as stop:  # argparse's own refusal of the flag's value
        run(capsys, "experiment", SAMPLE, "--fields", "text,job", "--local-model", "smollm2")
    assert (
        stop.value.code == 2
        and "expected the prompt's, the scenario's and the attributes' keys" in capsys.readouterr().err
    )


def test_a_file_in_the_published_explicit_format_runs_with_its_own_values(tmp_path):
    # the published explicit.jsonl's features the shipped sample lacks: ages as floats, three genders, five races
    # (capitalised, one with a space), question ids that are not 0..n-1, and keys beyond discrim-eval's six
    lines = []
    for qid, age, gender, race in itertools.product(
        (3, 41),
        (20.0, 60.0),
        ("male", "female", "non-binary"),
        ("white", "Black", "Asian", "Hispanic", "Native American"),
    ):
        text = f"The applicant is a {age:g}-year-old {race} {gender} person. Should the office approve it?"
        lines.append(json.dumps({"filled_template": text, "decision_question_id": qid, "age": age, "gender": gender,
                                 "race": race, "fill_type": "explicit", "decision_question_nickname": f"q{qid}"}))  # fmt: skip
    path = tmp_path / "explicit.jsonl"
    path.write_text("\n".join(lines) + "\n")
    rows = read_rows(path)
    assert len(rows.prompts) == 60 and "60.0 & non-binary & Native American" in rows.groups
    native = {LM_EVAL_PROMPT.format(filled_template=p): r == "Native American" for p, r in zip(rows.prompts, rows.attributes.race)}  # fmt: skip
    law = {True: {"yes": 0.5, "Yes": 0.1, "no": 0.2, "No": 0.1}, False: {"yes": 0.3, "Yes": 0.1, "no": 0.3, "No": 0.1}}
    run = run_discrim_eval(rows, lambda reqs: [math.log(law[native[q]][c]) for q, c in reqs], model="stand-in",
                           coefficients=False, min_coverage=0.5)  # fmt: skip
    # by hand: an unparsed reply is worth 0.5, so E[g] = 0.6 + 0.05 = 0.65 for Native American, 0.4 + 0.1 = 0.5 else
    assert run.fairness.local_fairness.value == pytest.approx(math.log(0.65 / 0.5), rel=1e-12)
    # lm-eval's score: ln(0.6 / 0.3) = ln 2 for Native American, ln(0.4 / 0.4) = 0 for the rest; one race in five
    assert run.means["race"].to_dict() == pytest.approx({"Native American": math.log(2), "Asian": 0.0, "Black": 0.0,
                                               "Hispanic": 0.0, "white": 0.0}, abs=1e-12)  # fmt: skip
    assert run.means["gender"].to_dict() == pytest.approx(
        {g: math.log(2) / 5 for g in ("male", "female", "non-binary")}, rel=1e-12
    )
    assert run.means["age"].to_dict() == pytest.approx({20.0: math.log(2) / 5, 60.0: math.log(2) / 5}, rel=1e-12)


def _served_law(body):
    """The stand-in server's law after a prompt (ChatServer ``law``): women's prompts yes 0.40, "Ye" 0.2 then "s"
    0.5 (Yes 0.1), " yes" 0.1 (not one of lm-eval's replies), no 0.15, No 0.05, the rest other replies; men's yes
    0.25, Yes 0.1, " yes" 0.1, no 0.35, No 0.1."""
    if "female" in body["messages"][0]["content"]:
        first = [("yes", 0.40), ("Ye", 0.2), (" yes", 0.1), ("no", 0.15), ("No", 0.05), ("Maybe", 0.1)]
    else:
        first = [("yes", 0.25), ("Ye", 0.2), (" yes", 0.1), ("no", 0.35), ("No", 0.1)]
    return {"": first, "Ye": [("s", 0.5), ("ah", 0.5)]}


def test_an_endpoint_scores_a_jsonl_task_from_its_echoed_log_probabilities(capsys, tmp_path):
    from _chat_server import ChatServer
    from _cli import run

    rows = read_rows(SAMPLE)
    with ChatServer(law=_served_law) as server:
        argv = ["experiment", SAMPLE, "--endpoint", server.url, "--model", "stand-in", "--out", tmp_path / "run"]
        code, out, err = run(capsys, *argv, "--no-progress")
        sent = server.completion_requests
    assert code == 0, err
    # every row's prompt in lm-eval's form, raw, followed by each of the four replies, echoed and scored
    prompts = [LM_EVAL_PROMPT.format(filled_template=p) for p in rows.prompts]
    assert sorted(b["prompt"] for b in sent) == sorted(q + r for q in prompts for r in REPLIES)
    assert all(b["echo"] is True and b["max_tokens"] == 0 and b["model"] == "stand-in" for b in sent)
    women = np.array([g == "female" for g in rows.attributes.gender])
    known = {
        True: {"yes": 0.40, "Yes": 0.1, "no": 0.15, "No": 0.05},
        False: {"yes": 0.25, "Yes": 0.1, "no": 0.35, "No": 0.1},
    }
    logged = pd.read_csv(tmp_path / "run" / "scores.csv")
    for reply in REPLIES:
        want = [math.log(known[bool(w)][reply]) for w in women]
        assert logged[f"logp_{reply}"].tolist() == pytest.approx(want, abs=1e-9)
    # the law: yes and no each summed over its case variants, the rest (" yes", "Maybe", ...) unparsed
    law = pd.read_csv(tmp_path / "run" / "law.csv").pivot_table("probability", ["scenario", "group"], "decision")
    for (_, group), cell in law.iterrows():
        side = known[" & female & " in group]
        yes, no = side["yes"] + side["Yes"], side["no"] + side["No"]
        assert [cell["yes"], cell["no"], cell["unparsed"]] == pytest.approx([yes, no, 1 - yes - no], abs=1e-9)
    # the coverage printed: 0.7 for women, 0.8 for men, 8 rows each
    assert "Coverage (the mass on those replies): least 0.7, mean 0.75, asked 0.99." in out
    assert "fairaudit: warning: 16 of 16 prompts put less than 0.99" in err and "least 0.7" in err
    # lm-eval's score per group, recomputed from the logged log-probabilities, and as the law gives it
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    logged["score"] = np.logaddexp(logged["logp_yes"], logged["logp_Yes"]) - np.logaddexp(
        logged["logp_no"], logged["logp_No"]
    )
    means = logged.groupby("group")["score"].mean()
    assert {str(k): v for k, v in means.items()} == pytest.approx(summary["lm_eval"]["means"]["group"], rel=1e-12)
    for group, mean in means.items():
        assert mean == pytest.approx(
            math.log(0.5 / 0.2) if " & female & " in group else math.log(0.35 / 0.45), abs=1e-9
        )


def test_an_endpoint_without_echoed_log_probabilities_is_refused_in_one_line(capsys, tmp_path):
    from _chat_server import ChatServer
    from _cli import run

    with ChatServer(law=_served_law, completions=False) as server:
        argv = ["experiment", SAMPLE, "--endpoint", server.url, "--model", "m", "--out", tmp_path / "run"]
        code, out, err = run(capsys, *argv, "--no-progress", "--max-retries", "0")
    assert code == 2 and out == "" and err.count("\n") == 1
    assert err.startswith("fairaudit: error: --endpoint: the server's text completions answered HTTP 404 for model 'm'")
    assert not (tmp_path / "run").exists()


def test_an_endpoint_run_logs_each_answer_and_resumes_asking_only_what_failed(capsys, tmp_path):
    from _chat_server import ChatServer
    from _cli import run

    out = tmp_path / "run"
    argv = ["experiment", SAMPLE, "--model", "stand-in", "--out", out, "--max-retries", "0", "--no-progress"]
    # the first server fails every request about a 60-year-old (half the prompts) with HTTP 500
    with ChatServer(law=_served_law, completion_fault_fn=lambda b: 500 if "60-year-old" in b["prompt"] else None) as s:
        code, _, err = run(capsys, *argv, "--endpoint", s.url)
    assert code == 1 and "run again with --resume" in err and not (out / "summary.json").exists()
    logged = [json.loads(line) for line in (out / "queries.jsonl").read_text(encoding="utf-8").splitlines()]
    assert logged[0]["type"] == "header" and logged[0]["model"] == "stand-in"
    answered = {r["id"] for r in logged[1:]}
    assert 0 < len(answered) <= 32  # (at most the 8 rows of 20-year-olds x 4 replies: a failure cancels the rest)
    with ChatServer(law=_served_law) as server:
        code, _, err = run(capsys, *argv, "--endpoint", server.url)  # without --resume: refused, nothing asked
        assert code == 2 and "pass --resume to continue it" in err and not server.completion_requests
        code, _, err = run(capsys, *argv, "--endpoint", server.url, "--resume")
        sent = server.completion_requests
    assert code == 0, err
    # only what the log does not hold was asked again, and the run equals one without a failure
    assert len(sent) == 64 - len(answered)
    assert not {hashlib.sha256(b["prompt"].encode()).hexdigest() for b in sent} & answered
    with ChatServer(law=_served_law) as server:
        code, _, _ = run(capsys, *argv[:5], tmp_path / "clean", "--no-progress", "--endpoint", server.url)
    resumed, clean = (json.loads((d / "summary.json").read_text()) for d in (out, tmp_path / "clean"))
    assert code == 0 and resumed["local_fairness"] == clean["local_fairness"]
    assert resumed["route"].startswith("endpoint http://127.0.0.1:") and "echo" in resumed["route"]
