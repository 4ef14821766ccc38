"""Array helpers shared by the core: labels (:class:`Labels`), validation, ratio extremes and total variation."""

from __future__ import annotations

import math
from collections.abc import Hashable, Iterable, Iterator, Sequence
from typing import Any, SupportsIndex, TypeAlias

import numpy as np
import numpy.typing as npt

from ._errors import InputError, cut

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
    A :class:`Labels` gives its tuple.
    """
    if isinstance(values, Labels):
        return values.tuple
    if type(values) is tuple and _known(values) is not None:
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
        _remember(Labels(None, labels))
    return labels


_VALIDATED: dict[int, Labels] = {}
"""The last few large label tuples that passed :func:`as_labels`, by id, each with its :class:`Labels`
(a tuple is immutable: it stays valid; the entry keeps it alive, so its id is not reused)."""


def _known(labels: tuple[Any, ...]) -> Labels | None:
    """The :class:`Labels` of a tuple that :func:`as_labels` or :attr:`Labels.tuple` made, else None."""
    known = _VALIDATED.get(id(labels))
    return known if known is not None and known._tuple is labels else None


def _remember(labels: Labels) -> None:
    assert labels._tuple is not None
    _VALIDATED[id(labels._tuple)] = labels
    while len(_VALIDATED) > 8:
        del _VALIDATED[next(iter(_VALIDATED))]


_INT64 = (-(1 << 63), (1 << 63) - 1)


class Labels:
    """The distinct labels of one axis of a table, kept compact: a ``range``, a 1-D array, or a tuple.

    Labels given as a non-empty ``range`` of machine integers or as a 1-D numpy array of integers or
    text stay that (a read-only copy of the array): no Python object per label, and checking that they
    are distinct is one vectorised pass. Anything else goes through :func:`as_labels` (a tuple). Build
    with :meth:`of`. ``labels[i]`` is the i-th label as :func:`as_labels` gives it (a Python scalar);
    :attr:`tuple` is the whole tuple, made on first use and kept.

    Examples
    --------
    >>> c = Labels.of(range(10**6), "contexts")
    >>> len(c), c[123456], c.tuple[:3]
    (1000000, 123456, (0, 1, 2))
    >>> Labels.of(np.array(["b", "a"]), "groups").same(Labels.of(["b", "a"], "groups"))
    True
    """

    def __init__(self, compact: range | npt.NDArray[Any] | None, labels: tuple[Any, ...] | None) -> None:
        self._compact = compact
        self._tuple = labels

    @classmethod
    def of(cls, values: object, field: str) -> Labels:
        """The labels ``values`` (a sequence, a range, a numpy array or a :class:`Labels`), checked distinct.

        Raises
        ------
        InputError
            As :func:`as_labels`: no label, a repeated label, an unhashable label.
        """
        if isinstance(values, Labels):
            return values
        if type(values) is tuple and (known := _known(values)) is not None:
            return known
        compact = _compact(values)
        if compact is None:
            labels = as_labels(values, field)  # type: ignore[arg-type]  # as_labels names what is wrong
            return _known(labels) or cls(None, labels)
        if not isinstance(compact, range) and not _sorted_distinct(compact):
            as_labels(compact, field)  # raises, naming the first repeat
        return cls(compact, None)

    def __len__(self) -> int:
        if self._compact is None:
            assert self._tuple is not None
            return len(self._tuple)
        return len(self._compact)

    def __getitem__(self, i: SupportsIndex) -> Any:
        """The i-th label, as :func:`as_labels` gives it (numpy scalars as Python ones)."""
        if self._compact is None:
            return self._tuple[i]  # type: ignore[index]
        if isinstance(self._compact, range):
            return self._compact[i]
        return self._compact[i].item()

    def __iter__(self) -> Iterator[Any]:
        return iter(self.tuple)

    def __repr__(self) -> str:
        n = len(self)
        head = ", ".join(repr(self[i]) for i in range(min(n, 3)))
        return f"Labels([{head}{', ...' if n > 3 else ''}], {n} labels)"

    @property
    def tuple(self) -> tuple[Any, ...]:
        """The labels as a tuple of Python labels (what :func:`as_labels` returns), made once."""
        if self._tuple is None:
            c = self._compact
            self._tuple = tuple(c) if isinstance(c, range) else tuple(c.tolist())  # type: ignore[union-attr]
            if len(self._tuple) >= 1024:
                _remember(self)
        return self._tuple

    def same(self, other: Labels) -> bool:
        """True when both hold the same labels in the same order (as their tuples compare)."""
        if self is other:
            return True
        if len(self) != len(other):
            return False
        a, b = self._compact, other._compact
        if a is None or b is None:
            return self.tuple == other.tuple
        if isinstance(a, range) and isinstance(b, range):
            return a == b
        x, y = _as_array(a), _as_array(b)
        kinds = {x.dtype.kind.replace("u", "i"), y.dtype.kind.replace("u", "i")}
        return len(kinds) == 1 and bool(np.array_equal(x, y))


def _compact(values: object) -> range | npt.NDArray[Any] | None:
    """``values`` as a compact label sequence (a range of int64 values, a read-only 1-D int or text array), or None."""
    if isinstance(values, range):
        ok = len(values) > 0 and _INT64[0] <= min(values[0], values[-1]) and max(values[0], values[-1]) <= _INT64[1]
        return values if ok else None
    if isinstance(values, np.ndarray) and values.ndim == 1 and values.size and values.dtype.kind in "iuUS":
        array = np.array(values)  # our own copy
        array.setflags(write=False)
        return array
    return None


def _as_array(values: range | npt.NDArray[Any]) -> npt.NDArray[Any]:
    return np.arange(values.start, values.stop, values.step) if isinstance(values, range) else values


def _sorted_distinct(values: npt.NDArray[Any]) -> bool:
    """True when the 1-D array has no repeated value (one comparison pass when increasing, else a sort)."""
    if values.size < 2 or bool(np.all(values[1:] > values[:-1])):
        return True
    s = np.sort(values)
    return not bool(np.any(s[1:] == s[:-1]))


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
    """Human form of a label: tuples (product attributes) joined by ' & '; text with spaces around it quoted.

    Examples
    --------
    >>> format_label(("a", 1)), format_label(" Male"), format_label("")
    ('a & 1', "' Male'", "''")
    """
    if isinstance(label, tuple):
        return " & ".join(format_label(v) for v in label)
    text = str(label)
    if isinstance(label, str) and (not text or text != text.strip()):
        return repr(text)  # the spaces a reader would not see (a CSV field after ", "), or an empty label
    return text


def label_list(labels: Sequence[object], most: int = 20) -> str:
    """Labels as a message lists them: each by :func:`format_label`, cut after 80 characters, the first ``most``.

    Examples
    --------
    >>> label_list(["a", ("b", 1)])
    "['a', 'b & 1']"
    >>> label_list(range(30), most=2)
    "['0', '1', ... (30 in all)]"
    """
    shown = [cut(format_label(v)) for v in list(labels)[:most]]
    if len(labels) <= most:
        return repr(shown)
    return repr(shown)[:-1] + f", ... ({len(labels)} in all)]"


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
BLOCK = 1 << 22  # elements per block of a (block, n, m) temporary


def row_blocks(n: int, per_row: int) -> list[slice]:
    """Slices of range(n) whose rows times ``per_row`` elements stay near 4M (chunked pairwise work)."""
    step = max(1, BLOCK // max(1, per_row))
    return [slice(i, min(n, i + step)) for i in range(0, n, step)]


def first_max(values: FloatArray) -> int | None:
    """The first index of the largest value of a 1-D array, NaN ignored (as ``numpy.nanargmax``); None when all are NaN.

    Examples
    --------
    >>> first_max(np.array([np.nan, 2.0, np.inf, 1.0, np.inf])), first_max(np.array([np.nan]))
    (2, None)
    """
    if not values.size:
        return None
    i = int(np.argmax(values))  # the first largest value, or the first NaN: then there is no NaN at all when not
    if not np.isnan(values[i]):
        return i
    best = np.fmax.reduce(values)  # some NaN: the largest of the rest
    return None if np.isnan(best) else int(np.argmax(values == best))


def max_tv_pairs(dist: FloatArray) -> tuple[FloatArray, IntArray, IntArray]:
    """Largest TV over pairs of rows along axis -2 of ``dist`` (..., n_groups, n_decisions), pair by pair.

    The route for many decisions (:func:`use_events` false): a loop over pairs of groups, each step vectorised
    over the leading axes. Returns (value, a, a') with the leading shape: the first pair (a < a') in loop order
    with the largest TV, NaN rows (absent groups) ignored.
    """
    n = dist.shape[-2]
    lead = dist.shape[:-2]
    if math.prod(lead) * n * n * dist.shape[-1] <= 1 << 14:  # few cells: every pair at once, the same numbers
        return _max_tv_all_pairs(dist)
    best = np.full(lead, np.nan)
    arg_a = np.zeros(lead, dtype=int)
    arg_b = np.zeros(lead, dtype=int)
    for a in range(n):
        for b in range(a + 1, n):  # TV is symmetric: each unordered pair once, reported in label order
            tv = np.clip(dist[..., a, :] - dist[..., b, :], 0.0, None).sum(axis=-1)
            tv = np.where(np.isnan(dist[..., a, 0]) | np.isnan(dist[..., b, 0]), np.nan, tv)
            better = ~np.isnan(tv) & (np.isnan(best) | (tv > best))
            best = np.where(better, tv, best)
            arg_a = np.where(better, a, arg_a)
            arg_b = np.where(better, b, arg_b)
    return best, arg_a, arg_b


def _max_tv_all_pairs(dist: FloatArray) -> tuple[FloatArray, IntArray, IntArray]:
    """:func:`max_tv_pairs` with the pairs as one axis: each TV summed as there (over the decisions of one row),
    the first pair in the loop's order (a, then b) with the largest, NaN ignored."""
    a, b = np.triu_indices(dist.shape[-2], 1)
    tv = np.clip(dist[..., a, :] - dist[..., b, :], 0.0, None).sum(axis=-1)
    tv = np.where(np.isnan(dist[..., a, 0]) | np.isnan(dist[..., b, 0]), np.nan, tv)
    best = np.fmax.reduce(tv, axis=-1) if tv.shape[-1] else np.full(tv.shape[:-1], np.nan)
    first = np.argmax(tv == best[..., None], axis=-1) if tv.shape[-1] else np.zeros(tv.shape[:-1], dtype=int)
    found = ~np.isnan(best)
    return best, np.where(found, a[first] if a.size else 0, 0), np.where(found, b[first] if b.size else 0, 0)


