"""count_file's DuckDB engine (fairaudit._count_engine) against the pandas route, on tricky CSV and Parquet files.

The oracle is ``count_records(read_records(path))``: pandas reads the whole
file (``read_csv`` infers each column's type, ``read_parquet`` converts Arrow
types) and counts it; ``count_file`` counts the file with one DuckDB
``GROUP BY`` and converts only the grouped table. Both must give the same
labels (values, Python types, ``repr`` — so the sign of a zero too — and
order), the same int64 counts, or the same error text.
"""

from __future__ import annotations

import ast
import csv
import datetime as dt
import decimal
import gzip
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

import fairaudit._count_engine as engine
import fairaudit.estimate as estimate
from fairaudit import InputError, count_file, count_records
from fairaudit._count_engine import sql_identifier

pa = pytest.importorskip("pyarrow")
pq = pytest.importorskip("pyarrow.parquet")

from _counting import counted, reference, spy_fallback  # noqa: E402


def _describe(labels):
    return [(repr(v), type(v)) if not isinstance(v, tuple) else tuple((repr(x), type(x)) for x in v) for v in labels]


def assert_same(ref, got):
    """The same error text, or the same labels (repr, type, order), columns and int64 counts."""
    if isinstance(ref, InputError) or isinstance(got, InputError):
        assert isinstance(ref, InputError) and isinstance(got, InputError), (ref, got)
        assert str(ref) == str(got)
        return
    for axis in ("contexts", "groups", "decisions"):
        assert getattr(ref, axis) == getattr(got, axis), axis
        assert _describe(getattr(ref, axis)) == _describe(getattr(got, axis)), axis
    assert (ref.context_columns, ref.sensitive_columns, ref.outcome_column) == (
        got.context_columns,
        got.sensitive_columns,
        got.outcome_column,
    )
    assert ref.counts.dtype == got.counts.dtype == np.int64
    assert ref.counts.tolist() == got.counts.tolist()


# ---------------------------------------------------------------- quoting SQL identifiers


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
            "n": [5, 5, 6, 6],  # the name DuckDB's count column would take
            "N_": [0, 0, 0, 1],
        }
    )
    path = tmp_path / f"r{suffix}"
    df.to_csv(path, index=False) if suffix == ".csv" else df.to_parquet(path)
    kw = dict(sensitive=['a"b', "two words"], outcome="count(*)", context=["n", "N_"])
    t = count_file(path, **kw)
    assert t.groups == (("p", "x"), ("p", "y"), ("q", "x"), ("q", "y")) and t.n == 4
    assert_same(reference(path, **kw), t)


def test_columns_differing_only_in_case(tmp_path):
    # DuckDB matches names ignoring case (and renames the second column of a Parquet file): counted by position
    df = pd.DataFrame({"g": ["a", "b", "b"], "G": ["x", "x", "y"], "y": [1, 0, 1]})
    for suffix in (".csv", ".parquet"):
        path = tmp_path / f"r{suffix}"
        df.to_csv(path, index=False) if suffix == ".csv" else df.to_parquet(path)
        for sens in ("g", "G"):
            t = count_file(path, sensitive=sens, outcome="y")
            assert t.groups == tuple(sorted(set(df[sens])))
            assert_same(reference(path, sensitive=sens, outcome="y"), t)


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
    assert_same(reference(tmp_path / name, sensitive="g", outcome="y"), t)


# ---------------------------------------------------------------- CSV: pandas' type inference on distinct fields only

FIELDS = [
    "1", "01", "007", "-0", "0", "-0.0", "0.0", "+1", "1.", ".5", "1e3", "1E-2", "2.50",
    "9223372036854775807", "9223372036854775808", "-9223372036854775809", "18446744073709551616",
    "inf", "-inf", "Infinity", "nan", "NaN", "NA", "N/A", "n/a", "null", "NULL", "None", "<NA>", "#N/A", "-nan",
    "True", "False", "TRUE", "false", "true", "yes", "t",
    "a", "B", "é", "a b", " 1", "1 ", "  ", "x,y", 'say "hi"', "line\nbreak", "tab\there", "0x10", "1_000", "١",
    "",
]  # fmt: skip


