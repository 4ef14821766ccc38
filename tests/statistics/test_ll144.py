"""Impact ratios (NYC Local Law 144, 6 RCNY 5-301): hand computations in exact fractions, the 2% rule, unknown
categories, scoring rates about the median, simultaneous intervals (and their coverage on simulated data), the CLI.
"""

from __future__ import annotations

from fractions import Fraction
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from _cli import run, run_json

from fairaudit import InputError, count_file, count_records, indicator
from fairaudit.statistics.impact_inputs import median_score, scoring_utility
from fairaudit.statistics.ll144 import FourFifths, impact_ratios

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "impact_ratio" / "applicants.csv"
COMMAND = ["audit", EXAMPLE, "--sensitive", "sex,race", "--outcome", "selected", "--dropna", "--report", "impact-ratio"]

# the shipped example, by hand: (sex, race) -> (applicants, selected); 3 more records have no sex
HAND = {("Male", "White"): (40, 20), ("Male", "Black"): (30, 12), ("Female", "White"): (50, 20)}
HAND |= {("Female", "Black"): (25, 8), ("Female", "Asian"): (2, 1)}


def _rates(key):
    """Per category of one type (a function of (sex, race)), (applicants, Fraction rate) from HAND."""
    out: dict = {}
    for cell, (n, k) in HAND.items():
        c = key(cell)
        out[c] = (out.get(c, (0, 0))[0] + n, out.get(c, (0, 0))[1] + k)
    return {c: (n, Fraction(k, n)) for c, (n, k) in out.items()}


def test_shipped_example_matches_the_hand_computation():
    t = count_file(EXAMPLE, sensitive=["sex", "race"], outcome="selected", dropna=True)
    report = impact_ratios(t, indicator(1, t.decisions))
    total = sum(n for n, _ in HAND.values())  # 147 records with a known sex
    assert t.n == total
    for name, key in (("sex", lambda c: c[0]), ("race", lambda c: c[1]), ("sex x race", lambda c: c)):
        hand = _rates(key)
        included = {c: r for c, (n, r) in hand.items() if Fraction(n, total) >= Fraction(2, 100)}
        best = max(included.values())
        rows = [r for r in report.rows if r.type == name]
        assert [r.category for r in rows] == sorted(hand)
        for r in rows:
            n, rate = hand[r.category]
            assert (r.n, r.rate) == (n, float(rate))
            if r.category in included:
                assert not r.excluded and r.impact_ratio == pytest.approx(float(rate / best), rel=1e-15)
                if rate == best:  # the comparator: no test, no interval
                    assert r.interval is None and r.p_value is None and r.verdict == "not below"
                else:
                    lo, hi = r.interval
                    assert 0 <= lo <= r.impact_ratio <= hi and 0 < r.p_value <= 1
            else:
                assert r.excluded and r.impact_ratio is None and r.interval is None
    # Female 29/77 against Male 32/70; Black 20/55 against White 40/90; Female & Black 8/25 against Male & White 1/2
    by = {(r.type, r.category): r.impact_ratio for r in report.rows}
    assert by[("sex", "Female")] == pytest.approx(2030 / 2464, rel=1e-15)
    assert by[("race", "Black")] == pytest.approx(9 / 11, rel=1e-15)
    assert by[("sex x race", ("Female", "Black"))] == pytest.approx(0.64, rel=1e-15)
    assert report.unknown == {"sex": 3.0, "race": 0.0, "sex x race": 3.0}


def test_scoring_rate_is_the_share_above_the_whole_samples_median():
    df = pd.DataFrame({"g": ["a"] * 4 + ["b"] * 4, "score": [10, 20, 30, 40, 15, 25, 35, 35]})
    t = count_records(df, sensitive="g", outcome="score")
    # eight scores: the median is (25 + 30) / 2 = 27.5; a: 30, 40 above (2/4); b: 35, 35 above (2/4)
    assert median_score(t) == 27.5
    assert scoring_utility(t).name == "1{score > median 27.5}"
    report = impact_ratios(t)
    assert (report.rate, report.median) == ("scoring", 27.5)
    assert [(r.category, r.rate, r.impact_ratio) for r in report.rows] == [("a", 0.5, 1.0), ("b", 0.5, 1.0)]
    odd = count_records(df.iloc[:7], sensitive="g", outcome="score")
    assert median_score(odd) == 25  # seven scores: the fourth, 25