def use_events(n_groups: int, n_decisions: int) -> bool:
    """TV by events (2^(K-1) - 1 sums per group) when cheaper than by pairs of groups."""
    events = (1 << max(n_decisions - 1, 0)) - 1
    return n_decisions <= 24 and events * n_groups <= n_groups * (n_groups - 1) // 2 * n_decisions


def event_sums(ct: FloatArray) -> Iterator[tuple[int, FloatArray]]:
    """(m, P(S_m)) for every non-empty subset S_m of the first K − 1 decisions of ``ct`` (n_decisions, ...).

    m is the subset's bit mask; P(S_m) = Σ_{u in S_m} ct[u], added from the largest decision down (the same
    number for the same subset in every caller). Depth first: at most K − 1 partial sums are alive at once,
    whatever the number of subsets (a subset and its complement give the same range, so the last decision is
    never needed).
    """
    K = ct.shape[0]

    def below(mask: int, total: FloatArray, top: int) -> Iterator[tuple[int, FloatArray]]:
        for u in range(top - 1, -1, -1):
            s = total + ct[u]
            yield mask | 1 << u, s
            yield from below(mask | 1 << u, s, u)

    for v in range(K - 2, -1, -1):
        yield 1 << v, ct[v]
        yield from below(1 << v, ct[v], v)


