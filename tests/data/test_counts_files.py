"""Out-of-core counts (count_file): identical to pandas' count_records on the records written; count tables; the CLI.

The independent route is pandas: ``count_records`` counts the DataFrame that was
written to the Parquet file, in memory (``factorize`` and ``bincount``), while
``count_file`` counts the file with one DuckDB ``GROUP BY`` (more text and
Parquet cases in test_record_files.py); missing values are checked against
``DataFrame.isna`` on the whole frame, counts against ``groupby().size()`` and
hand counts.
"""

from __future__ import annotations

import json
import math
import sqlite3
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

pa = pytest.importorskip("pyarrow")
pq = pytest.importorskip("pyarrow.parquet")

from _cli import run, run_json  # noqa: E402

import fairaudit as fa  # noqa: E402
from fairaudit import InputError, count_file, count_records, count_table  # noqa: E402


def _outcome(fn, *args, **kw):
    """The CountTable, or the InputError raised."""
    try:
        return fn(*args, **kw)
    except InputError as exc:
        return exc


def streamed(path, **kw):
    """count_file's table, or the error it raises."""
    return _outcome(count_file, path, **kw)


def in_memory(frame, **kw):
    """The records counted by pandas in memory, a categorical as its values (a file's labels: its values, sorted)."""
    plain = frame.apply(lambda c: c.astype(object) if isinstance(c.dtype, pd.CategoricalDtype) else c)
    return _outcome(count_records, plain, **kw)


def _types(labels):
    return [tuple(map(type, v)) if isinstance(v, tuple) else type(v) for v in labels]


def assert_identical(a, b):
    """Same error text, or the same labels (values, Python types, order), columns and int64 counts."""
    if isinstance(a, InputError) or isinstance(b, InputError):
        assert isinstance(a, InputError) and isinstance(b, InputError), (a, b)
        assert str(a) == str(b)
        return
    for axis in ("contexts", "groups", "decisions"):
        la, lb = getattr(a, axis), getattr(b, axis)
        assert la == lb, axis
        assert _types(la) == _types(lb), axis
    assert (a.context_columns, a.sensitive_columns, a.outcome_column) == (
        b.context_columns,
        b.sensitive_columns,
        b.outcome_column,
    )
    assert a.counts.dtype == b.counts.dtype == np.int64
    assert a.counts.tolist() == b.counts.tolist()


# ---------------------------------------------------------------- records of every dtype, with nulls and NaN


def _column(draw, kind, n):
    """One column of n values of a dtype (pandas side), with missing values sometimes."""
    nulls = draw(st.booleans())
    mask = draw(st.lists(st.booleans(), min_size=n, max_size=n)) if nulls else [False] * n
    if kind == "int":
        vals = draw(st.lists(st.sampled_from([-3, 0, 2, 7, 10]), min_size=n, max_size=n))
        if nulls:  # nullable Int64 (kept by the pandas metadata) or float64 with NaN
            arr = pd.array([None if m else v for v, m in zip(vals, mask)], dtype="Int64")
            return arr if draw(st.booleans()) else arr.astype("float64")
        return np.array(vals, dtype=np.int64)
    if kind == "str":
        vals = draw(st.lists(st.sampled_from(["a", "b", "B", "é", ""]), min_size=n, max_size=n))
        return pd.array([None if m else v for v, m in zip(vals, mask)], dtype=object)
    if kind == "bool":
        vals = draw(st.lists(st.booleans(), min_size=n, max_size=n))
        return np.array(vals) if not nulls else pd.array([None if m else v for v, m in zip(vals, mask)], dtype=object)
    if kind == "float":  # -0.0 and 0.0 are one value for pandas and two keys for Arrow
        vals = draw(st.lists(st.sampled_from([-1.5, -0.0, 0.0, 0.25, 3.0]), min_size=n, max_size=n))
        return np.array([np.nan if m else v for v, m in zip(vals, mask)], dtype=float)
    # pandas categorical: categories in a drawn order, some unused, ordered or not
    cats = draw(st.permutations(["z", "m", "a", "q"]))
    vals = draw(st.lists(st.sampled_from(cats[:3]), min_size=n, max_size=n))
    return pd.Categorical([None if m else v for v, m in zip(vals, mask)], categories=cats, ordered=draw(st.booleans()))


KINDS = ["int", "str", "bool", "float", "cat"]


