"""Errors raised by fairaudit.

Every error about the caller's input is an :class:`InputError`: one line that
names the field, column or argument, says what is wrong and quotes the
offending value. The command-line interface prints it and exits with status 2.
"""

from __future__ import annotations

import importlib
import os
from typing import Any

__all__ = [
    "ECHO_LIMIT",
    "FairauditError",
    "InputError",
    "MemoryLimitError",
    "UnderflowError",
    "cut",
    "echo",
    "optional_modules",
]


class FairauditError(Exception):
    """Base class of every error that fairaudit raises on purpose."""


class InputError(FairauditError, ValueError):
    """Invalid input: names the field and the offending value.

    Parameters
    ----------
    field : str
        The argument, table, spec field or column at fault, for example
        ``"kernel"``, ``"privacy.sensitive.epsilon"`` or ``"column 'race'"``.
    problem : str
        What is wrong, in a few words.
    value : object, optional
        The offending value; quoted in the message by :func:`echo` (``repr``,
        numpy scalars as Python numbers, cut after :data:`ECHO_LIMIT` characters).

    Examples
    --------
    >>> str(InputError("tau", "must be positive", -0.5))
    'tau: must be positive (got -0.5)'
    """

    _missing = object()

    def __init__(self, field: str, problem: str, value: object = _missing) -> None:
        self.field = field
        self.problem = problem
        self.value = value
        text = f"{field}: {problem}"
        if value is not InputError._missing:
            text += f" (got {echo(value)})"
        super().__init__(text)

    def under(self, field: str, keep_own: bool = True) -> InputError:
        """The same error placed under an outer ``field`` (for example a spec's path and section).

        With ``keep_own`` the original field stays in the message as a prefix of the problem.

        Examples
        --------
        >>> str(InputError("keep", "must lie in [1/k, 1]", 1.7).under("spec.toml: privacy.sensitive"))
        'spec.toml: privacy.sensitive: keep: must lie in [1/k, 1] (got 1.7)'
        """
        problem = f"{self.field}: {self.problem}" if keep_own and self.field else self.problem
        return InputError(field, problem, self.value)  # an error without a value passes _missing on: still none


class UnderflowError(InputError):
    """A probability that is positive exactly but below the smallest normal float (2.2e-308): floating point cannot
    hold it, and a ratio or logarithm computed from it would be wrong (randomized response above about 708 nats, whose
    q = 1/(e^ε + k − 1) underflows). Raised instead of a silent wrong number; callers that can go on without the
    value (a certificate's observed metrics) leave it out and say why.

    Examples
    --------
    >>> isinstance(UnderflowError("kernel", "underflows"), InputError)
    True
    """


class MemoryLimitError(InputError):
    """Work the inputs imply would need more memory than the limit (:mod:`fairaudit.base.resources`): raised before
    anything is allocated, with what it would need, the inputs that drive it, the limit and what to do instead.

    Examples
    --------
    >>> isinstance(MemoryLimitError("memory", "one table would need 4 GiB"), InputError)
    True
    """


def optional_modules(field: str, problem: str, *names: str) -> tuple[Any, ...]:
    """The modules ``names`` (of an optional extra), imported now, or an :class:`InputError` when one is missing.

    Parameters
    ----------
    field, problem : str
        The error's field and its problem, which names the extra that installs the modules.
    *names : str
        Dotted module names (``"PIL.Image"`` gives the module that ``from PIL import Image`` does).

    Examples
    --------
    >>> optional_modules("format", "needs json", "json")[0].__name__
    'json'
    >>> optional_modules("format", "needs nomodule: pip install it", "json", "nomodule")
    Traceback (most recent call last):
    fairaudit.base.errors.InputError: format: needs nomodule: pip install it
    """
    try:
        return tuple(importlib.import_module(name) for name in names)
    except ImportError:
        raise InputError(field, problem) from None


ECHO_LIMIT = 80
"""How many characters of a value :func:`echo` shows before it cuts it."""

PATH_LIMIT = 1024
"""The longest text with a ``/`` that :func:`echo` quotes whole, as a file path."""


def echo(value: object, limit: int = ECHO_LIMIT) -> str:
    """A value as an error message quotes it: its ``repr``, numpy scalars as Python ones, cut to ``limit`` characters.

    Text longer than ``limit`` shows the ``repr`` of its first ``limit``
    characters, then ``…`` and its length; other values longer than that as
    ``repr`` show its first ``limit`` characters, then ``…`` and the length
    of the ``repr``. A numpy scalar (``np.float64(nan)`` in numpy 2) is
    quoted as the Python number it holds (``nan``), also inside a tuple or
    list. Line breaks in a ``repr`` (a numpy array's) become spaces. A file
    path is quoted whole, since its end names the file: an ``os.PathLike``,
    or text with a ``/`` of at most :data:`PATH_LIMIT` characters and no
    line break.

    Parameters
    ----------
    value : object
        What the user gave: a label, a column's name, a field, a number.
    limit : int
        Characters shown (default :data:`ECHO_LIMIT`).

    Returns
    -------
    str

    Examples
    --------
    >>> import numpy as np
    >>> echo("Male"), echo(np.float64("nan")), echo((np.int64(1), "a"))
    ("'Male'", 'nan', "(1, 'a')")
    >>> echo("x" * 1_000_000, limit=5)
    "'xxxxx'… (1000000 characters)"
    >>> echo("/data/" + "2024/" * 20 + "applicants.csv") == repr("/data/" + "2024/" * 20 + "applicants.csv")
    True
    """
    if isinstance(value, os.PathLike):
        value = os.fspath(value)
    value = _plain(value)
    if isinstance(value, str) and len(value) <= PATH_LIMIT and os.sep in value and "\n" not in value:
        return repr(value)
    if isinstance(value, (str, bytes)):
        return repr(value) if len(value) <= limit else f"{value[:limit]!r}… ({len(value)} characters)"
    return cut(" ".join(repr(value).split()), limit)


def cut(text: object, limit: int = ECHO_LIMIT) -> str:
    """``str(text)`` as a message shows it unquoted (a column's name in a list): cut after ``limit`` characters.

    Examples
    --------
    >>> cut("race"), cut("y" * 100, limit=3)
    ('race', 'yyy… (100 characters)')
    """
    text = str(text)
    return text if len(text) <= limit else f"{text[:limit]}… ({len(text)} characters)"


def _plain(value: object) -> object:
    """``value`` with numpy scalars (also in a tuple or list) as the Python scalars they hold."""
    if type(value).__module__ == "numpy" and getattr(value, "shape", None) == () and hasattr(value, "item"):
        return value.item()
    if isinstance(value, (tuple, list)) and any(type(v).__module__ == "numpy" for v in value):
        items = [_plain(v) for v in value]
        return tuple(items) if isinstance(value, tuple) else items
    return value
