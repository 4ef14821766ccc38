"""The NYC Local Law 144 bias-audit table: exact rates and ratios, the exact joint-box intervals, the threshold marks,
the headline over the tables' categories, the report's order, and the tidy DataFrame.

Expected values come from routes that share no code with fairaudit.statistics.ll144: exact fractions of hand counts,
pandas groupbys of the records, and a brute force over the vertices (and a grid) of the box of rates.
"""

from __future__ import annotations

import itertools
import math
from fractions import Fraction
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from _cli import run, run_json
from hypothesis import given
from hypothesis import strategies as st

from fairaudit import InputError, count_records, indicator
from fairaudit.statistics.ll144 import VERDICTS, FourFifths, impact_ratios
from fairaudit.statistics.rate_ratio import ratio_range

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "impact_ratio" / "applicants.csv"
COMMAND = ["audit", EXAMPLE, "--sensitive", "sex,race", "--outcome", "selected", "--dropna", "--report", "impact-ratio"]


# ------------------------------------------------------------------------------------------ exact ratio ranges
def _ratio(p: list[Fraction], i: int) -> Fraction:
    """p_i / max_j p_j, 0/0 = 1 (every rate 0: parity), in exact arithmetic."""
    top = max(p)
    return Fraction(1) if top == 0 else p[i] / top


def _box_extremes(lower: list[Fraction], upper: list[Fraction]) -> list[tuple[Fraction, Fraction]]:
    """Each ratio's min and max over the vertices of the box (the ratio is monotone in each rate)."""
    values = [[_ratio(list(v), i) for v in itertools.product(*zip(lower, upper))] for i in range(len(lower))]
    return [(min(v), max(v)) for v in values]


ends = st.fractions(min_value=0, max_value=1, max_denominator=12)
boxes = st.lists(st.tuples(ends, ends).map(sorted), min_size=1, max_size=5)


@pytest.mark.slow
@given(boxes)
def test_ratio_range_is_the_exact_range_over_the_box(box):
    lower, upper = [b[0] for b in box], [b[1] for b in box]
    low, high = ratio_range([float(v) for v in lower], [float(v) for v in upper])
    for (want_low, want_high), got_low, got_high in zip(_box_extremes(lower, upper), low, high):
        assert got_low == pytest.approx(float(want_low), abs=1e-12)
        assert got_high == pytest.approx(float(want_high), abs=1e-12)


@pytest.mark.slow
@given(st.lists(st.tuples(ends, ends).map(sorted), min_size=2, max_size=3))
def test_ratio_range_contains_every_ratio_on_a_grid_of_the_box(box):
    lower, upper = [float(b[0]) for b in box], [float(b[1]) for b in box]
    low, high = ratio_range(lower, upper)
    axes = [np.linspace(lo, hi, 7) for lo, hi in zip(lower, upper)]
    for p in itertools.product(*axes):
        top = max(p)
        for i in range(len(p)):
            r = 1.0 if top == 0 else p[i] / top
            assert low[i] - 1e-12 <= r <= high[i] + 1e-12


def test_ratio_range_edge_cases():
    # one category: its ratio is 1 whatever its rate; all rates 0: parity (0/0 = 1)
    assert [a.tolist() for a in ratio_range([0.2], [0.5])] == [[1.0], [1.0]]
    assert [a.tolist() for a in ratio_range([0.0, 0.0], [0.0, 0.0])] == [[1.0, 1.0], [1.0, 1.0]]
    # a rate surely highest (its lower end above the others' upper ends) has ratio exactly 1; the other's range
    # is [0.1 / 0.9, 0.3 / 0.6]; with the lower end 0 and another upper end above 0 a ratio reaches 0
    low, high = ratio_range([0.6, 0.1], [0.9, 0.3])
    assert (low[0], high[0]) == (1.0, 1.0) and (low[1], high[1]) == (0.1 / 0.9, 0.3 / 0.6)
    low, high = ratio_range([0.0, 0.2], [0.1, 0.4])
    assert (low[0], high[0]) == (0.0, 0.5) and (low[1], high[1]) == (1.0, 1.0)


