"""count_spark in Spark's local mode, against count_records on the same records in pandas.

The independent routes: hand counts, count_records on a pandas frame built
directly or on ``frame.toPandas()`` (the full records, counted by pandas),
pandas reading the COMPAS CSV itself, and the metrics of fairaudit.metrics.observed.observe
on both tables. One local Spark session serves the whole test session.
"""

from __future__ import annotations

import math
import os
import shutil
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fairaudit import InputError, indicator
from fairaudit.data.counts import count_records
from fairaudit.data.spark import count_spark
from fairaudit.metrics.observed import observe

try:
    import pyspark  # noqa: F401
    from pyspark.sql import types as T
except ImportError:  # pragma: no cover - depends on the environment
    T = None
    SKIP = "pyspark is not installed (pip install 'fairness-certify[spark]')"
else:
    SKIP = None if shutil.which("java") else "no `java` on PATH: Spark's local mode needs a Java runtime"

# pyspark 4 warns on every toPandas that it does not yet fully support pandas 3, and uses a deprecated keyword.
# The tests on a Spark session are marked `spark` (a JVM start and Spark jobs): the default run leaves them out;
# `python -m pytest -m spark` runs them (.ci/run does), this module on one xdist worker (--dist loadfile), one session.
pytestmark = [
    pytest.mark.filterwarnings("ignore:PySpark does not yet fully support pandas:FutureWarning"),
    pytest.mark.filterwarnings("ignore:The copy keyword is deprecated:Warning"),
]


@pytest.fixture(scope="session")
def spark():
    """A local Spark session (2 threads, no UI, 2 shuffle partitions, loopback only).

    Adaptive query execution is off: on these tiny frames its re-planning
    roughly doubles the time of each job, and the counts do not depend on it.
    """
    if SKIP:
        pytest.skip(SKIP)
    from pyspark.sql import SparkSession

    os.environ.setdefault("PYSPARK_PYTHON", sys.executable)
    session = (
        SparkSession.builder.master("local[2]")
        .appName("fairaudit-tests")
        .config("spark.ui.enabled", "false")
        .config("spark.ui.showConsoleProgress", "false")
        .config("spark.sql.shuffle.partitions", "2")
        .config("spark.sql.adaptive.enabled", "false")
        .config("spark.driver.host", "127.0.0.1")
        .config("spark.driver.bindAddress", "127.0.0.1")
        .config("spark.log.level", "ERROR")
        .getOrCreate()
    )
    session.sparkContext.setLogLevel("ERROR")
    yield session
    session.stop()


def _typed(labels):
    """Labels with their Python types, so that 1 == 1.0 == True do not pass for one another."""
    return [(type(v).__name__, _typed(v) if isinstance(v, tuple) else v) for v in labels]


def assert_same_table(got, want):
    assert got.counts.dtype == np.int64 and want.counts.dtype == np.int64
    assert got.counts.shape == want.counts.shape
    np.testing.assert_array_equal(got.counts, want.counts)
    assert _typed(got.contexts) == _typed(want.contexts)
    assert _typed(got.groups) == _typed(want.groups)
    assert _typed(got.decisions) == _typed(want.decisions)
    assert (got.context_columns, got.sensitive_columns, got.outcome_column) == (
        want.context_columns,
        want.sensitive_columns,
        want.outcome_column,
    )


def _error(fn, *args, **kwargs) -> str:
    with pytest.raises(InputError) as info:
        fn(*args, **kwargs)
    return str(info.value)


# job (context), sex and age (sensitive), hired (outcome); hand counts below.
HAND = [
    ("clerk", "F", 30, True),
    ("clerk", "F", 30, False),
    ("clerk", "M", 30, True),
    ("clerk", "M", 45, True),
    ("clerk", "M", 45, True),
    ("driver", "F", 45, False),
    ("driver", "M", 30, True),
    ("driver", "M", 30, False),
    ("driver", "M", 30, False),
]
HAND_SCHEMA = "job string, sex string, age int, hired boolean"


