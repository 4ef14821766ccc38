"""The `fairaudit` command: contract keys, real values by independent routes, exit codes, errors."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from _cli import OFFICE_SPEC, run, run_json

import fairaudit as fa
from fairaudit.cli import main

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples" / "llm_hiring"
SHARED = ROOT.parent / "shared" / "data"


def num(v):
    """A JSON number, with the contract's "inf" read back as infinity."""
    return math.inf if v == "inf" else v


def _get(d, dotted):
    for part in dotted.split("."):
        d = d[part]
    return d


# -- certify on the shipped GPT example ---------------------------------------------------------------

CERTIFY_KEYS = [
    "certified",
    "privacy.sensitive.epsilon",
    "privacy.sensitive.delta",
    "bounds.paper",
    "bounds.tight",
    "bounds.black_box",
    "observed.local.value",
    "observed.local.context",
    "observed.local.group",
    "observed.local.other_group",
    "observed.global.value",
    "observed.global.group",
    "observed.global.other_group",
    "observed.demographic_parity",
    "observed.equalized_odds",
    "observed.sup_local",
    "observed.sup_global",
    "targets.local.target",
    "targets.local.met",
    "calibration.epsilon",
    "calibration.keep_probability",
]


def _first_rank_share(model: str) -> pd.DataFrame:
    """P(rank 1 | job, demo) straight from the shipped count table, by pandas (an independent route)."""
    t = pd.read_csv(EXAMPLES / "gpt_rank_counts.csv", dtype={"rank": str})
    t = t[t["model"] == model]
    total = t.groupby(["job", "demo"])["count"].sum()
    first = t[t["rank"] == "1"].set_index(["job", "demo"])["count"]
    return (first / total).unstack("demo")


@pytest.mark.parametrize("spec,model", [("gpt35.toml", "gpt-3.5-turbo"), ("gpt4.toml", "gpt-4")])
def test_certify_gpt_example_matches_pandas(capsys, spec, model):
    code, d, _ = run_json(capsys, "certify", EXAMPLES / spec)
    for key in CERTIFY_KEYS:
        _get(d, key)  # every contract key exists
    share = _first_rank_share(model)  # rows: job, columns: demo
    # Unfiltered: the model as measured.
    ratio = share.max(axis=1) / share.min(axis=1)
    job = ratio.idxmax()
    assert d["unfiltered"]["local"]["value"] == pytest.approx(math.log(ratio.max()), rel=1e-12)
    assert d["unfiltered"]["local"]["context"] == job
    assert d["unfiltered"]["local"]["group"] == share.loc[job].idxmax()
    assert d["unfiltered"]["local"]["other_group"] == share.loc[job].idxmin()
    overall = share.mean(axis=0)  # uniform jobs, independent of the group
    assert d["unfiltered"]["global"]["value"] == pytest.approx(math.log(overall.max() / overall.min()), rel=1e-12)
    # Behind 8-ary randomized response at epsilon = 0.5: keep p, move to each other group with (1 - p)/7.
    p = math.exp(0.5) / (math.exp(0.5) + 7)
    s = share.to_numpy()
    filtered = p * s + (1 - p) / 7 * (s.sum(axis=1, keepdims=True) - s)
    assert d["observed"]["local"]["value"] == pytest.approx(
        math.log((filtered.max(1) / filtered.min(1)).max()), rel=1e-12
    )
    # Any model behind the filter: every bound here is epsilon (g = 1{rank 1} has lower = 0).
    assert d["privacy"]["sensitive"]["epsilon"] == pytest.approx(0.5, rel=1e-15)
    assert d["privacy"]["sensitive"]["keep_probability"] == pytest.approx(p, rel=1e-15)
    assert d["bounds"]["black_box"] == pytest.approx(0.5, rel=1e-12)
    assert d["bounds"]["paper"] == pytest.approx(0.5, rel=1e-12)
    assert d["targets"]["local"]["met"] is True and d["certified"] is True and code == 0
    assert d["calibration"]["epsilon"] == pytest.approx(0.5, rel=1e-12)


