"""Intervals through the interfaces: ``audit --confidence --method``, ``certify`` from counts, the Python API."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from _cli import run, run_json
from scipy.stats import binomtest

import fairaudit as fa
from fairaudit import IntervalOptions
from fairaudit.statistics.intervals import fairness_intervals

ROOT = Path(__file__).resolve().parents[2]
GPT35 = ROOT / "examples" / "llm_hiring" / "gpt35.toml"


def num(v):
    return math.inf if v == "inf" else v


def _records(tmp_path):
    # one context; a: 12 of 40 selected, b: 30 of 40, c: 20 of 40
    rows = [("a", 1)] * 12 + [("a", 0)] * 28 + [("b", 1)] * 30 + [("b", 0)] * 10 + [("c", 1)] * 20 + [("c", 0)] * 20
    path = tmp_path / "r.csv"
    pd.DataFrame(rows, columns=["grp", "y"]).to_csv(path, index=False)
    return path


def _cp(k, n, level):
    ci = binomtest(k, n).proportion_ci(confidence_level=level, method="exact")
    return ci.low, ci.high


def test_audit_confidence_fills_every_interval_by_hand(tmp_path, capsys):
    code, d, _ = run_json(
        capsys, "audit", _records(tmp_path), "--sensitive", "grp", "--outcome", "y", "--confidence", "0.9"
    )
    assert code == 0
    # one context: 3 cells share alpha = 0.1 (the groups are the cells, not counted twice)
    level = 1 - 0.1 / 3
    (la, ha), (lb, hb), (lc, hc) = _cp(12, 40, level), _cp(30, 40, level), _cp(20, 40, level)
    lo, hi = d["local"]["interval"]
    assert hi == pytest.approx(math.log(hb / la), rel=1e-7)  # b over a at the far corners
    assert lo == pytest.approx(math.log(lb / ha), rel=1e-7)  # b's floor over a's ceiling
    assert d["global"]["interval"] == pytest.approx([lo, hi], rel=1e-12)
    iv = d["intervals"]
    assert (iv["method"], iv["confidence"], iv["sets"]) == ("clopper-pearson", 0.9, 3)
    assert (iv["local"]["group"], iv["local"]["other_group"], iv["local"]["context"]) == ("b", "a", "all")
    # binary outcome: the gaps come with the same set; DP upper = max over pairs of hi_b - lo_a
    assert iv["demographic_parity"]["upper"] == pytest.approx(hb - la, rel=1e-7)
    assert iv["demographic_parity"]["lower"] == pytest.approx(lb - ha, rel=1e-7)
    cells = {c["group"]: c["interval"] for c in d["cells"]}
    assert cells["c"] == pytest.approx([lc, hc], rel=1e-7)


@pytest.mark.parametrize("method", ["multinomial", "bayes"])
def test_audit_method_names_itself_and_covers_the_estimate(tmp_path, capsys, method):
    code, d, _ = run_json(
        capsys,
        "audit",
        _records(tmp_path),
        "--sensitive",
        "grp",
        "--outcome",
        "y",
        "--confidence",
        "0.95",
        "--method",
        method,
        "--seed",
        "3",
    )
    assert code == 0 and d["intervals"]["method"] == method
    lo, hi = d["local"]["interval"]
    assert lo < math.log(30 / 12) < num(hi)
    if method == "bayes":
        assert (d["intervals"]["seed"], d["intervals"]["draws"], d["intervals"]["concentration"]) == (3, 4000, 1.0)


def test_audit_text_shows_intervals(tmp_path, capsys):
    code, out, _ = run(
        capsys, "audit", _records(tmp_path), "--sensitive", "grp", "--outcome", "y", "--confidence", "0.9"
    )
    assert code == 0 and "intervals: simultaneous 0.9 (clopper-pearson)" in out
    # one per metric line: five, as the records have no context (no true label) and so no equalized-odds line
    assert out.count("interval [") == 5 and "equalized odds" not in out


def test_audit_method_needs_confidence_and_bad_values_exit_2(tmp_path, capsys):
    path = _records(tmp_path)
    code, out, err = run(capsys, "audit", path, "--sensitive", "grp", "--outcome", "y", "--method", "bayes")
    assert code == 2 and "--method" in err and "--confidence" in err and len(err.strip().splitlines()) == 1
    code, _, err = run(
        capsys,
        "audit",
        path,
        "--sensitive",
        "grp",
        "--outcome",
        "y",
        "--confidence",
        "0.9",
        "--method",
        "bayes",
        "--draws",
        "10",
    )
    assert code == 2 and "draws" in err
    code, _, err = run(
        capsys,
        "audit",
        path,
        "--sensitive",
        "grp",
        "--outcome",
        "y",
        "--utility",
        "2 * u",
        "--confidence",
        "0.9",
        "--method",
        "clopper-pearson",
    )
    assert code == 2 and "clopper-pearson needs a 0/1 utility" in err


def test_audit_bounded_utility_uses_multinomial(tmp_path, capsys):
    path = tmp_path / "s.csv"
    pd.DataFrame({"grp": ["a"] * 30 + ["b"] * 30, "score": [0, 1, 2] * 20}).to_csv(path, index=False)
    code, d, _ = run_json(
        capsys, "audit", path, "--sensitive", "grp", "--outcome", "score", "--utility", "u / 2", "--confidence", "0.95"
    )
    assert code == 0 and d["intervals"]["method"] == "multinomial"
    # identical groups: the estimate is 0 and the interval's lower end is 0
    assert d["local"]["value"] == 0 and d["local"]["interval"][0] == 0


def test_certify_from_counts_reports_white_box_interval(capsys):
    code, d, _ = run_json(capsys, "certify", GPT35)
    assert code == 0
    obs = d["observed"]
    spec = fa.load_spec(GPT35)
    k = spec.kernel()
    table = fa.CountTable(k.counts, k.contexts, k.groups, k.decisions, ("job",), ("demo",), "rank")
    ref = fairness_intervals(
        table,
        spec.utility,
        IntervalOptions(confidence=0.95),
        sensitive_mechanism=spec.sensitive_mechanism,
        population=spec.population,
    )
    assert obs["local"]["interval"] == pytest.approx([ref.local_fairness.lower, ref.local_fairness.upper], rel=1e-12)
    assert obs["intervals"]["filtered"] is True and obs["intervals"]["method"] == "clopper-pearson"
    # the filtered certificate is far tighter than the model's own interval, and both cover their estimates
    own = d["unfiltered"]["local"]["interval"]
    assert obs["local"]["interval"][1] < own[0] < d["unfiltered"]["local"]["value"] < own[1]
    assert obs["local"]["interval"][0] <= obs["local"]["value"] <= obs["local"]["interval"][1]
    code, out, _ = run(capsys, "certify", GPT35)
    assert "white-box certificate L <= 0.113625 nats" in out and "evidence of unfairness L >= 0.0172078 nats" in out


def test_certify_confidence_and_method_flags(capsys):
    code, d, _ = run_json(capsys, "certify", GPT35, "--confidence", "0.8", "--method", "multinomial")
    iv = d["observed"]["intervals"]
    assert (iv["confidence"], iv["method"]) == (0.8, "multinomial")
    assert iv["demographic_parity"] is not None  # multinomial bounds U's whole distribution
    with pytest.raises(SystemExit) as exc:
        run(capsys, "certify", GPT35, "--confidence", "1.5")
    assert exc.value.code == 2 and "--confidence" in capsys.readouterr().err


def test_certify_probability_table_says_why_no_intervals(capsys):
    code, d, _ = run_json(capsys, "certify", ROOT / "examples" / "hr_office" / "hr_office.toml")
    assert "intervals" not in d["observed"]
    assert "probabilities, not counts" in d["observed"]["intervals_reason"]


def test_api_certify_without_confidence():
    c = fa.certify(GPT35, intervals=None)
    assert c.intervals is None and c.omitted["intervals"] == "no confidence level asked for"
    with pytest.raises(fa.InputError, match=r"^intervals: must be an IntervalOptions \(got 'float'\)$"):
        fa.certify(GPT35, intervals=0.95)


def test_interval_object_repeats_method_and_level():
    t = fa.count_records(pd.DataFrame({"g": list("aabb"), "y": [1, 0, 1, 1]}), sensitive=["g"], outcome="y")
    iv = fa.fairness_intervals(t, fa.indicator(1, t.decisions), fa.IntervalOptions(confidence=0.9))
    L = iv.local_fairness
    assert isinstance(L, fa.Interval) and (L.method, L.confidence) == ("clopper-pearson", 0.9)
    assert iv.table is t and iv.confidence == 0.9
    assert np.all(iv.cell_lower <= iv.cell_upper)