@pytest.mark.spark
def test_hand_counted_table_and_labels(spark):
    sdf = spark.createDataFrame(HAND, HAND_SCHEMA)
    t = count_spark(sdf, sensitive=["sex", "age"], outcome="hired", context=["job"])
    assert t.contexts == ("clerk", "driver")
    assert _typed(t.groups) == [
        ("tuple", [("str", "F"), ("int", 30)]),
        ("tuple", [("str", "F"), ("int", 45)]),
        ("tuple", [("str", "M"), ("int", 30)]),
        ("tuple", [("str", "M"), ("int", 45)]),
    ]
    assert _typed(t.decisions) == [("bool", False), ("bool", True)]
    # counts[x, a, u]: [False, True] per group (F30, F45, M30, M45)
    assert t.counts.tolist() == [[[1, 1], [0, 0], [0, 1], [0, 2]], [[0, 0], [1, 0], [2, 1], [0, 0]]]
    pdf = pd.DataFrame(HAND, columns=["job", "sex", "age", "hired"])
    assert_same_table(t, count_records(pdf, sensitive=["sex", "age"], outcome="hired", context=["job"]))
    # one sensitive column as a string, no context: one context "all"
    t1 = count_spark(sdf, sensitive="sex", outcome="hired")
    assert (t1.contexts, t1.groups, t1.counts.tolist()) == (("all",), ("F", "M"), [[[2, 1], [2, 4]]])


MIXED_SCHEMA = "i int, l long, s string, b boolean, d double, f float"
MIXED = [
    (3, 10, "b", True, 0.5, 1.25),
    (1, 10, "a", False, 2.0, 0.5),
    (3, 7, "a", True, 0.5, 0.5),
    (2, 7, "c", False, -1.5, 1.25),
    (1, 10, "b", True, 2.0, 0.5),
    (3, 7, "b", True, -1.5, 0.1),
    (2, 10, "a", True, 0.5, 0.1),
    (1, 7, "c", False, 2.0, 1.25),
]


@pytest.mark.spark
@pytest.mark.parametrize(
    "roles",
    [
        dict(sensitive=["s"], outcome="b"),
        dict(sensitive=["i"], outcome="d", context=["s"]),
        dict(sensitive=["b", "s"], outcome="i", context=["d"]),
        dict(sensitive=["l"], outcome="f", context=["b", "i"]),
        dict(sensitive=["d", "f"], outcome="l", context=["s", "b"]),
        dict(sensitive=["s", "i", "b"], outcome="s"),
    ],
)
def test_dtypes_match_count_records_on_to_pandas(spark, roles):
    sdf = spark.createDataFrame(MIXED, MIXED_SCHEMA)
    t = count_spark(sdf, **roles)
    assert_same_table(t, count_records(sdf.toPandas(), **roles))
    # and on a pandas frame built without Spark (float32 for the Spark float column)
    pdf = pd.DataFrame(MIXED, columns=["i", "l", "s", "b", "d", "f"]).astype({"i": "int32", "f": "float32"})
    assert_same_table(t, count_records(pdf, **roles))


NULLS = [
    (1, "a", True, 0.5),
    (None, "a", False, float("nan")),
    (2, None, True, 0.5),
    (2, "b", None, None),
    (1, "b", True, float("nan")),
    (2, "a", False, 1.5),
    (1, "a", True, 1.5),
]
NULLS_SCHEMA = "i int, s string, b boolean, d double"


