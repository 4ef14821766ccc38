"""count_file and read_records read files with DuckDB alone (fairaudit.data.record_files): labels, errors, names, speed.

Expected values come from routes independent of DuckDB: the records made in Python (counted with
``collections.Counter``, their labels typed by the documented rule written again here in Python, :func:`typed`), or
pandas counting the same records in memory (``count_records`` on the DataFrame written to the file).
"""

from __future__ import annotations

import ast
import csv
import datetime as dt
import decimal
import gzip
import os
import re
import subprocess
import sys
import tempfile
from collections import Counter
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import fairaudit.data.counts as estimate
import fairaudit.data.record_files as engine
from fairaudit import CsvFormat, InputError, count_file, count_records, read_records
from fairaudit.data.record_files import NA, sql_identifier

pa = pytest.importorskip("pyarrow")
pq = pytest.importorskip("pyarrow.parquet")


def _describe(labels):
    return [(repr(v), type(v)) if not isinstance(v, tuple) else tuple((repr(x), type(x)) for x in v) for v in labels]


def assert_same(ref, got):
    """The same labels (repr, type, order), columns and int64 counts."""
    for axis in ("contexts", "groups", "decisions"):
        assert _describe(getattr(ref, axis)) == _describe(getattr(got, axis)), axis
    assert (ref.context_columns, ref.sensitive_columns, ref.outcome_column) == (
        got.context_columns,
        got.sensitive_columns,
        got.outcome_column,
    )
    assert ref.counts.dtype == got.counts.dtype == np.int64
    assert ref.counts.tolist() == got.counts.tolist()


def _error(fn, *args, **kw) -> InputError:
    with pytest.raises(InputError) as e:
        fn(*args, **kw)
    return e.value


# ---------------------------------------------------------------- quoting SQL identifiers and file names


def test_sql_identifier_quotes_and_doubles_quotes():
    assert sql_identifier('a"b') == '"a""b"'
    assert sql_identifier("two words") == '"two words"'
    assert sql_identifier('"') == '""""'
    assert sql_identifier("x; DROP TABLE t; --") == '"x; DROP TABLE t; --"'


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_column_names_that_need_quoting(tmp_path, suffix):
    df = pd.DataFrame(
        {
            'a"b': ["p", "q", "p", "q"],
            "two words": ["x", "x", "y", "y"],
            "count(*)": [1, 0, 1, 1],
            "n": [5, 5, 6, 6],  # the name of the count column in the engine's SQL
            "k0": [0, 0, 0, 1],  # the name of its first key
        }
    )
    path = tmp_path / f"r{suffix}"
    df.to_csv(path, index=False) if suffix == ".csv" else df.to_parquet(path)
    kw = dict(sensitive=['a"b', "two words"], outcome="count(*)", context=["n", "k0"])
    t = count_file(path, **kw)
    assert t.groups == (("p", "x"), ("p", "y"), ("q", "x"), ("q", "y")) and t.n == 4
    assert_same(count_records(df, **kw), t)


def test_columns_differing_only_in_case(tmp_path):
    # DuckDB matches names ignoring case (and renames the second column of a Parquet file): read by position
    df = pd.DataFrame({"g": ["a", "b", "b"], "G": ["x", "x", "y"], "y": [1, 0, 1]})
    for suffix in (".csv", ".parquet"):
        path = tmp_path / f"r{suffix}"
        df.to_csv(path, index=False) if suffix == ".csv" else df.to_parquet(path)
        for sens in ("g", "G"):
            t = count_file(path, sensitive=sens, outcome="y")
            assert t.groups == tuple(sorted(set(df[sens])))
            assert_same(count_records(df, sensitive=sens, outcome="y"), t)
        assert list(read_records(path).columns) == ["g", "G", "y"]