def test_the_surely_highest_category_gets_exactly_one():
    """The issue's [0.77, 1]: a category whose rate is surely the highest on the simultaneous event has [1, 1]."""
    df = pd.DataFrame({"g": ["a"] * 1000 + ["b"] * 1000, "y": [1] * 900 + [0] * 100 + [1] * 100 + [0] * 900})
    box = FourFifths(adjustment="simultaneous")
    rows = {r.category: r for r in impact_ratios(df, sensitive="g", outcome="y", four_fifths=box).rows}
    assert rows["a"].interval == (1.0, 1.0) and rows["a"].verdict == "not below"
    assert rows["b"].impact_ratio == float(Fraction(1, 9)) and rows["b"].verdict == "below, significant"
    assert rows["b"].interval[1] < 0.8 and rows["b"].comparator == "a"


# ------------------------------------------------------------------------------------------ rates and ratios
def test_ratios_are_the_exact_fractions_of_the_counts():
    """Each ratio is k_i n_b / (n_i k_b) rounded once: what a published figure rounds at any precision."""
    t = count_records(pd.read_csv(EXAMPLE).dropna(), sensitive=["sex", "race"], outcome="selected")
    rows = {(r.type, r.category): r for r in impact_ratios(t).rows}
    # hand counts (docs/ll144.md): women 29 of 77, men 32 of 70; Black 20 of 55, White 40 of 90
    assert rows[("sex", "Female")].impact_ratio == float(Fraction(29, 77) / Fraction(32, 70))
    assert rows[("sex", "Female")].rate == float(Fraction(29, 77))
    assert (rows[("sex", "Female")].n, rows[("sex", "Female")].selected) == (77, 29)
    assert rows[("race", "Black")].impact_ratio == float(Fraction(9, 11))
    assert rows[("sex x race", ("Female", "Black"))].impact_ratio == 0.64


def test_verdicts_follow_the_ratio_the_adjusted_p_value_and_the_threshold():
    """Second route: scipy's Fisher test against the highest rate of each type, Holm's step-down by hand."""
    from scipy.stats import fisher_exact

    df = pd.read_csv(EXAMPLE).dropna()
    for threshold in (0.3, 0.5, 0.8, 0.9, 1.0):
        report = impact_ratios(df, sensitive=["sex", "race"], outcome="selected", four_fifths=FourFifths(threshold))
        assert report.four_fifths.threshold == threshold and report.test == "fisher"
        tested = [r for r in report.rows if not r.excluded and r.category != r.comparator]
        raw = []
        for r in tested:
            c = next(x for x in report.rows if x.type == r.type and x.category == r.comparator)
            table = [[round(r.selected), round(r.n - r.selected)], [round(c.selected), round(c.n - c.selected)]]
            raw.append(fisher_exact(table).pvalue)
        order = sorted(range(len(raw)), key=raw.__getitem__)
        holm, running = [0.0] * len(raw), 0.0
        for rank, i in enumerate(order):
            running = max(running, min(1.0, raw[i] * (len(raw) - rank)))
            holm[i] = running
        assert report.tested == len(tested)
        for r, p in zip(tested, holm, strict=True):
            assert r.p_value == pytest.approx(p, rel=1e-12)
            want = (
                "not below"
                if r.impact_ratio >= threshold
                else "below, significant"
                if p < 0.05
                else "below, inconclusive"
            )
            assert r.verdict == want and r.verdict in VERDICTS
        for r in report.rows:
            assert (r.verdict is None) == r.excluded
    # women 29/77 against men 32/70: ratio 0.8239, not significant (Fisher p 0.51)
    female = next(r for r in impact_ratios(df, sensitive="sex", outcome="selected", four_fifths=FourFifths(0.9)).rows)
    assert female.verdict == "below, inconclusive" and female.comparator == "Male"
    for bad in (0, -0.1, 1.5, float("nan")):
        with pytest.raises(InputError, match="^threshold"):
            FourFifths(bad)


# ------------------------------------------------------------------------------------------ the tidy DataFrame
def _groupby_table(df: pd.DataFrame, column, y: str) -> pd.DataFrame:
    """n, selected, rate and the ratio to the highest rate among categories of >= 2% of the records, by pandas."""
    g = df.groupby(column)[y].agg(n="size", selected="sum")
    g["rate"] = g["selected"] / g["n"]
    included = g["n"] >= 0.02 * len(df)
    g["impact_ratio"] = (g["rate"] / g.loc[included, "rate"].max()).where(included)
    return g


