"""Small array helpers shared by the core: labels, validation, ratio extremes."""

from __future__ import annotations

from collections.abc import Hashable, Iterable, Sequence
from typing import Any, TypeAlias

import numpy as np
import numpy.typing as npt

from ._errors import InputError

FloatArray: TypeAlias = npt.NDArray[np.float64]
"""A float64 array (probabilities, expectations, log ratios in nats)."""
BoolArray: TypeAlias = npt.NDArray[np.bool_]
"""A boolean mask."""
IntArray: TypeAlias = npt.NDArray[np.intp]
"""An array of indices."""

ROW_TOLERANCE = 1e-9
"""Largest accepted deviation of a probability row's sum from 1."""


def as_labels(values: Iterable[Hashable], field: str) -> tuple[Any, ...]:
    """Return ``values`` as a tuple of distinct hashable labels.

    Numpy scalars become Python scalars and lists become tuples. Linear in the
    number of labels with C-level passes (a numpy array converts with
    ``tolist``; distinctness is one ``set``), so a million labels take
    milliseconds; the error path finds the first repeat. A label that cannot
    be hashed (a dict, a set) is an :class:`InputError` naming ``field``.
    """
    if type(values) is tuple and _VALIDATED.get(id(values)) is values:
        return values
    if isinstance(values, (str, bytes)):
        raise InputError(field, "must be a list of labels, not a single string", values)
    labels = tuple(values.tolist()) if isinstance(values, np.ndarray) else tuple(values)
    if any(issubclass(t, (np.generic, list, np.ndarray)) for t in set(map(type, labels))):
        labels = tuple(_plain(v) for v in labels)
    if not labels:
        raise InputError(field, "must name at least one value", list(labels))
    try:
        distinct = len(set(labels)) == len(labels)
    except TypeError:  # a dict or set among them: labels are dictionary keys
        bad = next(v for v in labels if not _hashable(v))
        raise InputError(
            field, f"a label must be hashable (a string, number or tuple), not a {type(bad).__name__}", bad
        ) from None
    if not distinct:
        seen: set[Hashable] = set()
        for label in labels:
            if label in seen:
                raise InputError(field, "labels must be distinct; repeated label", label)
            seen.add(label)
    if len(labels) >= 1024:  # remember big label sets: a law's contexts are checked again by every table built on them
        _VALIDATED[id(labels)] = labels
        while len(_VALIDATED) > 8:
            del _VALIDATED[next(iter(_VALIDATED))]
    return labels


_VALIDATED: dict[int, tuple[Any, ...]] = {}
"""The last few large label tuples that passed :func:`as_labels` (a tuple is immutable: it stays valid)."""