@pytest.mark.parametrize(
    "name, sibling",
    [
        ("d?.csv", "da.csv"),
        ("d[ab].csv", "da.csv"),
        ("d*.parquet", "da.parquet"),
        ("d?.parquet", "da.parquet"),
        ("{a,b}.csv", "a.csv"),
    ],
)
def test_file_names_with_glob_characters_are_read_as_they_are(tmp_path, name, sibling):
    # DuckDB expands *, ? and [..] in a file name: d?.parquet would count da.parquet too
    df = pd.DataFrame({"g": ["a", "b"], "y": [1, 0]})
    other = pd.DataFrame({"g": ["a"] * 5, "y": [1] * 5})
    for file, frame in ((name, df), (sibling, other)):
        path = tmp_path / file
        frame.to_csv(path, index=False) if file.endswith(".csv") else frame.to_parquet(path)
    t = count_file(tmp_path / name, sensitive="g", outcome="y")
    assert t.n == 2
    assert_same(count_records(df, sensitive="g", outcome="y"), t)


def test_relative_paths(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    df = pd.DataFrame({"g": ["a", "b"], "y": [1, 0]})
    df.to_csv("r.csv", index=False)
    df.to_parquet("r.parquet")
    for name in ("r.csv", "r.parquet", Path("r.csv")):
        assert count_file(name, sensitive="g", outcome="y").counts.tolist() == [[[0, 1], [1, 0]]]


# ---------------------------------------------------------------- text: the labels of DuckDB's reading


def _integer(field: str) -> bool:
    return re.fullmatch(r"0|-?[1-9][0-9]*", field) is not None and -(2**63) <= int(field) < 2**63


def _real(field: str) -> bool:
    try:
        return repr(float(field)) == field  # (Python writes these fields' floats as DuckDB does)
    except ValueError:
        return False


def typed(fields) -> dict:
    """The label of each distinct non-missing field of a text column, by the rule of record_files' module docstring."""
    fields = set(fields)
    if all(_integer(f) for f in fields):
        return {f: int(f) for f in fields}
    if all(_integer(f) or _real(f) for f in fields) and len({float(f) for f in fields}) == len(fields):
        return {f: float(f) for f in fields}
    return {f: f for f in fields}


def _written_twice(fields) -> bool:
    """Whether two distinct fields are one decimal number or one boolean (``01`` and ``1``, ``True`` and ``true``)."""
    meanings = set()
    for f in set(fields):
        word = f.strip().lower()
        if word in ("true", "false"):
            meaning = ("boolean", word)
        elif re.fullmatch(r"[+-]?([0-9]+\.?[0-9]*|\.[0-9]+)([eE][+-]?[0-9]+)?", word):
            meaning = ("number", float(word))
        else:
            continue
        if meaning in meanings:
            return True
        meanings.add(meaning)
    return False


FIELDS = [
    "0", "1", "7", "-3", "10", "9223372036854775807", "9223372036854775808",  # integers (the last beyond int64)
    "01", "-0", "+1", " 1", "1 ", "1_000", "0x10",  # not as DuckDB writes an integer
    "1.0", "2.5", "-0.0", "0.0", "1e-05", "inf", "-inf", "1e3", "Infinity",  # floats, as DuckDB writes them or not
    "a", "B", "é", "a b", "x,y", 'say "hi"', "True", "true", "yes", "?",  # text
    "", "NA", "nan", "NULL", "None", "N/A", "#N/A", "<NA>",  # missing
]  # fmt: skip


@st.composite
def text_records(draw):
    """Records of 2-3 columns over a few fields each, the roles, and extra missing-value markers."""
    n_cols = draw(st.integers(2, 3))
    pools = [draw(st.lists(st.sampled_from(FIELDS), min_size=1, max_size=4, unique=True)) for _ in range(n_cols)]
    rows = [tuple(draw(st.sampled_from(pool)) for pool in pools) for _ in range(draw(st.integers(1, 25)))]
    na_values = tuple(draw(st.lists(st.sampled_from(["?", "yes", "0"]), max_size=2, unique=True)))
    return rows, n_cols, na_values


@pytest.mark.slow
@settings(suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture], max_examples=120)
@given(text_records(), st.sampled_from([",", ";", "\t"]), st.sampled_from(["\n", "\r\n"]))
def test_text_columns_are_labelled_by_the_rule(tmp_path, case, sep, newline):
    rows, n_cols, na_values = case
    names = [f"c{i}" for i in range(n_cols)]
    with tempfile.TemporaryDirectory(dir=tmp_path) as tmp:
        path = Path(tmp) / "r.csv"
        with open(path, "w", newline="", encoding="utf-8") as f:
            csv.writer(f, delimiter=sep, lineterminator=newline).writerows([names, *rows])
        kw = dict(sensitive=["c0"], outcome="c1", context=names[2:], dropna=True, mixed_outcome=True)
        missing = set(NA) | set(na_values)
        kept = [r for r in rows if not missing.intersection(r)]
        present = [
            [r[j] for r in rows if r[j] not in missing] for j in range(n_cols)
        ]  # a column's type: all its values
        fmt = CsvFormat(sep=sep, na_values=na_values)
        twice = [f"c{j}" for j in range(n_cols) if _written_twice(present[j])]
        if twice:  # one number or boolean written two ways: refused, naming a column that does it
            problem = str(_error(count_file, path, csv=fmt, **kw))
            assert re.match(r"column 'c\d': writes one value several ways", problem) and problem[8:10] in twice
            return
        if not kept:
            assert str(_error(count_file, path, csv=fmt, **kw)) == "DATA: has no records to count"
            return
        t = count_file(path, csv=fmt, **kw)
    labels = [typed(present[j]) for j in range(n_cols)]
    by_role = [[2] if n_cols == 3 else [], [0], [1]]  # context, sensitive, outcome columns

    def label(row, cols):
        values = tuple(labels[j][row[j]] for j in cols)
        return values[0] if len(cols) == 1 else values if cols else "all"

    axes = [sorted({label(r, cols) for r in kept}) for cols in by_role]
    assert [_describe(a) for a in axes] == [_describe(t.contexts), _describe(t.groups), _describe(t.decisions)]
    c = Counter(tuple(label(r, cols) for cols in by_role) for r in kept)
    assert t.counts.tolist() == [[[c[(x, a, u)] for u in axes[2]] for a in axes[1]] for x in axes[0]]