@st.composite
def records(draw):
    n = draw(st.integers(0, 40))
    kinds = draw(st.lists(st.sampled_from(KINDS), min_size=3, max_size=6))
    frame = pd.DataFrame({f"{k}{i}": _column(draw, k, n) for i, k in enumerate(kinds)})
    names = list(frame.columns)
    roles = draw(st.permutations(names))
    n_sens = draw(st.integers(1, 2))
    n_ctx = draw(st.integers(0, len(names) - 1 - n_sens))
    sensitive, outcome = list(roles[:n_sens]), roles[n_sens]
    context = list(roles[n_sens + 1 : n_sens + 1 + n_ctx])
    return (
        frame,
        dict(sensitive=sensitive, outcome=outcome, context=context, dropna=draw(st.booleans())),
        draw(st.sampled_from([3, 7, 1000])),
    )


@pytest.mark.slow
@settings(suppress_health_check=[HealthCheck.too_slow], max_examples=150)
@given(records())
def test_streamed_counts_identical_to_pandas(case):
    frame, kw, row_group = case
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "records.parquet"
        frame.to_parquet(path, row_group_size=row_group)  # several row groups (and batches)
        ref = in_memory(frame, **kw)
        event(f"error: {ref.problem.split(' ')[0]}" if isinstance(ref, InputError) else "counted")
        assert_identical(ref, streamed(path, **kw))
        if not isinstance(ref, InputError):  # and the counts are those of pandas groupby on the whole frame
            whole = frame[list(dict.fromkeys(kw["context"] + kw["sensitive"] + [kw["outcome"]]))]
            if kw["dropna"]:
                whole = whole.dropna()
            assert ref.n == len(whole)
        elif "missing values" in str(ref):  # N is the number of records with no value there (pandas isna)
            col = str(ref).split("'")[1]
            assert f"has {int(frame[col].isna().sum())} missing values" in str(ref)


def test_hand_counted_parquet_with_tuple_labels(tmp_path):
    # 3 contexts (two columns), 2 x 2 groups, 2 decisions: fixed by hand
    df = pd.DataFrame(
        {
            "site": ["n", "n", "s", "s", "s", "n", "s", "n"],
            "year": [2023, 2024, 2023, 2023, 2023, 2023, 2023, 2024],
            "race": ["b", "a", "a", "b", "a", "a", "a", "a"],
            "sex": ["w", "m", "m", "m", "m", "w", "w", "m"],
            "hired": [True, False, True, True, False, True, True, True],
        }
    )
    path = tmp_path / "r.parquet"
    df.to_parquet(path, row_group_size=3)
    t = count_file(path, sensitive=["race", "sex"], outcome="hired", context=["site", "year"])
    assert t.contexts == (("n", 2023), ("n", 2024), ("s", 2023))
    assert t.groups == (("a", "m"), ("a", "w"), ("b", "m"), ("b", "w"))
    assert t.decisions == (False, True)
    expect = np.zeros((3, 4, 2), dtype=int)
    expect[0, 3, 1] = 1  # n 2023 b w True
    expect[1, 0, 0] = 1  # n 2024 a m False
    expect[2, 0, 1] = 1  # s 2023 a m True
    expect[2, 2, 1] = 1  # s 2023 b m True
    expect[2, 0, 0] = 1  # s 2023 a m False
    expect[0, 1, 1] = 1  # n 2023 a w True
    expect[2, 1, 1] = 1  # s 2023 a w True
    expect[1, 0, 1] = 1  # n 2024 a m True
    assert t.counts.tolist() == expect.tolist()
    assert_identical(in_memory(df, sensitive=["race", "sex"], outcome="hired", context=["site", "year"]), t)


def test_nan_and_null_float_keys_are_all_missing(tmp_path):
    # NaN (of any payload) and null are different group keys for DuckDB; both are missing: 4 missing values
    other_nan = np.array([0x7FF8000000000001], dtype=np.uint64).view(np.float64)[0]
    f = pa.array([np.nan, None, 1.0, other_nan, -np.nan, 1.0], type=pa.float64(), from_pandas=False)
    path = tmp_path / "nan.parquet"
    pq.write_table(pa.table({"f": f, "y": pa.array([1, 0, 1, 1, 0, 0])}), path, row_group_size=2)
    err = streamed(path, sensitive="f", outcome="y")
    assert str(err) == "column 'f': has 4 missing values (drop those rows: `dropna`)"
    t = count_file(path, sensitive="f", outcome="y", dropna=True)
    assert (t.groups, t.decisions, t.counts.tolist(), t.missing) == ((1.0,), (0, 1), [[[1, 1]]], (("f", 4.0),))


