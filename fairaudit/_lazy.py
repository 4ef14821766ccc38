"""Result fields made on first read: an array a result may carry but few readers ask for.

:class:`LazyField` is a field of a frozen dataclass that holds either its value or a :class:`Deferred`, a
picklable recipe that makes the value when the field is first read (and keeps it). The per-context log ratios of
a local g-fairness result are one: a million logarithms cost as much as the rest of the pass over the law, and
only per-context reports read them.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Generic, TypeVar

__all__ = ["Deferred", "LazyField"]

T = TypeVar("T")
T_co = TypeVar("T_co", covariant=True)


class Deferred(Generic[T_co]):
    """A value to make on first read: ``make(*args)``; ``make`` is a module-level function (so it pickles)."""

    __slots__ = ("make", "args")

    def __init__(self, make: Callable[..., T_co], *args: Any) -> None:
        self.make, self.args = make, args

    def __call__(self) -> T_co:
        return self.make(*self.args)


class LazyField(Generic[T]):
    """A data descriptor for a dataclass field whose value may be given as a :class:`Deferred`.

    The dataclass's ``__init__`` stores the given value (frozen dataclasses store through ``object.__setattr__``,
    which calls :meth:`__set__`); the first read of a :class:`Deferred` makes the value and keeps it in its place.
    Two threads reading at once may both make it: the recipe must not change its inputs. The field has no default.
    """

    def __set_name__(self, owner: type, name: str) -> None:
        self.slot = "_lazy_" + name

    def __get__(self, obj: object | None, objtype: type | None = None) -> T:
        if obj is None:  # the class attribute: no default for the dataclass
            raise AttributeError(self.slot)
        value = obj.__dict__[self.slot]
        if isinstance(value, Deferred):
            value = value()
            obj.__dict__[self.slot] = value
        return value

    def __set__(self, obj: object, value: T | Deferred[T]) -> None:
        obj.__dict__[self.slot] = value