def test_certify_text_and_markdown(capsys):
    code, out, _ = run(capsys, "certify", EXAMPLES / "gpt35.toml")
    assert code == 0 and "certified: yes" in out and "financial analyst" in out
    code, out, _ = run(capsys, "certify", EXAMPLES / "gpt35.toml", "--format", "markdown")
    assert out.startswith("# fairaudit certificate") and "| paper (main theorem) |" in out


SPEC = OFFICE_SPEC + "tau = 0.25\n"


def write(tmp_path, text, name="spec.toml"):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_certify_target_not_met_exits_1(tmp_path, capsys):
    # Binary randomized response with p = 0.7 certifies ln(7/3) = 0.8473 for any model; 0.5 is not met.
    spec = write(tmp_path, SPEC + "[target]\nlocal = 0.5\n")
    code, d, err = run_json(capsys, "certify", spec)
    assert code == 1 and d["certified"] is False and d["targets"]["local"]["met"] is False
    assert d["bounds"]["black_box"] == pytest.approx(math.log(7 / 3), rel=1e-12)
    # ...and the calibration says which epsilon would: 0.5 itself for two groups and g in [0, 1].
    assert d["calibration"]["epsilon"] == pytest.approx(0.5, rel=1e-12)
    assert d["calibration"]["keep_probability"] == pytest.approx(math.exp(0.5) / (1 + math.exp(0.5)), rel=1e-12)


def test_certify_model_table_by_hand(tmp_path, capsys):
    # Model: always hands the document to HR_2's profile (paper, GPT-4o). Behind binary RR with p = 0.7:
    # P(chosen | HR_2) = 0.7, P(chosen | HR_1) = 0.3 in both contexts, so L = Lbar = ln(7/3).
    rows = [
        (doc, off, dec, 1.0 if (off == "HR_2") == (dec == "yes") else 0.0)
        for doc in ("maternity", "holiday")
        for off in ("HR_1", "HR_2")
        for dec in ("yes", "no")
    ]
    pd.DataFrame(rows, columns=["document", "office", "chosen", "probability"]).to_csv(tmp_path / "k.csv", index=False)
    spec = write(tmp_path, SPEC + '[model]\ntable = "k.csv"\n[target]\nlocal = 0.9\n')
    code, d, _ = run_json(capsys, "certify", spec)
    assert code == 0
    assert d["observed"]["local"]["value"] == pytest.approx(math.log(7 / 3), rel=1e-12)
    assert d["observed"]["global"]["value"] == pytest.approx(math.log(7 / 3), rel=1e-12)
    assert d["observed"]["local"]["group"] == "HR_2" and d["observed"]["local"]["other_group"] == "HR_1"
    assert d["unfiltered"]["local"]["value"] == "inf"  # without the filter HR_1 is never chosen
    assert d["observed"]["demographic_parity"] == pytest.approx(0.4, rel=1e-12)  # 0.7 - 0.3
    # the corollary's bound is attained: observed L equals epsilon and the black-box worst case
    assert d["bounds"]["black_box"] == pytest.approx(d["observed"]["local"]["value"], rel=1e-12)


# -- audit -------------------------------------------------------------------------------------------


def _records(tmp_path):
    # 2 contexts; in "x0" group a is hired 3/4, b 1/4; in "x1" both 1/2.
    rows = (
        [("x0", "a", 1)] * 3
        + [("x0", "a", 0)]
        + [("x0", "b", 1)]
        + [("x0", "b", 0)] * 3
        + [("x1", "a", 1), ("x1", "a", 0), ("x1", "b", 1), ("x1", "b", 0)]
    )
    df = pd.DataFrame(rows, columns=["ctx", "grp", "hired"])
    path = tmp_path / "records.csv"
    df.to_csv(path, index=False)
    return path


AUDIT_KEYS = [
    "n",
    "groups",
    "contexts",
    "local.value",
    "local.interval",
    "global.value",
    "global.interval",
    "demographic_parity",
    "equalized_odds",
    "sup_local",
    "sup_global",
]


