"""The columns of decision records by role (sensitive, outcome, context), shared by every way of counting them.

:mod:`fairaudit.data.counts` (pandas, Parquet) and :mod:`fairaudit.data.spark` count
the same records and report the same errors: an unknown column names the
parameter it was given in (``sensitive``, ``outcome``, ``context``), a column
with missing values says how many.
"""

from __future__ import annotations

from collections.abc import Hashable, Iterable, Sequence

from fairaudit.base.checks import columns
from fairaudit.base.errors import InputError, echo

__all__ = ["check_roles", "missing_values", "roles"]


def roles(
    sensitive: str | Sequence[str], outcome: str, context: str | Sequence[str]
) -> tuple[list[str], str, list[str]]:
    """The columns of each role as lists (a single name may be given as a string).

    Raises
    ------
    InputError
        ``sensitive`` names no column.
    """
    sensitive = [sensitive] if isinstance(sensitive, str) else list(sensitive)
    context = [context] if isinstance(context, str) else list(context)
    if not sensitive:
        raise InputError("sensitive", "name at least one column", sensitive)
    return sensitive, outcome, context


def check_roles(names: Iterable[Hashable], sensitive: Sequence[str], outcome: str, context: Sequence[str]) -> None:
    """Every column of every role is one of ``names``; the error names the role's parameter."""
    names = list(names)
    columns(sensitive, "sensitive", names)
    columns([outcome], "outcome", names)
    columns(context, "context", names)


def missing_values(column: Hashable, n: float) -> InputError:
    """The error for ``n`` missing values in ``column`` (when they are not to be dropped)."""
    return InputError(f"column {echo(column)}", f"has {int(n)} missing values (drop those rows: `dropna`)")
