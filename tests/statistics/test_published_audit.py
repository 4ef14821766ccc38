"""A published audit table, checked: hand-made tables with known inconsistencies, in the ACLU's format and plain."""

from __future__ import annotations

import io
from fractions import Fraction

import pandas as pd
import pytest

from fairaudit.base.errors import InputError
from fairaudit.statistics.missing_demographics import missing_data_bounds
from fairaudit.statistics.published_audit import check_published, printed


def _aclu_rows() -> pd.DataFrame:
    """Three audits in the ACLU dataset's columns (figures as text, as printed)."""
    rows = [
        # audit 1, sex: consistent, with 10 unknown of whom 3 selected
        ("a1", "sex", "Female", "Total", "100", "30", "0.30", "0.750"),
        ("a1", "sex", "Male", "Total", "120", "48", "0.40", "1.000"),
        ("a1", "sex", "Missing/Unknown", "Total", "10", "3", "0.30", "NA"),
        # audit 2, race: a rate off its counts, a ratio above 1, a category of 5% with no ratio
        ("a2", "race", "Total", "White", "200", "100", "0.50", "1.00"),
        ("a2", "race", "Total", "Black", "100", "40", "0.45", "0.80"),
        ("a2", "race", "Total", "Asian", "50", "30", "0.60", "1.20"),
        ("a2", "race", "Total", "Hispanic or Latino", "20", "5", "0.25", "NA"),
        # audit 3, sex: every ratio is the rate over Male's, not over the highest (Female's)
        ("a3", "sex", "Female", "Total", "50", "30", "60%", "1.2"),
        ("a3", "sex", "Male", "Total", "100", "50", "50%", "1.0"),
    ]
    columns = ["audit_id", "protected_char_group", "sex", "race_ethnicity", "number_of_applications",
               "n_selected_or_n_above_median", "result", "impact_ratio"]  # fmt: skip
    return pd.DataFrame(rows, columns=columns)


def test_printed_figures_are_read_exactly():
    assert printed("0.85") is not None and printed("0.85").value == Fraction(17, 20)
    assert printed("85%").value == Fraction(17, 20) and printed("85%").half_unit == Fraction(1, 200)
    assert printed("1,200").value == 1200
    assert printed("NA") is None and printed(float("nan")) is None and printed("") is None
    assert printed(0.1).half_unit == Fraction(1, 20)  # a float by its shortest repr, "0.1"
    # within half a unit of the last printed place, either side, and not beyond
    p = printed("0.75")
    assert p.matches(Fraction(3, 4) + Fraction(1, 200)) and not p.matches(Fraction(3, 4) + Fraction(1, 199))
    with pytest.raises(InputError, match="^published: a figure must be a number or a percentage"):
        printed("high")


def test_a_table_read_by_pandas_with_its_default_types_is_read_by_its_numbers():
    """pandas reads 0.3 as numpy's float64, whose repr under numpy 2 is ``np.float64(0.3)``: read as 0.3."""
    text = "category,applicants,selected,rate,impact_ratio\nFemale,100,30,0.3,0.75\nMale,120,48,0.4,1.0\n"
    checked = check_published(pd.read_csv(io.StringIO(text)))
    assert checked.consistent
    assert [(r.category, r.rate, r.impact_ratio) for r in checked.rows] == [("Female", 0.3, 0.75), ("Male", 0.4, 1.0)]


def test_the_aclu_format_is_read_and_each_inconsistency_named():
    checked = check_published(_aclu_rows())
    assert not checked.consistent
    by = {(r.audit, r.category): r for r in checked.rows}
    assert [r.findings for r in checked.rows if r.audit == "a1"] == [(), (), ()]
    # audit 2's highest rate is Asian's 30/50 = 0.6: White's printed 1.00 is 0.5/0.6, Black's 0.80 is 0.4/0.6
    assert by["a2", "White"].findings == ("ratio: printed 1.00, from the counts 0.8333",)
    assert by["a2", "Black"].findings == (
        "rate: printed 0.45, from the counts 0.4",  # 40/100
        "ratio: printed 0.80, from the counts 0.6667",
    )
    assert by["a2", "Asian"].findings == ("above 1: printed 1.20",)
    assert by["a2", "Hispanic or Latino"].findings == (
        "excluded: no ratio printed, yet 5.41% of the applicants (at least 2%)",  # 20 of 370
    )
    assert by["a2", "Hispanic or Latino"].recomputed_ratio == pytest.approx(0.25 / 0.6, rel=1e-15)
    assert by["a3", "Female"].findings == ("above 1: printed 1.2",)
    assert by["a3", "Male"].findings == ("ratio: printed 1.0, from the counts 0.8333",)
    # both tables divide by another category's rate than the highest: every printed ratio is rate / that rate
    assert checked.comparators == {("a2", "race"): "White", ("a3", "sex"): "Male"}


