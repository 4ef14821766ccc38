"""`fairaudit calibrate` and the `calibration` keys of `fairaudit certify`: keys, hand values, exit codes, errors."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pandas as pd
import pytest
from _cli import OFFICE_SPEC, run, run_json

import fairaudit as fa
from fairaudit.cli import main

ROOT = Path(__file__).resolve().parents[2]
GPT35 = ROOT / "examples" / "llm_hiring" / "gpt35.toml"

CONTRACT = ("epsilon", "keep_probability", "method", "bound")
EXTRA = ("feasible", "reason", "target", "kind", "mechanism", "groups")


SPEC = OFFICE_SPEC


def write_spec(tmp_path, extra="", model=False):
    """The two-office spec of tests/cli/test_main.py; with ``model`` a table of the model that picks HR_2's profile."""
    text = SPEC + extra
    if model:
        rows = [
            (doc, off, dec, 1.0 if (off == "HR_2") == (dec == "yes") else 0.0)
            for doc in ("maternity", "holiday")
            for off in ("HR_1", "HR_2")
            for dec in ("yes", "no")
        ]
        pd.DataFrame(rows, columns=["document", "office", "chosen", "probability"]).to_csv(
            tmp_path / "k.csv", index=False
        )
        text += '[model]\ntable = "k.csv"\n'
    p = tmp_path / "spec.toml"
    p.write_text(text)
    return p


# -- calibrate ------------------------------------------------------------------------------------------


def test_keys_and_hand_value(capsys):
    # k = 8, g in [0.1, 1]: t = (T rho (k-1) + T (1-rho) - rho (k-1)) / (1 - T rho), T = e^0.5
    # (proofs/black_box.md §3).
    code, d, _ = run_json(capsys, "calibrate", "--target", 0.5, "--groups", 8, "--lower", 0.1)
    big_t, rho, k = math.exp(0.5), 0.1, 8
    t = (big_t * rho * (k - 1) + big_t * (1 - rho) - rho * (k - 1)) / (1 - big_t * rho)
    assert code == 0
    for key in CONTRACT + EXTRA:
        assert key in d
    assert d["method"] == "black_box" and d["feasible"] is True and d["kind"] == "local" and d["groups"] == 8
    assert d["epsilon"] == pytest.approx(math.log(t), rel=1e-12)
    assert d["keep_probability"] == pytest.approx(t / (t + 7), rel=1e-12)
    assert d["bound"] == pytest.approx(0.5, rel=1e-12)
    assert d["mechanism"] == "8-ary randomized response" and d["target"] == 0.5 and d["tau"] is None


def test_infeasible_target_exits_1_and_still_reports(capsys):
    # L_A = 0.2, tau = 0.5: the floor is log(1.4) = 0.336472 nats.
    code, d, _ = run_json(capsys, "calibrate", "--target", 0.1, "--method", "tight", "--tau", 0.5, "--lipschitz", 0.2)
    assert code == 1 and d["feasible"] is False and d["epsilon"] is None and d["keep_probability"] is None
    assert d["bound"] == pytest.approx(math.log(1.4), rel=1e-12) and "0.336472" in d["reason"]
    code, out, err = run(capsys, "calibrate", "--target", 0.1, "--method", "paper", "--tau", 0.5, "--lipschitz", 0.2)
    assert code == 1 and out.startswith("no epsilon of 2-ary randomized response meets L <= 0.1 nats")
    assert "reason: the target 0.1 nats is below the floor" in out and err == ""


def test_delta_changes_tight_and_paper(capsys):
    # delta = 0.05, gamma = 1, tau = 0.5: c/tau = 0.1. tight: log(e - 0.1) = 0.962518; paper: 1 - log 1.1 = 0.904690.
    code, d, _ = run_json(capsys, "calibrate", "--target", 1, "--tau", 0.5, "--delta", 0.05)
    assert code == 0 and d["method"] == "tight" and d["delta"] == 0.05  # --delta makes tight the default
    assert d["epsilon"] == pytest.approx(math.log(math.e - 0.1), rel=1e-13)
    code, d, _ = run_json(capsys, "calibrate", "--target", 1, "--tau", 0.5, "--delta", 0.05, "--method", "paper")
    assert d["epsilon"] == pytest.approx(1 - math.log(1.1), rel=1e-13)
    code, d, _ = run_json(capsys, "calibrate", "--target", 1, "--tau", 0.5, "--method", "paper")
    assert d["epsilon"] == pytest.approx(1.0, rel=1e-13)  # without delta (and L_A = 0): the target
    code, d, _ = run_json(capsys, "calibrate", "--target", 1, "--tau", 0.5, "--method", "black_box")
    # black-box with tau: every model has E[g | x, a] in [0.5, 1], a ratio of at most 2 < e: every epsilon works
    assert d["epsilon"] == "inf" and d["bound"] == pytest.approx(math.log(2), rel=1e-9)


