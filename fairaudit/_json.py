"""JSON values of the report dictionaries: numbers and labels.

Each result builds its own report dictionary (``to_dict``) from these two
helpers; :mod:`fairaudit.report` renders the dictionaries.

Infinite values are the string ``"inf"`` (``"-inf"``), NaN is ``None``, tuple
labels (product attributes) are joined with ``" & "``.
"""

from __future__ import annotations

import math
from collections.abc import Hashable
from typing import Any, SupportsFloat, TypeAlias

import numpy as np

from ._arrays import format_label

__all__ = ["Report", "label", "number"]

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
