"""Read point clouds in the S3DIS format (Armeni et al. 2016), unchanged.

The Stanford Large-Scale 3D Indoor Spaces dataset (S3DIS; I. Armeni, O. Sener,
A. R. Zamir, H. Jiang, I. Brilakis, M. Fischer and S. Savarese, "3D Semantic
Parsing of Large-Scale Indoor Spaces", CVPR 2016) stores one folder per area
and one folder per room::

    Area_N/<room>/<room>.txt                       every point of the room
    Area_N/<room>/Annotations/<category>_<k>.txt   the same points, one file per instance

Each row is one point, ``x y z r g b``: coordinates in metres and colours
0-255, separated by single spaces. Room names are ``<kind>_<k>`` (``office_1``,
``hallway_3``, ``conferenceRoom_1``, ``WC_1``, ...). The 13 categories are
those of :data:`CATEGORIES` except ``"unlabelled"``.

:func:`read_room` and :func:`read_area` read that layout as it is. Rows that
do not parse (the real data has a stray character inside one number of
``Area_5/hallway_6``) are dropped and counted in ``skipped_rows``. Categories
are stored as small integer codes into :data:`CATEGORIES`.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from fairaudit import InputError

__all__ = [
    "CATEGORIES",
    "UNLABELLED",
    "Area",
    "Room",
    "iter_rooms",
    "read_area",
    "read_points",
    "read_room",
    "room_kind",
]

#: The 13 S3DIS categories, then ``"unlabelled"`` (points of a room read from
#: ``<room>.txt`` because it has no Annotations). A point's category is its
#: index in this tuple.
CATEGORIES = (
    "ceiling",
    "floor",
    "wall",
    "beam",
    "column",
    "window",
    "door",
    "table",
    "chair",
    "sofa",
    "bookcase",
    "board",
    "clutter",
    "unlabelled",
)

#: Code of ``"unlabelled"`` in :data:`CATEGORIES`.
UNLABELLED = CATEGORIES.index("unlabelled")

_CODE = {name: i for i, name in enumerate(CATEGORIES) if i != UNLABELLED}  # an Annotations file is never unlabelled
_INSTANCE = re.compile(r"^(?P<category>.+?)_(?P<k>\d+)$")


@dataclass(frozen=True, eq=False, kw_only=True)
class Room:
    """The points of one S3DIS room, with a category and an instance per point.

    Every array is read-only and has one row per point, in file order (the
    Annotations files in :attr:`instances` order, or ``<room>.txt``).

    Attributes
    ----------
    name : str
        The room folder's name, for example ``"office_1"``.
    points : numpy.ndarray
        Shape (n, 3), float64: x, y, z in metres.
    colors : numpy.ndarray
        Shape (n, 3), uint8: r, g, b (read values rounded and clipped to 0-255).
    categories : numpy.ndarray
        Shape (n,), uint8: codes into :data:`CATEGORIES`. An Annotations file
        whose category is not one of the 13 (the real data has a few
        ``stairs_*``) counts as ``"clutter"``, as in the usual S3DIS
        preprocessing. A room without Annotations is all ``"unlabelled"``
        (:data:`UNLABELLED`).
    instance_ids : numpy.ndarray
        Shape (n,), int32: index into :attr:`instances`, -1 for unlabelled points.
    instances : tuple of str
        The instance names (Annotations file names without ``.txt``, for
        example ``"chair_3"``), ordered by category then number; empty
        without Annotations.
    skipped_rows : int
        Rows dropped because they did not parse as six finite numbers.
    """

    name: str
    points: np.ndarray
    colors: np.ndarray
    categories: np.ndarray
    instance_ids: np.ndarray
    instances: tuple[str, ...]
    skipped_rows: int


@dataclass(frozen=True, eq=False)
class Area:
    """An S3DIS area: its rooms, sorted by name.

    Attributes
    ----------
    name : str
        The area folder's name, for example ``"Area_1"``.
    rooms : tuple of Room
        Sorted by :attr:`Room.name`.
    """

    name: str
    rooms: tuple[Room, ...]

    @property
    def room_names(self) -> tuple[str, ...]:
        """The rooms' names, sorted."""
        return tuple(r.name for r in self.rooms)


def room_kind(name: str) -> str:
    """A room's kind from its name: without a trailing ``_<k>`` (``"conferenceRoom"`` for ``conferenceRoom_1``).

    Examples
    --------
    >>> room_kind("conferenceRoom_1"), room_kind("WC_2"), room_kind("hall")
    ('conferenceRoom', 'WC', 'hall')
    """
    m = _INSTANCE.match(name)
    return m.group("category") if m else name