def test_global_flag_and_every_epsilon(capsys):
    code, d, _ = run_json(capsys, "calibrate", "--target", 0.4, "--global", "--groups", 3)
    assert code == 0 and d["kind"] == "global" and d["epsilon"] == pytest.approx(0.4, rel=1e-12)
    code, d, _ = run_json(capsys, "calibrate", "--target", math.log(2) + 1e-9, "--lower", 0.5)
    assert code == 0 and d["epsilon"] == "inf" and d["keep_probability"] == 1.0


@pytest.mark.parametrize(
    "argv,needle",
    [
        (["--target", "-1"], "--target: must be a finite non-negative number"),
        (["--target", "0.5", "--method", "tight", "--lipschitz", "0.2"], "--tau: the tight bound needs tau"),
        (["--target", "0.5", "--delta", "0.1", "--method", "black_box"], "--delta:"),
        (["--target", "0.5", "--delta", "2", "--tau", "0.5"], "--delta: must be a number in [0, 1] (got 2.0)"),
        (["--target", "0.5", "--groups", "1"], "--groups: randomized response needs at least 2 groups (got 1)"),
        (["--target", "0.5", "--lower", "2"], "--lower: must be a number in [0, gamma = 1] (got 2.0)"),
        (["--target", "0.5", "--tau", "0"], "--tau:"),
        (["--target", "0.5", "--method", "white_box"], "--spec: the white_box method needs a decision model"),
        (["--target", "0.5", "--spec", "nosuch.toml"], "--spec: no such file (got 'nosuch.toml')"),
    ],
)
def test_invalid_input_is_one_line_exit_2(capsys, argv, needle):
    code, out, err = run(capsys, "calibrate", *argv)
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and needle in err and "Traceback" not in err


@pytest.mark.parametrize(
    "argv,needle",
    [
        (["--target", "x"], "argument --target: invalid float value: 'x'"),
        (["--target", "0.5", "--method", "exact"], "argument --method: invalid choice: 'exact'"),
        (["--groups", "2"], "one of the arguments --target --target-impact-ratio is required"),
    ],
)
def test_usage_errors_are_one_line_exit_2(capsys, argv, needle):
    with pytest.raises(SystemExit) as exc:
        main(["calibrate", *argv])
    out, err = capsys.readouterr()
    assert exc.value.code == 2 and out == "" and err.count("\n") == 1 and needle in err


def test_groups_must_match_the_spec(tmp_path, capsys):
    code, out, err = run(capsys, "calibrate", "--target", 0.5, "--spec", write_spec(tmp_path), "--groups", 3)
    assert code == 2 and "--groups: the spec" in err and "has 2 groups (got 3)" in err


def test_spec_with_a_model_uses_white_box(tmp_path, capsys):
    # The model picks HR_2's profile: behind binary RR, P(yes | HR_2) = keep, P(yes | HR_1) = 1 - keep, so
    # L = L-bar = epsilon, and the largest epsilon keeping L <= 0.9 is 0.9.
    spec = write_spec(tmp_path, model=True)
    code, d, _ = run_json(capsys, "calibrate", "--target", 0.9, "--spec", spec)
    assert code == 0 and d["method"] == "white_box" and d["groups"] == 2
    assert d["epsilon"] == pytest.approx(0.9, rel=1e-9)
    # explicit method: black-box ignores the model (g in [0, 1]: epsilon = target too)
    code, d, _ = run_json(capsys, "calibrate", "--target", 0.9, "--spec", spec, "--method", "black_box")
    assert d["method"] == "black_box" and d["epsilon"] == pytest.approx(0.9, rel=1e-12)
    # flags override the spec: --lower 0.5 gives black-box rho = 1/2: t = (2T - 1)/(2 - T) with T = e^0.1
    code, d, _ = run_json(capsys, "calibrate", "--target", 0.1, "--spec", spec, "--method", "black_box", "--lower", 0.5)
    big_t = math.exp(0.1)
    assert d["lower"] == 0.5 and d["epsilon"] == pytest.approx(math.log((2 * big_t - 1) / (2 - big_t)), rel=1e-12)