def test_audit_by_hand(tmp_path, capsys):
    path = _records(tmp_path)
    code, d, _ = run_json(
        capsys,
        "audit",
        path,
        "--sensitive",
        "grp",
        "--outcome",
        "hired",
        "--context",
        "ctx",
        "--positive",
        "1",
        "--confidence",
        "0.9",
    )
    assert code == 0
    for key in AUDIT_KEYS:
        _get(d, key)
    assert d["n"] == 12
    assert d["groups"] == [{"label": "a", "n": 6}, {"label": "b", "n": 6}]
    # local: context x0, 3/4 vs 1/4 -> ratio 3
    assert d["local"]["value"] == pytest.approx(math.log(3), rel=1e-12)
    assert (d["local"]["context"], d["local"]["group"], d["local"]["other_group"]) == ("x0", "a", "b")
    # global: a hired 4/6, b 2/6 -> ratio 2
    assert d["global"]["value"] == pytest.approx(math.log(2), rel=1e-12)
    # DP gap 4/6 - 2/6; EO gap in x0: 3/4 - 1/4
    assert d["demographic_parity"] == pytest.approx(1 / 3, rel=1e-12)
    assert d["equalized_odds"] == pytest.approx(0.5, rel=1e-12)
    # sup over g of L: decision 0 in x0: (3/4)/(1/4) = 3 as well
    assert d["sup_local"] == pytest.approx(math.log(3), rel=1e-12)
    lo, hi = d["local"]["interval"]
    assert lo <= math.log(3) <= (math.inf if hi == "inf" else hi)


# The equalized-odds line of each format: the gap of U, then the gap of g (--gap-on g), 0.5 in context (label) 1
EO_LINES = {
    "text": [
        "  equalized odds gap           0.5                (a vs b in context 1)\n",
        "  equalized odds gap of g      0.5                (a vs b in context 1)\n",
    ],
    "markdown": [
        "| equalized odds gap | 0.5 |  | a vs b in context 1 |",
        "| equalized odds gap of g | 0.5 | a vs b in context 1 |",
    ],
    "html": [
        '<tr><td>equalized odds gap</td><td class="num">0.5</td><td></td><td>a vs b in context 1</td></tr>',
        '<tr><td>equalized odds gap of g</td><td class="num">0.5</td><td>a vs b in context 1</td></tr>',
    ],
}
DP_LINES = {
    "text": "  demographic parity gap       0.25               (a vs b)\n",
    "markdown": "| demographic parity gap | 0.25 |  | a vs b |",
    "html": '<tr><td>demographic parity gap</td><td class="num">0.25</td><td></td><td>a vs b</td></tr>',
}


@pytest.mark.parametrize("fmt", ["text", "markdown", "html"])
def test_audit_without_a_true_label_prints_no_equalized_odds_line(tmp_path, capsys, fmt):
    # hired: a 3/4 with label 1, 1/4 with label 0; b 1/4 and 1/4. DP = 4/8 - 2/8 = 0.25; within label 1 the gap is
    # 3/4 - 1/4 = 0.5 (label 0: none). Without the label there is one context and nothing but the DP gap to show
    df = pd.DataFrame(
        {
            "grp": list("aaaaaaaabbbbbbbb"),
            "label": [1, 1, 1, 1, 0, 0, 0, 0] * 2,
            "hired": [1, 1, 1, 0, 1, 0, 0, 0] + [1, 0, 0, 0, 1, 0, 0, 0],
        }
    )
    path = tmp_path / "r.csv"
    df.to_csv(path, index=False)
    args = ["audit", path, "--sensitive", "grp", "--outcome", "hired", "--gap-on", "g", "--format", fmt]
    code, out, err = run(capsys, *args)
    assert (code, err) == (0, "")
    assert "equalized odds" not in out and DP_LINES[fmt] in out
    code, labelled, err = run(capsys, *args, "--context", "label")
    assert (code, err) == (0, "")
    assert all(line in labelled for line in EO_LINES[fmt]) and DP_LINES[fmt] in labelled


