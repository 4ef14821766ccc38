"""The data's edges (issue 39, item 1): control characters in key values, outcome columns mixing numbers and text.

Every route that counts records refuses them with one line naming the column, the data row (counted from 1, the
first record after the header; a DataFrame's row by position) and the character as U+0000, never raw. The rows
expected are where each test put the bad value; the metrics expected are exact fractions counted by hand.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pandas as pd
import pytest
from _cli import run, run_json

from fairaudit import InputError, RecordOptions, audit, count_file, count_records, count_table
from fairaudit.data.key_values import check_key_values

# The case: group a hires 40 of 88, group b 30 of 80: L = ln((40/88) / (30/80)) = 0.19 nats. One of a's
# hired records with a NUL byte after its group would be a group of its own (rate 1): L = ln(1 / (30/80)) = 0.98.
CLEAN_L = math.log(Fraction(40, 88) / Fraction(30, 80))
SILENT_L = math.log(1 / Fraction(30, 80))


def _records(bad_row: int | None = None, bad: str = "a\x00") -> pd.DataFrame:
    """a: 40 of 88 hired, b: 30 of 80, interleaved; the record at data row ``bad_row`` (from 1, an a hired) gets ``bad``."""
    race = ["a"] * 88 + ["b"] * 80
    hired = [1] * 40 + [0] * 48 + [1] * 30 + [0] * 50
    frame = pd.DataFrame({"race": race, "hired": hired})
    if bad_row is not None:
        assert frame.loc[bad_row - 1, "race"] == "a" and frame.loc[bad_row - 1, "hired"] == 1
        frame.loc[bad_row - 1, "race"] = bad
    return frame


NUL_ERROR = (
    "fairaudit: error: column 'race': holds the control character U+0000 in data row 7 (data rows count from 1, "
    "the first record after the header); 1 record in all: remove control characters (tabs and line breaks too) "
    "from the values (got 'a\\x00')\n"
)


def test_the_clean_file_gives_the_hand_counted_l(tmp_path, capsys):
    path = tmp_path / "r.csv"
    _records().to_csv(path, index=False)
    code, d, _ = run_json(capsys, "audit", path, "--sensitive", "race", "--outcome", "hired")
    assert code == 0
    assert d["local"]["value"] == pytest.approx(CLEAN_L, rel=1e-12)
    assert round(CLEAN_L, 2) == 0.19 and round(SILENT_L, 2) == 0.98  # the numbers


@pytest.mark.parametrize("suffix", [".csv", ".csv.gz", ".parquet"])  # DuckDB on text, gzip and Parquet
def test_a_nul_byte_in_a_key_exits_2_naming_column_row_and_character(tmp_path, capsys, suffix):
    path = tmp_path / f"r{suffix}"
    frame = _records(bad_row=7)
    frame.to_parquet(path) if suffix == ".parquet" else frame.to_csv(path, index=False)
    out = tmp_path / "report.txt"
    code, stdout, err = run(capsys, "audit", path, "--sensitive", "race", "--outcome", "hired", "--output", out)
    assert (code, err) == (2, NUL_ERROR)
    assert "\x00" not in stdout + err and not out.exists()


def test_a_nul_byte_is_refused_in_python_on_frames_arrays_and_count_tables():
    frame = _records(bad_row=7)
    with pytest.raises(InputError, match=r"U\+0000 in data row 7 ") as e:
        count_records(frame, sensitive="race", outcome="hired")
    assert e.value.field == "column 'race'"
    with pytest.raises(InputError, match=r"U\+0000 in data row 7 "):
        audit(frame, sensitive=["race"], outcome="hired")
    with pytest.raises(
        InputError, match=r"column 'sensitive_feature_0': holds the control character U\+0000 in data row 7 "
    ):
        audit(y_pred=frame["hired"].tolist(), sensitive_features=frame["race"].tolist())
    table = frame.value_counts().rename("n").reset_index()  # the count table's rows: the bad one is its row 1
    row = int(np.flatnonzero(table["race"] == "a\x00")[0]) + 1
    with pytest.raises(InputError, match=rf"U\+0000 in data row {row} .*1 record in all"):
        count_table(table, sensitive="race", outcome="hired", count="n")


def test_a_parquet_folder_names_the_file_and_its_row(tmp_path):
    folder = tmp_path / "parts"
    folder.mkdir()
    frame = _records()
    frame.iloc[:84].to_parquet(folder / "part-0.parquet")
    second = frame.iloc[84:].reset_index(drop=True)
    second.loc[2, "race"] = "b\x1f"  # the third row of part-1 (a b record)
    second.to_parquet(folder / "part-1.parquet")
    with pytest.raises(InputError, match=r"U\+001F in data row 3 of part-1\.parquet ") as e:
        count_file(folder, sensitive="race", outcome="hired")
    assert "\x1f" not in str(e.value)


@pytest.mark.parametrize(
    "value, name",
    [("a\tb", "U+0009"), ("a\nb", "U+000A"), ("a\r", "U+000D"), ("a\x7f", "U+007F"), ("\x85a", "U+0085")],
)
def test_tabs_line_breaks_del_and_c1_controls_in_quoted_fields_are_refused(tmp_path, capsys, value, name):
    path = tmp_path / "r.csv"
    frame = _records()
    frame.loc[2, "race"] = value  # data row 3
    frame.to_csv(path, index=False, quoting=1)  # every field quoted
    code, stdout, err = run(capsys, "audit", path, "--sensitive", "race", "--outcome", "hired")
    assert code == 2 and stdout == ""
    assert err.startswith(f"fairaudit: error: column 'race': holds the control character {name} in data row 3 ")
    assert not any(c in err[:-1] for c in "\x00\t\r\x7f\x85") and err.count("\n") == 1


def test_rows_are_records_blank_lines_and_multiline_fields_not_counted_twice(tmp_path):
    # line 1 header, record 1 spans lines 2-3 (a quoted note), a blank line, record 2, record 3 holds the NUL
    text = 'race,note,hired\na,"two\nlines",1\n\nb,x,0\n"a\x00",y,1\na,z,0\n'
    path = tmp_path / "r.csv"
    path.write_bytes(text.encode())
    for read in (
        lambda: count_file(path, sensitive="race", outcome="hired"),
        lambda: count_records(pd.read_csv(path), sensitive="race", outcome="hired"),
    ):
        with pytest.raises(InputError, match=r"U\+0000 in data row 3 "):
            read()


def test_control_characters_in_the_outcome_and_a_context_are_refused_too():
    frame = pd.DataFrame({"g": ["a", "b", "a"], "x": ["day", "night", "day\x00"], "y": ["hire", "no\x1b", "hire"]})
    with pytest.raises(InputError, match=r"column 'x': .*U\+0000 in data row 3 "):
        count_records(frame, sensitive="g", outcome="y", context="x")
    with pytest.raises(InputError, match=r"column 'y': .*U\+001B in data row 2 "):
        count_records(frame, sensitive="g", outcome="y")


def test_a_huge_value_is_quoted_around_its_control_character_only():
    value = "x" * 100_000 + "\x00" + "y" * 100_000
    with pytest.raises(InputError) as e:
        check_key_values({"g": ["a", value], "y": [1, 0]}, "y")
    assert len(str(e.value)) < 400 and "'...xxx" in str(e.value) and "\\x00yyy" in str(e.value)


# ---------------------------------------------------------------- outcomes mixing numbers and text

YES_ROWS = (5, 30, 100)  # data rows where hired says "yes" (each a hired record)


def _mixed() -> pd.DataFrame:
    frame = _records()
    frame["hired"] = frame["hired"].astype(object)
    for row in YES_ROWS:
        assert frame.loc[row - 1, "hired"] == 1
        frame.loc[row - 1, "hired"] = "yes"
    return frame


MIXED_ERROR = (
    "fairaudit: error: column 'hired': mixes numbers and text: 3 of 168 records are text ('yes') where the others "
    "are numbers, in data rows 5, 30, 100 (data rows count from 1, the first record after the header): fix the "
    'data, give --utility as an expression of the values read as text (e.g. u in ["1", "yes"]), or, if the text '
    "values are outcomes of their own (a rank and 'unranked'), say so with --mixed-outcome (got 'yes')\n"
)


@pytest.mark.parametrize("suffix", [".csv", ".csv.gz", ".parquet"])
def test_yes_among_numbers_in_the_outcome_exits_2_naming_the_rows(tmp_path, capsys, suffix):
    path = tmp_path / f"r{suffix}"
    frame = _mixed()
    if suffix == ".parquet":
        frame.astype({"hired": str}).to_parquet(path)  # a text column: "0", "1", "yes"
    else:
        frame.to_csv(path, index=False)
    for positive in ((), ("--positive", "1")):
        code, stdout, err = run(capsys, "audit", path, "--sensitive", "race", "--outcome", "hired", *positive)
        assert (code, stdout, err) == (2, "", MIXED_ERROR)


def test_a_utility_that_maps_the_text_counts_it_as_said(tmp_path, capsys):
    path = tmp_path / "r.csv"
    _mixed().to_csv(path, index=False)
    code, d, _ = run_json(
        capsys, "audit", path, "--sensitive", "race", "--outcome", "hired", "--utility", 'u in ["1", "yes"]'
    )
    assert code == 0
    assert d["local"]["value"] == pytest.approx(CLEAN_L, rel=1e-12)  # "yes" read as 1: the clean records' L
    r = audit(_mixed(), sensitive=["race"], outcome="hired", utility='u in ["1", "yes"]')
    assert r.observed.local_fairness.value == pytest.approx(CLEAN_L, rel=1e-12)
    assert [str(d) for d in r.table.decisions] == ["0", "1", "yes"]


def test_the_rows_of_the_fewer_kind_are_listed_first_five_and_how_many():
    y = ["hire"] * 10 + ["reject"] * 10
    for i in (2, 4, 6, 8, 11, 13, 17):  # seven numbers among text (0-based positions)
        y[i] = str(i % 2)
    frame = pd.DataFrame({"g": ["a", "b"] * 10, "y": y})
    with pytest.raises(InputError) as e:
        count_records(frame, sensitive="g", outcome="y")
    assert e.value.problem.startswith(
        "mixes numbers and text: 7 of 20 records are numbers ('0', '1') where the others are text, "
        "in data rows 3, 5, 7, 9, 12 (the first 5) "
    )


@pytest.mark.parametrize(
    "values, mixed",
    [
        (["1", "0", "yes"], True),
        ([1, 0, "yes"], True),
        (["True", "False", "maybe"], True),  # booleans count as numbers
        ([True, False, "maybe"], True),
        ([" 2.5", "-3e2", "x"], True),
        (["hire", "reject", "hold"], False),  # text only
        ([1.0, 0.0, np.nan], False),  # numbers only (a missing value is not text)
        (["1", "0", None], False),
        (["inf", "1"], True),  # "inf" is no finite number
    ],
)
def test_what_mixed_means(values, mixed):
    frame = pd.DataFrame({"g": ["a", "b", "c"][: len(values)], "y": pd.Series(values, dtype=object)})
    if mixed:
        with pytest.raises(InputError, match="mixes numbers and text"):
            count_records(frame, sensitive="g", outcome="y", dropna=True)
        assert count_records(frame, sensitive="g", outcome="y", dropna=True, mixed_outcome=True).n == len(values)
    else:
        count_records(frame, sensitive="g", outcome="y", dropna=True)


def test_mixed_sensitive_values_are_labels_not_an_error():
    frame = pd.DataFrame({"g": ["1", "x", "1"], "y": [1, 0, 1]})
    assert count_records(frame, sensitive="g", outcome="y").groups == ("1", "x")


def test_mixed_outcome_counts_ranks_and_unranked_as_they_are(tmp_path, capsys):
    frame = pd.DataFrame({"g": ["a", "a", "b", "b", "b"], "rank": ["1", "2", "1", "unranked", "2"]})
    path = tmp_path / "r.csv"
    frame.to_csv(path, index=False)
    code, _, err = run(capsys, "audit", path, "--sensitive", "g", "--outcome", "rank", "--positive", "1")
    assert code == 2 and "1 of 5 records is text ('unranked') where the others are numbers, in data row 4 " in err
    code, d, _ = run_json(
        capsys, "audit", path, "--sensitive", "g", "--outcome", "rank", "--positive", "1", "--mixed-outcome"
    )
    assert code == 0 and d["decisions"] == ["1", "2", "unranked"]
    assert d["local"]["value"] == pytest.approx(math.log(Fraction(1, 2) / Fraction(1, 3)), rel=1e-12)
    r = audit(frame, sensitive=["g"], outcome="rank", positive="1", records=RecordOptions(mixed_outcome=True))
    assert r.observed.local_fairness.value == pytest.approx(d["local"]["value"], rel=1e-12)


# ---------------------------------------------------------------- every report lists the outcome values


def test_every_report_lists_each_outcome_value_with_its_records_and_g(tmp_path, capsys):
    frame = pd.DataFrame({"g": ["a"] * 6 + ["b"] * 5, "score": [3, 1, 2, 3, 3, 1, 2, 2, 1, 3, 2]})
    path = tmp_path / "r.csv"
    frame.to_csv(path, index=False)
    want = frame["score"].value_counts().sort_index()  # 1: 3, 2: 4, 3: 4
    argv = ("audit", path, "--sensitive", "g", "--outcome", "score", "--utility", "u >= 2")
    code, d, _ = run_json(capsys, *argv)
    assert code == 0
    assert d["outcome_values"] == [{"label": int(u), "n": int(n), "g": float(u >= 2)} for u, n in want.items()]
    _, text, _ = run(capsys, *argv)
    assert "records per outcome value: 1 3 (g 0), 2 4 (g 1), 3 4 (g 1)\n" in text
    _, markdown, _ = run(capsys, *argv, "--format", "markdown")
    assert "| outcome value | records | g(u) |\n|---|---|---|\n| 1 | 3 | 0 |\n| 2 | 4 | 1 |\n| 3 | 4 | 1 |" in markdown
    _, html, _ = run(capsys, *argv, "--format", "html")
    assert "Records per outcome value" in html and html.count("<td") >= 9


def test_weighted_outcome_values_are_sums_of_weights():
    frame = pd.DataFrame({"g": ["a", "a", "b", "b"], "y": [1, 0, 1, 0], "w": [0.5, 2.0, 1.5, 1.0]})
    d = audit(frame, sensitive=["g"], outcome="y", records=RecordOptions(weights="w")).to_dict()
    want = frame.groupby("y")["w"].sum()  # 0: 3.0, 1: 2.0
    assert d["outcome_values"] == [{"label": 0, "n": 3.0, "g": 0.0}, {"label": 1, "n": 2.0, "g": 1.0}]
    assert [v["n"] for v in d["outcome_values"]] == want.tolist()


def test_a_long_text_value_among_numbers_is_quoted_cut_with_its_length():
    """The mixed-outcome line quotes the text values as every error line does: cut after 80 characters, with the
    value's length (a 5,000-character value is not echoed whole)."""
    long = "y" * 5000
    frame = pd.DataFrame({"g": ["a", "a", "b", "b"], "u": ["1", long, "0", "1"]})
    with pytest.raises(InputError) as info:
        audit(frame, sensitive=["g"], outcome="u", positive="1")
    message = str(info.value)
    assert long not in message and "(5000 characters)" in message and len(message) < 1000