def _plain(value: object) -> Hashable:
    """Numpy scalars to Python scalars, lists to tuples (hashable labels)."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, (list, np.ndarray)):
        return tuple(_plain(v) for v in value)
    return value


def _hashable(value: object) -> bool:
    try:
        hash(value)
    except TypeError:
        return False
    return True


def format_label(label: object) -> str:
    """Human form of a label: tuples (product attributes) joined by ' & '."""
    if isinstance(label, tuple):
        return " & ".join(format_label(v) for v in label)
    return str(label)


def as_float_array(values: object, field: str, ndim: int | None = None, *, copy: bool = True) -> FloatArray:
    """Convert to a float64 array; reject ragged input and wrong dimension.

    With ``copy=False`` a float64 array is returned as it is (no copy); the
    caller must own it.
    """
    try:
        array = np.array(values, dtype=float) if copy else np.asarray(values, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InputError(field, f"must be numeric ({exc})", values) from None
    if ndim is not None and array.ndim != ndim:
        raise InputError(field, f"must be a {ndim}-dimensional table, not {array.ndim}-dimensional", array.shape)
    return array


def check_shape(array: npt.NDArray[Any], shape: Sequence[int], field: str, axes: Sequence[str]) -> None:
    """Raise if ``array.shape`` differs from ``shape`` (axes named in the message)."""
    if tuple(array.shape) != tuple(shape):
        expected = " x ".join(f"{n} {a}" for n, a in zip(shape, axes))
        raise InputError(field, f"shape must be ({expected})", tuple(array.shape))


def check_probabilities(
    array: FloatArray,
    field: str,
    axis_labels: Sequence[tuple[Any, ...]],
    axis_names: Sequence[str],
    *,
    rows_sum_to_one: bool = True,
    skip_rows: BoolArray | None = None,
) -> None:
    """Check finiteness, non-negativity and (optionally) rows summing to one.

    The last axis is the one that sums to one. ``skip_rows`` (shape of the
    leading axes) marks rows that are not checked (empty cells of an estimated
    table, which hold NaN).
    """
    lead = array.shape[:-1]
    if array.size and _valid_fast(array, skip_rows, rows_sum_to_one):
        return
    mask = np.ones(lead, dtype=bool) if skip_rows is None else ~np.asarray(skip_rows, dtype=bool)
    checked = array[mask]
    if checked.size and not np.all(np.isfinite(checked)):
        idx = np.argwhere(~np.isfinite(array) & mask[..., None])[0]
        raise InputError(
            field, f"entry at {_where(idx, axis_labels, axis_names)} is not finite", float(array[tuple(idx)])
        )
    if checked.size and np.any(checked < 0):
        idx = np.argwhere((array < 0) & mask[..., None])[0]
        raise InputError(
            field, f"entry at {_where(idx, axis_labels, axis_names)} is negative", float(array[tuple(idx)])
        )
    if rows_sum_to_one:
        sums = array.sum(axis=-1)
        bad = mask & (np.abs(sums - 1.0) > ROW_TOLERANCE)
        if np.any(bad):
            idx = np.argwhere(bad)[0]
            raise InputError(
                field,
                f"row {_where(idx, axis_labels, axis_names)} sums to {float(sums[tuple(idx)]):.12g}, not 1",
            )


def _valid_fast(array: FloatArray, skip_rows: BoolArray | None, rows_sum_to_one: bool) -> bool:
    """True when every checked row is finite, non-negative and (optionally) sums to one.

    Two reductions with no temporary of the table's size: the row sums (a
    non-finite entry makes its row's sum non-finite) and the minimum. False
    means "look closer": the caller's slow path finds and names the culprit.
    """
    sums = np.einsum("...u->...", array) if array.ndim > 1 else array.sum(keepdims=True)
    if skip_rows is not None:
        skip = np.asarray(skip_rows, dtype=bool)
        if skip.any():
            keep = ~skip
            sums = sums[keep]
            array = array[keep]
    if not sums.size:
        return True
    hi, lo = sums.max(), sums.min()  # NaN or inf anywhere shows here
    if not (np.isfinite(hi) and np.isfinite(lo) and array.min() >= 0):
        return False
    return not rows_sum_to_one or bool(hi - 1.0 <= ROW_TOLERANCE and 1.0 - lo <= ROW_TOLERANCE)


def _where(index: Iterable[int], axis_labels: Sequence[tuple[Any, ...]], axis_names: Sequence[str]) -> str:
    parts = []
    for i, name, labels in zip(index, axis_names, axis_labels):
        parts.append(f"{name}={format_label(labels[int(i)])!r}")
    return "(" + ", ".join(parts) + ")"


def ratio_extremes(values: npt.ArrayLike, axis: int = -1) -> tuple[FloatArray, IntArray, IntArray]:
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
    return ratio_of_extremes(vmax, vmin, count), argmax, argmin


def ratio_of_extremes(vmax: FloatArray, vmin: FloatArray, count: npt.NDArray[np.integer[Any]] | int) -> FloatArray:
    """``vmax / vmin`` with fairaudit's conventions: 0/0 = 1, c/0 = +inf (c > 0), NaN where ``count`` < 2.

    The arrays broadcast; ``count`` is how many entries the extremes were taken over.

    Examples
    --------
    >>> ratio_of_extremes(np.array([4.0, 0.0, 3.0, 2.0]), np.array([1.0, 0.0, 0.0, 2.0]), np.array([2, 3, 2, 1])).tolist()
    [4.0, 1.0, inf, nan]
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(vmax == 0, 1.0, np.where(vmin == 0, np.inf, vmax / vmin))
    return np.where(count >= 2, ratio, np.nan)


def safe_log(value: float) -> float:
    """Natural log (nats) of a ratio in [0, +inf]: log(inf) = inf, log(0) = -inf, NaN stays NaN, no warnings.

    The one log of the package's ratio helpers; ``safe_log(max(r, 1.0))`` is the log of a ratio that cannot be below 1.
    """
    with np.errstate(divide="ignore"):
        return float(np.log(value))


EXP_SAFE = 700.0  # e^ε is a finite double up to ε ≈ 709.78; above this, work with logarithms
BLOCK = 1 << 22  # elements per block of a (block, n, m) temporary


def row_blocks(n: int, per_row: int) -> list[slice]:
    """Slices of range(n) whose rows times ``per_row`` elements stay near 4M (chunked pairwise work)."""
    step = max(1, BLOCK // max(1, per_row))
    return [slice(i, min(n, i + step)) for i in range(0, n, step)]