def test_errors_name_the_parameter():
    df = pd.DataFrame({"g": ["a", "b"], "y": ["yes", "no"], "s": [1, 5]})
    t = count_records(df, sensitive="g", outcome="y")
    with pytest.raises(InputError, match="^positive: the outcome 'y' has two values, 'no' and 'yes': say which one"):
        impact_ratios(t)
    with pytest.raises(InputError, match="^positive: say which outcome is a selection: the outcome is not a score"):
        median_score(t)
    from fairaudit import from_table

    half = from_table([0.5, 1.0], t.decisions)
    with pytest.raises(InputError, match="^utility: impact ratios need a 0/1 utility"):
        impact_ratios(t, half)
    with pytest.raises(InputError, match="^confidence"):
        FourFifths(confidence=1.5)
    with pytest.raises(InputError, match="^adjustment: must be one of holm, none, simultaneous"):
        FourFifths(adjustment="sidak")


@pytest.mark.parametrize("adjustment", ["simultaneous", "holm"])
def test_intervals_cover_the_true_ratios_simultaneously(adjustment):
    """Binomial samples from known rates: every ratio inside its interval, at least 90% of the time at 0.90 (Holm's
    intervals at Bonferroni's level cover the true rate over the comparator's true rate, all at once)."""
    rng = np.random.default_rng(11)
    rates = {"a": 0.30, "b": 0.22, "c": 0.40, "d": 0.35}
    sizes = {"a": 120, "b": 90, "c": 60, "d": 150}
    truth = {g: r / max(rates.values()) for g, r in rates.items()}
    hits, reps = 0, 300
    for _ in range(reps):
        counts = np.array([[[sizes[g] - k, k] for g, k in ((g, rng.binomial(sizes[g], rates[g])) for g in rates)]])
        from fairaudit.data.counts import CountTable

        t = CountTable(counts, ("all",), tuple(rates), (0, 1), (), ("g",), "y")
        rows = impact_ratios(
            t, indicator(1, (0, 1)), four_fifths=FourFifths(confidence=0.90, adjustment=adjustment)
        ).rows
        if adjustment == "simultaneous":
            hits += all(r.interval[0] <= truth[r.category] <= r.interval[1] for r in rows)
        else:
            hits += all(
                r.interval[0] <= rates[r.category] / rates[r.comparator] <= r.interval[1] for r in rows if r.interval
            )
    assert hits / reps >= 0.90


def test_weighted_impact_ratios_use_weighted_rates():
    df = pd.DataFrame({"g": ["a", "a", "b", "b"], "y": [1, 0, 1, 0], "w": [3.0, 1.0, 1.0, 1.0]})
    t = count_records(df, sensitive="g", outcome="y", weights="w")
    rows = impact_ratios(t, indicator(1, t.decisions)).rows
    assert [(r.category, r.n, r.rate, r.impact_ratio) for r in rows] == [("a", 4.0, 0.75, 1.0), ("b", 2.0, 0.5, 2 / 3)]


