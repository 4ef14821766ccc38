"""count_file's DuckDB engine on text files read with ``csv`` options: separators, no header, names, NA markers.

The oracle is the pandas route with the same options,
``count_records(read_records(path, csv))``: the same labels (values, types,
``repr``, order), int64 counts, or the same error text. The files DuckDB
leaves to pandas (another separator, ``skip_initial_space``, bz2) are
checked against the oracle too, and which route counted is checked by a spy.
"""

from __future__ import annotations

import bz2
import gzip
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

import fairaudit._count_engine as engine
import fairaudit.estimate as estimate
from fairaudit import CsvFormat, InputError, count_file, count_records, read_records

pytest.importorskip("duckdb")

from _counting import spy_fallback  # noqa: E402
from test_count_duckdb import assert_same  # noqa: E402

SEPARATORS = sorted(engine.DUCKDB_SEPARATORS) + [" ", "#"]  # the last two go to pandas


def reference(path, csv, **kw):
    """The pandas route with the file's options, or the error it raises."""
    try:
        return count_records(read_records(path, csv), **kw)
    except InputError as exc:
        return exc


def counted(path, csv, **kw):
    try:
        return count_file(path, csv=csv, **kw)
    except InputError as exc:
        return exc


def _write(path: Path, text: str) -> None:
    data = text.encode()
    if path.suffix == ".gz":
        data = gzip.compress(data)
    elif path.suffix == ".bz2":
        data = bz2.compress(data)
    path.write_bytes(data)


PIECES = ["x", "1", "2.5", " ", '"', "NA", "?", "-", "0", "True", "é", "\\", "#", ",", ";", "\t", "|", ":", ""]


@st.composite
def formatted_texts(draw):
    """A delimited text with its CsvFormat: a separator, a header or names, NA markers; fields quoted or not."""
    sep = draw(st.sampled_from(SEPARATORS + sorted(engine.DUCKDB_SEPARATORS)))  # DuckDB's twice as likely
    n = draw(st.integers(2, 3))

    def field():
        body = "".join(draw(st.lists(st.sampled_from(PIECES), max_size=3)))
        mode = draw(st.sampled_from(["raw"] * 40 + ["quoted"] * 20 + ["spaced"]))
        if mode == "raw":
            return "".join(c for c in body if c not in f'{sep}"\r\n')
        quoted = '"' + body.replace('"', '""') + '"'
        return " " + quoted if mode == "spaced" else quoted

    header = draw(st.booleans())
    newline = draw(st.sampled_from(["\n", "\r\n"]))
    rows = [sep.join(f"h{i}" for i in range(n))] if header else []
    for _ in range(draw(st.integers(0, 12))):
        width = n + draw(st.sampled_from([0] * 60 + [-1, 1]))
        rows.append(sep.join(field() for _ in range(max(width, 1))))
    text = newline.join(rows) + draw(st.sampled_from([newline, ""]))
    names = tuple(f"c{i}" for i in range(n)) if not header or draw(st.booleans()) else None
    fmt = CsvFormat(
        header=header,
        names=names,
        sep=None if sep == "," and draw(st.booleans()) else sep,
        na_values=tuple(draw(st.lists(st.sampled_from(["?", "-", "x", "é", "1"]), max_size=2, unique=True))),
        skip_initial_space=draw(st.sampled_from([False] * 9 + [True])),
    )
    cols = list(names) if names else [f"h{i}" for i in range(n)]
    context = [cols[2]] if n == 3 and draw(st.booleans()) else []
    suffix = draw(st.sampled_from([".csv", ".txt", ".csv.gz", ".data"]))
    return text, fmt, suffix, dict(sensitive=cols[0], outcome=cols[1], context=context, dropna=draw(st.booleans()))


@settings(suppress_health_check=[HealthCheck.too_slow], max_examples=200)
@given(formatted_texts())
def test_text_with_options_counted_as_pandas_reads_it(case):
    text, fmt, suffix, kw = case
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"r{suffix}"
        _write(path, text)
        kind = estimate.file_kind(path)
        routed = engine.csv_group_by(path, [kw["sensitive"], kw["outcome"]], kind, fmt)
        event("DuckDB" if routed is not None else "pandas")
        assert_same(reference(path, fmt, **kw), counted(path, fmt, **kw))