@pytest.mark.parametrize(
    "text, groups",
    [
        ("g,y\n01,1\n2,0\n007,1\n", ("007", "01", "2")),  # leading zeros: text, never a number
        ("g,y\n2,1\n10,0\n-3,1\n", (-3, 2, 10)),  # integers sort as numbers
        ("g,y\nTrue,1\nFALSE,0\n", ("FALSE", "True")),  # booleans are text
        ("g,y\n2,1\n2.5,0\n10,1\n", (2.0, 2.5, 10.0)),  # floats
        ("g,y\n1,1\n,0\n2,1\n", (1, 2)),  # a missing value leaves integers integers
        ("g,y\nNA,1\nnan,0\n-nan,1\nNULL,1\n<NA>,1\n#N/A,0\na,1\n", ("a",)),  # the missing-value markers
        ('g,y\n"",1\n"NA",0\na,1\n', ("a",)),  # quoted markers are missing too
        ('g,y\n"a, b",1\n"say ""hi""",0\nb,1\n', ("a, b", "b", 'say "hi"')),  # quoted separator and quote
        ("g,y\r\na,1\r\nb,0\r\n", ("a", "b")),
        ("g,y\na,1\n\nb,0\n\n", ("a", "b")),  # blank lines are skipped
        ("\n\ng,y\na,1\nb,0\n", ("a", "b")),  # before the header too
        ("\ufeffg,y\na,1\nb,0", ("a", "b")),  # a byte order mark, no final newline
        ("g,y\ra,1\rb,0\r", ("a", "b")),  # lone carriage returns
        ("g,y\n a,1\nb ,0\n", (" a", "b ")),  # spaces around an unquoted field are kept
    ],
)
def test_tricky_text_fields(tmp_path, text, groups):
    path = tmp_path / "r.csv"
    path.write_bytes(text.encode())
    t = count_file(path, sensitive="g", outcome="y", dropna=True, mixed_outcome=True)
    assert _describe(t.groups) == _describe(groups)


