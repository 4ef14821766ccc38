"""``RecordOptions`` (issue 81, item 5): how ``audit`` reads and counts records, checked field by field.

Expected values are hand counts: weights 1, 1, 2, 1, 1 for the women and 3, 1, 1, 1, 2 for the men (docs/audit.md,
"Sample weights") select 4 of 6 and 4 of 8 units of weight.
"""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np
import pandas as pd
import pytest

import fairaudit as fa
from fairaudit import InputError, RecordOptions, audit, count_records

Y_PRED = [1, 0, 1, 1, 0, 1, 0, 0, 1, 0]
SEX = ["F"] * 5 + ["M"] * 5
W = [1.0, 1.0, 2.0, 1.0, 1.0, 3.0, 1.0, 1.0, 1.0, 2.0]


def test_defaults_and_values_kept():
    r = RecordOptions()
    assert (r.dropna, r.weights, r.count, r.min_count, r.mixed_outcome) == (False, None, None, None, False)
    r = RecordOptions(dropna=np.bool_(True), weights="w", min_count=np.int64(3), mixed_outcome=True)
    assert (r.dropna, r.weights, r.min_count, r.mixed_outcome) == (True, "w", 3, True)
    assert type(r.dropna) is bool and type(r.min_count) is int
    assert RecordOptions(count="n").count == "n"
    with pytest.raises(TypeError):
        RecordOptions(False)  # keyword-only, as IntervalOptions


def test_a_weights_array_is_a_read_only_float_copy():
    given = np.array([1, 2, 3])
    r = RecordOptions(weights=given)
    given[0] = 9
    assert r.weights.dtype == np.float64 and r.weights.tolist() == [1.0, 2.0, 3.0]
    with pytest.raises(ValueError):
        r.weights[0] = 5.0
    assert RecordOptions(weights=pd.Series([0.5, np.nan])).weights.tolist()[0] == 0.5  # NaN: a missing weight
    with pytest.raises(AttributeError):
        r.dropna = True  # frozen


def test_equal_options_are_equal_and_hash_alike():
    assert RecordOptions(weights=[1, 2]) == RecordOptions(weights=np.array([1.0, 2.0]))
    assert hash(RecordOptions(weights=[1, 2])) == hash(RecordOptions(weights=(1.0, 2.0)))
    assert RecordOptions(weights=[1, 2]) != RecordOptions(weights=[1, 3])
    assert RecordOptions(weights="w") != RecordOptions(weights="v")
    assert RecordOptions(min_count=2) == RecordOptions(min_count=2) != RecordOptions()
    assert len({RecordOptions(), RecordOptions(), RecordOptions(dropna=True)}) == 2
    assert RecordOptions() != {"dropna": False}


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"dropna": 1}, "dropna: must be True or False (got 1)"),
        ({"dropna": "yes"}, "dropna: must be True or False (got 'yes')"),
        ({"mixed_outcome": None}, "mixed_outcome: must be True or False (got None)"),
        ({"weights": 3}, "weights: must be a non-empty list or array of one number per record (got ())"),
        ({"weights": []}, "weights: must be a non-empty list or array of one number per record (got (0,))"),
        ({"weights": [[1.0, 2.0]]}, "weights: must be a non-empty list or array of one number per record (got (1, 2))"),
        ({"weights": ["a", "b"]}, "weights: must be the name of a column, or a list or array of one number per record"),
        ({"weights": [True, False]}, "weights: must be the name of a column, or a list or array of one number per"),
        ({"weights": [1.0, -0.5]}, "weights: must be finite non-negative numbers; record 2 is not (got -0.5)"),
        ({"weights": [math.inf, 1.0]}, "weights: must be finite non-negative numbers; record 1 is not (got inf)"),
        ({"count": 3}, "count: must be the name of the column that holds each row's number of records (got 3)"),
        ({"count": "n", "weights": "w"}, "weights: a count table (`count`) is counted already: give its counts"),
        ({"min_count": 0}, "min_count: must be a whole number >= 1 (got 0)"),
        ({"min_count": 2.0}, "min_count: must be a whole number >= 1 (got 2.0)"),
        ({"min_count": True}, "min_count: must be a whole number >= 1 (got True)"),
    ],
)
def test_errors_name_the_field(kwargs, message):
    with pytest.raises(InputError) as err:
        RecordOptions(**kwargs)
    assert str(err.value).startswith(message), str(err.value)
    assert "\n" not in str(err.value)


