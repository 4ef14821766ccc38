"""Labels of a table's axes (:class:`Labels`): checked once, kept as given, formatted for messages and reports."""

from __future__ import annotations

from collections.abc import Hashable, Iterable, Iterator, Sequence
from typing import Any, SupportsIndex

import numpy as np
import numpy.typing as npt

from fairaudit.base.errors import InputError, cut


def as_labels(values: Iterable[Hashable], field: str) -> tuple[Any, ...]:
    """Return ``values`` as a tuple of distinct hashable labels.

    Numpy scalars become Python scalars and lists become tuples. Linear in the
    number of labels with C-level passes (a numpy array converts with
    ``tolist``; distinctness is one ``set``), so a million labels take
    milliseconds; the error path finds the first repeat. A label that cannot
    be hashed (a dict, a set) is an :class:`InputError` naming ``field``.
    A :class:`Labels` gives its tuple.
    """
    if isinstance(values, Labels):
        return values.tuple
    if type(values) is tuple and _known(values) is not None:
        return values
    if isinstance(values, (str, bytes)):
        raise InputError(field, "must be a list of labels, not a single string", values)
    labels = tuple(values.tolist()) if isinstance(values, np.ndarray) else tuple(values)
    if any(issubclass(t, (np.generic, list, np.ndarray)) for t in set(map(type, labels))):
        labels = tuple(_plain(v) for v in labels)
    if not labels:
        raise InputError(field, "must name at least one value", list(labels))
    try:
        distinct = len(set(labels)) == len(labels)
    except TypeError:  # a dict or set among them: labels are dictionary keys
        bad = next(v for v in labels if not is_hashable(v))
        raise InputError(
            field, f"a label must be hashable (a string, number or tuple), not a {type(bad).__name__}", bad
        ) from None
    if not distinct:
        seen: set[Hashable] = set()
        for label in labels:
            if label in seen:
                raise InputError(field, "labels must be distinct; repeated label", label)
            seen.add(label)
    if len(labels) >= 1024:  # remember big label sets: a law's contexts are checked again by every table built on them
        _remember(Labels(None, labels))
    return labels


_VALIDATED: dict[int, Labels] = {}
"""The last few large label tuples that passed :func:`as_labels`, by id, each with its :class:`Labels`
(a tuple is immutable: it stays valid; the entry keeps it alive, so its id is not reused)."""


def _known(labels: tuple[Any, ...]) -> Labels | None:
    """The :class:`Labels` of a tuple that :func:`as_labels` or :attr:`Labels.tuple` made, else None."""
    known = _VALIDATED.get(id(labels))
    return known if known is not None and known._tuple is labels else None


def _remember(labels: Labels) -> None:
    assert labels._tuple is not None
    _VALIDATED[id(labels._tuple)] = labels
    while len(_VALIDATED) > 8:
        del _VALIDATED[next(iter(_VALIDATED))]


_INT64 = (-(1 << 63), (1 << 63) - 1)