def max_tv_pair(rows: FloatArray) -> tuple[float, int | None, int | None]:
    """The largest TV between two rows of ``rows`` (n_groups, n_decisions), and its pair, in linear time.

    TV(P, P') = max over events S of P(S) − P'(S), so the largest TV over pairs of groups is the largest range
    over groups of P(S), S over the subsets of :func:`event_sums`: O(n_groups · 2^(K − 1)) when
    :func:`use_events`, no pair of groups enumerated (otherwise, many decisions, :func:`max_tv_pairs`).
    Rows with NaN (absent groups) are left out.

    Ties are named by one rule: S is the first subset (by bit mask) with the largest range, and the pair is
    the first group (in row order) with the largest P(S) and the first with the smallest, given in row order
    (a < a'). When every row is the same (TV 0), the first two present rows; by pairs, the first pair
    (a < a') with the largest TV. The value is the pair's TV as Σ_u (P_a − P_a')⁺.
    Returns (value, a, a'): NaN and None when fewer than two rows are present.

    Examples
    --------
    >>> max_tv_pair(np.array([[0.5, 0.5], [0.9, 0.1], [np.nan, np.nan], [0.1, 0.9], [0.9, 0.1]]))
    (0.8, 1, 3)
    """
    present = np.flatnonzero(~np.isnan(rows[:, 0]))
    if present.size < 2:
        return math.nan, None, None
    r = rows[present]
    K = r.shape[1]
    if not use_events(len(present), K):
        tv, a, b = max_tv_pairs(r)
        return float(tv), int(present[int(a)]), int(present[int(b)])
    best, mask, ai, bi = -1.0, 0, 0, 1
    for m, s in event_sums(np.ascontiguousarray(r.T)):
        hi, lo = int(np.argmax(s)), int(np.argmin(s))
        spread = float(s[hi] - s[lo])
        if spread > best or (spread == best and m < mask):
            best, mask, ai, bi = spread, m, hi, lo
    ai, bi = (min(ai, bi), max(ai, bi)) if best > 0.0 else (0, 1)
    value = float(np.clip(r[ai] - r[bi], 0.0, None).sum())
    return value, int(present[ai]), int(present[bi])


def tv_chunk(ct: FloatArray, nan: bool) -> FloatArray:
    """Largest TV over pairs of groups per context of a chunk ``ct`` (n_decisions, n_groups, chunk).

    The largest range over groups of P(S) over the subsets S of :func:`event_sums` (a subset and its
    complement give the same range). Otherwise (many decisions) :func:`max_tv_pairs`. NaN where fewer than
    two groups are present.
    """
    K, A, C = ct.shape
    big, small = (np.fmax, np.fmin) if nan else (np.maximum, np.minimum)
    if use_events(A, K):
        best = np.zeros(C)
        for _, s in event_sums(ct):
            np.maximum(best, big.reduce(s, axis=0) - small.reduce(s, axis=0), out=best)
        if nan:
            best[(~np.isnan(ct[0])).sum(axis=0) < 2] = np.nan
        return best
    return max_tv_pairs(ct.transpose(2, 1, 0))[0]
