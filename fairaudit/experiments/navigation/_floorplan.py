"""What the two writers of S3DIS-layout floors share: wall faces, door openings, checked folders, staged rooms.

:func:`~fairaudit.experiments.navigation.synthetic.write_office_floor` and the benchmarks' building-size area
(``write_building`` in ``benchmarks/s3dis_building.py``) draw rooms as rectangles whose walls are
:data:`HALF_WALL` thick on each side, with door openings up to :data:`DOOR_TOP` framed by jambs :data:`FRAME`
wide, and write each room into a hidden temporary folder renamed into place when complete.
"""

from __future__ import annotations

import os
import re
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from fairaudit import InputError

__all__ = ["DOOR_TOP", "FRAME", "HALF_WALL", "area_folder", "intervals_minus", "staged_room", "wall_face"]

HALF_WALL = 0.05
"""Walls are 0.1 m thick: each room's wall face is this far inside its rectangle, metres."""
DOOR_TOP = 2.1
"""Top of a door opening, metres; the frame's head goes up to 2.2 m, a lintel wall above."""
FRAME = 0.05
"""Width of a door jamb, metres."""
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")


def wall_face(rect: tuple[float, float, float, float], side: str) -> tuple[str, float, float, float]:
    """(axis, position of the wall face, start, end along the wall) of one side of a room (x0, x1, y0, y1).

    >>> wall_face((0.0, 4.0, 0.0, 3.0), "north")
    ('y', 2.95, 0.0, 4.0)
    """
    x0, x1, y0, y1 = rect
    return {
        "south": ("y", y0 + HALF_WALL, x0, x1),
        "north": ("y", y1 - HALF_WALL, x0, x1),
        "west": ("x", x0 + HALF_WALL, y0, y1),
        "east": ("x", x1 - HALF_WALL, y0, y1),
    }[side]


def intervals_minus(a: float, b: float, holes: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """The parts of [a, b] outside the ``holes`` (intervals), in order; parts shorter than 1e-9 dropped.

    >>> intervals_minus(0.0, 5.0, [(1.0, 2.0), (3.0, 3.5)])
    [(0.0, 1.0), (2.0, 3.0), (3.5, 5.0)]
    """
    out, start = [], a
    for h0, h1 in sorted(holes):
        if h0 > start:
            out.append((start, min(h0, b)))
        start = max(start, h1)
    if start < b:
        out.append((start, b))
    return [(u, v) for u, v in out if v - u > 1e-9]


def area_folder(folder: str | Path, area: str) -> Path:
    """``folder / area`` after checking that ``folder`` exists and ``area`` is a plain folder name.

    Raises
    ------
    InputError
        Naming ``folder`` or ``area``.
    """
    base = Path(folder)
    if not base.is_dir():
        raise InputError("folder", "folder does not exist", str(folder))
    if not isinstance(area, str) or not _NAME.match(area) or area in (".", ".."):
        raise InputError("area", "must be a folder name (letters, digits, '_', '.', '-')", area)
    return base / area


@contextmanager
def staged_room(area_dir: Path, name: str) -> Iterator[Path]:
    """A hidden temporary folder in ``area_dir`` for room ``name``, with its ``Annotations`` folder made.

    The caller writes the room into it and renames it into place inside the block; if the block fails, the
    folder is removed, so an interrupted write leaves no partial room. Its permissions follow the umask, as
    ``mkdir`` would (``mkdtemp`` makes it private).

    Raises
    ------
    InputError
        Naming ``folder`` when ``area_dir`` cannot be written.
    """
    try:
        tmp = Path(tempfile.mkdtemp(prefix=f".{name}.", suffix=".tmp", dir=area_dir))
    except OSError as exc:
        raise InputError("folder", f"cannot write there ({exc.strerror})", str(area_dir)) from None
    try:
        mask = os.umask(0)
        os.umask(mask)
        os.chmod(tmp, 0o777 & ~mask)
        (tmp / "Annotations").mkdir()
        yield tmp
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
