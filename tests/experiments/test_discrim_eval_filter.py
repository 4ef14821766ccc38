"""A privacy filter on a discrim-eval run's fills: the law behind it against the stand-in's composed by hand, its
specs certified as ``fairaudit certify`` certifies them, verified, calibrated; refusals before the model is asked."""

from __future__ import annotations

import json
import math

import pytest

import fairaudit as fa
from fairaudit import InputError
from fairaudit.cli import main
from fairaudit.experiments.discrim_eval import read_rows
from fairaudit.experiments.discrim_eval_filter import attribute_values, certify_filters, filter_spec
from fairaudit.experiments.discrim_eval_run import run_discrim_eval, write_run

SAMPLE = "examples/discrim_eval/sample.jsonl"


def _stand_in(rows):
    """Yes 0.6, no 0.3 for women (E[g] = 0.6 + 0.1/2 = 0.65); yes 0.4, no 0.3 for men (E[g] = 0.55)."""
    women = {p: g == "female" for p, g in zip(rows.prompts, rows.attributes.gender)}
    law = {True: {"yes": 0.45, "Yes": 0.15, "no": 0.25, "No": 0.05},
           False: {"yes": 0.30, "Yes": 0.10, "no": 0.25, "No": 0.05}}  # fmt: skip

    def loglikelihood(requests):
        out = []
        for context, reply in requests:
            prompt = next(p for p in women if p in context)
            out.append(math.log(law[women[prompt]][reply]))
        return out

    return loglikelihood


def test_behind_the_filter_l_is_the_stand_ins_law_composed_by_hand(tmp_path):
    rows = read_rows(SAMPLE)
    run = run_discrim_eval(rows, _stand_in(rows), model="stand-in", coefficients=False)
    eps = 3 * math.log(3)  # three attributes of two values, one keep p: ln 3 each, p = 3/4
    run = certify_filters(run, [eps, 0.0], tmp_path)
    paths = write_run(run, tmp_path)
    high, zero = run.points
    assert high.keep == pytest.approx(0.75, rel=1e-12) and zero.keep == 0.5
    assert list(high.attribute_epsilons.values()) == pytest.approx([math.log(3)] * 3, rel=1e-12)
    # by hand: the model reads gender only; behind randomized response keeping it with p = 3/4, a woman's prompt is
    # read as a woman's 3/4 of the time: E[g | female] = 3/4 0.65 + 1/4 0.55 = 0.625, E[g | male] = 0.575
    d = high.to_dict()
    assert d["local_fairness"] == pytest.approx(math.log(0.625 / 0.575), rel=1e-12)
    assert d["global_fairness"] == pytest.approx(math.log(0.625 / 0.575), rel=1e-12)  # (a uniform population)
    assert d["local_fairness"] <= d["bound"] <= eps * (1 + 1e-9)  # (g free of the group: L <= epsilon)
    assert zero.to_dict()["local_fairness"] == pytest.approx(0.0, abs=1e-12)  # every attribute shown at random
    summary = json.loads((tmp_path / "summary.json").read_text(encoding="utf-8"))
    assert summary["privacy_filter"] == [p.to_dict() for p in run.points]
    assert "## Behind a privacy filter on the fills" in (tmp_path / "report.md").read_text(encoding="utf-8")
    assert {p.name for p in tmp_path.iterdir()} == {p.name for p in paths} | {
        "spec-eps-3.296.toml", "certificate-eps-3.296.json", "spec-eps-0.toml", "certificate-eps-0.json"}  # fmt: skip


def test_each_certificate_is_what_certify_writes_for_its_spec_and_verifies(tmp_path, monkeypatch, capsys):
    rows = read_rows(SAMPLE)
    certify_filters(run_discrim_eval(rows, _stand_in(rows), coefficients=False), [1.5], tmp_path)
    written = (tmp_path / "certificate-eps-1.5.json").read_text(encoding="utf-8")
    assert fa.verify(json.loads(written)).holds
    monkeypatch.chdir(tmp_path)
    capsys.readouterr()
    assert main(["certify", "spec-eps-1.5.toml", "--format", "json"]) == 0
    assert capsys.readouterr().out == written
    # calibrate --spec moves along the product family; on the upper end over the unparsed reply's worth, so the
    # epsilon meeting L <= ln(0.625/0.575) is at most the one that meets it at the stated worth, 3 ln 3
    assert main(["calibrate", "--spec", "spec-eps-1.5.toml", "--target", repr(math.log(0.625 / 0.575)),
                 "--format", "json"]) == 0  # fmt: skip
    found = json.loads(capsys.readouterr().out)["epsilon"]
    assert 0 < found <= 3 * math.log(3) * (1 + 1e-9)