def test_audit_refuses_what_is_not_record_options():
    with pytest.raises(InputError, match=r"^records: must be a RecordOptions \(got 'dict'\)$"):
        audit(y_pred=[1, 0], sensitive_features=["a", "b"], records={"dropna": True})


def test_arrays_with_a_weights_array_equal_the_frame_with_a_weights_column():
    frame = pd.DataFrame({"y_pred": Y_PRED, "sex": SEX, "w": W})
    by_column = audit(frame, sensitive=["sex"], outcome="y_pred", records=RecordOptions(weights="w"))
    by_array = audit(y_pred=Y_PRED, sensitive_features=pd.Series(SEX, name="sex"), records=RecordOptions(weights=W))
    # by hand: F selects 1 + 2 + 1 = 4 of 6, M 3 + 1 = 4 of 8
    for r in (by_column, by_array):
        assert r.by_group["n"].tolist() == [6.0, 8.0]
        assert r.by_group["rate"].tolist() == [float(Fraction(4, 6)), float(Fraction(4, 8))]
        assert r.observed.global_fairness.value == pytest.approx(math.log(4 / 3), rel=1e-15)
        assert r.observed.global_fairness.group == "F"
        assert r.observed.demographic_parity.value == pytest.approx(1 / 6, rel=1e-15)
    assert by_array.table.weight_column == "sample_weight" and by_column.table.weight_column == "w"
    np.testing.assert_array_equal(by_array.table.counts, by_column.table.counts)
    np.testing.assert_array_equal(by_array.table.squares, by_column.table.squares)
    intervals = fa.IntervalOptions(confidence=0.9)
    a = audit(frame, sensitive=["sex"], outcome="y_pred", records=RecordOptions(weights="w"), intervals=intervals)
    b = audit(y_pred=Y_PRED, sensitive_features={"sex": SEX}, records=RecordOptions(weights=W), intervals=intervals)
    assert a.to_frame().equals(b.to_frame())


def test_a_weights_array_goes_with_arrays_only():
    frame = pd.DataFrame({"y": Y_PRED, "sex": SEX})
    with pytest.raises(InputError) as err:
        audit(frame, sensitive=["sex"], outcome="y", records=RecordOptions(weights=W))
    assert str(err.value) == (
        "weights: one weight per record is for records given as arrays (y_pred, sensitive_features); "
        "with `data` name its weight column (got 'DataFrame')"
    )
    table = count_records(frame, sensitive="sex", outcome="y")
    with pytest.raises(InputError, match=r"^weights: one weight per record is for records given as arrays"):
        audit(table, records=RecordOptions(weights=W))
    with pytest.raises(InputError, match=r"^weights: has 9 rows where y_pred has 10$"):
        audit(y_pred=Y_PRED, sensitive_features=SEX, records=RecordOptions(weights=W[:9]))


def test_dropna_drops_a_missing_weight():
    w = [1.0, np.nan, 2.0, 1.0]
    with pytest.raises(InputError, match=r"^column 'sample_weight': has 1 missing values"):
        audit(y_pred=[1, 0, 1, 0], sensitive_features=["a", "a", "b", "b"], records=RecordOptions(weights=w))
    r = audit(
        y_pred=[1, 0, 1, 0], sensitive_features=["a", "a", "b", "b"], records=RecordOptions(weights=w, dropna=True)
    )
    assert r.table.n == 4.0 and r.by_group["rate"].tolist() == [1.0, 2 / 3]


def test_the_audit_repeats_min_count():
    frame = pd.DataFrame({"x": list("pppppppqqqq"), "g": list("aaaabbbaaab"), "y": [1, 0, 1, 1, 0, 0, 1, 1, 0, 1, 1]})
    r = audit(frame, sensitive=["g"], outcome="y", context=["x"], records=RecordOptions(min_count=2))
    assert r.min_count == 2 and r.to_dict()["min_count"] == 2
    assert [(c.context, c.group, c.n) for c in r.left_out] == [("q", "b", 1.0)]
    assert r.table.n == 10
    assert audit(frame, sensitive=["g"], outcome="y", context=["x"]).min_count is None
