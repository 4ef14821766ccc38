"""Atomic file writes: a temporary file in the target's folder, then a rename.

:func:`write_atomic` is how every report, table and figure that fairaudit
writes reaches the disk; a killed writer's leftovers are removed by the next
write of the same target.
"""

from __future__ import annotations

import os
import re
import stat
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from ._errors import InputError

__all__ = ["STALE_SECONDS", "write_atomic"]


def write_atomic(
    path: str | os.PathLike[str], content: str | bytes | Callable[[str], object], *, field: str = "--output"
) -> None:
    """Write ``content`` to ``path`` atomically: a temporary file in the same folder, then rename.

    An existing file is replaced only once the new one is complete; on any
    error it is left untouched and the temporary file removed. The file gets
    the usual permissions (0666 less the umask).

    The temporary file is ``.NAME.XXXXXXXX.tmpSUFFIX`` next to ``NAME``
    (``tempfile.mkstemp``). A writer killed before its rename (SIGKILL, power
    loss) leaves it behind; each write first removes the leftovers of *the
    same* target: regular files in that folder whose name is exactly that
    pattern for ``NAME`` and that are older than :data:`STALE_SECONDS` (a
    live writer's file is younger: it is written as soon as it is made).
    No other file is touched.

    Parameters
    ----------
    path : str or os.PathLike
    content : str, bytes or callable
        Text (UTF-8), bytes, or a function that writes the file given the
        temporary path (for example a matplotlib ``savefig``).
    field : str
        The option named in errors (``--output``, ``--plot``, ...).

    Raises
    ------
    InputError
        If the folder does not exist or cannot be written, or ``path`` is a folder.
    """
    p = Path(path)
    folder = p.parent if str(p.parent) else Path(".")
    if not folder.is_dir():
        raise InputError(field, "folder does not exist", str(folder))
    if p.is_dir():
        raise InputError(field, "is a directory", str(p))
    _remove_stale_temporaries(folder, p)
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.", suffix=".tmp" + p.suffix, dir=folder)
    except OSError as exc:
        raise InputError(field, f"cannot write there ({exc.strerror})", str(path)) from None
    try:
        if callable(content):
            os.close(fd)
            content(tmp)
        else:
            data = content.encode("utf-8") if isinstance(content, str) else bytes(content)
            with os.fdopen(fd, "wb") as fh:
                fh.write(data)
                fh.flush()
                os.fsync(fh.fileno())
        mask = os.umask(0)
        os.umask(mask)
        os.chmod(tmp, 0o666 & ~mask)  # mkstemp makes 0600; a report gets the usual permissions
        os.replace(tmp, p)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


STALE_SECONDS = 60.0
"""Age (by modification time) after which :func:`write_atomic` removes a temporary file left by a killed writer."""


def _remove_stale_temporaries(folder: Path, target: Path) -> None:
    """Remove the temporary files that killed writers of ``target`` left in ``folder`` (best effort)."""
    pattern = re.compile(re.escape(f".{target.name}.") + r"[a-z0-9_]{8}" + re.escape(".tmp" + target.suffix))
    now = time.time()
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return
    for entry in entries:
        if not pattern.fullmatch(entry.name):
            continue
        try:
            info = entry.stat(follow_symlinks=False)
            if stat.S_ISREG(info.st_mode) and now - info.st_mtime > STALE_SECONDS:
                os.unlink(entry.path)
        except OSError:
            pass  # gone already, or not ours to remove