def test_the_missing_data_bounds_of_a_published_table():
    checked = check_published(_aclu_rows())
    female = next(r for r in checked.rows if r.audit == "a1" and r.category == "Female")
    sharp = missing_data_bounds(["F", "M"], [100, 120], [30, 48], 10, 3)
    assert (female.ratio_lower, female.ratio_upper) == (float(sharp.ratio_lower[0]), float(sharp.ratio_upper[0]))
    # the ACLU's: every unknown in the row's category, over the highest printed rate 0.40 (their max(result))
    assert female.aclu_upper == pytest.approx(40 / 110 / 0.4, rel=1e-15)
    assert female.aclu_lower == pytest.approx(30 / 110 / 0.4, rel=1e-15)
    # proportional: 10 · 100/220 of them
    m = 10 * 100 / 220
    assert female.aclu_upper_proportional == pytest.approx((30 + m) / (100 + m) / 0.4, rel=1e-15)
    assert female.aclu_lower_proportional == pytest.approx(30 / (100 + m) / 0.4, rel=1e-15)


def test_rates_without_counts_are_checked_over_their_rounding():
    # 0.33 / 0.41 = 0.8049 from the printed rates; true rates in [0.325, 0.335] x [0.405, 0.415] allow 0.783..0.827
    t = pd.DataFrame({"category": ["A", "B"], "rate": ["0.33", "0.41"], "impact_ratio": ["0.79", "1.00"]})
    assert check_published(t).consistent
    t.loc[0, "impact_ratio"] = "0.75"
    assert check_published(t).rows[0].findings == ("ratio: printed 0.75, from the printed rates 0.8049",)


def test_a_table_without_categories_or_figures_is_refused():
    with pytest.raises(InputError, match="^category: the published table needs a category column"):
        check_published(pd.DataFrame({"rate": ["0.5"]}))
    with pytest.raises(InputError, match="^rate: the published table needs rates, or applicants and selected"):
        check_published(pd.DataFrame({"category": ["A"], "applicants": ["3"]}))
    with pytest.raises(InputError, match="^rate: is not a column of the published table"):
        check_published(pd.DataFrame({"category": ["A"], "r": ["0.5"]}), {"rate": "sr"})


def test_the_command_exits_1_on_an_inconsistent_table_and_0_on_a_consistent_one(tmp_path, capsys):
    from _cli import run, run_json

    table = _aclu_rows()
    path = tmp_path / "published.csv"
    table.to_csv(path, index=False)
    code, d, _ = run_json(capsys, "audit", "--published", path)
    assert code == 1 and not d["published_details"]["consistent"] and d["published_details"]["rows"] == 9
    assert d["published_details"]["comparators"] == {"a2 / race": "White", "a3 / sex": "Male"}
    for fmt in ("text", "markdown", "html"):
        code, out, _ = run(capsys, "audit", "--published", path, "--format", fmt)
        assert code == 1 and "above 1: printed 1.20" in out and "every printed ratio is the rate over White" in out
    table[table["audit_id"] == "a1"].to_csv(path, index=False)
    code, out, _ = run(capsys, "audit", "--published", path)
    assert code == 0 and out.endswith("3 rows checked: consistent\n")


def test_the_command_refuses_data_with_a_published_table_and_needs_its_columns_without(tmp_path, capsys):
    from _cli import run

    path = tmp_path / "published.csv"
    _aclu_rows().to_csv(path, index=False)
    code, _, err = run(capsys, "audit", path, "--published", path)
    assert code == 2 and "--published: checks a published table alone: give it without DATA" in err
    code, _, err = run(capsys, "audit", "--sensitive", "sex", "--outcome", "y")
    assert code == 2 and "DATA: give the records to audit (or --published TABLE" in err
    code, _, err = run(capsys, "audit", path, "--outcome", "y")
    assert (code, err) == (2, "fairaudit: error: --sensitive: is required with DATA\n")


def test_the_verdicts_of_a_published_table_are_fishers_and_holms():
    """Second route: scipy's Fisher test against each type's highest rate from the counts, Holm by hand."""
    from pathlib import Path

    from scipy.stats import fisher_exact

    path = Path(__file__).resolve().parents[2] / "examples" / "impact_ratio" / "published.csv"
    rows = {r.category: r for r in check_published(pd.read_csv(path, dtype=str)).rows}

    def central(table: list[list[int]]) -> float:  # twice the smaller one-sided p-value
        return min(1.0, 2 * min(fisher_exact(table, alternative=a).pvalue for a in ("less", "greater")))

    raw = {
        "Female": central([[127, 410 - 127], [191, 530 - 191]]),  # against Male, 191/530
        "White": central([[182, 520 - 182], [60, 150 - 60]]),  # against Asian, 60/150
        "Black": central([[62, 230 - 62], [60, 150 - 60]]),
    }
    order = sorted(raw, key=raw.get)
    holm, running = {}, 0.0
    for rank, name in enumerate(order):
        running = max(running, min(1.0, raw[name] * (3 - rank)))
        holm[name] = running
    for name, p in holm.items():
        assert rows[name].p_value == pytest.approx(p, rel=1e-12)
    assert rows["Black"].verdict == ("below, significant" if holm["Black"] < 0.05 else "below, inconclusive")
    assert rows["Female"].verdict == "not below" and rows["Asian"].verdict == "not below"
    assert rows["Asian"].p_value is None and rows["Hispanic or Latino"].verdict is None


