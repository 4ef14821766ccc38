"""Reading TOML documents (certify specs, task files), with one-line errors.

:func:`parse_toml` reads the text; a pydantic model validates it (pydantic is imported by the modules that
define the models: :mod:`fairaudit.certification.spec_schema`, the plug-ins' task files);
:func:`validation_error` turns pydantic's first error into one
:class:`~fairaudit.InputError` naming the file, the dotted field and the value.
Validators raise :class:`FieldProblem` to point at part of their field.
"""

from __future__ import annotations

import tomllib
from collections.abc import Hashable
from datetime import datetime
from typing import TYPE_CHECKING, Any

from fairaudit.base.errors import InputError
from fairaudit.base.labels import format_label

if TYPE_CHECKING:
    from pydantic import ValidationError

__all__ = [
    "LABEL_DEPTH",
    "FieldProblem",
    "distinct_labels",
    "parse_toml",
    "toml_label",
    "validation_error",
    "value_kind",
]


def parse_toml(text: str, source: str) -> dict[str, Any]:
    """The TOML document ``text`` as a dictionary (read by :mod:`tomllib`), with a one-line error.

    Parameters
    ----------
    text : str
    source : str
        Where the text came from (a file's name), the field of the error.

    Raises
    ------
    InputError
        Field ``source``: not valid TOML, or nested too deeply to read.

    Examples
    --------
    >>> parse_toml('epsilon = 1.5', "spec.toml")
    {'epsilon': 1.5}
    >>> parse_toml('epsilon = ', "spec.toml")
    Traceback (most recent call last):
    ...
    fairaudit.base.errors.InputError: spec.toml: is not valid TOML (Invalid value (at end of document))
    """
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(source, f"is not valid TOML ({exc})") from None
    except (RecursionError, MemoryError):  # the parser recurses: arrays or inline tables nested ~500 deep
        raise InputError(source, "is too deeply nested (or too large) to read") from None


LABEL_DEPTH = 8
"""How deep lists may nest inside one label (a tuple label of tuple labels ...)."""


class FieldProblem(ValueError):
    """A pydantic validator's error about part of its field: ``sub`` ("[2]", ".tau") extends the error's location.

    :func:`validation_error` writes it as ``source: field + sub: problem (got value)``.

    Parameters
    ----------
    sub : str
        The part of the field at fault, appended to its location (``""``: the field itself).
    problem : str
        What is wrong, in a few words.
    value : object, optional
        The offending value, quoted in the message.

    Examples
    --------
    A table whose validator checks two of its fields together and names the one at fault:

    >>> from pydantic import BaseModel, ValidationError, model_validator
    >>> class Range(BaseModel):
    ...     low: float
    ...     high: float
    ...
    ...     @model_validator(mode="after")
    ...     def _ordered(self):
    ...         if self.low > self.high:
    ...             raise FieldProblem(".low", f"must be at most high = {self.high:g}", self.low)
    ...         return self
    >>> try:
    ...     Range.model_validate(parse_toml("low = 2\\nhigh = 1", "range.toml"))
    ... except ValidationError as err:
    ...     print(validation_error(err, "range.toml", whole="range"))
    range.toml: low: must be at most high = 1 (got 2.0)
    """

    def __init__(self, sub: str, problem: str, value: object = InputError._missing) -> None:
        super().__init__(problem)
        self.sub = sub
        self.problem = problem
        self.value = value


def value_kind(value: object) -> str:
    """What a TOML value is, for messages: "a string", "a number", "a boolean", "a list", "an inline table", ...

    Integers and floats are both "a number"; a date-time with an offset and one without are different kinds (the
    two cannot be ordered against each other).
    """
    if isinstance(value, datetime):
        return "a local date-time" if value.tzinfo is None else "an offset date-time"
    kinds = (
        (bool, "a boolean"),
        ((int, float), "a number"),
        (str, "a string"),
        (dict, "an inline table"),
        (list, "a list"),
    )
    # (TOML's local date and local time: "a date", "a time")
    return next((kind for types, kind in kinds if isinstance(value, types)), f"a {type(value).__name__}")


def toml_label(value: object, where: str, depth: int = 0) -> Hashable:
    """A TOML value as a label: a list becomes a tuple (its lists too, up to 8 deep); an inline table is an error."""
    if isinstance(value, dict):
        raise FieldProblem(
            where, "a label is a string, number, boolean, date or a list of them, not an inline table", value
        )
    if isinstance(value, (list, tuple)):
        if not value:
            raise FieldProblem(where, "a list label must not be empty", value)
        if depth >= LABEL_DEPTH:
            raise FieldProblem(where, f"a label may nest lists at most {LABEL_DEPTH} deep", value)
        return tuple(toml_label(v, f"{where}[{i}]", depth + 1) for i, v in enumerate(value))
    assert isinstance(value, Hashable)  # (TOML scalars: str, int, float, bool, dates and times)
    return value