def _quote(text):
    return '"' + text.replace('"', '""') + '"'


@st.composite
def csv_files(draw):
    """A CSV text (pandas' dialect) of 2-4 columns over tricky fields, quoted minimally or always, and roles."""
    n_cols = draw(st.integers(2, 4))
    pools = [draw(st.lists(st.sampled_from(FIELDS), min_size=1, max_size=4, unique=True)) for _ in range(n_cols)]
    n = draw(st.integers(0, 25))
    rows = [[draw(st.sampled_from(pool)) for pool in pools] for _ in range(n)]
    always = draw(st.booleans())
    newline = draw(st.sampled_from(["\n", "\r\n"]))

    def field(text):
        needs = always or any(c in text for c in ',"\n\r') or text.startswith(" ") or text.endswith(" ")
        return _quote(text) if needs and text != "" else text

    names = [f"c{i}" for i in range(n_cols)]
    text = newline.join([",".join(names)] + [",".join(field(v) for v in row) for row in rows]) + newline
    roles = draw(st.permutations(names))
    n_ctx = draw(st.integers(0, n_cols - 2))
    kw = dict(sensitive=[roles[0]], outcome=roles[1], context=list(roles[2 : 2 + n_ctx]), dropna=draw(st.booleans()))
    return text, kw


@settings(suppress_health_check=[HealthCheck.too_slow], max_examples=150)
@given(csv_files())
def test_csv_fields_counted_as_pandas_reads_them(case):
    text, kw = case
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "r.csv"
        path.write_bytes(text.encode())
        ref = reference(path, **kw)
        event(f"error: {ref.problem.split(' ')[0]}" if isinstance(ref, InputError) else "counted")
        assert_same(ref, counted(path, **kw))


PIECES = ["x", "1", " ", "\t", '"', '""', ",", "\n", "\r\n", "\r", "NA", "-0", "0", "True", "é", "\\", "#", "1.5", ""]


@st.composite
def csv_texts(draw):
    """CSV text field by field: raw fields, quoted ones (with delimiters, quotes, line ends), a few irregularities."""

    def field():
        body = "".join(draw(st.lists(st.sampled_from(PIECES), max_size=4)))
        mode = draw(st.sampled_from(["raw"] * 20 + ["quoted"] * 10 + ["spaced"]))
        if mode == "raw":
            return "".join(c for c in body if c not in ',"\r\n')
        quoted = _quote(body)
        return " " + quoted if mode == "spaced" else quoted

    n = draw(st.integers(2, 3))
    newline = draw(st.sampled_from(["\n", "\r\n"]))
    rows = [",".join(f"c{i}" for i in range(n))]
    for _ in range(draw(st.integers(0, 12))):
        width = n + draw(st.sampled_from([0] * 30 + [-1, 1]))
        rows.append(",".join(field() for _ in range(max(width, 1))))
        if draw(st.integers(0, 40)) == 0:
            rows.append(draw(st.sampled_from(["", " ", "\t"])))
    text = newline.join(rows) + draw(st.sampled_from([newline, ""]))
    context = ["c2"] if n == 3 and draw(st.booleans()) else []
    return text, dict(sensitive="c0", outcome="c1", context=context, dropna=draw(st.booleans()))


@settings(suppress_health_check=[HealthCheck.too_slow], max_examples=150)
@given(csv_texts())
def test_csv_text_counted_as_pandas_reads_it(case):
    text, kw = case
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "r.csv"
        path.write_bytes(text.encode())
        event("DuckDB" if engine.csv_group_by(path, ["c0", "c1"]) is not None else "pandas")
        assert_same(reference(path, **kw), counted(path, **kw))


