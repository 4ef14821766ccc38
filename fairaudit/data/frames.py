"""Decision records given as arrays, as a fairlearn user holds them: one DataFrame with named columns.

fairlearn's ``MetricFrame`` takes ``y_pred``, ``sensitive_features``,
``control_features`` and per-metric ``sample_weight`` as lists, numpy arrays,
pandas Series or DataFrames (or dicts of columns); :func:`fairaudit.audit`
takes the same (the weights as ``records=RecordOptions(weights=...)``) and
turns them into records with one column per feature.
Rows are matched by position (a Series' index is not aligned), as numpy
arrays are.
"""

from __future__ import annotations

import sys
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any, TypeAlias

import numpy as np

from fairaudit.base.errors import InputError, echo

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["ArrayLike", "records_from_arrays"]

ArrayLike: TypeAlias = Any
"""A list, numpy array, pandas Series or DataFrame, or a dict of columns."""

Roles: TypeAlias = tuple[list[str], str, list[str], "str | None"]
"""(sensitive columns, outcome column, context columns, weight column)."""


def records_from_arrays(
    y_pred: ArrayLike,
    sensitive_features: ArrayLike,
    control_features: ArrayLike,
    weights: ArrayLike,
    y_true: ArrayLike = None,
) -> tuple[pd.DataFrame, Roles]:
    """One DataFrame of records from fairlearn-style arrays, and the columns of each role.

    Unnamed columns are called ``y_pred``, ``sensitive_feature_0``, ...,
    ``control_feature_0``, ... and, for ``weights`` (one per record), ``sample_weight`` (fairlearn's names).
    ``y_true``, the true labels, is a context column (``y_true``) ahead of
    the control features: the metrics then compare groups within each true
    label, as fairlearn's equalized odds does.

    Raises
    ------
    InputError
        Naming the parameter: ``y_pred`` or ``sensitive_features`` missing,
        an array that is not one value (or one row) per record, a length
        other than ``y_pred``'s, or a column name used by two of them.

    Examples
    --------
    >>> frame, roles = records_from_arrays([1, 0], {"sex": ["F", "M"]}, None, None)
    >>> list(frame.columns), roles
    (['y_pred', 'sex'], (['sex'], 'y_pred', [], None))
    """
    import pandas as pd

    if y_pred is None:
        raise InputError("y_pred", "give the decisions, one per record")
    if sensitive_features is None:
        raise InputError("sensitive_features", "give the sensitive feature(s), one value (or row) per record")
    outcome = _columns(y_pred, "y_pred", "y_pred", one=True)
    n = len(next(iter(outcome.values())))
    sensitive = _columns(sensitive_features, "sensitive_features", "sensitive_feature_{}", n=n)
    context = {} if y_true is None else _columns(y_true, "y_true", "y_true", n=n, one=True)
    if control_features is not None:
        context |= _columns(control_features, "control_features", "control_feature_{}", n=n)
    weight = {} if weights is None else _columns(weights, "weights", "sample_weight", n=n, one=True)
    columns: dict[str, Any] = {}
    for param, cols in (("y_pred", outcome), ("sensitive_features", sensitive), ("control_features", context)):
        for name, values in cols.items():
            if name in columns:
                raise InputError(param, "names a column that another argument names too; rename one", name)
            columns[name] = values
    weight_name = None
    if weight:
        weight_name = next(iter(weight))
        while weight_name in columns:  # the weights' own name never clashes with a feature's
            weight_name = "_" + weight_name
        columns[weight_name] = next(iter(weight.values()))
    roles: Roles = (list(sensitive), next(iter(outcome)), list(context), weight_name)
    return pd.DataFrame(columns), roles


def _columns(
    value: ArrayLike, param: str, default: str, *, n: int | None = None, one: bool = False
) -> dict[str, np.ndarray]:
    """The columns of one argument by name (numpy arrays of one value per record)."""
    pd = sys.modules.get("pandas")
    if isinstance(value, Mapping):
        named = {str(k): _values(v, param) for k, v in value.items()}
    elif pd is not None and isinstance(value, pd.DataFrame):
        named = {str(c): value[c].to_numpy() for c in value.columns}
        if len(named) < value.shape[1]:
            raise InputError(param, "has two columns of the same name", list(map(str, value.columns)))
    elif pd is not None and isinstance(value, pd.Series):
        named = {default.format(0) if value.name is None else str(value.name): value.to_numpy()}
    else:
        array = _values(value, param, ndim=(1,) if one else (1, 2))
        named = {default.format(j): column for j, column in enumerate(array.reshape(len(array), -1).T)}
    if not named:
        raise InputError(param, "has no columns")
    if one and len(named) > 1:
        raise InputError(param, "must be one value per record (one column)", list(named))
    for name, column in named.items():
        if column.ndim != 1:
            raise InputError(param, f"column {echo(name)} must be one value per record", column.shape)
        if n is not None and len(column) != n:
            quoted = () if one and name == default else (name,)  # (a name the caller gave, or a feature's number)
            raise InputError(param, f"has {len(column)} rows where y_pred has {n}", *quoted)
    return named


def _values(value: ArrayLike, param: str, ndim: tuple[int, ...] = (1,)) -> np.ndarray:
    """An argument as a numpy array of one value (or row, when 2 is in ``ndim``) per record."""
    pd = sys.modules.get("pandas")
    if pd is not None and isinstance(value, pd.Series):
        return value.to_numpy()
    try:
        array = np.asarray(value)
        if array.dtype.kind == "U" and not isinstance(value, np.ndarray):
            array = np.asarray(value, dtype=object)  # numpy's str dtype would drop trailing NUL characters
    except (ValueError, TypeError) as exc:
        raise InputError(param, f"is not an array of one value per record ({exc})") from None
    if array.ndim not in ndim or len(array) == 0:
        what = "one value per record" if ndim == (1,) else "one value or row per record"
        raise InputError(param, f"must be a non-empty list or array of {what}", array.shape)
    return array