def distinct_labels(v: list[Any] | None, what: str = "values") -> list[Any] | None:
    """Labels (lists as tuples) that are distinct as text (labels are matched by their text) and as values, all of
    one kind: strings, numbers, booleans, dates, ... or lists of one length whose entries agree in kind, place by
    place (``[["Female"], "Male"]`` and ``[25, "55"]`` are refused, naming the entry).

    A pydantic field validator of a list of labels (a spec's or a task file's ``values``); its errors are
    :class:`FieldProblem` (``ValueError`` when the list is empty).

    Examples
    --------
    >>> from pydantic import BaseModel, ValidationError, field_validator
    >>> class Attribute(BaseModel):
    ...     values: list
    ...
    ...     @field_validator("values")
    ...     @classmethod
    ...     def _distinct(cls, v):
    ...         return distinct_labels(v)
    >>> Attribute.model_validate(parse_toml('values = [["f", 1], ["m", 1]]', "task.toml")).values
    [('f', 1), ('m', 1)]
    >>> try:
    ...     Attribute.model_validate(parse_toml("values = [1, 2, 1.0]", "task.toml"))
    ... except ValidationError as err:
    ...     print(validation_error(err, "task.toml", whole="task"))
    task.toml: values: values must be distinct; 1 and 1.0 are equal (got [1, 2, 1.0])
    """
    if v is None:
        return v
    if len(v) == 0:
        raise ValueError("must list at least one value")
    labels = [toml_label(x, f"[{i}]") for i, x in enumerate(v)]
    texts: set[str] = set()
    for lab in labels:
        text = format_label(lab)
        if text in texts:
            raise FieldProblem("", f"{what} must be distinct as text; {text!r} repeats", v)
        texts.add(text)
    seen: dict[Hashable, Hashable] = {}
    for lab in labels:
        if lab in seen:  # 1, 1.0 and true are equal in Python though not as text
            raise FieldProblem("", f"{what} must be distinct; {seen[lab]!r} and {lab!r} are equal", v)
        seen[lab] = lab
    for i, x in enumerate(v[1:], 1):
        found = _kind_difference(v[0], x, "")
        if found is not None:
            sub, kind, first_kind, value = found
            raise FieldProblem(
                f"[{i}]{sub}", f"is {kind}, but {what}[0]{sub} is {first_kind}: all {what} are of one kind", value
            )
    return labels


def _kind_difference(first: object, other: object, where: str) -> tuple[str, str, str, object] | None:
    """The first place (a path below both) where label ``other`` differs from ``first`` in kind or in length.

    Returns the path, what ``other`` is there, what ``first`` is there and ``other``'s value there; None when
    both are of one kind all the way down (lists of one length whose entries agree in kind, place by place).
    """

    def kind(x: object) -> str:
        return value_kind(x) + (f" of {len(x)} value{'s' * (len(x) != 1)}" if isinstance(x, list) else "")

    if kind(first) != kind(other):
        return where, kind(other), kind(first), other
    if isinstance(first, list) and isinstance(other, list):
        for j, (a, b) in enumerate(zip(first, other)):
            found = _kind_difference(a, b, f"{where}[{j}]")
            if found is not None:
                return found
    return None


def validation_error(err: ValidationError, source: str, *, whole: str) -> InputError:
    """The first error of a pydantic validation as one line: ``source: field.path: problem (got value)``.

    ``whole`` names the document when the error is about all of it (``"spec"``, ``"task"``). A
    :class:`FieldProblem` raised by a validator extends the location with its ``sub``; a strict number
    (``Annotated[float, pydantic.Strict()]``) given as text or a boolean says ``must be a number, not a string``.

    Examples
    --------
    >>> from typing import Annotated
    >>> from pydantic import BaseModel, ConfigDict, Strict, ValidationError
    >>> class Filter(BaseModel):
    ...     model_config = ConfigDict(extra="forbid")
    ...     keep: list[Annotated[float, Strict()]]
    >>> for text in ('keep = [0.7, "0.8"]', "keep = [0.7]\\nepsilon = 1"):
    ...     try:
    ...         Filter.model_validate(parse_toml(text, "task.toml"))
    ...     except ValidationError as err:
    ...         print(validation_error(err, "task.toml", whole="task"))
    task.toml: keep[1]: must be a number, not a string (got '0.8')
    task.toml: epsilon: is not a known field
    """
    first = err.errors()[0]
    loc = "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in first["loc"]).lstrip(".")
    loc = loc.replace("global_", "global")
    error = (first.get("ctx") or {}).get("error")
    if isinstance(error, FieldProblem):  # a validator's error about part of the field
        return InputError(f"{source}: {(loc + error.sub).lstrip('.') or whole}", error.problem, error.value)
    loc = loc or whole
    msg = first["msg"].removeprefix("Value error, ")
    value = first.get("input", InputError._missing)
    if first["type"] == "float_type":  # strict numbers: TOML 0.7, not "0.7" or true
        big = isinstance(value, int) and not isinstance(value, bool)
        problem = "is too large for a number" if big else f"must be a number, not {value_kind(value)}"
        return InputError(f"{source}: {loc}", problem, value)
    fixed = {"missing": "is required", "extra_forbidden": "is not a known field"}.get(first["type"])
    if fixed is not None:
        return InputError(f"{source}: {loc}", fixed)
    if isinstance(value, dict):
        return InputError(f"{source}: {loc}", msg)
    return InputError(f"{source}: {loc}", msg, value)