@pytest.mark.spark
def test_missing_values_nulls_and_nan_counted_exactly(spark):
    sdf = spark.createDataFrame(NULLS, NULLS_SCHEMA)
    # d: one null and two NaN; Spark keeps NaN apart from null, pandas counts both
    assert (
        _error(count_spark, sdf, sensitive=["s"], outcome="d")
        == "column 's': has 1 missing values (drop those rows: `dropna`)"
    )
    assert (
        _error(count_spark, sdf, sensitive=["b"], outcome="d")
        == "column 'b': has 1 missing values (drop those rows: `dropna`)"
    )
    assert (
        _error(count_spark, sdf, sensitive=["d"], outcome="b")
        == "column 'd': has 3 missing values (drop those rows: `dropna`)"
    )
    assert (
        _error(count_spark, sdf, sensitive=["i"], outcome="i", context=["s"])
        == "column 's': has 1 missing values (drop those rows: `dropna`)"
    )
    # records, not groups: five nulls and three NaN fall in two groups of the aggregated table
    repeated = spark.createDataFrame([(None, 1)] * 5 + [(float("nan"), 1)] * 3 + [(1.0, 0)], "d double, u int")
    assert (
        _error(count_spark, repeated, sensitive=["d"], outcome="u")
        == "column 'd': has 8 missing values (drop those rows: `dropna`)"
    )
    pdf = sdf.toPandas()
    for roles in (dict(sensitive=["d"], outcome="b"), dict(sensitive=["i", "s"], outcome="b", context=["d"])):
        assert _error(count_spark, sdf, **roles) == _error(count_records, pdf, **roles)


@pytest.mark.spark
def test_dropna_drops_those_records(spark):
    sdf = spark.createDataFrame(NULLS, NULLS_SCHEMA)
    t = count_spark(sdf, sensitive=["i"], outcome="b", context=["d"], dropna=True)
    # (i, b, d) left: (1, T, 0.5), (2, T, 0.5), (2, F, 1.5), (1, T, 1.5); s is not used, its null does not count.
    # The int column with nulls comes back as floats, as in pandas.
    assert _typed(t.contexts) == [("float", 0.5), ("float", 1.5)]
    assert _typed(t.groups) == [("float", 1.0), ("float", 2.0)]
    assert t.counts.tolist() == [[[0, 1], [0, 1]], [[0, 1], [1, 0]]]
    for roles in (
        dict(sensitive=["i"], outcome="b", context=["d"]),
        dict(sensitive=["s", "b"], outcome="i"),
        dict(sensitive=["b"], outcome="s"),
    ):
        assert_same_table(count_spark(sdf, dropna=True, **roles), count_records(sdf.toPandas(), dropna=True, **roles))
    # nothing left
    only_missing = spark.createDataFrame([(None, "a"), (2, None)], "i int, s string")
    assert (
        _error(count_spark, only_missing, sensitive=["i"], outcome="s", dropna=True) == "DATA: has no records to count"
    )
    assert _error(count_spark, only_missing.limit(0), sensitive=["i"], outcome="s") == "DATA: has no records to count"


@pytest.mark.spark
def test_unknown_columns_name_the_flag_and_list_the_columns(spark):
    sdf = spark.createDataFrame(HAND, HAND_SCHEMA)
    listing = "unknown column; the data has: job, sex, age, hired"
    assert _error(count_spark, sdf, sensitive=["race"], outcome="hired") == f"sensitive: {listing} (got 'race')"
    assert _error(count_spark, sdf, sensitive=["sex"], outcome="Hired") == f"outcome: {listing} (got 'Hired')"
    assert (
        _error(count_spark, sdf, sensitive=["sex"], outcome="hired", context=["job", "city"])
        == f"context: {listing} (got 'city')"
    )
    assert _error(count_spark, sdf, sensitive=[], outcome="hired") == "sensitive: name at least one column (got [])"
    pdf = sdf.toPandas()
    assert _error(count_spark, sdf, sensitive=["sex"], outcome="x") == _error(
        count_records, pdf, sensitive=["sex"], outcome="x"
    )