def test_to_frame_matches_a_pandas_groupby():
    df = pd.read_csv(EXAMPLE).dropna(subset=["sex"])
    frame = impact_ratios(df, sensitive=["sex", "race"], outcome="selected").to_frame()
    assert list(frame.columns) == [
        "type",
        "category",
        "n",
        "selected",
        "selection_rate",
        "impact_ratio",
        "ci_low",
        "ci_high",
        "p_value",
        "verdict",
        "comparator",
        "unknown_low",
        "unknown_high",
        "excluded",
    ]
    assert frame["n"].dtype == np.int64 and frame["selected"].dtype == np.int64 and frame["excluded"].dtype == bool
    assert all(isinstance(c, str) for c in frame["category"])
    for kind, column in (("sex", "sex"), ("race", "race"), ("sex x race", ["sex", "race"])):
        want = _groupby_table(df, column, "selected")
        want.index = [" & ".join(i) if isinstance(i, tuple) else i for i in want.index]
        got = frame[frame["type"] == kind].set_index("category")
        assert list(got.index) == list(want.index)
        assert got["n"].tolist() == want["n"].tolist() and got["selected"].tolist() == want["selected"].tolist()
        np.testing.assert_allclose(got["selection_rate"], want["rate"], rtol=1e-15)
        np.testing.assert_allclose(got["impact_ratio"], want["impact_ratio"], rtol=1e-15)  # NaN where excluded
        assert (got["excluded"] == want["impact_ratio"].isna()).all()
        assert got.loc[got["excluded"], ["ci_low", "ci_high"]].isna().all().all()
        assert ((got["ci_low"] <= got["impact_ratio"]) | got["ci_low"].isna()).all()
        assert got["ci_low"].isna().sum() == got["excluded"].sum() + 1  # and the comparator
    assert frame.attrs["threshold"] == 0.8 and frame.attrs["unknown"] == {"sex": 0.0, "race": 0.0, "sex x race": 0.0}


def test_dataframe_call_equals_the_count_table_call():
    df = pd.read_csv(EXAMPLE)
    t = count_records(df, sensitive=["sex", "race"], outcome="selected", dropna=True)
    a = impact_ratios(df, sensitive=["sex", "race"], outcome="selected", dropna=True)
    b = impact_ratios(t, indicator(1, t.decisions))
    assert a.rows == b.rows and a.unknown == b.unknown == {"sex": 3.0, "race": 0.0, "sex x race": 3.0}
    assert impact_ratios(df, "u == 1", sensitive=["sex", "race"], outcome="selected", dropna=True).rows == a.rows
    assert impact_ratios(df, sensitive=["sex", "race"], outcome="selected", dropna=True, positive=1).rows == a.rows
    with pytest.raises(InputError, match="^sensitive: goes with a DataFrame"):
        impact_ratios(t, sensitive=["sex"])
    with pytest.raises(InputError, match="^data: must be a CountTable or a pandas DataFrame"):
        impact_ratios([1, 2, 3])
    with pytest.raises(InputError, match="^positive: give positive or utility, not both"):
        impact_ratios(df, "u == 1", sensitive="sex", outcome="selected", dropna=True, positive=1)


def test_scoring_frame_on_real_scores(shared_data):
    """COMPAS decile scores by race: the share above the whole sample's median, against pandas."""
    df = pd.read_csv(shared_data / "compas" / "compas-scores-two-years.csv", usecols=["race", "sex", "decile_score"])
    frame = impact_ratios(df, sensitive=["race", "sex"], outcome="decile_score").to_frame()
    median = df["decile_score"].median()
    assert frame.attrs["median"] == median and "scoring_rate" in frame and "above_median" in frame
    df["above"] = (df["decile_score"] > median).astype(int)
    want = _groupby_table(df, "race", "above")
    got = frame[frame["type"] == "race"].set_index("category")
    assert got["above_median"].tolist() == want["selected"].tolist()
    np.testing.assert_allclose(got["impact_ratio"], want["impact_ratio"], rtol=1e-15)


def test_selection_rates_on_real_rankings(shared_data):
    """GPT-3.5's rank-1 picks of 8 resumes (Bloomberg): the selection rate per race and gender, against pandas."""
    df = pd.read_csv(shared_data / "llm_hiring" / "bloomberg_gpt_resume_rankings_long.csv")
    df = df[(df["model_dir"] == df["model_dir"].iloc[0]) & (df["oversampled"] == 0)].copy()
    df["selected"] = (df["gpt_rank"] == 1).astype(int)
    frame = impact_ratios(df, sensitive=["race", "gender"], outcome="selected").to_frame()
    for kind, column in (("race", "race"), ("gender", "gender")):
        want = _groupby_table(df, column, "selected")
        got = frame[frame["type"] == kind].set_index("category")
        assert got["n"].tolist() == want["n"].tolist()
        np.testing.assert_allclose(got["impact_ratio"], want["impact_ratio"], rtol=1e-15)