class Labels:
    """The distinct labels of one axis of a table, kept compact: a ``range``, a 1-D array, or a tuple.

    Labels given as a non-empty ``range`` of machine integers or as a 1-D numpy array of integers or
    text stay that (a read-only copy of the array): no Python object per label, and checking that they
    are distinct is one vectorised pass. Anything else goes through :func:`as_labels` (a tuple). Build
    with :meth:`of`. ``labels[i]`` is the i-th label as :func:`as_labels` gives it (a Python scalar);
    :attr:`tuple` is the whole tuple, made on first use and kept.

    Examples
    --------
    >>> c = Labels.of(range(10**6), "contexts")
    >>> len(c), c[123456], c.tuple[:3]
    (1000000, 123456, (0, 1, 2))
    >>> Labels.of(np.array(["b", "a"]), "groups").same(Labels.of(["b", "a"], "groups"))
    True
    """

    def __init__(self, compact: range | npt.NDArray[Any] | None, labels: tuple[Any, ...] | None) -> None:
        self._compact = compact
        self._tuple = labels

    @classmethod
    def of(cls, values: object, field: str) -> Labels:
        """The labels ``values`` (a sequence, a range, a numpy array or a :class:`Labels`), checked distinct.

        Raises
        ------
        InputError
            As :func:`as_labels`: no label, a repeated label, an unhashable label.
        """
        if isinstance(values, Labels):
            return values
        if type(values) is tuple and (known := _known(values)) is not None:
            return known
        compact = _compact(values)
        if compact is None:
            labels = as_labels(values, field)  # type: ignore[arg-type]  # as_labels names what is wrong
            return _known(labels) or cls(None, labels)
        if not isinstance(compact, range) and not _sorted_distinct(compact):
            as_labels(compact, field)  # raises, naming the first repeat
        return cls(compact, None)

    def __len__(self) -> int:
        if self._compact is None:
            assert self._tuple is not None
            return len(self._tuple)
        return len(self._compact)

    def __getitem__(self, i: SupportsIndex) -> Any:
        """The i-th label, as :func:`as_labels` gives it (numpy scalars as Python ones)."""
        if self._compact is None:
            return self._tuple[i]  # type: ignore[index]
        if isinstance(self._compact, range):
            return self._compact[i]
        return self._compact[i].item()

    def __iter__(self) -> Iterator[Any]:
        return iter(self.tuple)

    def __repr__(self) -> str:
        n = len(self)
        head = ", ".join(repr(self[i]) for i in range(min(n, 3)))
        return f"Labels([{head}{', ...' if n > 3 else ''}], {n} labels)"

    @property
    def tuple(self) -> tuple[Any, ...]:
        """The labels as a tuple of Python labels (what :func:`as_labels` returns), made once."""
        if self._tuple is None:
            c = self._compact
            self._tuple = tuple(c) if isinstance(c, range) else tuple(c.tolist())  # type: ignore[union-attr]
            if len(self._tuple) >= 1024:
                _remember(self)
        return self._tuple

    def same(self, other: Labels) -> bool:
        """True when both hold the same labels in the same order (as their tuples compare)."""
        if self is other:
            return True
        if len(self) != len(other):
            return False
        a, b = self._compact, other._compact
        if a is None or b is None:
            return self.tuple == other.tuple
        if isinstance(a, range) and isinstance(b, range):
            return a == b
        x, y = _as_array(a), _as_array(b)
        kinds = {x.dtype.kind.replace("u", "i"), y.dtype.kind.replace("u", "i")}
        return len(kinds) == 1 and bool(np.array_equal(x, y))


def _compact(values: object) -> range | npt.NDArray[Any] | None:
    """``values`` as a compact label sequence (a range of int64 values, a read-only 1-D int or text array), or None."""
    if isinstance(values, range):
        ok = len(values) > 0 and _INT64[0] <= min(values[0], values[-1]) and max(values[0], values[-1]) <= _INT64[1]
        return values if ok else None
    if isinstance(values, np.ndarray) and values.ndim == 1 and values.size and values.dtype.kind in "iuUS":
        array = np.array(values)  # our own copy
        array.setflags(write=False)
        return array
    return None


def _as_array(values: range | npt.NDArray[Any]) -> npt.NDArray[Any]:
    return np.arange(values.start, values.stop, values.step) if isinstance(values, range) else values


def _sorted_distinct(values: npt.NDArray[Any]) -> bool:
    """True when the 1-D array has no repeated value (one comparison pass when increasing, else a sort)."""
    if values.size < 2 or bool(np.all(values[1:] > values[:-1])):
        return True
    s = np.sort(values)
    return not bool(np.any(s[1:] == s[:-1]))


def _plain(value: object) -> Hashable:
    """Numpy scalars to Python scalars, lists to tuples (hashable labels)."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, (list, np.ndarray)):
        return tuple(_plain(v) for v in value)
    return value


def is_hashable(value: object) -> bool:
    """Whether ``hash(value)`` works (a tuple holding a list is a ``Hashable`` instance and still fails)."""
    try:
        hash(value)
    except TypeError:
        return False
    return True


def format_label(label: object) -> str:
    """Human form of a label: tuples (product attributes) joined by ' & '; text with spaces around it quoted.

    Examples
    --------
    >>> format_label(("a", 1)), format_label(" Male"), format_label("")
    ('a & 1', "' Male'", "''")
    """
    if isinstance(label, tuple):
        return " & ".join(format_label(v) for v in label)
    text = str(label)
    if isinstance(label, str) and (not text or text != text.strip()):
        return repr(text)  # the spaces a reader would not see (a CSV field after ", "), or an empty label
    return text


def label_list(labels: Sequence[object], most: int = 20) -> str:
    """Labels as a message lists them: each by :func:`format_label`, cut after 80 characters, the first ``most``.

    Examples
    --------
    >>> label_list(["a", ("b", 1)])
    "['a', 'b & 1']"
    >>> label_list(range(30), most=2)
    "['0', '1', ... (30 in all)]"
    """
    shown = [cut(format_label(v)) for v in list(labels)[:most]]
    if len(labels) <= most:
        return repr(shown)
    return repr(shown)[:-1] + f", ... ({len(labels)} in all)]"