def _frozen(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


def read_points(path: str | Path) -> tuple[np.ndarray, int]:
    """The rows ``x y z r g b`` of one S3DIS text file, and how many rows were dropped.

    The file is read with pandas' C parser (fast path; pyarrow's CSV reader
    measured no faster on these files, see ``benchmarks/bench_navigation.py``).
    When that fails or finds rows that are short or not numbers, it is read again by splitting
    each line on whitespace and coercing each field to a number: the rows that
    do not have exactly six finite numbers are dropped and counted. Blank
    lines are ignored and not counted.

    Parameters
    ----------
    path : str or pathlib.Path

    Returns
    -------
    rows : numpy.ndarray
        Shape (n, 6), float64.
    skipped : int
        Rows dropped.

    Raises
    ------
    InputError
        Naming the path: the file cannot be read, its rows do not have six
        columns (most rows have another count), or no row parses.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     f = Path(tmp, "wall_1.txt")
    ...     _ = f.write_text("1.0 2.0 0.5 90 90 95\\n1.0 2.\\x100 1.5 90 90 95\\n1.0 2.0 2.5 90 90\\n")
    ...     rows, skipped = read_points(f)
    >>> rows.tolist(), skipped
    ([[1.0, 2.0, 0.5, 90.0, 90.0, 95.0]], 2)
    """
    p = Path(path)
    try:
        frame = pd.read_csv(p, sep=" ", header=None, dtype=np.float64, engine="c")
    except pd.errors.EmptyDataError:
        return np.empty((0, 6)), 0
    except FileNotFoundError:
        raise InputError(str(p), "file not found") from None
    except OSError as exc:
        raise InputError(str(p), f"cannot read ({exc.strerror or exc})") from None
    except (ValueError, pd.errors.ParserError):
        return _read_points_coercing(p)
    values = frame.to_numpy(dtype=np.float64)
    if values.shape[1] != 6 or not np.isfinite(values).all():
        return _read_points_coercing(p)
    return values, 0


def _read_points_coercing(p: Path) -> tuple[np.ndarray, int]:
    try:
        text = p.read_bytes().decode("latin-1")
    except OSError as exc:
        raise InputError(str(p), f"cannot read ({exc.strerror or exc})") from None
    lines = pd.Series(text.splitlines(), dtype=object)
    lines = lines[lines.str.strip().str.len() > 0]
    if len(lines) == 0:
        return np.empty((0, 6)), 0
    parts = lines.str.split(expand=True)
    counts = parts.notna().sum(axis=1).to_numpy()
    modal = int(np.bincount(counts).argmax())
    if modal != 6:
        raise InputError(str(p), "rows must have 6 columns (x y z r g b)", f"{modal} columns")
    good = counts == 6
    numbers = parts.loc[good, parts.columns[:6]].apply(pd.to_numeric, errors="coerce").to_numpy(dtype=np.float64)
    finite = np.isfinite(numbers).all(axis=1)
    values = numbers[finite]
    if len(values) == 0:
        raise InputError(str(p), "no row has six numbers x y z r g b")
    return values, int(len(lines) - len(values))


def _instance_key(stem: str) -> tuple:
    m = _INSTANCE.match(stem)
    return (m.group("category"), int(m.group("k")), stem) if m else (stem, -1, stem)


def read_room(room_dir: str | Path) -> Room:
    """Read one S3DIS room folder (the layout of Armeni et al. 2016, see the module docstring).

    With an ``Annotations`` folder holding ``.txt`` files, every point gets
    the category of its file (``<category>_<k>.txt``); otherwise the points of
    ``<room>.txt`` are all ``"unlabelled"``.

    Parameters
    ----------
    room_dir : str or pathlib.Path
        The room folder, for example ``Area_1/office_1``.

    Returns
    -------
    Room

    Raises
    ------
    InputError
        Naming the path: the folder does not exist, it has neither
        ``<room>.txt`` nor Annotations, or a file is malformed (see
        :func:`read_points`).

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     ann = Path(tmp, "office_1", "Annotations")
    ...     ann.mkdir(parents=True)
    ...     _ = Path(ann, "floor_1.txt").write_text("0.5 0.5 0.0 200 190 180\\n1.5 0.5 0.0 200 190 180\\n")
    ...     _ = Path(ann, "chair_1.txt").write_text("1.5 0.5 0.4 20 20 200\\n1.5 0.5 0.x 20 20 200\\n")
    ...     room = read_room(Path(tmp, "office_1"))
    >>> room.instances, [CATEGORIES[c] for c in room.categories], room.skipped_rows
    (('chair_1', 'floor_1'), ['chair', 'floor', 'floor'], 1)
    >>> room.points[0].tolist(), room.colors[0].tolist()
    ([1.5, 0.5, 0.4], [20, 20, 200])
    """
    folder = Path(room_dir)
    if not folder.is_dir():
        raise InputError("room_dir", "folder not found", str(folder))
    name = folder.name
    annotations = folder / "Annotations"
    files = sorted(annotations.glob("*.txt"), key=lambda f: _instance_key(f.stem)) if annotations.is_dir() else []
    if files:
        read = [read_points(f) for f in files]
        skipped = sum(bad for _, bad in read)
        codes = [_CODE.get(room_kind(f.stem), _CODE["clutter"]) for f in files]
        sizes = [len(block) for block, _ in read]
        rows = np.concatenate([block for block, _ in read])
        categories = np.repeat(np.array(codes, dtype=np.uint8), sizes)
        instance_ids = np.repeat(np.arange(len(files), dtype=np.int32), sizes)
        instances = tuple(f.stem for f in files)
    else:
        whole = folder / f"{name}.txt"
        if not whole.is_file():
            raise InputError(str(folder), f"room has neither {name}.txt nor Annotations/*.txt")
        rows, skipped = read_points(whole)
        categories = np.full(len(rows), UNLABELLED, dtype=np.uint8)
        instance_ids = np.full(len(rows), -1, dtype=np.int32)
        instances = ()
    return Room(
        name=name,
        points=_frozen(np.ascontiguousarray(rows[:, :3], dtype=np.float64)),
        colors=_frozen(np.clip(np.rint(rows[:, 3:6]), 0, 255).astype(np.uint8)),
        categories=_frozen(categories),
        instance_ids=_frozen(instance_ids),
        instances=instances,
        skipped_rows=int(skipped),
    )


def read_area(area_dir: str | Path) -> Area:
    """Read every room of an S3DIS area folder (Armeni et al. 2016).

    Every sub-folder whose name does not start with ``.`` is a room; files
    next to them (``Area_1_alignmentAngle.txt``, ``.DS_Store``) are ignored.

    Parameters
    ----------
    area_dir : str or pathlib.Path
        For example ``Stanford3dDataset_v1.2_Aligned_Version/Area_5``.

    Returns
    -------
    Area
        Rooms sorted by name.

    Raises
    ------
    InputError
        Naming ``area_dir``: the folder does not exist, or it is a room
        folder (it holds ``Annotations`` or ``<name>.txt``); naming the path:
        it holds no room, or a room cannot be read (:func:`read_room`).

    Examples
    --------
    >>> import tempfile
    >>> from fairaudit.experiments.navigation import write_office_floor
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     area = read_area(write_office_floor(tmp, spacing=0.25))
    >>> area.name, area.room_names
    ('Area_1', ('WC_1', 'conferenceRoom_1', 'hallway_1', 'lobby_1', 'office_1', 'office_2', 'storage_1'))
    >>> room_kind(area.rooms[4].name), sum(room.skipped_rows for room in area.rooms)
    ('office', 0)
    """
    folder = Path(area_dir)
    return Area(name=folder.name, rooms=tuple(iter_rooms(folder)))


def iter_rooms(area_dir: str | Path) -> Iterator[Room]:
    """The rooms of an S3DIS area folder, read one at a time, in name order (streaming :func:`read_area`).

    Only the room being read is in memory: the caller keeps what it needs of
    each :class:`Room`. The folder is listed at once (its errors are raised
    by this call); each room is read when the iterator reaches it.

    Parameters
    ----------
    area_dir : str or pathlib.Path

    Returns
    -------
    iterator of Room
        The rooms of :func:`read_area`, in the same order.

    Raises
    ------
    InputError
        As :func:`read_area` (the folder's errors at once, a room's when it is read).

    Examples
    --------
    >>> import tempfile
    >>> from fairaudit.experiments.navigation import write_office_floor
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     sizes = {room.name: len(room.points) for room in iter_rooms(write_office_floor(tmp, spacing=0.25))}
    >>> list(sizes)[:3], sizes["office_1"]
    (['WC_1', 'conferenceRoom_1', 'hallway_1'], 1196)
    """
    folder = Path(area_dir)
    if not folder.is_dir():
        raise InputError("area_dir", "folder not found", str(folder))
    if (folder / "Annotations").is_dir() or (folder / f"{folder.name}.txt").is_file():
        raise InputError("area_dir", "is a room folder (it holds Annotations or its .txt): give its area", str(folder))
    rooms = sorted((d for d in folder.iterdir() if d.is_dir() and not d.name.startswith(".")), key=lambda d: d.name)
    if not rooms:
        raise InputError(str(folder), "area has no room folders")
    return (read_room(d) for d in rooms)
