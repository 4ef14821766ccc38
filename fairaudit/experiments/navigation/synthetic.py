"""A small synthetic office floor written in the S3DIS format.

S3DIS (Armeni et al. 2016) cannot be downloaded here, so
:func:`write_office_floor` writes a deterministic stand-in with the same
layout and file format: the delivery scene of the paper (Methods: a robot
carries a document from a start room to one of two HR offices placed at the
same distance from the start).

The floor is 12 m x 8 m (x east, y north, z up, metres), ceiling at 2.7 m::

    y = 8  +-----------+-----------------+-----------+
           | office_1  | conferenceRoom_1| office_2  |
    y = 5  +---[door]--+-----[door]------+--[door]---+
           |                hallway_1                |
    y = 3  +--[door]---+----[opening]----+--[door]---+
           |   WC_1    |    lobby_1      | storage_1 |
    y = 0  +-----------+-----------------+-----------+
          x = 0       x = 4             x = 8       x = 12

With ``layout="two-corridors"`` the floor has the same size, but the lobby
leads into two separate corridors, ``office_1`` lies off one and ``office_2``
off the other (mirror images about x = 6 again), a conference room joins the
two corridors, and ``storage_1`` opens on ``hallway_1`` through a 0.3 m gap,
narrower than the robot::

    y = 8  +----------+-----------+-----------+----------+
           | storage_1|           |           |   WC_1   |
    y = 6.4+---[gap]--+ office_1  | office_2  +--[door]--+
           | hallway_1[door]      |      [door]hallway_2 |
    y = 5  |          +-----------+-----------+          |
           |          [door] conference  [door]          |
    y = 2.4|          +-----------------------+          |
           |          [open]   lobby_1   [open]          |
    y = 0  +----------+-----------------------+----------+
          x = 0      x = 2       x = 6       x = 10     x = 12

(the offices span y = 5 to 8, the corridors y = 0 to 6.4).

The layout and the furniture of ``office_1`` and ``office_2`` are mirror
images about x = 6 (the lobby's centre line), so the shortest routes from the
lobby's centre to the two offices' centres have the same length (up to the
jitter). Doors are 1 m wide (in the one-hallway plan the lobby opens on the hallway through a 2 m
opening), with the wall above them from 2.2 m (a lintel) and ``door``
instances on their frames (jambs and head). Walls are 0.1 m thick: each room
has its own wall faces 0.05 m inside its rectangle, and its floor covers the
whole rectangle, so the floors of two rooms meet under a doorway.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import TypeAlias, overload

import numpy as np
import pandas as pd

from fairaudit import InputError, choice, real, whole

from ._floorplan import DOOR_TOP, FRAME, area_folder, intervals_minus, staged_room, wall_face

__all__ = ["CEILING_HEIGHT", "COLORS", "FLOOR_SIZE", "LAYOUTS", "write_office_floor"]

#: Extent of the synthetic floor (x, y), metres.
FLOOR_SIZE = (12.0, 8.0)
#: The floor plans :func:`write_office_floor` can write (see the module docstring).
LAYOUTS = ("one-hallway", "two-corridors")
#: Height of its ceiling, metres.
CEILING_HEIGHT = 2.7
#: Base colour (r, g, b) of each category in the synthetic floor.
COLORS = {
    "ceiling": (235, 235, 228),
    "floor": (196, 182, 156),
    "wall": (206, 206, 212),
    "beam": (210, 210, 210),
    "column": (200, 200, 200),
    "window": (168, 200, 230),
    "door": (140, 92, 52),
    "table": (122, 82, 44),
    "chair": (62, 66, 160),
    "sofa": (84, 124, 84),
    "bookcase": (150, 112, 70),
    "board": (246, 246, 246),
    "clutter": (120, 120, 120),
}


_Rect: TypeAlias = tuple[float, float, float, float]  # x0, x1, y0, y1
_Box: TypeAlias = tuple[float, float, float, float, float, float]  # x0, x1, y0, y1, z0, z1


@dataclass
class _Spec:
    name: str
    rect: _Rect
    openings: list[tuple[str, float, float, bool]] = field(default_factory=list)  # (side, a0, a1, framed)
    windows: list[tuple[str, float, float, float, float]] = field(default_factory=list)  # (side, a0, a1, z0, z1)
    furniture: list[tuple[str, _Box]] = field(default_factory=list)  # (category, (x0, x1, y0, y1, z0, z1))
    boards: list[tuple[str, float, float, float, float]] = field(default_factory=list)  # (side, a0, a1, z0, z1)


@overload
def _mirror(box: _Rect) -> _Rect: ...
@overload
def _mirror(box: _Box) -> _Box: ...
def _mirror(box: tuple[float, ...]) -> tuple[float, ...]:
    x0, x1, *rest = box
    return (FLOOR_SIZE[0] - x1, FLOOR_SIZE[0] - x0, *rest)


def _mirrored(spec: _Spec, name: str) -> _Spec:
    """``spec`` mirrored about x = 6 m, named ``name``: its rectangle, openings, windows, furniture and boards."""

    def side(wall: str, a0: float, a1: float) -> tuple[str, float, float]:
        if wall in ("west", "east"):  # a wall along y: the opposite wall, the same span
            return ("east" if wall == "west" else "west", a0, a1)
        return (wall, FLOOR_SIZE[0] - a1, FLOOR_SIZE[0] - a0)

    return _Spec(
        name,
        _mirror(spec.rect),
        openings=[(*side(w, a0, a1), framed) for w, a0, a1, framed in spec.openings],
        windows=[(*side(w, a0, a1), z0, z1) for w, a0, a1, z0, z1 in spec.windows],
        furniture=[(c, _mirror(b)) for c, b in spec.furniture],
        boards=[(*side(w, a0, a1), z0, z1) for w, a0, a1, z0, z1 in spec.boards],
    )


def _layout() -> list[_Spec]:
    office_1 = _Spec(
        "office_1",
        (0.0, 4.0, 5.0, 8.0),
        openings=[("south", 2.5, 3.5, True)],
        windows=[("north", 1.0, 3.0, 0.9, 2.1)],
        furniture=[
            ("table", (0.3, 1.9, 7.15, 7.85, 0.0, 0.75)),
            ("chair", (0.85, 1.35, 6.55, 7.05, 0.0, 0.9)),
            ("bookcase", (0.1, 0.5, 5.3, 6.3, 0.0, 2.0)),
        ],
    )
    return [
        _Spec(
            "WC_1",
            (0.0, 4.0, 0.0, 3.0),
            openings=[("north", 1.0, 2.0, True)],
            furniture=[("clutter", (0.1, 1.0, 0.1, 0.6, 0.0, 0.9))],
        ),
        _Spec(
            "conferenceRoom_1",
            (4.0, 8.0, 5.0, 8.0),
            openings=[("south", 5.5, 6.5, True)],
            windows=[("north", 5.0, 7.0, 0.9, 2.1)],
            furniture=[
                ("table", (5.0, 7.0, 6.0, 7.0, 0.0, 0.75)),
                ("chair", (5.3, 5.8, 7.2, 7.7, 0.0, 0.9)),
                ("chair", (6.2, 6.7, 7.2, 7.7, 0.0, 0.9)),
            ],
            boards=[("east", 5.8, 7.2, 0.9, 2.0)],
        ),
        _Spec(
            "hallway_1",
            (0.0, 12.0, 3.0, 5.0),
            openings=[
                ("south", 1.0, 2.0, False),
                ("south", 5.0, 7.0, False),
                ("south", 10.0, 11.0, False),
                ("north", 2.5, 3.5, False),
                ("north", 5.5, 6.5, False),
                ("north", 8.5, 9.5, False),
            ],
            furniture=[
                ("clutter", (0.15, 0.55, 3.6, 4.4, 0.0, 1.2)),
                ("clutter", _mirror((0.15, 0.55, 3.6, 4.4, 0.0, 1.2))),
            ],
        ),
        _Spec(
            "lobby_1",
            (4.0, 8.0, 0.0, 3.0),
            openings=[("north", 5.0, 7.0, False)],
            furniture=[
                ("sofa", (5.0, 7.0, 0.15, 0.95, 0.0, 0.8)),
                ("chair", (4.2, 4.7, 1.2, 1.7, 0.0, 0.9)),
                ("chair", _mirror((4.2, 4.7, 1.2, 1.7, 0.0, 0.9))),
            ],
        ),
        office_1,
        _mirrored(office_1, "office_2"),
        _Spec(
            "storage_1",
            (8.0, 12.0, 0.0, 3.0),
            openings=[("north", 10.0, 11.0, True)],
            furniture=[("bookcase", (8.2, 11.8, 0.1, 0.5, 0.0, 2.0)), ("clutter", (11.2, 11.8, 1.5, 2.2, 0.0, 0.6))],
        ),
    ]


def _two_corridor_layout() -> list[_Spec]:
    office_1 = _Spec(
        "office_1",
        (2.0, 6.0, 5.0, 8.0),
        openings=[("west", 5.3, 6.3, True)],
        windows=[("north", 3.0, 5.0, 0.9, 2.1)],
        furniture=[
            ("table", (2.4, 4.0, 7.15, 7.85, 0.0, 0.75)),
            ("chair", (2.95, 3.45, 6.75, 7.1, 0.0, 0.9)),
            ("bookcase", (5.5, 5.9, 5.3, 6.3, 0.0, 2.0)),
        ],
    )
    corridor = [("east", 0.7, 1.7, False), ("east", 3.2, 4.2, False), ("east", 5.3, 6.3, False)]
    return [
        _Spec("WC_1", (10.0, 12.0, 6.4, 8.0), openings=[("south", 10.5, 11.5, True)]),
        _Spec(
            "conferenceRoom_1",
            (2.0, 10.0, 2.4, 5.0),
            openings=[("west", 3.2, 4.2, True), ("east", 3.2, 4.2, True)],
            furniture=[("table", (5.0, 7.0, 3.4, 3.9, 0.0, 0.75))],
            boards=[("north", 5.2, 6.8, 0.9, 2.0)],
        ),
        _Spec("hallway_1", (0.0, 2.0, 0.0, 6.4), openings=[*corridor, ("north", 0.85, 1.15, False)]),
        _Spec(
            "hallway_2",
            (10.0, 12.0, 0.0, 6.4),
            openings=[("west", a0, a1, f) for _, a0, a1, f in corridor] + [("north", 10.5, 11.5, False)],
        ),
        _Spec(
            "lobby_1",
            (2.0, 10.0, 0.0, 2.4),
            openings=[("west", 0.7, 1.7, False), ("east", 0.7, 1.7, False)],
            furniture=[
                ("sofa", (5.0, 7.0, 0.15, 0.75, 0.0, 0.8)),
                ("chair", (3.0, 3.5, 1.6, 2.1, 0.0, 0.9)),
                ("chair", _mirror((3.0, 3.5, 1.6, 2.1, 0.0, 0.9))),
            ],
        ),
        office_1,
        _mirrored(office_1, "office_2"),
        _Spec(
            "storage_1",
            (0.0, 2.0, 6.4, 8.0),
            openings=[("south", 0.85, 1.15, False)],
            furniture=[("bookcase", (0.1, 1.9, 7.6, 7.9, 0.0, 2.0))],
        ),
    ]


# -- surface sampling (every function returns an (n, 3) array of points) --------------------------------


def _ticks(a: float, b: float, s: float) -> np.ndarray:
    n = max(1, int(round((b - a) / s)))
    return a + (np.arange(n) + 0.5) * ((b - a) / n)


def _horizontal(x0: float, x1: float, y0: float, y1: float, z: float, s: float) -> np.ndarray:
    xs, ys = np.meshgrid(_ticks(x0, x1, s), _ticks(y0, y1, s))
    return np.column_stack([xs.ravel(), ys.ravel(), np.full(xs.size, z)])


def _vertical(axis: str, at: float, a0: float, a1: float, z0: float, z1: float, s: float) -> np.ndarray:
    """A vertical rectangle at x = at (axis "x": spans y) or y = at (axis "y": spans x)."""
    if a1 - a0 <= 1e-9 or z1 - z0 <= 1e-9:
        return np.empty((0, 3))
    us, zs = np.meshgrid(_ticks(a0, a1, s), _ticks(z0, z1, s))
    const = np.full(us.size, at)
    if axis == "x":
        return np.column_stack([const, us.ravel(), zs.ravel()])
    return np.column_stack([us.ravel(), const, zs.ravel()])


def _box(x0: float, x1: float, y0: float, y1: float, z0: float, z1: float, s: float) -> np.ndarray:
    sides = [_vertical("y", y, x0, x1, z0, z1, s) for y in (y0, y1)]  # south and north, then west and east
    sides += [_vertical("x", x, y0, y1, z0, z1, s) for x in (x0, x1)]
    return np.concatenate([_horizontal(x0, x1, y0, y1, z1, s), *sides])


def _room_instances(spec: _Spec, s: float) -> list[tuple[str, np.ndarray]]:
    """(category, points) of each instance of one room, in a fixed order."""
    x0, x1, y0, y1 = spec.rect
    top = CEILING_HEIGHT
    inst: list[tuple[str, np.ndarray]] = [
        ("ceiling", _horizontal(x0, x1, y0, y1, top, s)),
        ("floor", _horizontal(x0, x1, y0, y1, 0.0, s)),
    ]
    for side in ("south", "north", "west", "east"):
        axis, at, a, b = wall_face(spec.rect, side)
        openings = [o for o in spec.openings if o[0] == side]
        windows = [w for w in spec.windows if w[0] == side]
        pieces, doors = [], []
        # full-height wall outside the openings (and outside the frames of framed doors)
        holes = [(o[1] - (FRAME if o[3] else 0.0), o[2] + (FRAME if o[3] else 0.0)) for o in openings]
        holes += [(w[1], w[2]) for w in windows]
        pieces += [_vertical(axis, at, u, v, 0.0, top, s) for u, v in intervals_minus(a, b, holes)]
        for _, a0, a1, framed in openings:
            f = FRAME if framed else 0.0
            pieces.append(_vertical(axis, at, a0 - f, a1 + f, DOOR_TOP + 0.1, top, s))  # lintel
            if framed:
                jambs = [_vertical(axis, at, u, v, 0.0, DOOR_TOP, s) for u, v in ((a0 - f, a0), (a1, a1 + f))]
                head = _vertical(axis, at, a0 - f, a1 + f, DOOR_TOP, DOOR_TOP + 0.1, s)
                doors.append(np.concatenate([*jambs, head]))
        for _, a0, a1, z0, z1 in windows:
            pieces += [_vertical(axis, at, a0, a1, 0.0, z0, s), _vertical(axis, at, a0, a1, z1, top, s)]
        inst.append(("wall", np.concatenate(pieces)))
        inst += [("door", d) for d in doors]
        inst += [("window", _vertical(axis, at, w[1], w[2], w[3], w[4], s)) for w in windows]
    for category, box in spec.furniture:
        inst.append((category, _box(*box, s)))
    for side, a0, a1, z0, z1 in spec.boards:
        axis, at, _, _ = wall_face(spec.rect, side)
        inward = -0.02 if side in ("east", "north") else 0.02
        inst.append(("board", _vertical(axis, at + inward, a0, a1, z0, z1, s)))
    return inst


def _table(points: np.ndarray, category: str, rng: np.random.Generator, s: float) -> pd.DataFrame:
    jitter = rng.uniform(-0.1 * s, 0.1 * s, size=points.shape)
    xyz = points + jitter
    base = np.asarray(COLORS[category], dtype=float)
    rgb = np.clip(np.rint(base + rng.uniform(-6.0, 6.0, size=(len(points), 3))), 0, 255).astype(np.int64)
    return pd.DataFrame(
        {"x": xyz[:, 0], "y": xyz[:, 1], "z": xyz[:, 2], "r": rgb[:, 0], "g": rgb[:, 1], "b": rgb[:, 2]}
    )


def _write_table(frame: pd.DataFrame, path: Path) -> None:
    frame.to_csv(path, sep=" ", header=False, index=False, float_format="%.3f", lineterminator="\n")


def write_office_floor(
    folder: str | Path, *, area: str = "Area_1", spacing: float = 0.05, seed: int = 0, layout: str = "one-hallway"
) -> Path:
    """Write the synthetic office floor as an S3DIS area folder.

    Seven rooms (see the module docstring for the plan): ``lobby_1`` (the
    start), ``hallway_1``, the HR offices ``office_1`` and ``office_2``
    (mirror images about x = 6 m, so equally far from the lobby),
    ``conferenceRoom_1``, ``WC_1`` and ``storage_1``. With
    ``layout="two-corridors"``, eight: the lobby opens on two corridors
    ``hallway_1`` and ``hallway_2``, ``office_1`` lies off the first and
    ``office_2`` off the second, the conference room joins the corridors,
    and ``storage_1`` is reached only through a 0.3 m gap. Each room gets
    ``<room>.txt`` and ``Annotations/<category>_<k>.txt`` (ceiling, floor,
    walls, doors, windows, tables, chairs, a sofa, bookcases, a board,
    clutter). Points lie on the surfaces on a square pattern of side
    ``spacing``, moved by a seeded uniform jitter of at most 0.1 ``spacing``
    per coordinate, with coordinates written to the millimetre; colours are
    per category with a seeded ±6 noise.

    Each room is written to a hidden temporary folder and renamed into place
    once complete, so a crash never leaves a half-written room (an existing
    room of the same name is replaced; other folders are left alone).

    Parameters
    ----------
    folder : str or pathlib.Path
        An existing folder; the area is written to ``folder / area``.
    area : str
        The area folder's name (letters, digits, ``_``, ``.``, ``-``).
    spacing : float
        Distance between neighbouring points on a surface, metres, in
        [0.02, 0.5]. About 200,000 points (12 MB, twice: room files and
        Annotations) at 0.05; a quarter of that at 0.1.
    seed : int
        Seed of the jitter and colour noise: the same arguments write the same bytes.
    layout : {"one-hallway", "two-corridors"}
        The floor plan (:data:`LAYOUTS`).

    Returns
    -------
    pathlib.Path
        The area folder (``folder / area``).

    Raises
    ------
    InputError
        Naming ``folder`` (does not exist or cannot be written), ``area``,
        ``spacing``, ``seed`` or ``layout``.

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = write_office_floor(tmp, spacing=0.25)
    ...     rooms = sorted(p.name for p in path.iterdir())
    ...     office = sorted(p.name for p in (path / "office_1" / "Annotations").iterdir())
    >>> path.name, rooms
    ('Area_1', ['WC_1', 'conferenceRoom_1', 'hallway_1', 'lobby_1', 'office_1', 'office_2', 'storage_1'])
    >>> office[:6]
    ['bookcase_1.txt', 'ceiling_1.txt', 'chair_1.txt', 'door_1.txt', 'floor_1.txt', 'table_1.txt']
    """
    out = area_folder(folder, area)
    s = real(spacing, "spacing", low=0.02, high=0.5, what="a number of metres in [0.02, 0.5]")
    whole(seed, "seed")
    choice(layout, "layout", LAYOUTS)
    try:
        out.mkdir(exist_ok=True)
    except OSError as exc:
        raise InputError("folder", f"cannot write there ({exc.strerror})", str(out)) from None
    for index, spec in enumerate(_layout() if layout == LAYOUTS[0] else _two_corridor_layout()):
        rng = np.random.default_rng([int(seed), index])
        tables: list[pd.DataFrame] = []
        counts: dict[str, int] = {}
        with staged_room(out, spec.name) as tmp:
            for category, pts in _room_instances(spec, s):
                if len(pts):
                    counts[category] = counts.get(category, 0) + 1
                    tables.append(_table(pts, category, rng, s))
                    _write_table(tables[-1], tmp / "Annotations" / f"{category}_{counts[category]}.txt")
            _write_table(pd.concat(tables, ignore_index=True), tmp / f"{spec.name}.txt")
            _replace_room(tmp, out / spec.name)
    return out


def _replace_room(tmp: Path, target: Path) -> None:
    """Rename the staged room ``tmp`` to ``target``, moving an existing room aside first and removing it after."""
    old = None
    if target.exists():
        old = Path(tempfile.mkdtemp(prefix=f".{target.name}.", suffix=".old", dir=target.parent))
        os.rmdir(old)
        os.replace(target, old)
    os.replace(tmp, target)
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)
