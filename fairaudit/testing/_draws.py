"""The draws every strategy of :mod:`fairaudit.testing` shares: sizes into labels, numbers, integer weights,
probability rows, floats in an interval, masks and pairs of distinct indices.

Each takes hypothesis's ``draw`` and draws in a fixed order, so a strategy built on them draws the same examples as
one that wrote them out. Sizes and numbers are read as :mod:`fairaudit.testing.strategies` describes ("Sizes").
"""

from __future__ import annotations

from collections.abc import Hashable, Sequence
from typing import TypeAlias, overload

import numpy as np
from hypothesis import strategies as st
from hypothesis.errors import InvalidArgument
from hypothesis.extra import numpy as hnp

from fairaudit.base.arrays import FloatArray, IntArray

__all__ = [
    # constants
    "MAX_WEIGHT",
    # types
    "Number",
    "Size",
    # draws
    "alive",
    "between",
    "distinct_pair",
    "integers",
    "labels",
    "number",
    "rows",
    "table_labels",
    "weights",
]

MAX_WEIGHT = 50
"""Largest integer weight drawn before normalising a probability row."""

Size: TypeAlias = int | range | Sequence[Hashable]
"""A size argument: a fixed size, a range to draw it from, or the labels themselves."""
Number: TypeAlias = float | st.SearchStrategy[float]
"""A number argument: a float, or a strategy of floats drawn once per example."""


def labels(draw: st.DrawFn, spec: Size, prefix: str, minimum: int, what: str) -> tuple:
    """Resolve a size spec (int, range, or labels) into a tuple of labels of length ≥ ``minimum``."""
    if isinstance(spec, int) and not isinstance(spec, bool):  # (a bool is refused below)
        if spec < minimum:
            raise InvalidArgument(f"{what}={spec} must be at least {minimum}")
        n = spec
    elif isinstance(spec, range):
        sizes = [n for n in spec if n >= minimum]
        if not sizes:
            raise InvalidArgument(f"{what}={spec!r} has no size of at least {minimum}")
        n = draw(st.sampled_from(sizes))
    elif isinstance(spec, Sequence) and not isinstance(spec, (str, bytes)):
        given = tuple(spec)
        if len(given) < minimum:
            raise InvalidArgument(f"{what} needs at least {minimum} labels, got {len(given)}")
        return given
    else:
        raise InvalidArgument(f"{what}={spec!r}: give an int, a range or a sequence of labels")
    return tuple(f"{prefix}{i}" for i in range(n))


def table_labels(draw: st.DrawFn, sizes: tuple[Size, Size, Size], names: tuple[str, str, str]) -> tuple:
    """The labels of a table's three axes [x, a, u] (``"x0"``, ``"a0"``, ``"u0"``, ...), at least one each."""
    return tuple(labels(draw, size, prefix, 1, name) for size, prefix, name in zip(sizes, "xau", names))


@overload
def number(draw: st.DrawFn, value: Number, what: str) -> float: ...
@overload
def number(draw: st.DrawFn, value: Number | None, what: str) -> float | None: ...
def number(draw: st.DrawFn, value: Number | None, what: str) -> float | None:
    """A float, or one draw of a strategy of floats; None stays None."""
    if value is None:
        return None
    if isinstance(value, st.SearchStrategy):
        value = draw(value)
    try:
        return float(value)
    except (TypeError, ValueError):
        raise InvalidArgument(f"{what}={value!r} must be a number or a strategy of numbers") from None


def integers(draw: st.DrawFn, shape: tuple[int, ...], low: int, high: int) -> IntArray:
    """An integer array of ``shape`` with entries in [low, high]."""
    return draw(hnp.arrays(np.int64, shape, elements=st.integers(low, high)))


def weights(draw: st.DrawFn, shape: tuple[int, ...], allow_zeros: bool) -> FloatArray:
    """Integer weights of ``shape``; every row along the last axis has a positive sum."""
    w = integers(draw, shape, 0 if allow_zeros else 1, MAX_WEIGHT).astype(float)
    if w.size:
        w[..., 0] = np.where(w.sum(axis=-1) == 0, 1.0, w[..., 0])
    return w


def between(draw: st.DrawFn, shape: tuple[int, ...], low: float, high: float) -> FloatArray:
    """Floats in [low, high] (low ≤ high up to rounding) of ``shape``, drawn as fractions of the interval."""
    n = int(np.prod(shape))
    f = np.array(draw(st.lists(st.floats(0.0, 1.0), min_size=n, max_size=n)), dtype=float).reshape(shape)
    lo, hi = min(low, high), max(low, high)
    return np.clip(lo + f * (hi - lo), lo, hi)


def rows(draw: st.DrawFn, shape: tuple[int, ...], allow_zeros: bool) -> FloatArray:
    """Random probability rows along the last axis (each sums to 1)."""
    w = weights(draw, shape, allow_zeros)
    return w / w.sum(axis=-1, keepdims=True)


def alive(draw: st.DrawFn, n: int, need: int) -> np.ndarray:
    """A random mask of ``n`` entries with at least ``need`` of them True (the first ones switched on if too few)."""
    live = ~np.array(draw(st.lists(st.booleans(), min_size=n, max_size=n)))
    live[np.flatnonzero(~live)[: max(0, need - int(live.sum()))]] = True
    return live


def distinct_pair(draw: st.DrawFn, n: int) -> tuple[int, int]:
    """Two distinct indices in [0, n), or (0, 0) when n < 2."""
    return draw(st.sampled_from([(i, j) for i in range(n) for j in range(n) if i != j] or [(0, 0)]))
