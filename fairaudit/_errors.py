"""Errors raised by fairaudit.

Every error about the caller's input is an :class:`InputError`: one line that
names the field, column or argument, says what is wrong and quotes the
offending value. The command-line interface prints it and exits with status 2.
"""

from __future__ import annotations

__all__ = ["FairauditError", "InputError"]


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
        The offending value; quoted with ``repr`` in the message.

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
            text += f" (got {_short_repr(value)})"
        super().__init__(text)


def _short_repr(value: object, limit: int = 120) -> str:
    text = repr(value)
    text = " ".join(text.split())
    return text if len(text) <= limit else text[: limit - 3] + "..."