@pytest.mark.spark
def test_awkward_column_names_and_types(spark):
    # a dot, a backtick, a column named like the count, names differing only in case
    sdf = spark.createDataFrame(
        [("p", "q", 1, 0), ("p", "r", 2, 0), ("p", "q", 1, 1)], "`a.b` string, `x``y` string, count int, COUNT int"
    )
    roles = dict(sensitive=["a.b", "x`y"], outcome="count", context=["COUNT"])
    t = count_spark(sdf, **roles)
    assert (t.contexts, t.groups, t.decisions) == ((0, 1), (("p", "q"), ("p", "r")), (1, 2))
    assert t.counts.tolist() == [[[1, 0], [0, 1]], [[1, 0], [0, 0]]]
    assert_same_table(t, count_records(sdf.toPandas(), **roles))
    twice = spark.createDataFrame([(1, 2, 3)], "a int, b int, c int").toDF("a", "a", "u")
    assert (
        _error(count_spark, twice, sensitive=["a"], outcome="u")
        == "column 'a': is ambiguous: the frame has 2 columns of that name"
    )
    arrays = spark.createDataFrame([([1, 2], 0)], "a array<int>, u int")
    assert (
        _error(count_spark, arrays, sensitive=["a"], outcome="u")
        == "column 'a': must hold scalar values (string, number, boolean, date or time) (got 'array<int>')"
    )
    assert (
        _error(count_spark, pd.DataFrame({"a": [1], "u": [0]}), sensitive=["a"], outcome="u")
        == "frame: must be a Spark DataFrame (pyspark.sql.DataFrame) (got 'DataFrame')"
    )


_VALUES = {
    "i": [-2, 0, 7],
    "s": ["", "a", "B", "b"],
    "b": [True, False],
    "d": [-1.5, 0.0, 2.25],
}
_MISSING = {"i": [None], "s": [None], "b": [None], "d": [None, float("nan")]}


@st.composite
def _records(draw):
    """Records (i int, s string, b boolean, d double), column roles, dropna; half of the cases hold nulls or NaN."""
    order = draw(st.permutations(list(_VALUES)))
    k = draw(st.integers(0, 2))
    m = draw(st.integers(1, 4 - k))
    nulls = draw(st.booleans())
    values = [st.sampled_from(_VALUES[c] + (_MISSING[c] if nulls else [])) for c in "isbd"]
    rows = draw(st.lists(st.tuples(*values), min_size=1, max_size=30))
    roles = dict(context=order[:k], sensitive=order[k : k + m], outcome=draw(st.sampled_from(order)))
    return rows, roles, draw(st.booleans())


@pytest.mark.spark
@settings(max_examples=10, deadline=None)
@given(_records())
def test_generated_records_match_count_records(spark, case):
    rows, roles, dropna = case
    sdf = spark.createDataFrame(rows, "i int, s string, b boolean, d double")
    pdf = sdf.toPandas()
    try:
        want = count_records(pdf, dropna=dropna, **roles)
    except InputError as exc:
        assert _error(count_spark, sdf, dropna=dropna, **roles) == str(exc)
    else:
        assert_same_table(count_spark(sdf, dropna=dropna, **roles), want)


def _same_metrics(got, want):
    for name in (
        "local_fairness",
        "global_fairness",
        "demographic_parity",
        "equalized_odds",
        "sup_local_fairness",
        "sup_global_fairness",
    ):
        g, w = getattr(got, name), getattr(want, name)
        assert (g.value == w.value) or (math.isnan(g.value) and math.isnan(w.value)), name
        assert (g.group, g.other_group) == (w.group, w.other_group), name
        assert getattr(g, "context", None) == getattr(w, "context", None), name


@pytest.mark.spark
def test_metrics_end_to_end_equal_the_pandas_route(spark):
    sdf = spark.createDataFrame(HAND, HAND_SCHEMA)
    pdf = pd.DataFrame(HAND, columns=sdf.columns)
    for roles in (
        dict(sensitive=["sex", "age"], outcome="hired", context=["job"]),
        dict(sensitive=["sex"], outcome="hired"),
    ):
        ts, tp = count_spark(sdf, **roles), count_records(pdf, **roles)
        got = observe(ts.law(), indicator(True, ts.decisions), ts.population())
        _same_metrics(got, observe(tp.law(), indicator(True, tp.decisions), tp.population()))
    # by hand, sex alone: P(hired | F) = 1/3, P(hired | M) = 4/6, so L = L-bar = log 2 and the parity gap is 1/3
    assert got.local_fairness.value == pytest.approx(math.log(2), rel=1e-12)
    assert got.global_fairness.value == pytest.approx(math.log(2), rel=1e-12)
    assert (got.local_fairness.group, got.local_fairness.other_group) == ("M", "F")
    assert got.demographic_parity.value == pytest.approx(1 / 3, rel=1e-12)