# ------------------------------------------------------------------------------------------ the command's report
def test_headline_uses_the_tables_categories(capsys, tmp_path):
    """A 14-applicant category (1.4%) with no one selected: left out of the tables and of L and L-bar alike."""
    rows = [("a", 1)] * 300 + [("a", 0)] * 200 + [("b", 1)] * 250 + [("b", 0)] * 236 + [("c", 0)] * 14
    path = tmp_path / "small.csv"
    pd.DataFrame(rows, columns=["g", "selected"]).to_csv(path, index=False)
    code, d, err = run_json(
        capsys, "audit", path, "--sensitive", "g", "--outcome", "selected", "--report", "impact-ratio"
    )
    assert code == 0, err
    lowest = Fraction(250, 486) / Fraction(300, 500)  # b against a; c (14 of 1000 < 2%) left out
    assert [g["label"] for g in d["groups"]] == ["a", "b"] and d["n"] == 986
    assert d["global"]["value"] == pytest.approx(-math.log(lowest), rel=1e-12)
    assert d["local"]["value"] == pytest.approx(-math.log(lowest), rel=1e-12)
    assert d["impact_ratio_details"]["headline"] == {
        "type": "g",
        "left_out": [{"category": "c", "n": 14.0}],
        "includes_small": False,
    }
    code, out, _ = run(capsys, "audit", path, "--sensitive", "g", "--outcome", "selected", "--report", "impact-ratio")
    assert (
        "note: the metrics are over the categories of the impact ratios by g; left out, under 2% of the data: " in out
    )
    assert "c (14 records)" in out
    assert f"is L-bar = -ln 0.8573 = {-math.log(lowest):.6g} nats over its categories" in out


def test_headline_says_when_it_includes_small_categories(capsys, tmp_path):
    """Sixty categories of 1/60 each (< 2%): no ratio, so the metrics keep every category and say so."""
    df = pd.DataFrame({"g": [f"g{i:02d}" for i in range(60)] * 2, "selected": [1] * 60 + [0] * 60})
    path = tmp_path / "many.csv"
    df.to_csv(path, index=False)
    args = ("audit", path, "--sensitive", "g", "--outcome", "selected", "--report", "impact-ratio")
    code, d, err = run_json(capsys, *args)
    assert code == 0, err
    assert len(d["groups"]) == 60 and d["impact_ratio_details"]["headline"]["includes_small"]
    code, out, _ = run(capsys, *args)
    assert "note: the metrics include the categories under 2% of the data that the impact ratios by g leave out" in out


def test_reports_lead_with_the_impact_ratios(capsys):
    pytest.importorskip("jinja2")
    pytest.importorskip("matplotlib")
    code, text, _ = run(capsys, *COMMAND)
    assert code == 0 and text.startswith("impact ratios (NYC Local Law 144 bias audit): 147 applicants;")
    assert (
        text.index("impact ratios by sex x race:") < text.index("fairaudit audit: 145 records") < text.index("metrics:")
    )
    code, md, _ = run(capsys, *COMMAND, "--format", "markdown")
    assert md.startswith("# impact ratios") and md.index("## By sex x race") < md.index("## Metrics")
    code, html, _ = run(capsys, *COMMAND, "--format", "html")
    assert code == 0
    assert html.index("<h2>Impact ratios by sex</h2>") < html.index("<h2>The audit: 145 records</h2>")
    assert html.index("<h2>The audit: 145 records</h2>") < html.index("<h2>Metrics</h2>")
    assert html.index("<h1>impact ratios (NYC Local Law 144 bias audit)") < html.index("<h2>Impact ratios by sex</h2>")
    # the numbers align right, the p-value among them (Female's row: 77 applicants, rate, ratio, interval, p 1)
    female = html[html.index("<td>Female</td>") : html.index("</tr>", html.index("<td>Female</td>"))]
    assert female.count('<td class="num">') == 4 and '<td class="num">1</td>' in female


