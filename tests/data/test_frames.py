"""A fairlearn user's arrays audit in one call; sample weights; the per-group and per-metric frames.

Peers: fairlearn's ``MetricFrame`` (selection rates by group, with and without ``sample_weight`` through
``sample_params``, with control features) and ``demographic_parity_difference``; hand counts in exact fractions for
the weighted counts and Kish's effective sample sizes.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pandas as pd
import pytest
from _cli import run, run_json

import fairaudit as fa
from fairaudit import InputError, count_records

fairlearn_metrics = pytest.importorskip("fairlearn.metrics")


def _records(n=400, seed=3):
    rng = np.random.default_rng(seed)
    return {
        "y": rng.integers(0, 2, n),
        "race": rng.choice(["A", "B", "C"], n),
        "sex": rng.choice(["F", "M"], n),
        "site": rng.choice(["north", "south"], n),
        "w": rng.gamma(2.0, 1.5, n),
    }


@pytest.mark.parametrize("weighted", [False, True])
def test_selection_rates_match_fairlearn(weighted):
    r = _records()
    params = {"sample_params": {"selection_rate": {"sample_weight": r["w"]}}} if weighted else {}
    mf = fairlearn_metrics.MetricFrame(
        metrics={"selection_rate": fairlearn_metrics.selection_rate},
        y_true=r["y"],
        y_pred=r["y"],
        sensitive_features=pd.DataFrame({"race": r["race"], "sex": r["sex"]}),
        control_features=pd.Series(r["site"], name="site"),
        **params,
    )
    ours = fa.audit(
        y_pred=r["y"],
        sensitive_features=pd.DataFrame({"race": r["race"], "sex": r["sex"]}),
        control_features=pd.Series(r["site"], name="site"),
        records=fa.RecordOptions(weights=r["w"] if weighted else None),
    )
    theirs = mf.by_group["selection_rate"]
    by_group = ours.by_group
    assert by_group.index.names == ["site", "race x sex"]
    for (site, race, sex), rate in theirs.items():
        assert by_group.loc[(site, (race, sex)), "rate"] == pytest.approx(rate, rel=1e-14, abs=0)
    # demographic parity: the largest selection-rate difference over groups, fairlearn's number for a 0/1 outcome
    dpd = fairlearn_metrics.demographic_parity_difference(
        r["y"], r["y"], sensitive_features=r["race"], sample_weight=r["w"] if weighted else None
    )
    weights = fa.RecordOptions(weights=r["w"] if weighted else None)
    pooled = fa.audit(y_pred=r["y"], sensitive_features=r["race"], records=weights)
    assert pooled.observed.demographic_parity.value == pytest.approx(dpd, rel=1e-13)


def test_every_array_type_gives_the_same_audit():
    r = _records(60)
    expected = fa.audit(pd.DataFrame({"y_pred": r["y"], "race": r["race"]}), sensitive=["race"], outcome="y_pred")
    for y, s in (
        (r["y"].tolist(), {"race": r["race"].tolist()}),
        (r["y"], pd.Series(r["race"], name="race")),
        (pd.Series(r["y"]), pd.DataFrame({"race": r["race"]})),
    ):
        got = fa.audit(y_pred=y, sensitive_features=s)
        assert got.table.counts.tolist() == expected.table.counts.tolist()
        assert got.observed.global_fairness.value == expected.observed.global_fairness.value
    unnamed = fa.audit(y_pred=r["y"], sensitive_features=np.stack([r["race"], r["sex"]], axis=1))
    assert unnamed.table.sensitive_columns == ("sensitive_feature_0", "sensitive_feature_1")


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"y_pred": [1, 0, 1], "sensitive_features": ["a", "b"]}, "sensitive_features: has 2 rows where y_pred has 3"),
        (
            {"y_pred": [1, 0], "sensitive_features": ["a", "b"], "records": fa.RecordOptions(weights=[1.0])},
            "weights: has 1 rows where y_pred has 2",
        ),
        (
            {"y_pred": [1, 0], "sensitive_features": ["a", "b"], "records": fa.RecordOptions(weights="w")},
            "weights: names a column of a DataFrame `data`; with arrays give one weight per record (got 'w')",
        ),
        ({"sensitive_features": ["a", "b"]}, "y_pred: give the decisions, one per record"),
        ({"y_pred": [1, 0], "control_features": ["x", "y"]}, "sensitive_features: give the sensitive feature(s)"),
        ({"control_features": ["x", "y"]}, "control_features: goes with y_pred and sensitive_features"),
        (
            {"y_pred": pd.Series([1, 0], name="race"), "sensitive_features": pd.Series(["a", "b"], name="race")},
            "sensitive_features: names a column that another argument names too",
        ),
        (
            {"y_pred": [[1, 0], [0, 1]], "sensitive_features": ["a", "b"]},
            "y_pred: must be a non-empty list or array of one",
        ),
        (
            {"y_pred": [1, 0], "sensitive_features": ["a", "b"], "records": fa.RecordOptions(weights=[1.0, np.nan])},
            "column 'sample_weight': has 1 missing values (drop those rows: `dropna`)",
        ),
    ],
)
def test_array_errors_name_the_parameter(kwargs, message):
    with pytest.raises(InputError) as err:
        fa.audit(**kwargs)
    assert str(err.value).startswith(message) or message in str(err.value), str(err.value)
    assert "--" not in str(err.value)  # no flag names in Python errors


def test_data_and_arrays_together_are_refused():
    with pytest.raises(InputError, match="^data: give records as data or as arrays"):
        fa.audit(pd.DataFrame({"y": [1]}), y_pred=[1], sensitive_features=["a"])


# ---------------------------------------------------------------- weights: counts and Kish's effective sizes


def test_weighted_counts_and_effective_sizes_by_hand():
    df = pd.DataFrame(
        {"g": ["a", "a", "a", "b", "b"], "y": [1, 0, 1, 1, 0], "w": [1.0, 3.0, 0.5, 2.0, 2.0]},
    )
    t = count_records(df, sensitive="g", outcome="y", weights="w")
    assert t.counts.tolist() == [[[3.0, 1.5], [2.0, 2.0]]]
    assert t.squares.tolist() == [[[9.0, 1.25], [4.0, 4.0]]]
    assert (t.n, t.weight_column) == (8.5, "w")
    # cell a: W = 4.5, S = 10.25, n_eff = W^2 / S = 81/41; counts scaled by n_eff / W = W / S = 18/41
    scale_a, scale_b = Fraction(9, 2) / Fraction(41, 4), Fraction(4, 8)
    want = [[[float(3 * scale_a), float(Fraction(3, 2) * scale_a)], [float(2 * scale_b), float(2 * scale_b)]]]
    assert np.allclose(t.effective_counts(), want, rtol=1e-15, atol=0)
    assert float(t.effective_counts().sum()) == pytest.approx(float(Fraction(81, 41) + 2), rel=1e-15)


@pytest.mark.parametrize("method", ["clopper-pearson", "multinomial", "bayes"])
def test_unit_and_constant_weights_give_the_unweighted_intervals(method):
    r = _records(300)
    df = pd.DataFrame({"y": r["y"], "race": r["race"], "site": r["site"], "one": 1.0, "two": 2.0})
    kw = dict(
        sensitive=["race"],
        outcome="y",
        context=["site"],
        intervals=fa.IntervalOptions(confidence=0.9, method=method, draws=400),
    )
    plain = fa.audit(df, **kw).intervals
    for column in ("one", "two"):  # n_eff = n whatever the constant weight
        weighted = fa.audit(df, records=fa.RecordOptions(weights=column), **kw).intervals
        for name in ("local_fairness", "global_fairness"):
            a, b = getattr(plain, name), getattr(weighted, name)
            assert (b.lower, b.estimate) == pytest.approx((a.lower, a.estimate), rel=1e-12, abs=1e-15)
            assert b.upper == pytest.approx(a.upper, rel=1e-12, abs=1e-15)


def test_uneven_weights_widen_the_intervals():
    r = _records(300)
    df = pd.DataFrame({"y": r["y"], "race": r["race"], "w": np.where(np.arange(300) % 2 == 0, 1.0, 5.0)})
    kw = dict(sensitive=["race"], outcome="y", intervals=fa.IntervalOptions(confidence=0.9))
    plain = fa.audit(df, **kw).intervals
    # n_eff = n (1 + 5)^2 / (2 (1 + 25)) = 0.69 n per cell
    weighted = fa.audit(df, records=fa.RecordOptions(weights="w"), **kw).intervals
    assert np.all(weighted.cell_upper - weighted.cell_lower > plain.cell_upper - plain.cell_lower)


def test_weights_errors_name_the_column():
    df = pd.DataFrame({"g": ["a", "b"], "y": [1, 0], "w": [1.0, np.nan], "t": ["x", "y"]})
    with pytest.raises(InputError, match=r"^column 'w': has 1 missing values"):
        count_records(df, sensitive="g", outcome="y", weights="w")
    assert count_records(df, sensitive="g", outcome="y", weights="w", dropna=True).n == 1.0
    with pytest.raises(
        InputError,
        match=r"^column 't': must hold finite non-negative numbers; data row 1 \(g='a', y='1'\) is not \(got 'x'\)$",
    ):
        count_records(df, sensitive="g", outcome="y", weights="t")
    with pytest.raises(InputError, match=r"^weights: unknown column"):
        count_records(df, sensitive="g", outcome="y", weights="nope")


def test_cli_weights(tmp_path, capsys):
    path = tmp_path / "r.csv"
    pd.DataFrame({"g": ["a", "a", "b", "b"], "y": [1, 0, 1, 0], "w": [3.0, 1.0, 1.0, 1.0]}).to_csv(path, index=False)
    code, report, err = run_json(capsys, "audit", path, "--sensitive", "g", "--outcome", "y", "--weights", "w")
    assert code == 0, err
    assert report["weight_column"] == "w" and report["n"] == 6.0
    assert [(g["label"], g["n"]) for g in report["groups"]] == [("a", 4.0), ("b", 2.0)]
    assert report["global"]["ratio"] == 1.5  # 3/4 against 1/2
    code, _, err = run(capsys, "audit", path, "--sensitive", "g", "--outcome", "y", "--weights", "g")
    assert (code, err) == (
        2,
        "fairaudit: error: column 'g': must hold finite non-negative numbers; data row 1 (g='a', y='1') is not (got 'a')\n",
    )


def test_weighted_reports_say_total_weight(tmp_path, capsys):
    path = tmp_path / "r.csv"
    pd.DataFrame({"g": ["a", "a", "b", "b"], "y": [1, 0, 1, 0], "w": [3.5, 1.0, 1.0, 1.0]}).to_csv(path, index=False)
    args = ["audit", path, "--sensitive", "g", "--outcome", "y", "--weights", "w"]
    code, out, err = run(capsys, *args)
    assert out.splitlines()[0] == "fairaudit audit: total weight 6.5 (weights w); sensitive g; outcome y; context none"
    assert "records per group: a 4.5, b 2" in out and err == ""
    code, out, _ = run(capsys, *args, "--format", "markdown")
    assert out.startswith("# fairaudit audit: total weight 6.5 (weights w)\n")


def test_y_true_is_the_context_of_fairlearns_equalized_odds():
    """fairlearn's names, y_true included: the true label is a context, and the largest gap of E[g] within a label
    is fairlearn's equalized_odds_difference (its second route, on the same arrays)."""
    from fairlearn.metrics import demographic_parity_difference, equalized_odds_difference

    y_true = [1, 1, 0, 0, 1, 1, 0, 0, 1, 0]
    y_pred = [1, 1, 1, 0, 1, 0, 0, 0, 1, 1]
    groups = list("aaaabbbbab")
    r = fa.audit(y_true=y_true, y_pred=y_pred, sensitive_features=groups)
    assert r.table.context_columns == ("y_true",)
    gaps = r.gaps_on_g.to_dict()
    assert gaps["equalized_odds"]["value"] == pytest.approx(
        equalized_odds_difference(y_true, y_pred, sensitive_features=groups), rel=1e-12
    )
    assert gaps["demographic_parity"]["value"] == pytest.approx(
        demographic_parity_difference(y_true, y_pred, sensitive_features=groups), rel=1e-12
    )
    with pytest.raises(InputError, match="^y_true: goes with y_pred and sensitive_features"):
        fa.audit(pd.DataFrame({"g": groups, "y": y_pred}), sensitive=["g"], outcome="y", y_true=y_true)
    with pytest.raises(InputError, match="^y_true:"):
        fa.audit(y_true=y_true[:3], y_pred=y_pred, sensitive_features=groups)