@settings(suppress_health_check=[HealthCheck.too_slow], max_examples=100)
@given(csv_texts(), st.integers(1, 9))
def test_csv_scan_does_not_depend_on_block_boundaries(case, block):
    text, _ = case
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "r.csv"
        path.write_bytes(text.encode())
        whole = [engine.csv_regular(path, n) for n in (2, 3)]
        original = engine._SCAN_BLOCK
        engine._SCAN_BLOCK = block
        try:
            assert [engine.csv_regular(path, n) for n in (2, 3)] == whole
        finally:
            engine._SCAN_BLOCK = original


def _csv_column(draw, kind, n):
    """One column of a frame that pandas writes with to_csv: every kind read_csv infers back differently."""
    nulls = draw(st.booleans())
    mask = draw(st.lists(st.booleans(), min_size=n, max_size=n)) if nulls else [False] * n
    pools = {
        "int": [-3, 0, 2, 7, 10**18],
        "float": [-1.5, -0.0, 0.0, 0.25, 3.0, 1e-300, float("inf")],
        "bool": [True, False],
        "str": ["a", "b", "B", "é", "", "NA", "1", "01", " x", 'q"q', "a,b"],
        "mixed": [1, "1", 2.5, "x", True],
    }
    vals = draw(st.lists(st.sampled_from(pools[kind]), min_size=n, max_size=n))
    return pd.array([None if m else v for v, m in zip(vals, mask)], dtype=object)


@settings(suppress_health_check=[HealthCheck.too_slow], max_examples=100)
@given(st.data())
def test_csv_written_by_pandas_counted_as_pandas_reads_it(data):
    n = data.draw(st.integers(0, 30))
    kinds = data.draw(st.lists(st.sampled_from(["int", "float", "bool", "str", "mixed"]), min_size=2, max_size=5))
    frame = pd.DataFrame({f"{k}{i}": _csv_column(data.draw, k, n) for i, k in enumerate(kinds)})
    names = data.draw(st.permutations(list(frame.columns)))
    n_ctx = data.draw(st.integers(0, len(names) - 2))
    kw = dict(
        sensitive=[names[0]], outcome=names[1], context=list(names[2 : 2 + n_ctx]), dropna=data.draw(st.booleans())
    )
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / data.draw(st.sampled_from(["r.csv", "r.txt", "r.csv.gz"]))
        frame.to_csv(path, index=False)
        assert_same(reference(path, **kw), counted(path, **kw))


@pytest.mark.parametrize(
    "text, sensitive",
    [
        ("g,y\n01,1\n1,0\n001,1\n", "g"),  # leading zeros: one integer 1 for pandas
        ("g,y\n01,1\nx,0\n001,1\n", "g"),  # the same fields in a text column stay apart
        ("g,y\n1,1\n,0\n2,1\n", "g"),  # a missing value makes integers floats
        ("g,y\nTrue,1\nFALSE,0\ntrue,1\n", "g"),  # booleans
        ("g,y\nTrue,1\n,0\nfalse,1\n", "g"),  # booleans with a missing value: object
        ("g,y\nNA,1\nnan,0\n-nan,1\nNULL,1\n<NA>,1\n#N/A,0\na,1\n", "g"),  # pandas' missing markers
        ('g,y\n"",1\n"NA",0\na,1\n', "g"),  # quoted missing markers are missing too
        ("g,y\ninf,1\n-inf,0\n1.5,1\nInfinity,1\n", "g"),  # "inf" strings are numbers
        ("g,y\n1e400,1\n2,0\n", "g"),
        ("g,y\n9223372036854775808,1\n1,0\n", "g"),  # beyond int64: uint64
        ("g,y\n9223372036854775808,1\n-1,0\n", "g"),  # beyond both: object
        ("g,y\n1,1\n2.5,0\nx,1\n", "g"),  # mixed: text
        ('g,y\n"a, b",1\n"say ""hi""",0\n"two\nlines",1\n', "g"),  # quoted delimiter, quote and newline
        ("g,y\r\na,1\r\nb,0\r\n", "g"),
        ("g,y\na,1\n\nb,0\n\n", "g"),  # blank lines are skipped
        ("\ufeffg,y\na,1\nb,0", "g"),  # a byte order mark, no final newline
        ("g,y,\na,1,\nb,0,\n", "g"),  # an empty last column: "Unnamed: 2"
        ("g,y\n-0.0,1\n0,0\n", "g"),  # 0.0 and -0.0: the label is the one met first
        ("g,y\n0,1\n-0.0,0\n", "g"),
        ("g,y\n-0.0,1\n0,0\n", "y"),
    ],
)
def test_tricky_csv_fields(tmp_path, text, sensitive):
    path = tmp_path / "r.csv"
    path.write_bytes(text.encode())
    for dropna in (False, True):
        kw = dict(sensitive=sensitive, outcome="y" if sensitive != "y" else "g", dropna=dropna)
        assert_same(reference(path, **kw), counted(path, **kw))