def test_verdicts_in_every_format(capsys):
    pytest.importorskip("jinja2")
    pytest.importorskip("matplotlib")
    code, d, _ = run_json(capsys, *COMMAND, "--threshold", "0.7", "--adjustment", "none", "--test", "z")
    details = d["impact_ratio_details"]
    assert code == 0 and (details["threshold"], details["adjustment"], details["test"]) == (0.7, "none", "z")
    verdicts = {(r["type"], r["category"]): r["verdict"] for r in d["impact_ratios"]}
    assert verdicts[("sex", "Male")] == "not below" and verdicts[("race", "Asian")] is None
    assert verdicts[("sex x race", "Female & Black")] == "below, inconclusive"  # 8/25 against 20/40: 0.64
    for fmt in ("text", "markdown", "html"):
        code, out, _ = run(capsys, *COMMAND, "--threshold", "0.7", "--format", fmt)
        assert code == 0 and "threshold 0.7" in out and "not below" in out and "below, inconclusive" in out
        assert "Holm-adjusted" in out


@pytest.mark.parametrize("value", ["0", "2", "nan"])
def test_bad_threshold_exits_2_with_one_line(capsys, value):
    code, out, err = run(capsys, *COMMAND, "--threshold", value)
    assert (code, out) == (2, "") and err.count("\n") == 1
    assert err.startswith("fairaudit: error: --threshold: must be a finite number > 0 and <= 1 (got ")


def test_threshold_without_the_report_exits_2(capsys):
    code, out, err = run(capsys, *COMMAND[:-2], "--threshold", "0.8")
    assert code == 2 and out == ""
    assert (
        err == "fairaudit: error: --threshold: goes with the impact ratios: give --report impact-ratio too (got 0.8)\n"
    )


# ------------------------------------------------------------------------------------------ printed precision
def _half_up(x: Fraction, digits: int) -> Fraction:
    """x rounded half up to ``digits`` decimals, in integers (x >= 0)."""
    scale = 10**digits
    return Fraction(math.floor(x * scale + Fraction(1, 2)), scale)


@given(st.integers(0, 5000), st.integers(1, 5000), st.integers(0, 4))
def test_round_half_up_rounds_the_exact_fraction(k, n, digits):
    from fairaudit.statistics.ll144 import round_half_up

    x = Fraction(min(k, n), n)
    assert round_half_up(float(x), digits) == float(_half_up(x, digits))
    scale = 10**digits
    assert round_half_up(float(x), digits, "down") == float(Fraction(math.floor(x * scale), scale))
    assert round_half_up(float(x), digits, "up") == float(Fraction(math.ceil(x * scale), scale))


def test_frame_and_tables_at_a_printed_precision(capsys):
    """A rate of 5/16 = 0.3125 prints 0.313 at 3 decimals (half up, as published), where round() gives 0.312."""
    df = pd.DataFrame({"g": ["a"] * 16 + ["b"] * 16, "y": [1] * 5 + [0] * 11 + [1] * 10 + [0] * 6})
    frame = impact_ratios(df, sensitive="g", outcome="y").to_frame(digits=3)
    assert frame["selection_rate"].tolist() == [0.313, 0.625] and frame["impact_ratio"].tolist() == [0.5, 1.0]
    exact = impact_ratios(df, sensitive="g", outcome="y").to_frame()
    has = exact["ci_low"].notna()  # (the comparator, b, has no interval)
    assert has.tolist() == [True, False]
    assert (frame["ci_low"][has] <= exact["ci_low"][has]).all() and (
        frame["ci_high"][has] >= exact["ci_high"][has]
    ).all()
    code, out, _ = run(capsys, *COMMAND, "--digits", "2")
    assert code == 0
    assert "  Female    77                    0.38            0.82" in out
    assert "  Female & Black  25                    0.32            0.64" in out
    code, out, err = run(capsys, *COMMAND[:-2], "--digits", "2")
    assert (code, out) == (2, "") and err.startswith("fairaudit: error: --digits: goes with the impact ratios")


def test_round_half_up_refuses_an_unknown_direction_naming_how():
    from fairaudit import InputError
    from fairaudit.statistics.ll144 import round_half_up

    with pytest.raises(InputError, match=r"^how: must be 'half up', 'down' or 'up' \(got 'sideways'\)$"):
        round_half_up(0.5, 1, "sideways")
    assert (round_half_up(0.125, 2, "down"), round_half_up(0.125, 2, "up")) == (0.12, 0.13)  # 1/8 between them