@pytest.mark.parametrize(
    "text, shown",
    [
        ("g,y\n01,1\n1,0\n001,1\n", "('001', '01', '1'), in data rows 1, 2, 3"),
        ("g,y\n2,1\n2.0,0\n", "('2', '2.0'), in data rows 1, 2"),
        ("g,y\nTrue,1\nFALSE,0\ntrue,1\n", "('True', 'true'), in data rows 1, 3"),
    ],
)
def test_one_value_written_two_ways_in_a_text_file_is_refused(tmp_path, text, shown):
    """Two fields, one number (or boolean): as two labels they would be two groups, so the file is refused."""
    path = tmp_path / "r.csv"
    path.write_text(text)
    problem = str(_error(count_file, path, sensitive="g", outcome="y"))
    assert problem.startswith(f"column 'g': writes one value several ways {shown} (data rows count from 1")


def test_spaces_around_a_quoted_field_are_dropped_and_kept_around_others(tmp_path):
    path = tmp_path / "r.csv"
    path.write_text('g,y\na, "b" \n c ,0\n')
    t = count_file(path, sensitive="g", outcome="y", mixed_outcome=True)
    assert (t.groups, t.decisions) == ((" c ", "a"), ("0", "b"))


def test_a_short_record_is_padded_with_missing_values_and_a_long_one_refused(tmp_path):
    path = tmp_path / "r.csv"
    path.write_text("g,y\na,1\nb\nc,0\n")
    assert str(_error(count_file, path, sensitive="g", outcome="y")) == (
        "column 'y': has 1 missing values (drop those rows: `dropna`)"
    )
    t = count_file(path, sensitive="g", outcome="y", dropna=True)
    assert (t.groups, t.counts.tolist(), t.missing) == (("a", "c"), [[[0, 1], [1, 0]]], (("y", 1.0),))
    path.write_text("g,y\na,1\nb,0,2\n")
    assert str(_error(count_file, path, sensitive="g", outcome="y")) == (
        f"DATA: cannot be read by DuckDB (line 3: Expected Number of Columns: 2 Found: 3) (got {str(path)!r})"
    )


@pytest.mark.parametrize(
    "name, content, problem",
    [
        ("empty.csv", b"", "is empty"),
        ("header.csv", b"g,y\n", None),
        ("latin1.csv", "g,y\nJos\u00e9,1\n".encode("latin-1"), "cannot be read by DuckDB (line 2: Invalid unicode"),
        ("quote.csv", b'g,y\na,"1\n', "cannot be read by DuckDB (line 2: Value with unterminated quote found.)"),
        ("after.csv", b'g,y\na,"x"y\n', "cannot be read by DuckDB (line 2: Value with unterminated quote found.)"),
        ("ends.csv", b"g,y\na,1\rb,0\n", "cannot be read by DuckDB (InvalidInputException: "),
        ("bad.gz", b"not gzip", "cannot be read by DuckDB (IOException: IO Error: Input is not a GZIP stream"),
    ],
)
def test_text_duckdb_cannot_read_is_one_line_naming_the_file(tmp_path, name, content, problem):
    path = tmp_path / name
    path.write_bytes(content)
    err = _error(count_file, path, sensitive="g", outcome="y")
    if problem is None:
        assert str(err) == "DATA: has no records to count"
        return
    assert err.field == "DATA" and err.problem.startswith(problem) and err.value == str(path)
    assert "\n" not in str(err)
    assert str(_error(read_records, path)) == str(err)


