"""The spec's ``[model]`` table: records and tables of counts read into the kernel, checked against the direct API."""

from __future__ import annotations

import gzip
import math
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest
from _spec_head import HEAD_TAU

import fairaudit as fa
from fairaudit import InputError

# A spec of two profiles behind randomized response at epsilon = 1, in two documents; its [model] table left open.
RECORDS_SPEC = (
    HEAD_TAU.replace('name = "profile"', 'name = "profile"\nvalues = ["a", "b"]')
    + """
[context]
name = "doc"
values = ["holiday", "sick"]
[privacy.sensitive]
mechanism = "randomized_response"
epsilon = 1.0
[model]
"""
)


def test_records_model_matches_direct_api(tmp_path):
    # Records of a model that saw the released group; the spec counts them like count_records does.
    rng = np.random.default_rng(7)
    df = pd.DataFrame({"doc": rng.choice(["sick", "holiday"], 400), "profile": rng.choice(["a", "b"], 400)})
    df["office"] = np.where(rng.random(400) < np.where(df["profile"] == "a", 0.8, 0.3), "HR_2", "HR_1")
    df.to_csv(tmp_path / "records.csv", index=False)
    (tmp_path / "s.toml").write_text(RECORDS_SPEC + 'records = "records.csv"\n')
    cert = fa.certify(tmp_path / "s.toml")
    counts = pd.crosstab([df["doc"], df["profile"]], df["office"]).reindex(columns=["HR_1", "HR_2"])
    k = (counts.to_numpy() / counts.to_numpy().sum(1, keepdims=True)).reshape(2, 2, 2)
    p = math.e / (1 + math.e)
    share = k[:, :, 1]  # P(HR_2 | doc, released profile)
    behind = p * share + (1 - p) * share[:, ::-1]
    expected = np.log((behind.max(1) / behind.min(1)).max())
    assert cert.observed.local_fairness.value == pytest.approx(expected, rel=1e-12)


def test_records_model_in_a_headerless_text_file(tmp_path):
    # The same records as a UCI-style file (no header, ", " separators, "?" in an unused column, gzip): the same
    # kernel as from the plain CSV, and the format's errors under model.csv.
    rng = np.random.default_rng(8)
    df = pd.DataFrame({"doc": rng.choice(["sick", "holiday"], 300), "profile": rng.choice(["a", "b"], 300)})
    df["office"] = np.where(rng.random(300) < np.where(df["profile"] == "a", 0.7, 0.4), "HR_2", "HR_1")
    df["note"] = rng.choice(["x", "?"], 300)
    df.to_csv(tmp_path / "records.csv", index=False)
    text = "".join(", ".join(row) + "\n" for row in df.itertuples(index=False))
    (tmp_path / "records.data.gz").write_bytes(gzip.compress(text.encode()))
    spec = RECORDS_SPEC
    (tmp_path / "plain.toml").write_text(spec + 'records = "records.csv"\n')
    csv = '[model.csv]\nheader = false\nnames = ["doc", "profile", "office", "note"]\nna_values = ["?"]\n'
    (tmp_path / "raw.toml").write_text(spec + 'records = "records.data.gz"\n' + csv + "skip_initial_space = true\n")
    plain, raw = fa.certify(tmp_path / "plain.toml"), fa.certify(tmp_path / "raw.toml")
    assert (
        raw.observed.local_fairness.value == plain.observed.local_fairness.value
        and raw.observed.local_fairness.value > 0
    )
    assert raw.observed.global_fairness.value == plain.observed.global_fairness.value
    # without skip_initial_space the labels keep their space: " a" is not a value of the spec
    (tmp_path / "spaced.toml").write_text(spec + 'records = "records.data.gz"\n' + csv)
    with pytest.raises(InputError):
        fa.certify(tmp_path / "spaced.toml")
    (tmp_path / "bad.toml").write_text(spec + 'records = "records.data.gz"\n[model.csv]\nheader = false\n')
    with pytest.raises(InputError) as err:
        fa.certify(tmp_path / "bad.toml")
    assert str(err.value).endswith("model.csv.names: name the columns of a file without a header")


