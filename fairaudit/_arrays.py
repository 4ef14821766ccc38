"""Small array helpers shared by the core: labels, validation, ratio extremes."""

from __future__ import annotations

from collections.abc import Hashable, Iterable, Sequence

import numpy as np

from ._errors import InputError

ROW_TOLERANCE = 1e-9
"""Largest accepted deviation of a probability row's sum from 1."""


def as_labels(values: Iterable[Hashable], field: str) -> tuple:
    """Return ``values`` as a tuple of distinct hashable labels."""
    if isinstance(values, (str, bytes)):
        raise InputError(field, "must be a list of labels, not a single string", values)
    labels = tuple(_plain(v) for v in values)
    if not labels:
        raise InputError(field, "must name at least one value", list(labels))
    seen: dict = {}
    for label in labels:
        if label in seen:
            raise InputError(field, "labels must be distinct; repeated label", label)
        seen[label] = True
    return labels


def _plain(value):
    """Numpy scalars to Python scalars, lists to tuples (hashable labels)."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, list):
        return tuple(_plain(v) for v in value)
    return value


def format_label(label) -> str:
    """Human form of a label: tuples (product attributes) joined by ' & '."""
    if isinstance(label, tuple):
        return " & ".join(format_label(v) for v in label)
    return str(label)


def as_float_array(values, field: str, ndim: int | None = None) -> np.ndarray:
    """Convert to a float64 array; reject ragged input and wrong dimension."""
    try:
        array = np.array(values, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InputError(field, f"must be numeric ({exc})", values) from None
    if ndim is not None and array.ndim != ndim:
        raise InputError(field, f"must be a {ndim}-dimensional table, not {array.ndim}-dimensional", array.shape)
    return array


def check_shape(array: np.ndarray, shape: Sequence[int], field: str, axes: Sequence[str]) -> None:
    """Raise if ``array.shape`` differs from ``shape`` (axes named in the message)."""
    if tuple(array.shape) != tuple(shape):
        expected = " x ".join(f"{n} {a}" for n, a in zip(shape, axes))
        raise InputError(field, f"shape must be ({expected})", tuple(array.shape))


def check_probabilities(
    array: np.ndarray,
    field: str,
    axis_labels: Sequence[tuple],
    axis_names: Sequence[str],
    *,
    rows_sum_to_one: bool = True,
    skip_rows: np.ndarray | None = None,
) -> None:
    """Check finiteness, non-negativity and (optionally) rows summing to one.

    The last axis is the one that sums to one. ``skip_rows`` (shape of the
    leading axes) marks rows that are not checked (empty cells of an estimated
    table, which hold NaN).
    """
    lead = array.shape[:-1]
    mask = np.ones(lead, dtype=bool) if skip_rows is None else ~np.asarray(skip_rows, dtype=bool)
    checked = array[mask]
    if checked.size and not np.all(np.isfinite(checked)):
        idx = np.argwhere(~np.isfinite(array) & mask[..., None])[0]
        raise InputError(field, f"entry at {_where(idx, axis_labels, axis_names)} is not finite", float(array[tuple(idx)]))
    if checked.size and np.any(checked < 0):
        idx = np.argwhere((array < 0) & mask[..., None])[0]
        raise InputError(field, f"entry at {_where(idx, axis_labels, axis_names)} is negative", float(array[tuple(idx)]))
    if rows_sum_to_one:
        sums = array.sum(axis=-1)
        bad = mask & (np.abs(sums - 1.0) > ROW_TOLERANCE)
        if np.any(bad):
            idx = np.argwhere(bad)[0]
            raise InputError(
                field,
                f"row {_where(idx, axis_labels, axis_names)} sums to {float(sums[tuple(idx)]):.12g}, not 1",
            )


def _where(index, axis_labels, axis_names) -> str:
    parts = []
    for i, name, labels in zip(index, axis_names, axis_labels):
        parts.append(f"{name}={format_label(labels[int(i)])!r}")
    return "(" + ", ".join(parts) + ")"


def ratio_extremes(values: np.ndarray, axis: int = -1):
    """Largest ratio ``max / min`` along ``axis`` with fairaudit's zero conventions.

    NaN entries (excluded cells) are ignored. 0/0 counts as 1 (parity) and
    c/0 with c > 0 as +inf. Returns ``(ratio, argmax, argmin)``, each with
    ``axis`` removed; where fewer than two entries are present the ratio is NaN.

    Examples
    --------
    >>> r, hi, lo = ratio_extremes(np.array([[1.0, 2.0, 4.0], [0.0, 0.0, 0.0], [0.0, 3.0, np.nan]]))
    >>> r.tolist(), hi.tolist(), lo.tolist()
    ([4.0, 1.0, inf], [2, 0, 1], [0, 0, 0])
    """
    values = np.moveaxis(np.asarray(values, dtype=float), axis, -1)
    present = ~np.isnan(values)
    count = present.sum(axis=-1)
    hi_src = np.where(present, values, -np.inf)
    lo_src = np.where(present, values, np.inf)
    argmax = hi_src.argmax(axis=-1)
    argmin = lo_src.argmin(axis=-1)
    vmax = np.take_along_axis(hi_src, argmax[..., None], -1)[..., 0]
    vmin = np.take_along_axis(lo_src, argmin[..., None], -1)[..., 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(vmax == 0, 1.0, np.where(vmin == 0, np.inf, vmax / vmin))
    ratio = np.where(count >= 2, ratio, np.nan)
    return ratio, argmax, argmin


def safe_log(value: float) -> float:
    """Natural log with log(inf) = inf and log(0) = -inf, no warnings."""
    with np.errstate(divide="ignore"):
        return float(np.log(value))