def test_a_repeated_name_is_not_renamed(tmp_path):
    """pandas renames a second "g" to "g.1"; count_file does not: "g" is the first copy, "g.1" no column."""
    path = tmp_path / "r.csv"
    path.write_bytes(b"g,g,y\na,b,1\nb,c,0\n")
    with pytest.raises(InputError, match=r"^sensitive: unknown column; the data has: g, y \(got 'g.1'\)$"):
        count_file(path, sensitive="g.1", outcome="y")
    with pytest.raises(InputError, match=r"^DATA: names column 'g' 2 times, with different values"):
        count_file(path, sensitive="g", outcome="y")


@pytest.mark.parametrize(
    "text",
    [
        'g,y\na, "b"\nb,0\n',  # DuckDB would trim the spaces around a quoted field; pandas keeps them
        'g,y\na,"1" \nb,0\n',
        "\ng,y\na,1\nb,0\n",  # pandas skips a blank line before the header
        "g,y\na,1\nb\n",  # a short row: pandas fills it with a missing value
        "g,y\na,1,2\nb,0\n",  # a long row: pandas fails
        "g,y\na,1,2\nb,0,3\n",  # every row long: pandas takes the first field as the index
        'g,y\na,"1\n',  # an unclosed quote
        "g,y\na,1\n  \nb,0\n",  # a line of spaces
        "g,y\na,1\rb,0\n",  # mixed line ends
        'g,y\na,"x"y\n',  # text after a closing quote
        "g,y\na,1,\nb,0,\n",  # empty fields past the last column: DuckDB would drop them, pandas takes an index
        "g,y\na,1\nb,0,\n",  # pandas fails
        "g,y\n,\t,",
        'g,y\na,x"y\n',  # a quote inside an unquoted field
        '\ufeff"g",y\na,1\n',  # a quote after the byte order mark
        "g,y\ra,1\rb,0\r",  # lone carriage returns
    ],
)
def test_csv_that_duckdb_may_split_differently_is_left_to_pandas(tmp_path, monkeypatch, text):
    path = tmp_path / "r.csv"
    path.write_bytes(text.encode())
    kw = dict(sensitive="g", outcome="y", dropna=True)
    ref = reference(path, **kw)
    calls = spy_fallback(monkeypatch)
    assert_same(ref, counted(path, **kw))
    assert calls == [path]


def test_single_column_csv_is_left_to_pandas(tmp_path, monkeypatch):
    path = tmp_path / "r.csv"
    path.write_text("y\n1\n\n0\n1\n")  # pandas skips the blank line; DuckDB would read a missing value
    calls = spy_fallback(monkeypatch)
    t = count_file(path, sensitive="y", outcome="y")
    assert calls == [path] and t.n == 3
    assert_same(reference(path, sensitive="y", outcome="y"), t)