def test_audit_without_a_true_label_keeps_the_json_contract(tmp_path, capsys):
    # the JSON keeps every contract key: with one context the equalized-odds gap is the DP gap, 3/4 - 1/4
    path = tmp_path / "r.csv"
    pd.DataFrame({"grp": list("aaaabbbb"), "hired": [1, 1, 1, 0, 1, 0, 0, 0]}).to_csv(path, index=False)
    code, d, _ = run_json(capsys, "audit", path, "--sensitive", "grp", "--outcome", "hired", "--gap-on", "g")
    assert code == 0 and d["context_columns"] == []
    assert d["demographic_parity"] == d["equalized_odds"] == 0.5
    assert d["details"]["equalized_odds"]["context"] == "all"
    assert d["gaps_on_g"]["equalized_odds"] == {"value": 0.5, "context": "all", "group": "a", "other_group": "b"}


def test_audit_intersectional_and_expression(tmp_path, capsys):
    df = pd.DataFrame({"race": ["A", "A", "B", "B"] * 2, "sex": ["M", "W"] * 4, "score": [1, 2, 3, 4, 5, 6, 7, 8]})
    path = tmp_path / "r.csv"
    df.to_csv(path, index=False)
    code, d, _ = run_json(capsys, "audit", path, "--sensitive", "race,sex", "--outcome", "score", "--utility", "u")
    # E[score | group]: A&M (1+5)/2 = 3, A&W 4, B&M 5, B&W 6 -> Lbar = log(6/3)
    assert code == 0 and [g["label"] for g in d["groups"]] == ["A & M", "A & W", "B & M", "B & W"]
    assert d["global"]["value"] == pytest.approx(math.log(2), rel=1e-12)
    assert d["global"]["group"] == "B & W" and d["global"]["other_group"] == "A & M"


@pytest.mark.parametrize("negative", [0, False])
def test_audit_binary_outcome_with_no_positive_record(tmp_path, capsys, negative):
    # nobody is selected: E[g | x, a] = 0 for every group, 0/0 = 1, so L = L-bar = 0 (fairlearn gives NaN)
    df = pd.DataFrame({"grp": list("aaabbb"), "ctx": list("xyxyxy"), "hired": [negative] * 6})
    path = tmp_path / "none.csv"
    df.to_csv(path, index=False)
    code, d, _ = run_json(capsys, "audit", path, "--sensitive", "grp", "--context", "ctx", "--outcome", "hired")
    assert code == 0
    assert d["utility"]["name"] == ("1{outcome = True}" if negative is False else "1{outcome = 1}")
    assert (d["local"]["value"], d["global"]["value"], d["demographic_parity"]) == (0, 0, 0)
    r = fa.audit(df, sensitive=["grp"], outcome="hired")
    assert r.observed.local_fairness.value == 0 and r.observed.global_fairness.ratio == 1


def test_audit_parquet_matches_csv(tmp_path, capsys):
    path = _records(tmp_path)
    pq = tmp_path / "records.parquet"
    pd.read_csv(path).to_parquet(pq)
    _, a, _ = run_json(capsys, "audit", path, "--sensitive", "grp", "--outcome", "hired", "--context", "ctx")
    _, b, _ = run_json(capsys, "audit", pq, "--sensitive", "grp", "--outcome", "hired", "--context", "ctx")
    assert a["local"] == b["local"] and a["global"] == b["global"]