def test_categorical_with_different_dictionaries_per_row_group(tmp_path):
    # DuckDB reads a dictionary column as its values: labelled by them, sorted, whatever the row groups' dictionaries
    path = tmp_path / "cat.parquet"
    kind = pa.dictionary(pa.int32(), pa.string())
    with pq.ParquetWriter(path, pa.schema([("c", kind), ("y", pa.int64())])) as w:
        w.write_table(
            pa.table({"c": pa.DictionaryArray.from_arrays(pa.array([0, 1, 0], pa.int32()), ["q", "b"]), "y": [1, 0, 1]})
        )
        w.write_table(
            pa.table(
                {"c": pa.DictionaryArray.from_arrays(pa.array([0, 1, None], pa.int32()), ["a", "b"]), "y": [0, 0, 1]}
            )
        )
    t = count_file(path, sensitive="c", outcome="y", dropna=True)
    assert (t.groups, t.counts.tolist()) == (("a", "b", "q"), [[[1, 0], [2, 0], [0, 2]]])
    assert str(streamed(path, sensitive="c", outcome="y")).startswith("column 'c': has 1 missing values")


def test_folder_of_parquet_files(tmp_path):
    df = pd.DataFrame({"g": list("abab") * 3, "y": [1, 0, 0, 0, 1, 1] * 2})
    folder = tmp_path / "parts"
    folder.mkdir()
    df.iloc[:5].to_parquet(folder / "part-0.parquet")
    df.iloc[5:].to_parquet(folder / "part-1.parquet")
    t = count_file(folder, sensitive="g", outcome="y")
    ref = df.groupby(["g", "y"]).size()
    assert t.counts[0].tolist() == [[ref["a", 0], ref["a", 1]], [ref["b", 0], ref["b", 1]]]
    assert_identical(count_records(pd.read_parquet(folder), sensitive="g", outcome="y"), t)


# ---------------------------------------------------------------- errors


def test_unknown_column_names_the_flag_and_lists_the_schema(tmp_path):
    df = pd.DataFrame({"g": ["a", "b"], "y": [0, 1], "x": [1, 2]}, index=pd.Index([5, 6], name="rowid"))
    path = tmp_path / "r.parquet"
    df.to_parquet(path)  # the index is stored as a column 'rowid'; pandas reads it back as the index
    for flag, kw in (
        ("sensitive", dict(sensitive=["nope"], outcome="y")),
        ("outcome", dict(sensitive=["g"], outcome="nope")),
        ("context", dict(sensitive=["g"], outcome="y", context=["nope"])),
        ("sensitive", dict(sensitive=["rowid"], outcome="y")),
    ):
        err = streamed(path, **kw)
        bad = {"sensitive": kw["sensitive"][0], "outcome": kw["outcome"], "context": "nope"}[flag]
        assert str(err) == f"{flag}: unknown column; the data has: g, y, x (got {bad!r})"
        assert_identical(in_memory(df, **kw), err)
    assert str(streamed(path, sensitive=[], outcome="y")) == "sensitive: name at least one column (got [])"


def test_file_errors(tmp_path):
    assert str(streamed(tmp_path / "none.parquet", sensitive="g", outcome="y")) == (
        f"DATA: no such file (got {str(tmp_path / 'none.parquet')!r})"
    )
    bad = tmp_path / "bad.parquet"
    bad.write_text("not parquet\n")
    err = streamed(bad, sensitive="g", outcome="y")
    assert err.field == "DATA" and err.problem.startswith("cannot be read by DuckDB (") and "\n" not in str(err)
    empty = tmp_path / "empty.parquet"
    pd.DataFrame({"g": pd.Series([], dtype=str), "y": pd.Series([], dtype=int)}).to_parquet(empty)
    assert str(streamed(empty, sensitive="g", outcome="y")) == "DATA: has no records to count"


def test_csv_with_a_missing_group(tmp_path):
    df = pd.DataFrame({"g": ["a", "b", "b", None], "y": [1, 0, 1, 1]})
    path = tmp_path / "r.csv"
    df.to_csv(path, index=False)
    assert str(streamed(path, sensitive="g", outcome="y")) == (
        "column 'g': has 1 missing values (drop those rows: `dropna`)"
    )
    t = count_file(path, sensitive="g", outcome="y", dropna=True)
    assert (t.groups, t.counts.tolist()) == (("a", "b"), [[[0, 1], [1, 1]]])


# ---------------------------------------------------------------- count tables (count=COL)


