"""The JSON form of a privacy filter: its format, labels as JSON values, and the filter read back.

:meth:`fairaudit.filter.filters.PrivacyFilter.to_dict` writes it and
:meth:`~fairaudit.filter.filters.PrivacyFilter.from_dict` reads it (docs/filter.md, "The JSON"): integers as
decimal strings, labels as they are with tuples as lists.
"""

from __future__ import annotations

from collections.abc import Hashable, Mapping, Sequence
from contextlib import suppress
from typing import Any

import numpy as np

from fairaudit.base.errors import InputError
from fairaudit.base.json_values import number

__all__ = [
    "FORMAT",
    "FORMAT_VERSION",
    "KINDS",
    "json_labels",
    "labels_from_json",
    "parameters_filter",
]

FORMAT = "fairaudit-filter"
"""The ``"format"`` of a filter's dictionary (:meth:`PrivacyFilter.to_dict`)."""

FORMAT_VERSION = 1
"""The ``"format_version"`` of a filter's dictionary."""

KINDS = ("randomized_response", "matrix", "product")
"""The kinds of filters: how their rows are held."""


def parameters_filter(cls: Any, data: Mapping[str, Any], where: str) -> Any:
    """The filter ``cls`` (:class:`~fairaudit.filter.filters.PrivacyFilter`) of one filter dictionary without its
    format and version: a product's component, or the whole once its format is checked (``where``: the path of
    its fields, ``components[1].``); its ``epsilon``, when given, must be the filter's own."""

    def get(key: str) -> Any:
        if key not in data:
            raise InputError(f"{where}{key}", "is missing")
        return data[key]

    kind, name = get("mechanism"), str(data.get("name", "filter"))
    requested = data.get("requested_epsilon")
    extra: dict[str, Any] = {
        "rounding": str(data.get("rounding", "exact")),
        "requested_epsilon": None if requested is None else float(requested),
        "name": name,
    }
    try:
        if kind == "randomized_response":
            values = labels_from_json(get("values"))
            made = cls(kind, values, values, _whole(get("denominator"), f"{where}denominator"),
                       keep=_whole(get("keep"), f"{where}keep"), move=_whole(get("move"), f"{where}move"), **extra)  # fmt: skip
        elif kind == "matrix":
            rows = tuple(
                tuple(_whole(n, f"{where}rows[{i}][{j}]") for j, n in enumerate(row))
                for i, row in enumerate(get("rows"))
            )
            made = cls(kind, labels_from_json(get("inputs")), labels_from_json(get("outputs")),
                       _whole(get("denominator"), f"{where}denominator"), rows=rows, **extra)  # fmt: skip
        elif kind == "product":
            parts = [parameters_filter(cls, c, f"{where}components[{i}].") for i, c in enumerate(get("components"))]
            made = cls.product(*parts, name=name)
        else:
            raise InputError(f"{where}mechanism", f"must be one of {', '.join(KINDS)}", kind)
    except InputError as exc:
        if not where or exc.field.startswith(where):
            raise
        raise InputError(where + exc.field, exc.problem, exc.value) from None
    recorded = data.get("epsilon", InputError._missing)
    if recorded is not InputError._missing and recorded != number(made.epsilon):
        raise InputError(f"{where}epsilon", f"is not the filter's own epsilon {number(made.epsilon)}", recorded)
    return made


def _whole(value: Any, field: str) -> int:
    """An integer written as a decimal string (or a JSON integer)."""
    with suppress(ValueError):  # (text that is not a whole number)
        if isinstance(value, (str, int)) and not isinstance(value, bool):
            return int(value)
    raise InputError(field, "must be a whole number written as a decimal string", value)


def json_labels(labels: Sequence[Hashable]) -> list[Any]:
    """Labels as JSON values: tuples as lists, numpy scalars as Python ones."""
    return [_json_label(v) for v in labels]


def _json_label(label: Any) -> Any:
    if isinstance(label, tuple):
        return [_json_label(v) for v in label]
    if isinstance(label, np.generic):
        return label.item()
    if label is None or isinstance(label, (str, int, float, bool)):
        return label
    raise InputError("inputs", "holds a label JSON cannot write (give strings, numbers or tuples)", repr(label))


def labels_from_json(labels: Any) -> tuple:
    """JSON labels back as labels: lists as tuples."""
    if not isinstance(labels, list):
        raise InputError("values", "must be a list of labels", labels)
    return tuple(_label_from_json(v) for v in labels)


def _label_from_json(label: Any) -> Any:
    return tuple(_label_from_json(v) for v in label) if isinstance(label, list) else label
