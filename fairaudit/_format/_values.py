"""JSON values of the report dictionaries: numbers, labels and one fairness measure.

Infinite values are the string ``"inf"`` (``"-inf"``), NaN is ``None``, tuple
labels (product attributes) are joined with ``" & "``.
"""

from __future__ import annotations

import math
from collections.abc import Hashable
from typing import TYPE_CHECKING, Any, SupportsFloat, TypeAlias

import numpy as np

from .._arrays import format_label

if TYPE_CHECKING:
    from ..intervals import Interval
    from ..metrics import Fairness

__all__ = ["Report", "number", "label", "fairness_dict"]

Report: TypeAlias = dict[str, Any]
"""A report dictionary: JSON-ready (str keys; str, numbers, bools, None, lists and dicts as values)."""


def number(v: SupportsFloat | None) -> bool | int | float | str | None:
    """A number as JSON: bools and integers as they are, NaN as ``None``, ±inf as ``"inf"`` / ``"-inf"``.

    Examples
    --------
    >>> [number(v) for v in (None, True, np.int64(3), 0.5, float("nan"), float("inf"), -float("inf"))]
    [None, True, 3, 0.5, None, 'inf', '-inf']
    """
    if v is None:
        return None
    if isinstance(v, (bool, np.bool_)):
        return bool(v)
    if isinstance(v, (int, np.integer)):
        return int(v)
    f = float(v)
    if math.isnan(f):
        return None
    if math.isinf(f):
        return "inf" if f > 0 else "-inf"
    return f


def label(v: Hashable | None) -> Hashable | None:
    """A label as JSON: tuples joined with ``" & "``, numpy scalars as Python ones.

    Examples
    --------
    >>> label(("f", "over 40")), label(np.int64(2)), label(None)
    ('f & over 40', 2, None)
    """
    if v is None:
        return None
    if isinstance(v, tuple):
        return format_label(v)
    if isinstance(v, np.generic):
        return v.item()
    return v


def fairness_dict(f: Fairness, interval: Interval | None = None) -> Report:
    """One local or global g-fairness: value, ratio, (context,) the pair of groups and the interval (or None)."""
    d: Report = {"value": number(f.value), "ratio": number(f.ratio)}
    if f.kind == "local":
        d["context"] = label(f.context)
    d.update(
        group=label(f.group),
        other_group=label(f.other_group),
        interval=None if interval is None else [number(interval.lower), number(interval.upper)],
    )
    return d
