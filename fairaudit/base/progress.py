"""The progress bar of a long loop: tqdm's on stderr when it is installed and wanted, else one that shows nothing.

A loop whose caller says whether to show it passes ``enabled`` (the experiments' queries). The long steps deep inside
a computation, which no argument reaches (the worst cases' pair searches, the intervals behind a filter), ask with
``enabled=None``: they show a bar only inside a :func:`progress_shown` block, which ``certify(progress=True)`` opens
(``fairaudit certify`` unless ``--no-progress``). tqdm is an extra (``experiment``, ``test``): without it every bar
shows nothing. tqdm's own ``disable=None`` turns a bar off when stderr is not a terminal.
"""

from __future__ import annotations

import sys
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from typing import Protocol

__all__ = ["STEP_DELAY", "ProgressBar", "progress_bar", "progress_shown"]

STEP_DELAY = 0.5
"""Seconds a bar of a step inside a computation waits before it shows (tqdm's ``delay``): the many short searches
of a calibration show none, and a step that ends sooner leaves nothing to clear."""

_SHOWN: ContextVar[bool] = ContextVar("fairaudit_progress_shown", default=False)


class ProgressBar(Protocol):
    """A progress bar: tqdm's, or none."""

    @property
    def disable(self) -> bool | None:
        """True when it shows nothing (tqdm's is None or False when it draws)."""

    def update(self, n: int = 1) -> object: ...
    def set_postfix_str(self, s: str = "", refresh: bool = True) -> object: ...
    def close(self) -> None: ...
    def __enter__(self) -> ProgressBar: ...
    def __exit__(self, *exc: object) -> object: ...


class _NoBar:
    disable: bool | None = True

    def update(self, n: int = 1) -> None:
        pass

    def set_postfix_str(self, s: str = "", refresh: bool = True) -> None:
        pass

    def close(self) -> None:
        pass

    def __enter__(self) -> _NoBar:
        return self

    def __exit__(self, *exc: object) -> None:
        pass


@contextmanager
def progress_shown(enabled: bool = True) -> Iterator[None]:
    """Within the block (and in this thread or task only), the bars asked for with ``enabled=None`` show when
    ``enabled``; outside every block they show nothing.

    Examples
    --------
    >>> with progress_shown():
    ...     with progress_shown(False):
    ...         inner = _SHOWN.get()
    ...     outer = _SHOWN.get()
    >>> inner, outer, _SHOWN.get()
    (False, True, False)
    """
    token = _SHOWN.set(enabled)
    try:
        yield
    finally:
        _SHOWN.reset(token)


def progress_bar(
    total: int,
    desc: str,
    enabled: bool | None = None,
    *,
    unit: str = "it",
    delay: float = 0.0,
    bar_format: str | None = None,
) -> ProgressBar:
    """A bar of ``total`` steps labelled ``desc``, on stderr; none when not wanted, empty, or tqdm is missing.

    Parameters
    ----------
    total : int
        The steps the loop may take (it may stop early: the bar then closes short of them).
    desc : str
        The label before the bar.
    enabled : bool or None
        Whether to show it; None: as the enclosing :func:`progress_shown` block says (none outside one).
    unit : str
        What a step is, as tqdm shows it (``"query"``, ``"program"``).
    delay : float
        Seconds before the bar first shows (:data:`STEP_DELAY` for the steps of a computation).
    bar_format : str, optional
        tqdm's format of the line; its default shows the percentage and the time left.

    Returns
    -------
    ProgressBar
        tqdm's bar with ``disable=None`` (off when stderr is not a terminal), ``leave=False`` (cleared when closed)
        and ``miniters=1`` (redrawn at most every 0.1 s, checked at each update, so that slow steps after fast ones
        still redraw), or one that shows nothing. Both are context managers that close the bar.

    Examples
    --------
    >>> bar = progress_bar(10, "queries", enabled=False)
    >>> bar.update(1); bar.close()
    >>> progress_bar(10, "programs").disable  # enabled=None outside progress_shown: none
    True
    """
    if enabled is None:
        enabled = _SHOWN.get()
    if not enabled or total == 0 or not sys.stderr.isatty():  # (tqdm's disable=None would draw nothing either)
        return _NoBar()
    try:
        from tqdm import tqdm
    except ImportError:
        return _NoBar()
    return tqdm(
        total=total, desc=desc, unit=unit, disable=None, leave=False, delay=delay, miniters=1, bar_format=bar_format
    )