def _tiers() -> pd.DataFrame:
    """One audit with two tiers (the ACLU's ``selection_or_scoring_rate``), each a table of its own, a comparator
    flag, an empty category and two unknown rows in the second tier."""
    rows = [
        # tier "top": Male's 0.29 flagged as the comparator; Female at 0.27; 29 unknown applicants
        ("j", "Selection, top", "sex", "Male", "Total", "100", "29", "0.29", "1", "TRUE"),
        ("j", "Selection, top", "sex", "Female", "Total", "200", "54", "0.27", "0.93", "FALSE"),
        ("j", "Selection, top", "sex", "Missing/Unknown", "Total", "29", "NA", "NA", "NA", "NA"),
        # tier "top and middle": Male 0.64, Female 0.63, an empty category, two unknown rows (10 then 50)
        ("j", "Selection, top and middle", "sex", "Male", "Total", "100", "64", "0.64", "1", "TRUE"),
        ("j", "Selection, top and middle", "sex", "Female", "Total", "200", "126", "0.63", "0.98", "FALSE"),
        ("j", "Selection, top and middle", "sex", "Other", "Total", "0", "0", "NA", "NA", "FALSE"),
        ("j", "Selection, top and middle", "sex", "Missing/Unknown", "Total", "10", "NA", "NA", "NA", "NA"),
        ("j", "Selection, top and middle", "sex", "Missing/Unknown", "Missing/Unknown", "50", "NA", "NA", "NA", "NA"),
    ]
    columns = ["audit_id", "selection_or_scoring_rate", "protected_char_group", "sex", "race_ethnicity",
               "number_of_applications", "n_selected_or_n_above_median", "result", "impact_ratio",
               "comparator_group"]  # fmt: skip
    return pd.DataFrame(rows, columns=columns)


def test_each_tier_is_a_table_of_its_own_and_the_rows_keep_the_table_order():
    checked = check_published(_tiers())
    top, middle = "Selection, top", "Selection, top and middle"
    assert [(r.rate_kind, r.category) for r in checked.rows] == [
        (top, "Male"), (top, "Female"), (top, "Missing/Unknown"), (middle, "Male"), (middle, "Female"),
        (middle, "Other"), (middle, "Missing/Unknown"), (middle, "Missing/Unknown x Missing/Unknown"),
    ]  # fmt: skip
    # each tier's ratio is over its own highest rate: 54/200 / (29/100) and 126/200 / (64/100), by hand
    female_top, female_middle = checked.rows[1], checked.rows[4]
    assert female_top.recomputed_ratio == pytest.approx(0.27 / 0.29, rel=1e-15)
    assert female_middle.recomputed_ratio == pytest.approx(0.63 / 0.64, rel=1e-15)
    assert female_top.findings == () and female_middle.findings == ()


def test_the_aclu_bounds_divide_by_the_flagged_comparator_and_take_the_first_unknown_row():
    table = _tiers()
    table.loc[1, "result"] = "0.30"  # now Female prints the highest rate of the top tier; Male stays flagged
    rows = check_published(table).rows
    # theirs: the flagged row's printed rate (0.29), not the highest (0.30): 54/(200 + 29)/0.29 and 83/229/0.29
    assert rows[1].aclu_lower == pytest.approx(54 / 229 / 0.29, rel=1e-15)
    assert rows[1].aclu_upper == pytest.approx(83 / 229 / 0.29, rel=1e-15)
    # second tier: the first unknown row (10) as their code takes it; the empty category gets 0 to 10/10 / 0.64
    assert rows[4].aclu_lower == pytest.approx(126 / 210 / 0.64, rel=1e-15)
    assert rows[5].aclu_lower == 0 and rows[5].aclu_upper == pytest.approx(1 / 0.64, rel=1e-15)
    assert rows[5].aclu_lower_proportional is None  # their proportional variant adds 0 there: 0/0
    # without the flag column: the highest printed rate, 0.30
    unflagged = check_published(table.drop(columns="comparator_group")).rows
    assert unflagged[1].aclu_lower == pytest.approx(54 / 229 / 0.30, rel=1e-15)


def test_a_comparator_flag_that_is_not_a_truth_value_is_refused():
    table = _tiers()
    table.loc[0, "comparator_group"] = "maybe"
    with pytest.raises(InputError, match="^comparator_group: flags the comparator row: true or false"):
        check_published(table)