@pytest.mark.spark
def test_audit_counts_a_spark_frame_in_spark(spark):
    """fairaudit.audit takes the Spark DataFrame itself: the same Audit as on its pandas copy."""
    import fairaudit as fa

    sdf = spark.createDataFrame(HAND, HAND_SCHEMA)
    pdf = pd.DataFrame(HAND, columns=sdf.columns)
    got = fa.audit(sdf, sensitive=["sex"], outcome="hired", positive=True)
    want = fa.audit(pdf, sensitive=["sex"], outcome="hired", positive=True)
    assert got.table.counts.tolist() == want.table.counts.tolist() and got.table.groups == want.table.groups
    _same_metrics(got.observed, want.observed)
    assert got.observed.global_fairness.value == pytest.approx(math.log(2), rel=1e-12)  # 4/6 vs 1/3, as above
    with pytest.raises(InputError, match="^outcome: "):
        fa.audit(sdf, sensitive=["sex"], outcome="nope")


@pytest.mark.spark
def test_compas_equals_pandas(spark, shared_data):
    path = shared_data / "compas" / "compas-scores-two-years.csv"
    if not path.is_file():
        pytest.skip(f"COMPAS data not found at {path}")
    roles = dict(sensitive=["race"], outcome="score_text", context=["age_cat"])
    ts = count_spark(spark.read.csv(str(path), header=True), **roles)
    tp = count_records(pd.read_csv(path, low_memory=False), **roles)
    assert_same_table(ts, tp)
    assert ts.n == 7214 and ts.counts.shape == (3, 6, 3)
    assert ts.decisions == ("High", "Low", "Medium")
    _same_metrics(
        observe(ts.law(), indicator("High", ts.decisions), ts.population()),
        observe(tp.law(), indicator("High", tp.decisions), tp.population()),
    )


def test_without_pyspark_fairaudit_imports_and_count_spark_says_how_to_install():
    code = (
        "import sys; sys.modules['pyspark'] = None\n"
        "import fairaudit, fairaudit.data.spark\n"
        "try:\n"
        "    fairaudit.data.spark.count_spark(None, sensitive=['a'], outcome='u')\n"
        "except fairaudit.InputError as exc:\n"
        "    print(exc)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "pyspark: is needed to count a Spark DataFrame: pip install 'fairness-certify[spark]'"


@pytest.mark.spark
def test_control_characters_and_mixed_outcomes_name_the_dataframes_rows(spark):
    # a: 40 of 88 hired, b: 30 of 80 (as in tests/data/test_key_values.py); rows counted from 1 in the frame's order
    frame = pd.DataFrame({"race": ["a"] * 88 + ["b"] * 80, "hired": [1] * 40 + [0] * 48 + [1] * 30 + [0] * 50})
    bad = frame.copy()
    bad.loc[6, "race"] = "a\x00"  # data row 7
    message = _error(
        count_spark, spark.createDataFrame(bad, "race string, hired long"), sensitive=["race"], outcome="hired"
    )
    assert message == _error(count_records, bad, sensitive=["race"], outcome="hired")
    assert message.startswith("column 'race': holds the control character U+0000 in data row 7 ")
    mixed = frame.astype({"hired": str})
    mixed.loc[[4, 29, 99], "hired"] = "yes"  # data rows 5, 30, 100
    message = _error(
        count_spark, spark.createDataFrame(mixed, "race string, hired string"), sensitive=["race"], outcome="hired"
    )
    assert message == _error(count_records, mixed, sensitive=["race"], outcome="hired")
    assert "3 of 168 records are text ('yes') where the others are numbers, in data rows 5, 30, 100 " in message
    kept = count_spark(
        spark.createDataFrame(mixed, "race string, hired string"),
        sensitive=["race"],
        outcome="hired",
        mixed_outcome=True,
    )
    assert kept.decisions == ("0", "1", "yes") and kept.counts.tolist() == [[[48, 38, 2], [50, 29, 1]]]