def test_audit_compas_matches_pandas(capsys):
    path = SHARED / "compas" / "compas-scores-two-years.csv"
    if not path.is_file():
        pytest.skip("../shared/data/compas is absent")
    code, d, _ = run_json(
        capsys,
        "audit",
        path,
        "--sensitive",
        "race",
        "--context",
        "c_charge_degree",
        "--outcome",
        "decile_score",
        "--utility",
        "u >= 5",
    )
    df = pd.read_csv(path)
    high = (df["decile_score"] >= 5).astype(float)
    cell = high.groupby([df["c_charge_degree"], df["race"]]).mean().unstack()
    ratio = cell.max(axis=1) / cell.min(axis=1)
    assert num(d["local"]["value"]) == pytest.approx(math.log(ratio.max()), rel=1e-12)
    assert d["local"]["context"] == ratio.idxmax()
    group = high.groupby(df["race"]).mean()
    assert d["global"]["value"] == pytest.approx(math.log(group.max() / group.min()), rel=1e-12)
    assert d["n"] == len(df) == 7214


# -- calibrate ---------------------------------------------------------------------------------------


def test_calibrate_hand_closed_form(capsys):
    # k = 2, g in [0.5, 1]: rho = 1/2, the worst ratio is (2t + 1)/(t + 2); solve (2t + 1)/(t + 2) = e^0.1.
    code, d, _ = run_json(capsys, "calibrate", "--target", "0.1", "--groups", "2", "--lower", "0.5")
    big_t = math.exp(0.1)
    t = (2 * big_t - 1) / (2 - big_t)
    assert code == 0 and d["method"] == "black_box"
    assert d["epsilon"] == pytest.approx(math.log(t), rel=1e-12)
    assert d["keep_probability"] == pytest.approx(t / (1 + t), rel=1e-12)
    for key in ("epsilon", "keep_probability", "method", "bound"):
        assert key in d


def test_calibrate_every_epsilon(capsys):
    # g in [0.5, 1] can never differ by more than a factor 2: a target of log 2 holds for any epsilon.
    code, d, _ = run_json(capsys, "calibrate", "--target", str(math.log(2) + 1e-9), "--lower", "0.5")
    assert d["epsilon"] == "inf" and d["keep_probability"] == 1.0


# -- bad input: one line, exit 2, nothing written ---------------------------------------------------

BAD_SPECS = {
    "missing section": ("[sensitive]\nname='a'\nvalues=[1,2]\n[utility]\ndecision=1\n", "decision"),
    "unknown mechanism": (SPEC.replace('"randomized_response"', '"laplace"').replace("keep = 0.7", ""), "laplace"),
    "keep out of range": (SPEC.replace("keep = 0.7", "keep = 1.7"), "privacy.sensitive.keep"),
    "unknown field": (SPEC + "[target]\nlocal = 1\nfoo = 2\n", "target.foo"),
    "matrix rows": (
        SPEC.replace(
            'mechanism = "randomized_response"\nkeep = 0.7', 'mechanism = "matrix"\nrows = [[0.5, 0.4], [0.5, 0.5]]'
        ),
        "sums to 0.9",
    ),
    "negative entry": (
        SPEC.replace(
            'mechanism = "randomized_response"\nkeep = 0.7', 'mechanism = "matrix"\nrows = [[1.5, -0.5], [0.5, 0.5]]'
        ),
        "negative",
    ),
    "utility decision": (SPEC.replace('decision = "yes"', 'decision = "maybe"'), "maybe"),
    "tau above gamma": (SPEC.replace("tau = 0.25", "tau = 2"), "tau"),
    "bad toml": ("[sensitive\n", "not valid TOML"),
}


@pytest.mark.parametrize("name", sorted(BAD_SPECS))
def test_certify_bad_spec(tmp_path, capsys, name):
    text, needle = BAD_SPECS[name]
    spec = write(tmp_path, text)
    out_file = tmp_path / "report.json"
    out_file.write_text("previous report")
    code, out, err = run(capsys, "certify", spec, "--output", out_file)
    assert code == 2
    assert out == "" and err.count("\n") == 1 and needle in err and "Traceback" not in err
    assert out_file.read_text() == "previous report"  # nothing half-written