def _records_frame():
    rng = np.random.default_rng(5)
    n = 500
    return pd.DataFrame(
        {
            "ctx": rng.choice(["p", "q", "r"], n),
            "grp": rng.choice(["a", "b", "c"], n),
            "sex": rng.choice(["m", "w"], n),
            "decision": rng.choice([0, 1, 2], n),
        }
    )


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_count_table_file_equals_records(tmp_path, suffix):
    df = _records_frame()
    agg = df.groupby(["ctx", "grp", "sex", "decision"]).size().reset_index(name="n")
    agg = agg.sample(frac=1, random_state=1)  # any row order
    path = tmp_path / f"counts{suffix}"
    agg.to_csv(path, index=False) if suffix == ".csv" else agg.to_parquet(path)
    kw = dict(sensitive=["grp", "sex"], outcome="decision", context=["ctx"])
    assert_identical(count_records(df, **kw), count_file(path, count="n", **kw))


def test_count_table_from_sqlite_group_by_with_nulls(tmp_path):
    df = pd.DataFrame(
        {
            "ctx": ["p", "p", "q", "q", "q", None, "p"],
            "grp": ["a", "b", "a", None, "a", "b", "b"],
            "y": [1, 0, 1, 1, 0, 1, 0],
        }
    )
    con = sqlite3.connect(":memory:")
    df.to_sql("records", con, index=False)
    agg = pd.read_sql("SELECT ctx, grp, y, COUNT(*) AS n FROM records GROUP BY ctx, grp, y", con)
    path = tmp_path / "counts.csv"
    agg.to_csv(path, index=False)
    kw = dict(sensitive="grp", outcome="y", context="ctx")
    err = streamed(path, count="n", **kw)  # NULL keys are their own rows; reported like missing values in records
    assert str(err) == "column 'ctx': has 1 missing values (drop those rows: `dropna`)"
    assert str(err) == str(_err(count_records, df, **kw))
    t = count_file(path, count="n", dropna=True, **kw)
    assert (t.contexts, t.groups, t.counts.tolist()) == (("p", "q"), ("a", "b"), [[[0, 1], [2, 0]], [[1, 1], [0, 0]]])
    assert_identical(count_records(df, dropna=True, **kw), t)


def _err(fn, *args, **kw):
    try:
        fn(*args, **kw)
    except InputError as exc:
        return exc
    raise AssertionError("no error")


def test_count_table_errors(tmp_path):
    path = tmp_path / "counts.csv"
    pd.DataFrame({"g": ["a", "a", "b"], "y": [1, 1, 0], "n": [3, 2, 4]}).to_csv(path, index=False)
    err = streamed(path, sensitive="g", outcome="y", count="n")
    assert err.field == "count table" and "twice" in str(err) and "'g': 'a'" in str(err) and "'n': 2" in str(err)
    pd.DataFrame({"g": ["a", "b"], "y": [1, 0], "n": [3, -1]}).to_csv(path, index=False)
    assert str(streamed(path, sensitive="g", outcome="y", count="n")) == (
        "column 'n': must hold finite non-negative numbers; data row 2 (g='b', y='0') is not (got -1)"
    )
    assert str(streamed(path, sensitive="g", outcome="y", count="count")) == (
        "count: unknown column; the data has: g, y, n (got 'count')"
    )
    assert str(streamed(path, sensitive="h", outcome="y", count="n")).startswith("sensitive: unknown column")


def test_count_table_null_rows_weigh_their_counts():
    agg = pd.DataFrame({"g": ["a", None, "b", None], "y": [1, 1, 0, 0], "n": [3, 5, 4, 2]})
    err = _err(count_table, agg, sensitive="g", outcome="y", count="n")
    assert str(err) == "column 'g': has 7 missing values (drop those rows: `dropna`)"
    t = count_table(agg, sensitive="g", outcome="y", count="n", dropna=True)
    assert (t.groups, t.counts.tolist(), t.counts.dtype) == (("a", "b"), [[[0, 3], [4, 0]]], np.int64)
    # a row with no label and count 0 stands for no record: nothing is missing
    t = count_table(agg.assign(n=[3, 0, 4, 0]), sensitive="g", outcome="y", count="n")
    assert (t.groups, t.counts.tolist()) == (("a", "b"), [[[0, 3], [4, 0]]])


# ---------------------------------------------------------------- audit() of a CountTable


