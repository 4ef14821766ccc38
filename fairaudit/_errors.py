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

    def under(self, field: str, keep_own: bool = True) -> InputError:
        """The same error placed under an outer ``field`` (for example a spec's path and section).

        With ``keep_own`` the original field stays in the message as a prefix of the problem.

        Examples
        --------
        >>> str(InputError("keep", "must lie in [1/k, 1]", 1.7).under("spec.toml: privacy.sensitive"))
        'spec.toml: privacy.sensitive: keep: must lie in [1/k, 1] (got 1.7)'
        """
        problem = f"{self.field}: {self.problem}" if keep_own and self.field else self.problem
        if self.value is InputError._missing:
            return InputError(field, problem)
        return InputError(field, problem, self.value)


def _short_repr(value: object, limit: int = 120) -> str:
    text = repr(value)
    text = " ".join(text.split())
    return text if len(text) <= limit else text[: limit - 3] + "..."