@pytest.mark.parametrize(
    "table,needle",
    [
        ("document,office,chosen,probability\nmaternity,HR_1,yes,0.5\nmaternity,HR_1,no,0.4\n", "sums to 0.9"),
        ("document,office,chosen,probability\nmaternity,HR_9,yes,1\n", "HR_9"),
        ("document,office,chosen,probability\nmaternity,HR_1,yes,nan\n", "non-negative numbers"),
        (
            "document,office,chosen,probability\nmaternity,HR_1,yes,1\nmaternity,HR_1,no,0\n",
            "no rows (or only zeros) for",
        ),
        ("document,office,decision,probability\nmaternity,HR_1,yes,1\n", "chosen"),
    ],
)
def test_certify_bad_model_table(tmp_path, capsys, table, needle):
    full = "\n".join(
        f"{d},{o},{c},{0.5}" for d in ("maternity", "holiday") for o in ("HR_1", "HR_2") for c in ("yes", "no")
    )
    if "sums to" in needle:
        table = table + "\n".join(line for line in full.splitlines() if not line.startswith("maternity,HR_1")) + "\n"
    (tmp_path / "k.csv").write_text(table)
    spec = write(tmp_path, SPEC + '[model]\ntable = "k.csv"\n')
    code, out, err = run(capsys, "certify", spec)
    assert code == 2 and needle in err and err.count("\n") == 1, err


def test_missing_files_and_columns(tmp_path, capsys):
    code, _, err = run(capsys, "certify", tmp_path / "nope.toml")
    assert code == 2 and "nope.toml" in err
    path = _records(tmp_path)
    code, _, err = run(capsys, "audit", path, "--sensitive", "race", "--outcome", "hired")
    assert code == 2 and "'race'" in err and "unknown column" in err
    df = pd.read_csv(path)
    df.loc[[0, 3], "grp"] = np.nan
    df.to_csv(path, index=False)
    code, _, err = run(capsys, "audit", path, "--sensitive", "grp", "--outcome", "hired")
    assert code == 2 and "'grp'" in err and "2 missing values" in err
    code, _, err = run(capsys, "audit", path, "--sensitive", "grp", "--outcome", "hired", "--dropna")
    assert code == 0
    code, _, err = run(capsys, "audit", path, "--sensitive", "grp", "--outcome", "hired", "--positive", "7", "--dropna")
    assert code == 2 and "--positive" in err and "'7'" in err


def test_usage_errors_are_one_line(capsys):
    assert main(["audit", "x.csv", "--outcome", "y"]) == 2
    _, err = capsys.readouterr()
    assert err.count("\n") == 1 and "--sensitive" in err
    with pytest.raises(SystemExit) as exc:
        main(["audit", "x.csv", "--outcome"])
    _, err = capsys.readouterr()
    assert exc.value.code == 2 and err.count("\n") == 1 and "--outcome" in err


@pytest.mark.slow
def test_console_script_no_traceback(tmp_path):
    spec = write(tmp_path, "[sensitive]\nname = 1\n")
    proc = subprocess.run([sys.executable, "-m", "fairaudit.cli", "certify", str(spec)], capture_output=True, text=True)
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.count("\n") == 1 and "sensitive" in proc.stderr and "Traceback" not in proc.stderr


def test_after_the_command_line_is_done_ctrl_c_is_ignored(tmp_path):
    # a SIGINT pending as the command returns was a KeyboardInterrupt traceback from the interpreter's shutdown
    import subprocess
    import sys

    script = (
        "import os, signal, sys, time\n"
        "from fairaudit.cli import main\n"
        "sys.argv = ['fairaudit', 'plan', '--target', '0.5', '--datasets', '5']\n"
        "status = main()\n"
        "os.kill(os.getpid(), signal.SIGINT)\n"
        "time.sleep(0.05)\n"
        "print('still here', status, file=sys.stderr)\n"
    )
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=60)
    assert (done.returncode, done.stderr) == (0, "still here 0\n")
    in_process = subprocess.run(  # main(argv) is the library's call (tests, notebooks): Ctrl-C stays theirs
        [sys.executable, "-c", script.replace("status = main()", "status = main(sys.argv[1:])")],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert in_process.returncode != 0 and "KeyboardInterrupt" in in_process.stderr