def test_plain_csv_is_counted_by_duckdb_not_pandas(tmp_path, monkeypatch):
    path = tmp_path / "r.csv"
    path.write_text('ctx,g,y\np,a,1\np,"b, c",0\nq,a,1\nq,a,\n')
    calls = spy_fallback(monkeypatch)
    t = count_file(path, sensitive="g", outcome="y", context="ctx", dropna=True)
    assert calls == []
    assert (t.contexts, t.groups, t.decisions) == (("p", "q"), ("a", "b, c"), (0.0, 1.0))
    assert t.counts.tolist() == [[[0, 1], [1, 0]], [[0, 1], [0, 0]]]
    assert str(counted(path, sensitive="g", outcome="y", context="ctx")) == (
        "column 'y': has 1 missing values (drop those rows: `dropna`)"
    )


def test_gzip_csv(tmp_path):
    path = tmp_path / "r.csv.gz"
    with gzip.open(path, "wt") as f:
        f.write("g,y\na,1\nb,0\nb,1\n")
    t = count_file(path, sensitive="g", outcome="y")
    assert t.counts.tolist() == [[[0, 1], [1, 1]]]
    assert_same(reference(path, sensitive="g", outcome="y"), t)


def test_csv_errors_are_those_of_pandas(tmp_path):
    for name, content in (
        ("empty.csv", b""),
        ("header.csv", b"g,y\n"),
        ("latin1.csv", "g,y\nJos\u00e9,1\n".encode("latin-1")),
        ("gzip-named.csv", gzip.compress(b"g,y\na,1\n")),
        ("bad.gz", b"not gzip"),
        ("r.json", b"g,y\na,1\n"),
    ):
        path = tmp_path / name
        path.write_bytes(content)
        for kw in (dict(sensitive="g", outcome="y"), dict(sensitive="nope", outcome="y")):
            ref = reference(path, **kw)
            assert isinstance(ref, InputError), name
            assert_same(ref, counted(path, **kw))
    assert_same(
        reference(tmp_path / "none.csv", sensitive="g", outcome="y"),
        counted(tmp_path / "none.csv", sensitive="g", outcome="y"),
    )


def test_unknown_csv_column_names_the_flag(tmp_path):
    path = tmp_path / "r.csv"
    path.write_text("g,y\na,1\n")
    assert str(counted(path, sensitive="g", outcome="z")) == "outcome: unknown column; the data has: g, y (got 'z')"


def test_larger_csv_written_by_the_csv_module(tmp_path):
    rng = np.random.default_rng(11)
    n = 20_000
    rows = zip(
        rng.integers(0, 50, n),
        rng.choice(["a", "b", "c, d", 'e"f', ""], n),
        rng.choice(["1", "0", "NA", "1.0"], n),
    )
    path = tmp_path / "r.csv"
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["ctx", "grp", "y"])
        w.writerows(rows)
    kw = dict(sensitive="grp", outcome="y", context="ctx", dropna=True)
    assert_same(reference(path, **kw), count_file(path, **kw))


# ---------------------------------------------------------------- Parquet: Arrow types converted as read_parquet does


def test_parquet_types_converted_as_pandas_reads_them(tmp_path):
    n = 12
    df = pd.DataFrame(
        {
            "i8": np.array([1, 2, 3] * 4, dtype=np.int8),
            "u64": np.array([2**63, 1, 0] * 4, dtype=np.uint64),
            "f32": np.array([0.1, 0.25, np.nan] * 4, dtype=np.float32),
            "nb": pd.array([True, None, False] * 4, dtype="boolean"),
            "ni": pd.array([1, None, 3] * 4, dtype="Int64"),
            "s": pd.array(["a", None, "b"] * 4, dtype="string"),
            "ts": pd.to_datetime(["2020-01-01 00:00:00.000000001", "2021-05-06", "2020-01-01"] * 4, format="ISO8601"),
            "tz": pd.to_datetime(
                ["2020-01-01 00:00:00.000000001", "2021-05-06", "2020-01-01"] * 4, format="ISO8601"
            ).tz_localize("Europe/Paris"),
            "d": [dt.date(2020, 1, 1), dt.date(2021, 1, 2), None] * 4,
            "dec": [decimal.Decimal("1.10"), decimal.Decimal("2.00"), None] * 4,
            "b": [b"x", b"y", None] * 4,
            "empty": [None] * n,
            "cat": pd.Categorical(["z", "a", None] * 4, categories=["z", "q", "a"], ordered=True),
            "y": [0, 1, 1, 0] * 3,
        }
    )
    path = tmp_path / "r.parquet"
    df.to_parquet(path, row_group_size=5)
    for col in df.columns.drop("y"):
        for dropna in (False, True):
            kw = dict(sensitive=[col], outcome="y", dropna=dropna)
            assert_same(reference(path, **kw), counted(path, **kw))
    kw = dict(sensitive=["cat", "nb"], outcome="y", context=["tz", "d"], dropna=True)
    assert_same(reference(path, **kw), counted(path, **kw))


