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
from contextlib import suppress
from pathlib import Path

from fairaudit.base.errors import InputError

__all__ = ["STALE_SECONDS", "write_atomic"]


def write_atomic(
    path: str | os.PathLike[str], content: str | bytes | Callable[[str], object], *, field: str = "--output"
) -> None:
    """Write ``content`` to ``path`` atomically: a temporary file in the same folder, then rename.

    An existing file is replaced only once the new one is complete; on any
    error it is left untouched and the temporary file removed. A new file
    gets the usual permissions (0666 less the umask); an existing one keeps
    its own (a 0600 report stays 0600) and, where the process may set them,
    its owner and group.

    What is not a regular file is not replaced:

    - a symbolic link is followed: its target is written (atomically, as
      above) and the link stays a link;
    - a character or block device (``/dev/null``) or a named pipe (FIFO) is
      written through: opened and written, as a shell's ``>`` does (a pipe
      waits for its reader).

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
        If the folder does not exist or cannot be written, ``path`` is a
        folder, or writing fails (a full disk, a file size limit): the
        message names ``field``, the path and the system's reason.

    Examples
    --------
    >>> import os, stat, tempfile
    >>> folder = tempfile.mkdtemp()
    >>> report = os.path.join(folder, "report.txt")
    >>> write_atomic(report, "first\\n")
    >>> os.chmod(report, 0o600)
    >>> os.symlink(report, os.path.join(folder, "latest.txt"))
    >>> write_atomic(os.path.join(folder, "latest.txt"), "second\\n")
    >>> open(report).read(), oct(stat.S_IMODE(os.stat(report).st_mode)), os.path.islink(os.path.join(folder, "latest.txt"))
    ('second\\n', '0o600', True)
    >>> write_atomic(os.devnull, "nothing")  # written through: /dev/null stays a device
    >>> stat.S_ISCHR(os.stat(os.devnull).st_mode)
    True
    """
    p = Path(os.path.realpath(path)) if os.path.islink(path) else Path(path)
    try:
        info: os.stat_result | None = os.stat(p)
    except FileNotFoundError:
        info = None
    except OSError as exc:
        raise _cannot_write(field, path, exc) from None
    if info is not None and stat.S_ISDIR(info.st_mode):
        raise InputError(field, "is a directory", str(path))
    if info is not None and not stat.S_ISREG(info.st_mode):
        _write_through(p, content, field, path)
        return
    folder = p.parent if str(p.parent) else Path(".")
    if not folder.is_dir():
        raise InputError(field, "folder does not exist", str(folder))
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
            with os.fdopen(fd, "wb") as fh:
                fh.write(_bytes(content))
                fh.flush()
                os.fsync(fh.fileno())
        if info is None:
            mask = os.umask(0)
            os.umask(mask)
            os.chmod(tmp, 0o666 & ~mask)  # mkstemp makes 0600; a new report gets the usual permissions
        else:
            os.chmod(tmp, stat.S_IMODE(info.st_mode))  # an existing one keeps its own
            _keep_owner(tmp, info)
        os.replace(tmp, p)
    except BaseException as exc:
        with suppress(OSError):
            os.unlink(tmp)
        if isinstance(exc, OSError):
            raise _cannot_write(field, path, exc) from None
        raise


def _bytes(content: str | bytes) -> bytes:
    return content.encode("utf-8") if isinstance(content, str) else bytes(content)


def _write_through(
    p: Path, content: str | bytes | Callable[[str], object], field: str, path: str | os.PathLike[str]
) -> None:
    """Open the device or named pipe ``p`` and write ``content`` into it (a callable writes a temporary file first)."""
    try:
        if callable(content):
            with tempfile.TemporaryDirectory(prefix="fairaudit-") as folder:
                tmp = os.path.join(folder, "content" + p.suffix)
                content(tmp)
                data = Path(tmp).read_bytes()
        else:
            data = _bytes(content)
        with open(p, "wb") as fh:
            fh.write(data)
    except OSError as exc:
        raise _cannot_write(field, path, exc) from None


def _keep_owner(tmp: str, info: os.stat_result) -> None:
    """Give ``tmp`` the owner and group of the file it replaces, where the process may (best effort)."""
    mine = os.stat(tmp)
    if (mine.st_uid, mine.st_gid) != (info.st_uid, info.st_gid):
        with suppress(OSError):  # not ours to give: the file is then the writer's, as any new file
            os.chown(tmp, info.st_uid, info.st_gid)


def _cannot_write(field: str, path: str | os.PathLike[str], exc: OSError) -> InputError:
    """The one line of a failed write: the option, the system's reason (never an empty one) and the path."""
    reason = exc.strerror or str(exc) or type(exc).__name__
    return InputError(field, f"cannot be written ({reason})", os.fspath(path))


STALE_SECONDS = 60.0
"""Age (by modification time) after which :func:`write_atomic` removes a temporary file left by a killed writer."""


def _remove_stale_temporaries(folder: Path, target: Path) -> None:
    """Remove the temporary files that killed writers of ``target`` left in ``folder`` (best effort)."""
    pattern = re.compile(re.escape(f".{target.name}.") + r"[a-z0-9_]{8}" + re.escape(".tmp" + target.suffix))
    now = time.time()
    try:
        leftovers = [entry for entry in os.scandir(folder) if pattern.fullmatch(entry.name)]
    except OSError:
        return
    for entry in leftovers:
        with suppress(OSError):  # gone already, or not ours to remove
            info = entry.stat(follow_symlinks=False)
            if stat.S_ISREG(info.st_mode) and now - info.st_mtime > STALE_SECONDS:
                os.unlink(entry.path)
