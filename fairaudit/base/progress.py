"""The progress bar of a long loop: tqdm's on stderr when it is installed and wanted, else one that shows nothing."""

from __future__ import annotations

from typing import Protocol

__all__ = ["ProgressBar", "progress_bar"]


class ProgressBar(Protocol):
    """A progress bar: tqdm's, or none."""

    def update(self, n: int = 1) -> object: ...
    def close(self) -> None: ...


class _NoBar:
    def update(self, n: int = 1) -> None:
        pass

    def close(self) -> None:
        pass


def progress_bar(total: int, desc: str, enabled: bool, *, unit: str = "it") -> ProgressBar:
    """A bar of ``total`` steps labelled ``desc``, counted in ``unit``; none when not ``enabled``, empty, or tqdm is
    missing.

    tqdm's own ``disable=None`` turns it off when stderr is not a terminal.

    Examples
    --------
    >>> bar = progress_bar(10, "queries", enabled=False)
    >>> bar.update(1); bar.close()
    """
    if not enabled or total == 0:
        return _NoBar()
    try:
        from tqdm import tqdm
    except ImportError:
        return _NoBar()
    return tqdm(total=total, desc=desc, unit=unit, disable=None, leave=False)