def test_missing_and_unknown_files(tmp_path):
    assert str(_error(count_file, tmp_path / "none.csv", sensitive="g", outcome="y")) == (
        f"DATA: no such file (got {str(tmp_path / 'none.csv')!r})"
    )
    path = tmp_path / "r.json"
    path.write_text("g,y\na,1\n")
    assert _error(count_file, path, sensitive="g", outcome="y").problem.startswith("must be a .parquet/.pq file")


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="named pipes are POSIX")
def test_a_named_pipe_or_device_is_refused_not_read_in_part(tmp_path):
    # DuckDB opens DATA twice (its first record, then every record): a pipe would lose its first part or block
    fifo = tmp_path / "r.csv"
    os.mkfifo(fifo)
    err = _error(count_file, fifo, sensitive="g", outcome="y")
    assert (err.field, err.value) == ("DATA", str(fifo))
    assert err.problem == (
        "is a named pipe, not a regular file: DuckDB reads a file more than once; save the stream to a regular file first"
    )
    assert _error(read_records, os.devnull).problem.startswith("is a device or special file, not a regular file")


def test_a_repeated_name_is_not_renamed(tmp_path):
    path = tmp_path / "r.csv"
    path.write_bytes(b"g,g,y\na,b,1\nb,c,0\n")
    with pytest.raises(InputError, match=r"^sensitive: unknown column; the data has: g, y \(got 'g.1'\)$"):
        count_file(path, sensitive="g.1", outcome="y")
    with pytest.raises(InputError, match=r"^DATA: names column 'g' 2 times, with different values"):
        count_file(path, sensitive="g", outcome="y")
    assert count_file(path, sensitive="y", outcome="y").n == 2  # not used: no matter


def test_plain_csv_counts_and_missing_values(tmp_path):
    path = tmp_path / "r.csv"
    path.write_text('ctx,g,y\np,a,1\np,"b, c",0\nq,a,1\nq,a,\n')
    t = count_file(path, sensitive="g", outcome="y", context="ctx", dropna=True)
    assert (t.contexts, t.groups, t.decisions) == (("p", "q"), ("a", "b, c"), (0, 1))
    assert t.counts.tolist() == [[[0, 1], [1, 0]], [[0, 1], [0, 0]]]
    assert str(_error(count_file, path, sensitive="g", outcome="y", context="ctx")) == (
        "column 'y': has 1 missing values (drop those rows: `dropna`)"
    )


def test_gzip_and_zstd_text(tmp_path):
    import duckdb

    path = tmp_path / "r.csv.gz"
    with gzip.open(path, "wt") as f:
        f.write("g,y\na,1\nb,0\nb,1\n")
    assert count_file(path, sensitive="g", outcome="y").counts.tolist() == [[[0, 1], [1, 1]]]
    zst = tmp_path / "r.csv.zst"  # written by DuckDB (no zstd module in the standard library before Python 3.14)
    duckdb.sql(f"COPY (SELECT * FROM read_csv('{path}')) TO '{zst}' (HEADER, COMPRESSION zstd)")
    assert count_file(zst, sensitive="g", outcome="y").counts.tolist() == [[[0, 1], [1, 1]]]


def test_unknown_csv_column_names_the_flag(tmp_path):
    path = tmp_path / "r.csv"
    path.write_text("g,y\na,1\n")
    assert str(_error(count_file, path, sensitive="g", outcome="z")) == (
        "outcome: unknown column; the data has: g, y (got 'z')"
    )


def test_larger_csv_written_by_the_csv_module(tmp_path):
    rng = np.random.default_rng(11)
    n = 20_000
    rows = list(
        zip(
            rng.integers(0, 50, n).astype(str),
            rng.choice(["a", "b", "c, d", 'e"f', ""], n),
            rng.choice(["1", "0", "NA", "2"], n),
        )
    )
    path = tmp_path / "r.csv"
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["ctx", "grp", "y"])
        w.writerows(rows)
    t = count_file(path, sensitive="grp", outcome="y", context="ctx", dropna=True)
    kept = [(int(x), a, int(u)) for x, a, u in rows if a != "" and u != "NA"]
    c = Counter(kept)
    assert (t.contexts, t.groups, t.decisions) == (tuple(range(50)), ("a", "b", "c, d", 'e"f'), (0, 1, 2))
    assert t.counts.tolist() == [[[c[(x, a, u)] for u in t.decisions] for a in t.groups] for x in t.contexts]
    assert dict(t.missing) == {"grp": sum(a == "" for _, a, _ in rows), "y": sum(u == "NA" for _, _, u in rows)}