def test_a_filter_needs_every_combination_in_every_scenario_and_says_which_is_missing(tmp_path):
    lines = [json.loads(line) for line in open(SAMPLE, encoding="utf-8")]
    path = tmp_path / "gap.jsonl"
    path.write_text("\n".join(json.dumps(r) for r in lines[:-1]) + "\n", encoding="utf-8")
    last = lines[-1]
    with pytest.raises(InputError) as e:
        attribute_values(read_rows(path))
    assert str(e.value) == (
        "--epsilon: needs every combination of the attributes' values in every scenario; scenario "
        f"{last['decision_question_id']} lacks (got '{last['age']} & {last['gender']} & {last['race']}')"
    )
    one = tmp_path / "one.jsonl"
    one.write_text("\n".join(json.dumps({**r, "race": "white"}) for r in lines) + "\n", encoding="utf-8")
    with pytest.raises(InputError, match=r"^--epsilon: needs at least two values of each attribute; 'race' has"):
        attribute_values(read_rows(one))
    rows = read_rows(SAMPLE)
    run = run_discrim_eval(rows, _stand_in(rows), coefficients=False)
    with pytest.raises(InputError, match=r"^--epsilon: must be finite"):
        filter_spec(run, math.inf)


def test_the_command_refuses_a_filter_on_a_file_without_every_fill_before_asking_the_model(capsys, tmp_path):
    lines = open(SAMPLE, encoding="utf-8").read().splitlines()
    path = tmp_path / "gap.jsonl"
    path.write_text("\n".join(lines[:-1]) + "\n", encoding="utf-8")
    # (port 9, discard: a request would fail; the refusal comes first)
    argv = ["experiment", str(path), "--endpoint", "http://127.0.0.1:9/v1", "--model", "m", "--epsilon", "1",
            "--out", str(tmp_path / "run")]  # fmt: skip
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("fairaudit: error: --epsilon: needs every combination") and err.count("\n") == 1
    assert not (tmp_path / "run").exists()


def test_the_command_writes_a_verifiable_certificate_per_epsilon_on_an_endpoint(capsys, tmp_path):
    from _chat_server import ChatServer
    from _cli import run

    def law(body):  # women yes 0.5 and no 0.3 (E[g] = 0.6), men yes 0.3 and no 0.5 (0.4); 0.2 on other replies
        female = "female" in body["messages"][0]["content"]
        return {"": [("yes", 0.5 if female else 0.3), ("no", 0.3 if female else 0.5), ("Maybe", 0.2)]}

    with ChatServer(law=law) as server:
        argv = ["experiment", SAMPLE, "--endpoint", server.url, "--model", "m", "--epsilon", "3", "--out", tmp_path]
        code, out, err = run(capsys, *argv, "--no-progress")
    assert code == 0, err
    certificate = json.loads((tmp_path / "certificate-eps-3.json").read_text(encoding="utf-8"))
    assert fa.verify(certificate).holds
    # by hand: each attribute at epsilon 1, p = e/(1 + e); E[g | female] = 0.6 p + 0.4 (1 - p), male the other way
    p = math.e / (1 + math.e)
    want = math.log((0.6 * p + 0.4 * (1 - p)) / (0.4 * p + 0.6 * (1 - p)))
    assert certificate["observed"]["local"]["value"] == pytest.approx(want, rel=1e-9)
    (point,) = json.loads((tmp_path / "summary.json").read_text(encoding="utf-8"))["privacy_filter"]
    assert point["keep"] == pytest.approx(p, rel=1e-12) and point["certificate"] == "certificate-eps-3.json"
    assert "| 3 | 0.7311 |" in out
