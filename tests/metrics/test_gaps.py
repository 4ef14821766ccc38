"""Gaps of E[g] (--gap-on g): fairlearn's demographic_parity_difference and equalized_odds_difference, to 1e-15.

Peers: fairlearn on ProPublica's COMPAS file (../shared/data; skipped without it) with the true label as the
context, and hand counts on a small table.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from _cli import run, run_json

import fairaudit as fa

fairlearn_metrics = pytest.importorskip("fairlearn.metrics")
COMPAS = Path(__file__).resolve().parents[3] / "shared" / "data" / "compas" / "compas-scores-two-years.csv"


def test_hand_counts():
    # a: x = p 2/2, x = q 1/2; b: p 1/2, q 0/2 -> pooled 3/4 vs 1/4; within p 1 vs 1/2, within q 1/2 vs 0
    df = pd.DataFrame({"g": list("aaaabbbb"), "y": [1, 1, 1, 0, 1, 0, 0, 0], "x": list("ppqqppqq")})
    gaps = fa.audit(df, sensitive=["g"], outcome="y", context=["x"]).gaps_on_g
    assert (gaps.demographic_parity.value, gaps.demographic_parity.group) == (0.5, "a")
    eo = gaps.equalized_odds
    assert (eo.value, eo.context, eo.group, eo.other_group) == (0.5, "p", "a", "b")


@pytest.mark.skipif(not COMPAS.exists(), reason=f"the shared COMPAS file is not here: {COMPAS}")
def test_compas_matches_fairlearn():
    df = pd.read_csv(COMPAS, usecols=["race", "decile_score", "two_year_recid"])
    df = df[df.race.isin(["African-American", "Caucasian"])]
    y_pred = (df.decile_score >= 5).astype(int).to_numpy()
    dp = fairlearn_metrics.demographic_parity_difference(df.two_year_recid, y_pred, sensitive_features=df.race)
    eo = fairlearn_metrics.equalized_odds_difference(df.two_year_recid, y_pred, sensitive_features=df.race)
    r = fa.audit(y_pred=y_pred, sensitive_features=df.race, control_features=df.two_year_recid)
    gaps = r.gaps_on_g
    assert gaps.equalized_odds.value == pytest.approx(eo, rel=1e-14)
    assert gaps.demographic_parity.value == pytest.approx(dp, rel=1e-14)
    assert gaps.demographic_parity.group == "African-American"
    # with U the decile, the distribution gap is the largest difference over every event of U: at least g's
    deciles = fa.audit(df, sensitive=["race"], outcome="decile_score", utility="u >= 5")
    assert deciles.gaps_on_g.demographic_parity.value == pytest.approx(dp, rel=1e-14)
    assert deciles.observed.demographic_parity.value >= dp - 1e-15


def test_cli_gap_on_g(tmp_path, capsys):
    path = tmp_path / "r.csv"
    pd.DataFrame({"g": list("aaaabbbb"), "y": [1, 1, 1, 0, 1, 0, 0, 0], "x": list("ppqqppqq")}).to_csv(
        path, index=False
    )
    args = ["audit", path, "--sensitive", "g", "--outcome", "y", "--context", "x", "--gap-on", "g"]
    code, report, err = run_json(capsys, *args)
    assert code == 0, err
    assert report["gaps_on_g"] == {
        "utility": "1{outcome = 1}",
        "demographic_parity": {"value": 0.5, "group": "a", "other_group": "b"},
        "equalized_odds": {"value": 0.5, "context": "p", "group": "a", "other_group": "b"},
    }
    code, out, _ = run(capsys, *args)
    assert "demographic parity gap of g  0.5 " in out and "equalized odds gap of g      0.5 " in out
    code, report, _ = run_json(capsys, *args[:-2])
    assert "gaps_on_g" not in report
    assert np.isfinite(report["demographic_parity"])