@settings(suppress_health_check=[HealthCheck.too_slow], max_examples=60)
@given(formatted_texts(), st.integers(1, 9))
def test_scan_with_any_separator_does_not_depend_on_block_boundaries(case, block):
    text, fmt, _, _ = case
    sep = fmt.sep or ","
    if sep not in engine.DUCKDB_SEPARATORS:
        return
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "r.csv"
        path.write_bytes(text.encode())
        whole = [engine.csv_regular(path, n, sep=sep) for n in (2, 3)]
        original = engine._SCAN_BLOCK
        engine._SCAN_BLOCK = block
        try:
            assert [engine.csv_regular(path, n, sep=sep) for n in (2, 3)] == whole
        finally:
            engine._SCAN_BLOCK = original


def test_headerless_semicolon_file_with_a_missing_marker_is_counted_by_duckdb(tmp_path, monkeypatch):
    # UCI style: no header, "?" for a missing value; labels and counts by hand.
    path = tmp_path / "r.data"
    path.write_text('p;a;1\np;"b;c";0\nq;a;1\nq;?;1\nq;a;?\n')
    fmt = CsvFormat(header=False, names=("ctx", "g", "y"), sep=";", na_values=("?",))
    calls = spy_fallback(monkeypatch)
    t = count_file(path, sensitive="g", outcome="y", context="ctx", dropna=True, csv=fmt)
    assert calls == []
    assert (t.contexts, t.groups, t.decisions) == (("p", "q"), ("a", "b;c"), (0.0, 1.0))
    assert t.counts.tolist() == [[[0, 1], [1, 0]], [[0, 1], [0, 0]]]
    assert_same(reference(path, fmt, sensitive="g", outcome="y", context="ctx", dropna=True), t)
    # without dropna, the error pandas' route gives: two missing values in g and y
    assert str(counted(path, fmt, sensitive="g", outcome="y", context="ctx")) == str(
        reference(path, fmt, sensitive="g", outcome="y", context="ctx")
    )


def test_tsv_and_renamed_header_are_counted_by_duckdb(tmp_path, monkeypatch):
    path = tmp_path / "r.tsv"
    path.write_text("G\tY\nx\t1\ny\t0\nx\t0\n")
    calls = spy_fallback(monkeypatch)
    t = count_file(path, sensitive="G", outcome="Y")
    renamed = CsvFormat(names=("g", "y"))
    u = count_file(path, sensitive="g", outcome="y", csv=renamed)
    assert calls == []
    assert t.counts.tolist() == u.counts.tolist() == [[[1, 1], [1, 0]]]  # x: 0 once, 1 once; y: 0
    assert_same(reference(path, renamed, sensitive="g", outcome="y"), u)


@pytest.mark.parametrize(
    "name, fmt",
    [
        ("r.csv", CsvFormat(skip_initial_space=True)),  # pandas drops the space before a quote too
        ("r.csv", CsvFormat(sep=" ")),  # not one of DuckDB's separators here
        ("r.csv.bz2", CsvFormat()),  # a compression DuckDB does not read
    ],
)
def test_options_duckdb_does_not_take_are_left_to_pandas(tmp_path, monkeypatch, name, fmt):
    sep = fmt.sep or ","
    path = tmp_path / name
    _write(path, sep.join(["g", "y"]) + "\n" + f'a{sep} "1"\nb{sep}0\n'.replace(",", sep))
    calls = spy_fallback(monkeypatch)
    got = counted(path, fmt, sensitive="g", outcome="y")
    assert calls == [path]
    assert_same(reference(path, fmt, sensitive="g", outcome="y"), got)


def test_names_that_do_not_fit_the_records_give_pandas_error(tmp_path):
    path = tmp_path / "r.csv"
    path.write_text("a;1;x\nb;0;y\n")
    fmt = CsvFormat(header=False, names=("g", "y"), sep=";")
    ref, got = reference(path, fmt, sensitive="g", outcome="y"), counted(path, fmt, sensitive="g", outcome="y")
    assert isinstance(got, InputError) and str(got) == str(ref)
    assert got.field == "names"
