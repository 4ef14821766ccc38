"""Old names of result attributes, kept readable: :class:`renamed`, a read-only alias that warns.

Result attributes are named as the metric functions of :mod:`fairaudit.metrics`
(``local_fairness``, ``global_fairness``, ``sup_local_fairness``,
``sup_global_fairness``; ``docs/design.md "Conventions"``). Their old names
(``local``, ``global_``, ``sup_local``, ``sup_global``) stay as aliases that
return the new attribute and emit a :class:`DeprecationWarning`.
"""

from __future__ import annotations

import warnings
from typing import Any, Generic, Never, NoReturn, TypeVar, overload

__all__ = ["renamed"]

T = TypeVar("T")


class renamed(Generic[T]):  # lowercase, as ``property``: it is used like one
    """A deprecated, read-only old name of the attribute ``new_name``.

    Put it in the class body without an annotation, so that a dataclass does
    not take it for a field::

        global_ = renamed[Fairness]("global_fairness")

    Reading ``obj.global_`` returns ``obj.global_fairness`` and warns
    ``DeprecationWarning("Observed.global_ is deprecated: use
    Observed.global_fairness")`` at the caller's line; assigning or deleting it
    raises :class:`AttributeError`, as for a property without a setter. It
    lives on the class, never on the instance, so it works on frozen
    dataclasses with or without ``slots``. Read on the class, it is the alias
    itself.

    Parameters
    ----------
    new_name : str
        The attribute's canonical name.
    """

    def __init__(self, new_name: str) -> None:
        self.new_name = new_name
        self.old_name = new_name  # set by __set_name__
        self.owner = ""
        self.__doc__ = f"Deprecated alias of ``{new_name}``."

    def __repr__(self) -> str:
        return f"renamed({self.new_name!r})"

    def __set_name__(self, owner: type, name: str) -> None:
        self.owner = owner.__name__
        self.old_name = name

    @property
    def message(self) -> str:
        """The warning: ``"<Class>.<old> is deprecated: use <Class>.<new>"``."""
        return f"{self.owner}.{self.old_name} is deprecated: use {self.owner}.{self.new_name}"

    @overload
    def __get__(self, obj: None, objtype: type | None = None) -> renamed[T]: ...

    @overload
    def __get__(self, obj: object, objtype: type | None = None) -> T: ...

    def __get__(self, obj: object | None, objtype: type | None = None) -> Any:
        if obj is None:
            return self
        warnings.warn(self.message, DeprecationWarning, stacklevel=2)
        return getattr(obj, self.new_name)

    def __set__(self, obj: object, value: Never) -> NoReturn:
        raise AttributeError(f"{self.owner}.{self.old_name} is read-only ({self.message})")

    def __delete__(self, obj: object) -> NoReturn:
        raise AttributeError(f"{self.owner}.{self.old_name} is read-only ({self.message})")