def test_audit_of_a_count_table_equals_audit_of_records():
    df = _records_frame()
    kw = dict(sensitive=["grp"], outcome="decision", context=["ctx"])
    a = fa.audit(df, utility="u", intervals=fa.IntervalOptions(confidence=0.9), **kw)
    b = fa.audit(count_records(df, **kw), utility="u", intervals=fa.IntervalOptions(confidence=0.9))
    c = fa.audit(count_records(df, **kw), utility="u", intervals=fa.IntervalOptions(confidence=0.9), **kw)
    for r in (b, c):
        assert (
            r.observed.local_fairness.value == a.observed.local_fairness.value
            and r.observed.global_fairness.value == a.observed.global_fairness.value
        )
        assert (r.intervals.local_fairness.lower, r.intervals.local_fairness.upper) == (
            a.intervals.local_fairness.lower,
            a.intervals.local_fairness.upper,
        )
    t = count_records(df, **kw)
    assert str(_err(fa.audit, t, sensitive=["sex"])) == (
        "sensitive: does not match the count table, whose column(s) are [grp] (got 'sex')"
    )
    assert str(_err(fa.audit, t, outcome="y")).startswith("outcome: does not match the count table")
    assert str(_err(fa.audit, t, context=[])) == (
        "context: does not match the count table, whose column(s) are [ctx] (got '')"
    )
    assert str(_err(fa.audit, df, outcome="decision")) == "sensitive: name at least one column"


# ---------------------------------------------------------------- the command line


def _write_both(tmp_path, df):
    csv, parquet = tmp_path / "r.csv", tmp_path / "r.parquet"
    df.to_csv(csv, index=False)
    df.to_parquet(parquet, row_group_size=64)
    return csv, parquet


@pytest.mark.parametrize("fmt", ["json", "text", "markdown"])
def test_cli_parquet_output_equals_csv_output(tmp_path, capsys, fmt):
    df = _records_frame()
    csv, parquet = _write_both(tmp_path, df)
    args = [
        "--sensitive",
        "grp,sex",
        "--context",
        "ctx",
        "--outcome",
        "decision",
        "--utility",
        "u >= 1",
        "--confidence",
        "0.9",
        "--format",
        fmt,
    ]
    code_c, out_c, _ = run(capsys, "audit", csv, *args)
    code_p, out_p, _ = run(capsys, "audit", parquet, *args)
    assert code_c == code_p == 0 and out_p == out_c
    if fmt == "json":  # and the numbers are those of the records (pandas groupby)
        d = json.loads(out_p)
        hit = (df["decision"] >= 1).groupby([df["grp"], df["sex"]]).mean()
        assert d["n"] == 500 and d["global"]["value"] == pytest.approx(math.log(hit.max() / hit.min()), rel=1e-12)


def test_cli_count_table(tmp_path, capsys):
    df = _records_frame()
    csv, _ = _write_both(tmp_path, df)
    agg = tmp_path / "counts.parquet"
    df.groupby(["ctx", "grp", "decision"]).size().reset_index(name="n").to_parquet(agg)
    args = ["--sensitive", "grp", "--context", "ctx", "--outcome", "decision", "--positive", "2"]
    _, from_records, _ = run_json(capsys, "audit", csv, *args)
    code, from_counts, _ = run_json(capsys, "audit", agg, "--count", "n", *args)
    assert code == 0 and from_counts == from_records and from_counts["n"] == 500


def test_cli_bad_input_is_one_line_exit_2(tmp_path, capsys):
    df = pd.DataFrame({"g": ["a", None, "b"], "y": [1, 0, 1]})
    _, parquet = _write_both(tmp_path, df)
    for argv, needle in (
        (
            ["--sensitive", "race", "--outcome", "y"],
            "fairaudit: error: --sensitive: unknown column; the data has: g, y (got 'race')",
        ),
        (["--sensitive", "g", "--outcome", "y"], "fairaudit: error: column 'g': has 1 missing values"),
        (["--sensitive", "g", "--outcome", "y", "--count", "n"], "fairaudit: error: --count: unknown column"),
    ):
        code, out, err = run(capsys, "audit", parquet, *argv)
        assert code == 2 and out == "" and err.count("\n") == 1 and err.startswith(needle), err
    code, out, err = run(capsys, "audit", parquet, "--sensitive", "g", "--outcome", "y", "--dropna", "--format", "json")
    assert code == 0 and json.loads(out)["n"] == 2
    bad = tmp_path / "bad.parquet"
    bad.write_bytes(b"PAR1 not really")
    code, out, err = run(capsys, "audit", bad, "--sensitive", "g", "--outcome", "y")
    assert (
        code == 2 and err.count("\n") == 1 and err.startswith("fairaudit: error: DATA: cannot be read by DuckDB (")
    ), err