# One number written two ways: each text a label of its own. '1.0' beside '1' as an outcome would have g = 0 under
# --positive 1 (group a: 1 hired of 2 instead of 2 of 2); '01' beside '1' as a group, two groups.
@pytest.mark.parametrize(
    ("column", "values", "shown", "rows"),
    [
        ("hired", ["1", "1.0", "0", "1"], "('1', '1.0')", "data rows 1, 2, 4"),
        ("race", ["01", "1", "b", "b"], "('01', '1')", "data rows 1, 2"),
        ("race", ["-0", "0", "b", "b"], "('-0', '0')", "data rows 1, 2"),
        ("race", ["True", "true", "b", "b"], "('True', 'true')", "data rows 1, 2"),
    ],
)
@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_one_value_written_two_ways_exits_2_naming_the_rows(tmp_path, capsys, column, values, shown, rows, suffix):
    frame = pd.DataFrame({"race": ["a", "a", "b", "b"], "hired": ["1", "0", "0", "1"]})
    frame[column] = values
    path = tmp_path / f"r{suffix}"
    frame.to_parquet(path) if suffix == ".parquet" else frame.to_csv(path, index=False)
    code, _, err = run(capsys, "audit", path, "--sensitive", "race", "--outcome", "hired", "--positive", "1")
    assert code == 2 and err.startswith(f"fairaudit: error: column '{column}': writes one value several ways {shown}, ")
    assert f"in {rows} (data rows count from 1" in err and err.count("\n") == 1
    with pytest.raises(InputError, match=r"writes one value several ways"):
        count_records(frame, sensitive="race", outcome="hired")


def test_numbers_each_written_one_way_and_a_number_beside_text_are_labels():
    """'1' and '2', '1' and 'true' (a number and a boolean), '012' and '5': distinct values, so no refusal."""
    for values in (["1", "2", "2", "1"], ["1", "true", "true", "1"], ["012", "5", "5", "012"]):
        frame = pd.DataFrame({"race": values, "hired": [1, 0, 1, 0]})
        assert count_records(frame, sensitive="race", outcome="hired").groups == tuple(sorted(set(values)))