def test_the_issues_two_thousand_applicants():
    """2,000 applicants: Asian 85 of 218 (ratio 0.97) is not below by default; Black 135 of 520 (0.65) is below and
    significant (Fisher's p about 1e-7 against White's 320 of 800, Holm over three)."""
    counts = {"White": (800, 320), "Black": (520, 135), "Asian": (218, 85), "Hispanic": (462, 166)}
    race = [c for c, (n, _) in counts.items() for _ in range(n)]
    selected = [int(i < k) for _, (n, k) in counts.items() for i in range(n)]
    df = pd.DataFrame({"race": race, "selected": selected})
    rows = {r.category: r for r in impact_ratios(df, sensitive="race", outcome="selected").rows}
    assert rows["Asian"].impact_ratio == pytest.approx(float(Fraction(85, 218) / Fraction(320, 800)), rel=1e-15)
    assert rows["Asian"].verdict == "not below"
    assert rows["Black"].impact_ratio == pytest.approx(float(Fraction(135, 520) / Fraction(2, 5)), rel=1e-15)
    assert rows["Black"].verdict == "below, significant" and rows["Black"].p_value < 1e-4
    lo, hi = rows["Black"].interval
    assert lo < rows["Black"].impact_ratio < hi < 0.8


def test_counts_that_are_not_whole_give_the_ratios_of_weights(tmp_path, capsys):
    """5.5 applicants of whom 2.5 selected are used as given (the issue's 0.6667 came from rounding them), as the
    same rows read as weighted records give them; and in the header the total is 13.5, not 13."""
    rows = [("a", 1, 2.5), ("a", 0, 3.0), ("b", 1, 2.6), ("b", 0, 2.6), ("c", 1, 1.0), ("c", 0, 1.8)]
    counted, weighted = tmp_path / "counts.csv", tmp_path / "records.csv"
    pd.DataFrame(rows, columns=["g", "y", "n"]).to_csv(counted, index=False)
    pd.DataFrame(rows, columns=["g", "y", "w"]).to_csv(weighted, index=False)
    both = ["--sensitive", "g", "--outcome", "y", "--positive", "1", "--report", "impact-ratio"]
    code, by_count, err = run_json(capsys, "audit", counted, "--count", "n", *both)
    assert code == 0, err
    code, by_weight, err = run_json(capsys, "audit", weighted, "--weights", "w", *both)
    assert code == 0, err
    ratios = {r["category"]: r["impact_ratio"] for r in by_count["impact_ratios"]}
    assert ratios == {r["category"]: r["impact_ratio"] for r in by_weight["impact_ratios"]}
    assert ratios["a"] == pytest.approx((2.5 / 5.5) / 0.5, rel=1e-15) and by_count["n"] == 13.5
    assert by_count["impact_ratio_details"]["test"] == "z"
    code, text, _ = run(capsys, "audit", counted, "--count", "n", *both)
    assert "fairaudit audit: 13.5 records" in text and "records per group: a 5.5, b 5.2, c 2.8" in text


def test_the_rules_report_fields(capsys):
    """Data source and dates as given (6 RCNY 5-303), excluded categories with their applicants, share and rate."""
    args = [*COMMAND, "--data-source", "test", "--audit-date", "2026-11-29", "--distribution-date", "2024-01-15"]
    code, d, _ = run_json(capsys, *args)
    details = d["impact_ratio_details"]
    assert code == 0 and (details["data_source"], details["audit_date"], details["distribution_date"]) == (
        "test", "2026-11-29", "2024-01-15",
    )  # fmt: skip
    for fmt in ("text", "markdown", "html"):
        code, out, _ = run(capsys, *args, "--format", fmt)
        assert code == 0 and "data: test data; audit date 2026-11-29" in out
        assert "race Asian (2 applicants, 1.4% of 147; rate 0.5)" in out
    code, out, err = run(capsys, *COMMAND, "--distribution-date", "2024-13-01")
    assert (code, out) == (2, "") and err == (
        "fairaudit: error: --distribution-date: must be a date YYYY-MM-DD (got '2024-13-01')\n"
    )
    code, _, err = run(capsys, *COMMAND[:-2], "--data-source", "test")
    assert code == 2 and "--data-source: goes with the impact ratios" in err