def test_records_model_with_weights(tmp_path):
    # [model] weight_column: the kernel from weighted counts, as count_records(weights=...) makes it; intervals refused
    df = pd.DataFrame(
        {
            "profile": ["a", "a", "a", "b", "b", "b"],
            "office": ["HR_1", "HR_2", "HR_2", "HR_1", "HR_1", "HR_2"],
            "w": [1.0, 3.0, 1.0, 2.0, 1.0, 1.0],
        }
    )
    df.to_csv(tmp_path / "records.csv", index=False)
    spec = (
        HEAD_TAU.replace('name = "profile"', 'name = "profile"\nvalues = ["a", "b"]')
        + """
[privacy.sensitive]
mechanism = "randomized_response"
epsilon = 1.0
[model]
records = "records.csv"
weight_column = "w"
"""
    )
    (tmp_path / "s.toml").write_text(spec)
    cert = fa.certify(tmp_path / "s.toml")
    # unfiltered P(HR_2 | a) = 4/5, P(HR_2 | b) = 1/4; behind RR(eps = 1) each released group mixes the two
    p = math.e / (1 + math.e)
    a, b = p * 0.8 + (1 - p) * 0.25, p * 0.25 + (1 - p) * 0.8
    assert cert.observed.local_fairness.value == pytest.approx(math.log(max(a, b) / min(a, b)), rel=1e-12)
    # intervals on Kish's effective counts, as an audit of the same records with the same weights makes them
    assert cert.unfiltered_intervals is not None
    audited = fa.audit(
        df,
        sensitive=["profile"],
        outcome="office",
        records=fa.RecordOptions(weights="w"),
        positive="HR_2",
        intervals=fa.IntervalOptions(confidence=0.95),
    )
    assert cert.unfiltered_intervals.local_fairness.upper == pytest.approx(
        audited.intervals.local_fairness.upper, rel=1e-12
    )
    (tmp_path / "t.toml").write_text(spec.replace('records = "records.csv"', 'table = "records.csv"'))
    with pytest.raises(InputError, match="weight_column weighs records"):
        fa.certify(tmp_path / "t.toml")


TABLE_SPEC = """
[sensitive]
name = "profile"
values = ["a", "b"]
[context]
name = "doc"
values = ["1", "07", "x y"]
[decision]
name = "office"
values = ["HR_1", "HR_2"]
[privacy.sensitive]
mechanism = "randomized_response"
epsilon = 1.0
[utility]
decision = "HR_2"
[model]
table = "k.csv"
where = { model = "m1" }
"""


def _table(rng) -> pd.DataFrame:
    cells = [(d, p, o) for d in ("1", "07", "x y") for p in ("a", "b") for o in ("HR_1", "HR_2")]
    rows = [(d, p, o, int(rng.integers(1, 50)), model) for model in ("m1", "m2") for d, p, o in cells]
    return pd.DataFrame(rows, columns=["doc", "profile", "office", "count", "model"]).sample(frac=1, random_state=3)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_count_table_is_counted_without_pandas_as_count_table_counts_it(tmp_path, seed):
    """The spec's table of whole counts: DuckDB groups it and numpy counts it; the oracle is count_table on the
    DataFrame in memory (pandas). Fields matched by their text: "07" and "1" are two contexts, as the spec says."""
    frame = _table(np.random.default_rng(seed))
    frame.to_csv(tmp_path / "k.csv", index=False)
    (tmp_path / "s.toml").write_text(TABLE_SPEC)
    spec = fa.load_spec(tmp_path / "s.toml")
    kept = frame[frame["model"] == "m1"]
    labels = dict(contexts=("1", "07", "x y"), groups=("a", "b"), decisions=("HR_1", "HR_2"))
    table = fa.count_table(kept, sensitive="profile", outcome="office", context="doc", count="count", **labels)
    assert np.array_equal(
        spec.kernel().probabilities, fa.Kernel.from_counts(table.counts, *labels.values()).probabilities
    )
    code = f"import sys, fairaudit as fa; fa.load_spec({str(tmp_path / 's.toml')!r}).kernel(); print('pandas' in sys.modules)"
    assert subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout == "False\n"


def test_a_count_table_that_is_not_plain_is_reported_as_count_table_reports_it(tmp_path):
    frame = _table(np.random.default_rng(0))
    (tmp_path / "s.toml").write_text(TABLE_SPEC)
    first = frame.index[frame["model"] == "m1"][0]
    for column, value, message in (
        ("profile", "c", "value not among the sensitive values ['a', 'b'] (got 'c')"),
        (
            "count",
            -1,
            "column 'count': must hold finite non-negative numbers; data row 1 (doc='1', profile='a', office='HR_2') is not (got -1)",
        ),
    ):
        bad = frame.astype({column: object})
        bad.loc[first, column] = value
        bad.to_csv(tmp_path / "k.csv", index=False)
        with pytest.raises(InputError) as err:
            fa.load_spec(tmp_path / "s.toml").kernel()
        assert str(err.value).endswith(message), str(err.value)
    frame[frame["model"] == "m2"].to_csv(tmp_path / "k.csv", index=False)  # the filter selects no rows
    with pytest.raises(InputError, match=r"model.where.model: selects no rows \(got 'm1'\)$"):
        fa.load_spec(tmp_path / "s.toml").kernel()