def test_parquet_folder_with_glob_characters(tmp_path):
    folder = tmp_path / "part[s]"
    folder.mkdir()
    df = pd.DataFrame({"g": list("abab") * 3, "y": [1, 0, 0, 0, 1, 1] * 2})
    df.iloc[:5].to_parquet(folder / "part-0.parquet")
    df.iloc[5:].to_parquet(folder / "part-1.parquet")
    (tmp_path / "parts").mkdir()  # what the pattern part[s] would match
    df.to_parquet(tmp_path / "parts" / "part-0.parquet")
    t = count_file(folder, sensitive="g", outcome="y")
    assert t.n == 12
    assert_same(count_records(pd.read_parquet(folder), sensitive="g", outcome="y"), t)


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
    for kw in (dict(sensitive="s", outcome="y", dropna=True), dict(sensitive="ls", outcome="y", context="s")):
        assert_same(reference(path, **kw), counted(path, **kw))


def test_unreadable_parquet_is_one_line(tmp_path):
    path = tmp_path / "bad.parquet"
    path.write_bytes(b"PAR1" + b"\0" * 64 + b"PAR1")
    err = counted(path, sensitive="g", outcome="y")
    assert isinstance(err, InputError) and err.field == "DATA" and err.problem.startswith("cannot be read (")
    assert "\n" not in str(err)


def test_relative_paths(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    df = pd.DataFrame({"g": ["a", "b"], "y": [1, 0]})
    df.to_csv("r.csv", index=False)
    df.to_parquet("r.parquet")
    for name in ("r.csv", "r.parquet", Path("r.csv")):
        assert count_file(name, sensitive="g", outcome="y").counts.tolist() == [[[0, 1], [1, 0]]]


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
    code = "import sys, fairaudit.estimate; print(' '.join(m for m in ('pandas', 'pyarrow', 'duckdb') if m in sys.modules))"
    loaded = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert "duckdb" not in loaded
    if "pandas" not in loaded:  # pandas imports pyarrow itself (other modules of fairaudit may import pandas)
        assert "pyarrow" not in loaded


def test_plain_parquet_is_counted_without_pandas(tmp_path):
    """Integers, text, booleans and floats without missing values: labels from numpy, no pandas import."""
    path = tmp_path / "r.parquet"
    frame = pd.DataFrame(
        {
            "context": [3, 1, 2, 1] * 5,
            "group": ["b", "a", "é", "a"] * 5,
            "flag": [True, False] * 10,
            "score": np.array([0.5, 0.25, 0.5, 2.0] * 5, dtype=np.float32),
            "decision": np.array([0, 1, 2, 1, 1] * 4, dtype=np.uint8),
        }
    )
    frame.to_parquet(path)
    kw = dict(sensitive=["group", "flag"], outcome="decision", context=["context", "score"])
    assert_same(reference(path, **kw), count_file(path, **kw))
    code = (
        "import sys; from fairaudit.estimate import count_file; before = 'pandas' in sys.modules; "
        f"t = count_file({str(path)!r}, sensitive=['group', 'flag'], outcome='decision', context=['context', 'score']); "
        "print(before, 'pandas' in sys.modules, t.n)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    if out[0] == "True":
        pytest.skip("importing fairaudit imports pandas already")
    assert out == ["False", "False", "20"]