def test_spec_with_a_product_mechanism_uses_its_family(tmp_path, capsys):
    # Name x age, each randomized: the family is the product with epsilon split as the components' (here equal).
    text = """
[sensitive]
name = "profile"
[decision]
name = "chosen"
values = ["yes", "no"]
[privacy.sensitive]
mechanism = "product"
[[privacy.sensitive.components]]
mechanism = "randomized_response"
values = ["Tom", "Mary"]
keep = 0.7
[[privacy.sensitive.components]]
mechanism = "randomized_response"
values = [25, 55, 70]
keep = 0.6
[utility]
kind = "table"
values = [1.0, 0.1]
"""
    (tmp_path / "p.toml").write_text(text)
    spec = fa.load_spec(tmp_path / "p.toml")
    code, d, _ = run_json(capsys, "calibrate", "--target", 0.5, "--spec", tmp_path / "p.toml")
    assert code == 0 and d["groups"] == 6 and d["method"] == "black_box"
    fam = spec.sensitive_family
    assert d["family"] == fam.name
    # independent check: the exact worst case at the returned epsilon is the target, and exceeds it just above
    assert fa.black_box_bound(fam(d["epsilon"]), utility_class=fa.UtilityClass(lower=0.1)).value == pytest.approx(
        0.5, rel=1e-9
    )
    assert fa.black_box_bound(fam(d["epsilon"] * (1 + 1e-6)), utility_class=fa.UtilityClass(lower=0.1)).value > 0.5


def test_global_with_dependent_population_exits_1(tmp_path, capsys):
    spec = write_spec(tmp_path, "[population]\nprobabilities = [[0.4, 0.1], [0.1, 0.4]]\n")
    code, d, _ = run_json(capsys, "calibrate", "--target", 0.5, "--spec", spec, "--global")
    # the floor of the exact black-box bound on L-bar at epsilon = 0 is log 4 (P(x | a) = (0.8, 0.2) vs (0.2, 0.8))
    assert (
        code == 1 and d["feasible"] is False and "not independent" in d["reason"] and "below the floor" in d["reason"]
    )
    assert d["bound"] == pytest.approx(math.log(4), rel=1e-9)
    code, d, _ = run_json(
        capsys, "calibrate", "--target", 0.5, "--spec", spec, "--global", "--method", "tight", "--tau", 0.2
    )
    assert code == 1 and d["feasible"] is False and "use black_box" in d["reason"] and d["bound"] == "inf"


def test_text_markdown_and_output_file(tmp_path, capsys):
    code, out, _ = run(capsys, "calibrate", "--target", 0.5, "--groups", 8, "--lower", 0.1)
    assert out.splitlines()[:3] == [
        "largest epsilon of 8-ary randomized response meeting L <= 0.5 nats: 0.841803 nats",
        "keep probability (the price): 0.248971",
        "method: black_box; certified bound there: 0.5 nats",
    ]
    assert out.splitlines()[3].startswith("reason: exact worst case over every model")
    code, md, _ = run(capsys, "calibrate", "--target", 0.5, "--format", "markdown")
    assert md.startswith("# fairaudit calibration\n\n```\nlargest epsilon of 2-ary randomized response")
    target = tmp_path / "cal.json"
    code, out, err = run(capsys, "calibrate", "--target", 0.5, "--format", "json", "--output", target)
    assert code == 0 and out == "" and "report written to" in err
    assert json.loads(target.read_text())["epsilon"] == pytest.approx(0.5, rel=1e-12)


# -- certify: the calibration keys ------------------------------------------------------------------------


def test_certify_calibration_keys_on_the_gpt_example(capsys):
    code, d, _ = run_json(capsys, "certify", GPT35)
    c = d["calibration"]
    for key in CONTRACT + EXTRA:
        assert key in c and key in c["white_box"]
    # black-box: 8-ary RR, g in [0, 1] with tau = 0.05 (not binding at the worst case): epsilon = target = 0.5
    assert c["method"] == "black_box" and c["epsilon"] == pytest.approx(0.5, rel=1e-9)
    w = c["white_box"]
    assert w["method"] == "white_box" and w["feasible"] is True
    # independent check of the white-box epsilon: the model's L and L-bar at epsilon (pandas-free, by compose)
    spec = fa.load_spec(GPT35)
    kernel = spec.kernel()

    def worst(eps):
        law = fa.compose(kernel, fa.randomized_response(spec.groups, eps))
        return max(
            fa.local_fairness(law, spec.utility, spec.population).value,
            fa.global_fairness(law, spec.utility, spec.population).value,
        )

    assert worst(w["epsilon"]) == pytest.approx(0.5, rel=1e-9)
    assert worst(w["epsilon"] * (1 + 1e-6)) > 0.5
    assert w["epsilon"] >= c["epsilon"]  # the model is fairer than the worst case


