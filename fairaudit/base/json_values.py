"""JSON values of the report dictionaries: numbers and labels.

Each result builds its own report dictionary (``to_dict``) from these two
helpers; :mod:`fairaudit.reports.formats` renders the dictionaries.

Infinite values are the string ``"inf"`` (``"-inf"``), NaN is ``None``, tuple
labels (product attributes) are joined with ``" & "``.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Hashable
from typing import Any, SupportsFloat, TypeAlias

import numpy as np

from fairaudit.base.labels import format_label

__all__ = ["Report", "canonical_digest", "label", "number"]

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
    if isinstance(v, tuple):
        return format_label(v)
    if isinstance(v, np.generic):
        return v.item()
    return v


def pair_dict(
    kind: str, value: float, ratio: float, context: Hashable | None, group: Hashable | None, other: Hashable | None
) -> Report:
    """The head of a maximum's dictionary: value, ratio, the context (``kind == "local"`` only) and the pair.

    Examples
    --------
    >>> pair_dict("local", 0.5, 1.6487212707001282, "x", ("f", 1), "m")
    {'value': 0.5, 'ratio': 1.6487212707001282, 'context': 'x', 'group': 'f & 1', 'other_group': 'm'}
    >>> pair_dict("global", float("inf"), float("inf"), None, "a", "b")
    {'value': 'inf', 'ratio': 'inf', 'group': 'a', 'other_group': 'b'}
    """
    d: Report = {"value": number(value), "ratio": number(ratio)}
    if kind == "local":
        d["context"] = label(context)
    d.update(group=label(group), other_group=label(other))
    return d


def canonical_digest(value: Any) -> str:
    """SHA-256 (hex) of a JSON value's canonical text: keys sorted, no spaces, UTF-8, floats as ``repr``.

    What a certificate's ``inputs_sha256`` is (``docs/certificates.md``); NaN and infinities are refused (write them
    as :func:`number` does).

    Examples
    --------
    >>> canonical_digest({"b": [0.1], "a": "inf"}) == hashlib.sha256(b'{"a":"inf","b":[0.1]}').hexdigest()
    True
    """
    text = json.dumps(value, sort_keys=True, separators=(",", ":"), ensure_ascii=False, allow_nan=False)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()