def test_read_records_gives_the_labels_counted(tmp_path):
    path = tmp_path / "r.csv"
    path.write_text("g,y,w\n01,1,0.5\n2,,2\nx,3,1\n")
    frame = read_records(path)
    assert frame["g"].tolist() == ["01", "2", "x"]
    assert str(frame["y"].dtype) == "Int64" and frame["y"].tolist()[::2] == [1, 3] and frame["y"].isna().tolist()[1]
    assert frame["w"].tolist() == [0.5, 2.0, 1.0]
    kw = dict(sensitive="g", outcome="y", dropna=True)
    assert_same(count_records(frame, **kw), count_file(path, **kw))


# ---------------------------------------------------------------- Parquet: the file's types


def test_parquet_types_are_labels_or_duckdb_text(tmp_path):
    df = pd.DataFrame(
        {
            "i8": np.array([3, 1, 2], dtype=np.int8),
            "u64": np.array([2**63, 1, 0], dtype=np.uint64),
            "f32": np.array([0.25, 0.5, np.nan], dtype=np.float32),
            "nb": pd.array([True, None, False], dtype="boolean"),
            "ni": pd.array([10, None, 3], dtype="Int64"),
            "s": pd.array(["b", None, "a"], dtype="string"),
            "ts": pd.to_datetime(["2020-01-01 10:00", "2021-05-06", "2020-01-01"], format="ISO8601"),
            "d": [dt.date(2020, 1, 1), dt.date(2021, 1, 2), None],
            "dec": [decimal.Decimal("1.10"), decimal.Decimal("2.00"), None],
            "b": [b"x", b"y", None],
            "empty": [None] * 3,
            "cat": pd.Categorical(["z", "a", None], categories=["z", "q", "a"], ordered=True),
            "y": [0, 1, 1],
        }
    )
    path = tmp_path / "r.parquet"
    df.to_parquet(path, row_group_size=2)
    expected = {
        "i8": (1, 2, 3),
        "u64": (0, 1, 2**63),
        "f32": (0.25, 0.5),
        "nb": (False, True),
        "ni": (3, 10),
        "s": ("a", "b"),
        "ts": ("2020-01-01 00:00:00", "2020-01-01 10:00:00", "2021-05-06 00:00:00"),
        "d": ("2020-01-01", "2021-01-02"),
        "dec": (1.1, 2.0),
        "b": ("x", "y"),
        "empty": (),
        "cat": ("a", "z"),  # the values, sorted (not the categories' order)
    }
    for col, labels in expected.items():
        if not labels:
            assert str(_error(count_file, path, sensitive=col, outcome="y", dropna=True)) == (
                "DATA: has no records to count"
            )
            continue
        t = count_file(path, sensitive=col, outcome="y", dropna=True)
        assert _describe(t.groups) == _describe(labels), col
        assert t.n == len(labels)
    t = count_file(path, sensitive=["cat", "nb"], outcome="y", context=["d"], dropna=True)
    assert (t.contexts, t.groups, t.n) == (("2020-01-01",), (("z", True),), 1)


def test_parquet_folder_with_glob_characters(tmp_path):
    folder = tmp_path / "part[s]"
    folder.mkdir()
    df = pd.DataFrame({"g": list("abab") * 3, "y": [1, 0, 0, 0, 1, 1] * 2})
    df.iloc[:5].to_parquet(folder / "part-0.parquet")
    df.iloc[5:].to_parquet(folder / "part-1.parquet")
    (folder / "_SUCCESS").write_text("")  # left out, as Spark's marker files are
    (tmp_path / "parts").mkdir()  # what the pattern part[s] would match
    df.to_parquet(tmp_path / "parts" / "part-0.parquet")
    t = count_file(folder, sensitive="g", outcome="y")
    assert t.n == 12
    assert_same(count_records(df, sensitive="g", outcome="y"), t)
    empty = tmp_path / "empty"
    empty.mkdir()
    assert str(_error(count_file, empty, sensitive="g", outcome="y")) == (
        f"DATA: is a folder without Parquet files (got {str(empty)!r})"
    )