def test_certify_calibration_skipped_for_group_dependent_utility(tmp_path, capsys):
    # g differs between the offices and the spec gives no lipschitz: no black-box calibration, with the reason.
    table = '[utility]\nkind = "table"\nvalues = [[[1.0, 0.0], [0.5, 0.0]], [[1.0, 0.0], [0.5, 0.0]]]\n'
    spec = write_spec(tmp_path, "").read_text().replace('[utility]\nkind = "indicator"\ndecision = "yes"\n', table)
    (tmp_path / "g.toml").write_text(spec + "[target]\nlocal = 1.0\n")
    code, d, _ = run_json(capsys, "certify", tmp_path / "g.toml")
    c = d["calibration"]
    assert c["epsilon"] is None and c["keep_probability"] is None and "lipschitz" in c["reason"]
    # with a Lipschitz constant (and tau) the black-box class is the general one (LP) and the calibration is back:
    # at epsilon = 0 a model can still give E in [0.25, 0.75] by group, a floor of log 3 = 1.0986 nats.
    given = spec.replace("values = [[[1.0", "lipschitz = 0.5\ntau = 0.25\nvalues = [[[1.0")
    fam = fa.randomized_response_family(["HR_1", "HR_2"])
    assert fa.black_box_bound(fam(0.0), utility_class=fa.UtilityClass(tau=0.25, lipschitz=0.5)).value == pytest.approx(
        math.log(3), rel=1e-7
    )
    (tmp_path / "h.toml").write_text(given + "[target]\nlocal = 1.0\n")
    code, d, _ = run_json(capsys, "certify", tmp_path / "h.toml")
    c = d["calibration"]
    assert c["method"] == "black_box" and c["feasible"] is False and c["bound"] == pytest.approx(math.log(3), rel=1e-7)
    (tmp_path / "h.toml").write_text(given + "[target]\nlocal = 1.3\n")  # below the identity's log 4
    code, d, _ = run_json(capsys, "certify", tmp_path / "h.toml")
    c = d["calibration"]
    assert c["method"] == "black_box" and c["lipschitz"] == 0.5 and c["tau"] == 0.25
    at = fa.black_box_bound(fam(c["epsilon"]), utility_class=fa.UtilityClass(tau=0.25, lipschitz=0.5)).value
    assert at == pytest.approx(1.3, rel=1e-8)
    assert (
        fa.black_box_bound(fam(c["epsilon"] * (1 + 1e-6)), utility_class=fa.UtilityClass(tau=0.25, lipschitz=0.5)).value
        > 1.3
    )


def test_certify_text_names_both_calibrations(tmp_path, capsys):
    spec = write_spec(tmp_path, "[target]\nlocal = 0.9\n", model=True)
    code, out, _ = run(capsys, "certify", spec)
    assert "calibration: 2-ary randomized response with epsilon <= 0.9 nats" in out
    assert "calibration for this model: epsilon <= 0.9 nats" in out


def test_a_billion_groups_calibrate_in_constant_memory(capsys, monkeypatch):
    """Issue 83: k = 10^9 was a MemoryError traceback (its labels, 33.5 GiB). Randomized response's worst case over
    every model with utilities in [0, 1] is ε whatever k (proofs/black_box.md §3): the target itself, keep
    probability e^ε / (e^ε + k − 1) by hand."""
    monkeypatch.setenv("FAIRAUDIT_MAX_MEMORY", "100M")
    code, report, err = run_json(capsys, "calibrate", "--target", "0.5", "--groups", "1000000000")
    assert code == 0 and err == ""
    assert (report["epsilon"], report["bound"], report["groups"]) == (0.5, 0.5, 10**9)
    assert report["keep_probability"] == pytest.approx(math.exp(0.5) / (math.exp(0.5) + 10**9 - 1), rel=1e-12)
