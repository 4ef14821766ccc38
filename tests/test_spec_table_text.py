"""A spec's CSV count table read without pandas (fairaudit._text_table) equals the pandas route whenever it answers.

The pandas route is the spec's own (read_records, the ``where`` filters on the fields' text, count_table with the
spec's labels). Generated files mix the fields on which pandas and the text differ: integers with leading zeros or
signs, floats, booleans in any case, missing-value markers, quotes, spaces.
"""

from __future__ import annotations

import csv
import shutil
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from fairaudit import InputError, load_spec
from fairaudit._text_table import count_table_text
from fairaudit.estimate import count_table, read_records

ROOT = Path(__file__).resolve().parents[1]
FIELDS = (
    ["a", "b", "HR specialist", "x,y", 'q"t', " a", "a ", "unranked", "A_M"]  # text
    + ["0", "1", "2", "12", "-3", "01", "+1", "-0", " 1", "1 ", "99999999999999999999"]  # integers, canonical or not
    + ["1.0", "1.5", "1e3", "inf", "-inf", "nan", "NA", "", "None", "null", "<NA>", "n/a"]  # floats and missing
    + ["True", "true", "FALSE", "false"]  # booleans
)
PLAIN_TEXT = ["a", "b", "HR specialist", "x,y", " a", "unranked"]
PLAIN_INT = ["0", "1", "2", "3", "12"]
COUNTS = ["0", "1", "7", "98", "120", "01", "-1", "1.0", "2.5", "", "x"]


def _pandas_route(path: Path, where: dict, roles: tuple, count: str, labels: tuple) -> np.ndarray | None:
    """What the spec reads through pandas (spec.Spec._read_kernel's table branch); None when it refuses."""
    frame = read_records(path)
    for col, want in where.items():
        frame = frame[frame[col].astype(str) == str(want)]
        if frame.empty:
            return None
    ctx, sens, dec = roles
    try:
        table = count_table(
            frame,
            sensitive=[sens],
            outcome=dec,
            context=[] if ctx is None else [ctx],
            count=count,
            contexts=labels[0],
            groups=labels[1],
            decisions=labels[2],
        )
    except InputError:
        return None
    return table.counts


@st.composite
def _tables(draw):
    n = draw(st.integers(1, 12))
    pools = [PLAIN_TEXT, PLAIN_INT, PLAIN_TEXT + PLAIN_INT, FIELDS]  # the last one: anything
    columns = {
        name: draw(st.lists(st.sampled_from(draw(st.sampled_from(pools))), min_size=n, max_size=n))
        for name in ("job", "demo", "rank")
    }
    columns["model"] = draw(st.lists(st.sampled_from(["m1", "m2", "1", "01"]), min_size=n, max_size=n))
    plain_counts = draw(st.integers(0, 3)) > 0
    columns["count"] = draw(
        st.lists(st.sampled_from(["1", "2", "7", "98"] if plain_counts else COUNTS), min_size=n, max_size=n)
    )
    quote_all = draw(st.booleans())
    with_context = draw(st.booleans())
    where = draw(st.sampled_from([{}, {}, {"model": "m1"}, {"model": 1}]))

    def labels(values: list[str]) -> tuple:
        distinct = sorted(set(values))
        as_int = [int(v) if v in {"0", "1", "2", "3", "12"} and draw(st.booleans()) else v for v in distinct]
        if draw(st.integers(0, 3)) == 0 and len(as_int) > 1:
            as_int = as_int[1:]  # a value missing from the spec's labels
        return tuple(dict.fromkeys(as_int))

    spec_labels = (
        labels(columns["job"]) if with_context else ("all",),
        labels(columns["demo"]),
        labels(columns["rank"]),
    )
    return columns, quote_all, with_context, where, spec_labels


def _write(path: Path, columns: dict, quote_all: bool) -> None:
    names = list(columns)
    with open(path, "w", newline="", encoding="utf-8") as f:
        writer = csv.writer(f, quoting=csv.QUOTE_ALL if quote_all else csv.QUOTE_MINIMAL)
        writer.writerow(names)
        writer.writerows(zip(*(columns[c] for c in names)))


@settings(max_examples=300, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(_tables())
def test_text_route_equals_pandas_route_whenever_it_answers(tmp_path, case):
    columns, quote_all, with_context, where, labels = case
    path = tmp_path / "table.csv"
    _write(path, columns, quote_all)
    roles = ("job" if with_context else None, "demo", "rank")
    fast = count_table_text(path, where=where, roles=roles, count=None, labels=labels)
    event("text route answered" if fast is not None else "left to pandas")
    if fast is None:
        return
    ref = _pandas_route(path, where, roles, "count", labels)
    assert ref is not None, "the text route answered where the pandas route refuses"
    assert fast.dtype == ref.dtype == np.int64
    np.testing.assert_array_equal(fast, ref)


def test_text_route_answers_on_the_shipped_example_and_equals_pandas(tmp_path):
    """Not vacuous: the shipped table is read by the text route, with the counts pandas reads."""
    spec = load_spec(ROOT / "examples" / "llm_hiring" / "gpt35.toml")
    path = ROOT / "examples" / "llm_hiring" / "gpt_rank_counts.csv"
    labels = (spec.contexts, spec.groups, spec.decisions)
    roles = ("job", "demo", "rank")
    fast = count_table_text(path, where={"model": "gpt-3.5-turbo"}, roles=roles, count=None, labels=labels)
    assert fast is not None
    np.testing.assert_array_equal(fast, _pandas_route(path, {"model": "gpt-3.5-turbo"}, roles, "count", labels))
    assert fast.sum() == 4 * 8 * 1000  # 4 jobs x 8 names ranked 1,000 times
    kernel = spec.kernel()
    np.testing.assert_array_equal(kernel.counts, fast)
    np.testing.assert_array_equal(kernel.probabilities, fast / fast.sum(axis=-1, keepdims=True))


@pytest.mark.parametrize(
    "edit",
    [
        lambda t: t.replace("gpt-3.5-turbo,HR specialist,A_M,1,98", "gpt-3.5-turbo,HR specialist,A_M,1,98.0"),
        lambda t: t.replace("gpt-3.5-turbo,HR specialist,A_M,1,98", "gpt-3.5-turbo,HR specialist,A_M,1,"),
        lambda t: t.replace("gpt-3.5-turbo,HR specialist,A_M,1,98", "gpt-3.5-turbo,HR specialist,A_M,1,98,extra"),
        lambda t: t.replace("gpt-3.5-turbo,HR specialist,A_M,1,98", "gpt-3.5-turbo,NA,A_M,1,98"),
        lambda t: t.replace("model,job", "job,job"),
    ],
    ids=["float count", "missing count", "ragged row", "missing label", "duplicate column"],
)
def test_text_route_leaves_irregular_tables_to_pandas(tmp_path, edit):
    src = ROOT / "examples" / "llm_hiring"
    shutil.copy(src / "gpt35.toml", tmp_path / "gpt35.toml")
    text = (src / "gpt_rank_counts.csv").read_text(encoding="utf-8")
    (tmp_path / "gpt_rank_counts.csv").write_text(edit(text), encoding="utf-8")
    spec = load_spec(ROOT / "examples" / "llm_hiring" / "gpt35.toml")
    labels = (spec.contexts, spec.groups, spec.decisions)
    fast = count_table_text(
        tmp_path / "gpt_rank_counts.csv",
        where={"model": "gpt-3.5-turbo"},
        roles=("job", "demo", "rank"),
        count=None,
        labels=labels,
    )
    assert fast is None