def test_parquet_arrow_strings_and_large_strings(tmp_path):
    table = pa.table(
        {
            "s": pa.array(["b", "a", None, "b"], type=pa.string()),
            "ls": pa.array(["x", "y", "x", "x"], type=pa.large_string()),
            "y": pa.array([1, 0, 1, 1], type=pa.int32()),
        }
    )
    path = tmp_path / "r.parquet"
    pq.write_table(table, path)
    t = count_file(path, sensitive="s", outcome="y", dropna=True)
    assert (t.groups, t.decisions, t.counts.tolist()) == (("a", "b"), (0, 1), [[[1, 0], [0, 2]]])
    t = count_file(path, sensitive="ls", outcome="y", context="s", dropna=True)
    assert (t.contexts, t.groups, t.counts.tolist()) == (("a", "b"), ("x", "y"), [[[0, 0], [1, 0]], [[0, 2], [0, 0]]])


def test_unreadable_parquet_is_one_line(tmp_path):
    path = tmp_path / "bad.parquet"
    path.write_bytes(b"PAR1" + b"\0" * 64 + b"PAR1")
    err = _error(count_file, path, sensitive="g", outcome="y")
    assert err.field == "DATA" and err.problem.startswith("cannot be read by DuckDB (") and "\n" not in str(err)


# ---------------------------------------------------------------- import time


@pytest.mark.parametrize("module", [estimate, engine])
def test_no_heavy_module_imported_at_top_level(module):
    """pandas, pyarrow and duckdb are imported inside the functions that use them (``import fairaudit`` stays fast)."""
    tree = ast.parse(Path(module.__file__).read_text())
    top = []
    for node in tree.body:  # not inside functions, nor under `if TYPE_CHECKING:`
        if isinstance(node, ast.Import):
            top += [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module:
            top.append(node.module)
    assert [m for m in top if m.split(".")[0] in {"pandas", "pyarrow", "duckdb"}] == []


def test_importing_estimate_does_not_start_duckdb():
    code = "import sys, fairaudit.data.counts; print(' '.join(m for m in ('pandas', 'pyarrow', 'duckdb') if m in sys.modules))"
    loaded = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert "duckdb" not in loaded
    if "pandas" not in loaded:  # pandas imports pyarrow itself (other modules of fairaudit may import pandas)
        assert "pyarrow" not in loaded


@pytest.mark.slow
@pytest.mark.parametrize("suffix", [".parquet", ".csv"])
def test_files_are_counted_without_pandas_nor_pyarrow(tmp_path, suffix):
    """Any keys, missing values and categoricals included: DuckDB groups, numpy counts; pandas is not imported."""
    path = tmp_path / f"r{suffix}"
    frame = pd.DataFrame(
        {
            "context": [3, 1, 2, 1] * 5,
            "group": pd.Categorical(["b", "a", "é", None] * 5),
            "flag": [True, False] * 10,
            "score": np.array([0.5, 0.25, 0.5, 2.0] * 5, dtype=np.float32),
            "decision": np.array([0, 1, 2, 1, 1] * 4, dtype=np.uint8),
        }
    )
    frame.to_parquet(path) if suffix == ".parquet" else frame.to_csv(path, index=False)
    kw = dict(sensitive=["group", "flag"], outcome="decision", context=["context", "score"], dropna=True)
    assert count_file(path, **kw).n == count_records(frame, **kw).n == 15
    code = (
        "import sys; from fairaudit.data.counts import count_file; "
        f"t = count_file({str(path)!r}, **{kw!r}); "
        "print([m for m in ('pandas', 'pyarrow') if m in sys.modules], t.n)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out == "[] 15\n"
