"""Float arrays: their types, checks of shape and probabilities, ratio extremes, logarithms, the first maximum."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any, TypeAlias

import numpy as np
import numpy.typing as npt

from fairaudit.base.errors import InputError
from fairaudit.base.labels import format_label

FloatArray: TypeAlias = npt.NDArray[np.float64]
"""A float64 array (probabilities, expectations, log ratios in nats)."""
BoolArray: TypeAlias = npt.NDArray[np.bool_]
"""A boolean mask."""
IntArray: TypeAlias = npt.NDArray[np.intp]
"""An array of indices."""

ROW_TOLERANCE = 1e-9
"""Largest accepted deviation of a probability row's sum from 1."""


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
    axis_labels: Sequence[Any],
    axis_names: Sequence[str],
    *,
    rows_sum_to_one: bool = True,
    skip_rows: BoolArray | None = None,
    source: FloatArray | None = None,
) -> None:
    """Check finiteness, non-negativity and (optionally) rows summing to one.

    The last axis is the one that sums to one. ``skip_rows`` (shape of the
    leading axes) marks rows that are not checked (empty cells of an estimated
    table, which hold NaN). ``source`` (same shape as ``array``), when given, is
    copied into ``array`` block by block as it is checked: one pass over the
    table, no temporary of its size.

    A fast pass reads the table in blocks that stay in cache (minimum and row
    sums); only when it finds something, or a row sum within 1e-13 of the
    tolerance, does the exact pass below name the culprit (its row sums decide).
    """
    lead = array.shape[:-1]
    if not array.size:
        if source is not None:
            np.copyto(array, source)
    elif _valid_fast(array, skip_rows, rows_sum_to_one, source):
        return
    mask = np.ones(lead, dtype=bool) if skip_rows is None else ~np.asarray(skip_rows, dtype=bool)
    for bad, problem in ((~np.isfinite(array), "is not finite"), (array < 0, "is negative")):  # (NaN: not finite)
        found = np.argwhere(bad & mask[..., None])
        if found.size:
            idx = found[0]
            raise InputError(
                field, f"entry at {_where(idx, axis_labels, axis_names)} {problem}", float(array[tuple(idx)])
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


CHECK_BLOCK = 1 << 16
"""Entries per block of the fast check of :func:`check_probabilities` (512 kB of float64)."""
_FAST_TOLERANCE = ROW_TOLERANCE - 1e-13  # row sums nearer the tolerance than this go to the exact check


def _valid_fast(
    array: FloatArray, skip_rows: BoolArray | None, rows_sum_to_one: bool, source: FloatArray | None = None
) -> bool:
    """True when every checked row is finite, non-negative and (optionally) sums to one; copies ``source`` in.

    Blocks of whole rows: per block the minimum (NaN shows there), the maximum (inf) and the row sums
    (a matrix-vector product with ones). False means "look closer": :func:`check_probabilities`'s
    exact pass finds and names the culprit (``source`` is then fully copied already).
    """
    width = array.shape[-1]
    rows = array.reshape(-1, width)  # a view when ``array`` is contiguous, else a copy that is only read
    if source is not None and not np.may_share_memory(rows, array):
        np.copyto(array, source)
        source = None
    src = None if source is None else source.reshape(-1, width)
    skip = None if skip_rows is None else np.asarray(skip_rows, dtype=bool).reshape(-1)
    if skip is not None and not skip.any():
        skip = None
    ones = np.ones(width)
    step = max(1, CHECK_BLOCK // width)
    for start in range(0, rows.shape[0], step):
        stop = min(rows.shape[0], start + step)
        block = rows[start:stop]
        if src is not None:
            np.copyto(block, src[start:stop])
        if skip is not None and skip[start:stop].any():
            block = block[~skip[start:stop]]
            if not block.size:
                continue
        if rows_sum_to_one:  # NaN shows in the minimum, +inf in its row's sum
            sums = block @ ones
            ok = block.min() >= 0 and sums.max() - 1.0 <= _FAST_TOLERANCE and 1.0 - sums.min() <= _FAST_TOLERANCE
        else:
            ok = block.min() >= 0 and np.isfinite(block.max())
        if not ok:
            if src is not None and stop < rows.shape[0]:
                np.copyto(rows[stop:], src[stop:])
            return False
    return True


def _where(index: Iterable[int], axis_labels: Sequence[Any], axis_names: Sequence[str]) -> str:
    parts = (f"{name}={format_label(labels[int(i)])!r}" for i, name, labels in zip(index, axis_names, axis_labels))
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
    if isinstance(vmax, np.ndarray) and isinstance(vmin, np.ndarray) and vmax.shape == vmin.shape:
        shape = vmax.shape  # (the common case, checked without numpy's shape machinery)
    else:
        shape = np.broadcast_shapes(np.shape(vmax), np.shape(vmin))
    count_shape = () if isinstance(count, (int, np.integer)) else np.shape(count)
    wide = count_shape not in ((), shape) and np.broadcast_shapes(shape, count_shape) != shape
    if not shape or wide:  # scalars, or ``count`` widens the shape: the two ``where`` as they read
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(vmax == 0, 1.0, np.where(vmin == 0, np.inf, vmax / vmin))
        return np.where(count >= 2, ratio, np.nan)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.true_divide(vmax, vmin)
    # the same numbers as those two ``where``, written into the quotient: c/0 -> inf, then 0/. -> 1
    np.copyto(ratio, np.inf, where=np.equal(vmin, 0))
    np.copyto(ratio, 1.0, where=np.equal(vmax, 0))
    if not count_shape:
        if not count >= 2:
            ratio.fill(np.nan)
    else:
        np.copyto(ratio, np.nan, where=~np.greater_equal(count, 2))
    return ratio


def safe_log(value: float) -> float:
    """Natural log (nats) of a ratio in [0, +inf]: log(inf) = inf, log(0) = -inf, NaN stays NaN, no warnings.

    The one log of the package's ratio helpers; ``safe_log(max(r, 1.0))`` is the log of a ratio that cannot be below 1.
    """
    with np.errstate(divide="ignore"):
        return float(np.log(value))


EXP_SAFE = 700.0  # e^ε is a finite double up to ε ≈ 709.78; above this, work with logarithms


def first_max(values: FloatArray, order: IntArray | None = None) -> int | None:
    """The index of the largest value of a 1-D array, NaN ignored; None when there is none.

    Among equal largest values, the first one, or with ``order`` (an integer key per value, such as a flat index
    of the pair each value belongs to) the one of smallest key. Without ``order`` this is ``numpy.nanargmax``
    with None for "all NaN".

    Examples
    --------
    >>> first_max(np.array([np.nan, 2.0, np.inf, 1.0, np.inf])), first_max(np.array([np.nan]))
    (2, None)
    >>> first_max(np.array([3.0, 1.0, 3.0]), order=np.array([5, 0, 4]))
    2
    """
    if not values.size:
        return None
    if order is not None:
        ok = ~np.isnan(values)
        if not ok.any():
            return None
        at = np.flatnonzero(ok & (values == values[ok].max()))
        return int(at[np.argmin(order[at])])
    i = int(np.argmax(values))  # the first largest value, or the first NaN: then there is no NaN at all when not
    if not np.isnan(values[i]):
        return i
    best = np.fmax.reduce(values)  # some NaN: the largest of the rest
    return None if np.isnan(best) else int(np.argmax(values == best))