def test_cli_report(capsys):
    args = COMMAND
    code, report, err = run_json(capsys, *args)
    assert code == 0, err
    first = report["impact_ratios"][0]
    assert set(first) == {
        "type", "category", "n", "selected", "rate", "impact_ratio", "interval", "p_value", "verdict", "comparator",
        "unknown_range", "aclu_ranges", "excluded",
    }  # fmt: skip
    assert [r["type"] for r in report["impact_ratios"]] == ["sex"] * 2 + ["race"] * 3 + ["sex x race"] * 5
    assert report["impact_ratio_details"]["unknown"] == {"sex": 3.0, "race": 0.0, "sex x race": 3.0}
    asian = next(r for r in report["impact_ratios"] if r["category"] == "Asian")
    assert asian == {
        "type": "race",
        "category": "Asian",
        "n": 2.0,
        "selected": 1.0,
        "rate": 0.5,
        "impact_ratio": None,
        "interval": None,
        "p_value": None,
        "verdict": None,
        "comparator": None,
        "unknown_range": None,
        "aclu_ranges": None,
        "excluded": True,
    }
    for fmt in ("text", "markdown"):
        code, out, _ = run(capsys, *args, "--format", fmt)
        assert code == 0 and "impact ratio" in out and "records of unknown category: sex 3, sex x race 3" in out
    with pytest.raises(SystemExit) as exit_:  # argparse's choices: exit 2 with one line
        run(capsys, *args[:-1], "selection-rate")
    assert exit_.value.code == 2 and "--report" in capsys.readouterr().err


def test_markdown_and_html_tables(capsys, tmp_path):
    """The impact-ratio tables parse as tables (python-markdown; the stdlib HTML parser), one row per category."""
    markdown = pytest.importorskip("markdown")
    pytest.importorskip("jinja2")
    pytest.importorskip("matplotlib")
    from html.parser import HTMLParser

    args = COMMAND

    class Rows(HTMLParser):
        def __init__(self):
            super().__init__()
            self.tables, self.cells = [], None

        def handle_starttag(self, tag, attrs):
            if tag == "table":
                self.tables.append([])
            elif tag == "tr":
                self.tables[-1].append([])
            elif tag in ("td", "th"):
                self.cells = ""

        def handle_data(self, data):
            if self.cells is not None:
                self.cells += data

        def handle_endtag(self, tag):
            if tag in ("td", "th"):
                self.tables[-1][-1].append(self.cells.strip())
                self.cells = None

    for fmt, render in (("markdown", lambda t: markdown.markdown(t, extensions=["tables"])), ("html", lambda t: t)):
        code, out, _ = run(capsys, *args, "--format", fmt)
        assert code == 0
        parser = Rows()
        parser.feed(render(out))
        impact = [t for t in parser.tables if t and t[0][:2] == ["category", "number of applicants"]]
        assert [len(t) - 1 for t in impact] == [2, 3, 5]
        assert impact[2][1] == ["Female & Asian", "2", "0.5", "excluded (< 2%)", "", "", "", ""]
        assert impact[2][2] == [
            "Female & Black", "25", "0.32", "0.64", *impact[2][2][4:6], "[0.5785, 0.7269]", "below, inconclusive"
        ]  # fmt: skip


def test_the_unknown_records_range_by_hand():
    """The shipped example's 3 records of unknown sex (1 selected): women 29/77 against men 32/70 range from
    (29/79)/(33/71) (the 2 unselected with the women, the selected with the men) to (30/78)/(32/72)."""
    report = impact_ratios(pd.read_csv(EXAMPLE), sensitive=["sex", "race"], outcome="selected", dropna=True)
    by = {(r.type, r.category): r for r in report.rows}
    lo, hi = by[("sex", "Female")].unknown_range
    assert lo == float(Fraction(29, 79) / Fraction(33, 71)) and hi == float(Fraction(30, 78) / Fraction(32, 72))
    assert by[("sex", "Male")].unknown_range == (1.0, 1.0)
    assert by[("race", "Black")].unknown_range is None  # race is known for every record
    assert report.table.unknown_outcomes == (("sex", ((1, 1.0), (0, 2.0))), ("sex x race", ((1, 1.0), (0, 2.0))))
    # the ACLU's variants: all 3 in the row's category (selected, or not) over men's 32/70 held; 3 · 77/147 of them
    (lo, hi), (lo_p, hi_p) = by[("sex", "Female")].aclu_ranges
    assert (lo, hi) == pytest.approx((29 / 80 / (32 / 70), 32 / 80 / (32 / 70)), rel=1e-14)
    m = 3 * 77 / 147
    assert (lo_p, hi_p) == pytest.approx((29 / (77 + m) / (32 / 70), (29 + m) / (77 + m) / (32 / 70)), rel=1e-14)
