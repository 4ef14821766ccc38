"""A building-size synthetic area in the S3DIS format: a long hallway with rooms on both sides (a benchmark fixture).

S3DIS's ``Area_5`` holds tens of millions of points in about 70 rooms;
:func:`write_building` writes a deterministic stand-in of that size in the
same on-disk layout (Armeni et al. 2016), to run the map pipeline at full
scale (issue 24). It is a fixture of ``benchmarks/bench_navigation.py`` and
``tests/experiments/navigation/test_building.py``, not part of the package:
the test loads it from this folder, and the benchmark imports it from beside
itself. The plan (x east, y north, metres; ``D`` = 6 m room depth, ``W`` =
2.4 m hallway width, ``L`` = hallway length)::

    y = 2D+W +--------+----------+------------------+----------+---- ... --+
             |        | office_1 | conferenceRoom_1 | office_3 |           |
    y = D+W  |        +--[door]--+-----[door]-------+--[door]--+---- ... --+
             |lobby_1             hallway_1                                |
    y = D    |        +--[door]--+----[door]---+-----[door]-----+--- ... --+
             |        | office_2 |    WC_1     |    storage_1   |          |
    y = 0    +--------+----------+-------------+----------------+--- ... --+
           x = 0    x = 8                                             x = 8 + L

``lobby_1`` (8 m wide, the full depth of the building) opens on the west end
of ``hallway_1`` over the hallway's whole width. The other rooms line the
hallway on both sides; their kinds (``office``, ``conferenceRoom``, ``WC``,
``storage``, ``pantry``, ``copyRoom``) and widths are drawn from ``seed``,
and each opens on the hallway through a 1 m door (``door`` points on its
jambs and head, no wall points in the opening, the floors of the room and
the hallway meeting under it). The two rooms next to the lobby are the HR
offices of the delivery scene: ``office_1`` (north) and ``office_2``
(south) are mirror images about the hallway's centre line y = D + W/2, as
are the lobby's furniture and the hallway's clutter, so the shortest routes
from the lobby's centre to the two offices' centres have the same length (up
to the jitter of the points).

Every room has a floor, a ceiling (2.7 m; 3.0 m in the hallway and the
lobby), walls 0.1 m thick (each room's wall face 0.05 m inside its
rectangle), furniture against its walls (tables, chairs, bookcases, a sofa,
a board) and random clutter, all drawn from ``seed``. Furniture stands flush
against the walls (or around the conference table), leaving the middle of
each room and the way to its door free, so every room is reachable from the
lobby on the traversability map when the points are dense enough (spacing
below about 0.8 times the map's resolution).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import TypeAlias

import numpy as np

from fairaudit import InputError
from fairaudit.experiments.navigation._floorplan import (
    DOOR_TOP,
    FRAME,
    HALF_WALL,
    area_folder,
    intervals_minus,
    staged_room,
    wall_face,
)
from fairaudit.experiments.navigation.synthetic import COLORS

__all__ = ["DEPTH", "HALLWAY_WIDTH", "LOBBY_WIDTH", "building_rooms", "write_building"]

#: Depth (y) of a room on either side of the hallway, metres.
DEPTH = 6.0
#: Width (y) of the hallway, metres.
HALLWAY_WIDTH = 2.4
#: Width (x) of the lobby at the west end, metres.
LOBBY_WIDTH = 8.0

_CEILING = 2.7
_HIGH_CEILING = 3.0
_DOOR = 1.0  # width of a door opening
_KINDS: tuple[tuple[str, float, float], ...] = (  # (kind, probability, smallest width in metres)
    ("office", 0.58, 4.0),
    ("conferenceRoom", 0.1, 6.0),
    ("WC", 0.08, 3.0),
    ("storage", 0.12, 3.0),
    ("pantry", 0.06, 3.5),
    ("copyRoom", 0.06, 3.0),
)

_Rect: TypeAlias = tuple[float, float, float, float]  # x0, x1, y0, y1
_Box: TypeAlias = tuple[float, float, float, float, float, float]  # x0, x1, y0, y1, z0, z1
# A surface: ("h", x0, x1, y0, y1, z) horizontal, or ("x" | "y", at, a0, a1, z0, z1) vertical at x = at
# (spanning y) or y = at (spanning x).
_Surface: TypeAlias = tuple


@dataclass
class _Spec:
    name: str
    rect: _Rect
    ceiling: float = _CEILING
    openings: list[tuple[str, float, float, bool]] = field(default_factory=list)  # (side, a0, a1, framed)
    furniture: list[tuple[str, _Box]] = field(default_factory=list)
    boards: list[tuple[str, float, float]] = field(default_factory=list)  # (side, a0, a1)


def _side_kinds(rng: np.random.Generator, n: int) -> list[tuple[str, float]]:
    """(kind, width) of ``n`` rooms along one side of the hallway."""
    probs = np.array([k[1] for k in _KINDS])
    picks = rng.choice(len(_KINDS), size=n, p=probs / probs.sum())
    jitter = rng.integers(0, 6, size=n) * 0.2  # 0 to 1 m wider
    return [(_KINDS[i][0], round(_KINDS[i][2] + float(j), 1)) for i, j in zip(picks, jitter)]


def building_rooms(rooms: int = 56, seed: int = 0) -> tuple[str, ...]:
    """The room names of :func:`write_building` with these arguments, sorted, without writing anything.

    Parameters
    ----------
    rooms : int
        Number of rooms, lobby and hallway included (>= 4).
    seed : int
        Seed of the layout (non-negative).

    Returns
    -------
    tuple of str
        Sorted like :attr:`~fairaudit.experiments.navigation.s3dis.Area.room_names`.

    Raises
    ------
    InputError
        Naming ``rooms`` or ``seed``.

    Examples
    --------
    >>> names = building_rooms()
    >>> len(names), names[:3], "hallway_1" in names and "lobby_1" in names
    (56, ('WC_1', 'WC_2', 'conferenceRoom_1'), True)
    >>> building_rooms(4)
    ('hallway_1', 'lobby_1', 'office_1', 'office_2')
    """
    _check_int("rooms", rooms, 4)
    _check_int("seed", seed, 0)
    return tuple(sorted(s.name for s in _layout(int(rooms), int(seed))))


def _check_int(name: str, value: object, low: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
        raise InputError(name, f"must be an integer >= {low}", value)
    return int(value)


def _layout(rooms: int, seed: int) -> list[_Spec]:
    """The rooms of the building: lobby, hallway and ``rooms - 2`` side rooms (HR offices first)."""
    rng = np.random.default_rng([seed, 0])
    n_north = (rooms - 2 + 1) // 2
    n_south = rooms - 2 - n_north
    north = [("office", 4.0)] + _side_kinds(rng, n_north - 1)
    south = [("office", 4.0)] + _side_kinds(rng, n_south - 1)
    length = max(sum(w for _, w in north), sum(w for _, w in south))
    for row in (north, south):  # the shorter side's last room reaches the hallway's east end
        row[-1] = (row[-1][0], round(row[-1][1] + length - sum(w for _, w in row), 1))
    x_start, y_mid = LOBBY_WIDTH, DEPTH + HALLWAY_WIDTH / 2
    counters: dict[str, int] = {}
    hall_openings: list[tuple[str, float, float, bool]] = []
    specs: list[_Spec] = []
    for i in range(max(n_north, n_south)):  # office_1 north, office_2 south, then alternating numbering
        for side, seq in (("north", north), ("south", south)):
            if i >= len(seq):
                continue
            kind, width = seq[i]
            x0 = x_start + sum(w for _, w in seq[:i])
            counters[kind] = counters.get(kind, 0) + 1
            spec = _side_room(f"{kind}_{counters[kind]}", kind, x0, width, side, rng)
            if i == 0 and side == "south":
                spec = _mirrored(specs[-1], "office_2", y_mid)
            specs.append(spec)
            door = spec.openings[0]
            hall_openings.append((side, door[1], door[2], False))
    hall = (x_start, x_start + length, DEPTH, DEPTH + HALLWAY_WIDTH)
    hallway = _Spec("hallway_1", hall, _HIGH_CEILING, [("west", DEPTH, DEPTH + HALLWAY_WIDTH, False)])
    hallway.openings += hall_openings
    hallway.furniture = _hallway_clutter(hall, hall_openings, rng)
    return [_lobby(y_mid), hallway, *specs]


def _lobby(y_mid: float) -> _Spec:
    top = 2 * DEPTH + HALLWAY_WIDTH
    spec = _Spec("lobby_1", (0.0, LOBBY_WIDTH, 0.0, top), _HIGH_CEILING)
    spec.openings = [("east", DEPTH, DEPTH + HALLWAY_WIDTH, False)]
    spec.furniture = [
        ("sofa", (0.1, 0.9, y_mid - 1.2, y_mid + 1.2, 0.0, 0.8)),
        ("table", (1.4, 2.2, y_mid - 0.6, y_mid + 0.6, 0.0, 0.45)),
        ("chair", (2.0, 2.6, 0.1, 0.7, 0.0, 0.9)),
        ("chair", (2.0, 2.6, top - 0.7, top - 0.1, 0.0, 0.9)),
        ("clutter", (LOBBY_WIDTH - 0.7, LOBBY_WIDTH - 0.1, 0.1, 0.7, 0.0, 1.1)),
        ("clutter", (LOBBY_WIDTH - 0.7, LOBBY_WIDTH - 0.1, top - 0.7, top - 0.1, 0.0, 1.1)),
    ]
    return spec


def _mirrored(spec: _Spec, name: str, y_mid: float) -> _Spec:
    """``spec`` mirrored about y = y_mid (north and south swap)."""
    flip = {"north": "south", "south": "north", "east": "east", "west": "west"}
    x0, x1, y0, y1 = spec.rect
    return _Spec(
        name,
        (x0, x1, 2 * y_mid - y1, 2 * y_mid - y0),
        spec.ceiling,
        [(flip[s], a0, a1, f) for s, a0, a1, f in spec.openings],
        [(c, (b[0], b[1], 2 * y_mid - b[3], 2 * y_mid - b[2], b[4], b[5])) for c, b in spec.furniture],
        [(flip[s], a0, a1) for s, a0, a1 in spec.boards],
    )


def _side_room(name: str, kind: str, x0: float, width: float, side: str, rng: np.random.Generator) -> _Spec:
    """A room of the given kind on one side of the hallway, its door on the hallway wall."""
    y0 = DEPTH + HALLWAY_WIDTH if side == "north" else 0.0
    rect = (x0, x0 + width, y0, y0 + DEPTH)
    door_at = x0 + round(float(rng.uniform(0.6, width - 0.6 - _DOOR)), 1)
    spec = _Spec(name, rect, openings=[("south" if side == "north" else "north", door_at, door_at + _DOOR, True)])
    # "back" is the wall opposite the door; furniture along the back and the side walls, away from the door
    inner = HALF_WALL + 0.05
    back = y0 + DEPTH - inner if side == "north" else y0 + inner
    sgn = -1.0 if side == "north" else 1.0  # from the back wall towards the hallway
    near = y0 + DEPTH / 2
    xa, xb = x0 + inner, x0 + width - inner

    def against_back(u0: float, u1: float, depth: float, height: float, offset: float = 0.0) -> _Box:
        lo, hi = sorted((back + sgn * offset, back + sgn * (offset + depth)))
        return (u0, u1, lo, hi, 0.0, height)

    def against_side(west: bool, v_from_back: float, length: float, depth: float, height: float) -> _Box:
        v0, v1 = sorted((back + sgn * v_from_back, back + sgn * (v_from_back + length)))
        return (xa, xa + depth, v0, v1, 0.0, height) if west else (xb - depth, xb, v0, v1, 0.0, height)

    mid = (xa + xb) / 2
    f = spec.furniture
    if kind == "office":
        f.append(("table", against_back(xa + 0.3, xa + 1.9, 0.7, 0.75)))
        f.append(("chair", against_back(xa + 0.85, xa + 1.35, 0.5, 0.9, 0.8)))
        f.append(("bookcase", against_side(False, 0.0, 1.2, 0.4, 2.0)))
    elif kind == "conferenceRoom":
        f.append(("table", against_back(mid - 1.0, mid + 1.0, 1.0, 0.75)))
        f += [("chair", against_back(u, u + 0.5, 0.5, 0.9, 1.1)) for u in (mid - 0.8, mid + 0.3)]
        spec.boards.append(("east", near - 0.7, near + 0.7))
    elif kind in ("storage", "copyRoom"):
        f.append(("bookcase", against_back(xa, xb, 0.4, 2.0)))
        f.append(("bookcase" if kind == "storage" else "table", against_side(True, 0.5, 1.5, 0.5, 1.0)))
    elif kind == "pantry":
        f.append(("table", against_back(xa, xb, 0.6, 0.9)))
    # random clutter against the side walls, in the back half of the room
    for k in range(int(rng.integers(1, 4))):
        length, depth = float(rng.uniform(0.3, 0.6)), float(rng.uniform(0.3, 0.5))
        height = float(rng.uniform(0.3, 1.2))
        f.append(("clutter", against_side(k % 2 == 1, 2.0 + 1.0 * (k // 2), length, depth, height)))
    return spec


def _hallway_clutter(
    hall: _Rect, openings: list[tuple[str, float, float, bool]], rng: np.random.Generator
) -> list[tuple[str, _Box]]:
    """Clutter in pairs on the two walls at the same x (mirror images), never within 0.8 m of a door."""
    x0, x1, y0, y1 = hall
    inner = HALF_WALL + 0.05
    out: list[tuple[str, _Box]] = []
    x = x0 + 6.0
    while x + 0.6 < x1 - 1.0:
        if all(x + 0.6 < a0 - 0.8 or x > a1 + 0.8 for _, a0, a1, _ in openings):
            depth, height = float(rng.uniform(0.3, 0.45)), float(rng.uniform(0.5, 1.4))
            out.append(("clutter", (x, x + 0.6, y0 + inner, y0 + inner + depth, 0.0, height)))
            out.append(("clutter", (x, x + 0.6, y1 - inner - depth, y1 - inner, 0.0, height)))
            x += 6.0
        else:
            x += 0.5
    return out


# -- surfaces, point counts and sampling ------------------------------------------------------------------


def _box_surfaces(box: _Box) -> list[_Surface]:
    x0, x1, y0, y1, z0, z1 = box
    return [
        ("h", x0, x1, y0, y1, z1),
        ("y", y0, x0, x1, z0, z1),
        ("y", y1, x0, x1, z0, z1),
        ("x", x0, y0, y1, z0, z1),
        ("x", x1, y0, y1, z0, z1),
    ]


def _instances(spec: _Spec) -> list[tuple[str, list[_Surface]]]:
    """(category, surfaces) of each instance of a room, in a fixed order."""
    x0, x1, y0, y1 = spec.rect
    top = spec.ceiling
    out: list[tuple[str, list[_Surface]]] = [
        ("ceiling", [("h", x0, x1, y0, y1, top)]),
        ("floor", [("h", x0, x1, y0, y1, 0.0)]),
    ]
    for side in ("south", "north", "west", "east"):
        axis, at, a, b = wall_face(spec.rect, side)
        openings = [o for o in spec.openings if o[0] == side]
        holes = [(o[1] - (FRAME if o[3] else 0.0), o[2] + (FRAME if o[3] else 0.0)) for o in openings]
        pieces: list[_Surface] = [(axis, at, u, v, 0.0, top) for u, v in intervals_minus(a, b, holes)]
        doors: list[list[_Surface]] = []
        for _, a0, a1, framed in openings:
            f = FRAME if framed else 0.0
            if top > DOOR_TOP + 0.1 and not (a0 <= a + 1e-9 and a1 >= b - 1e-9):
                pieces.append((axis, at, a0 - f, a1 + f, DOOR_TOP + 0.1, top))  # lintel
            if framed:
                doors.append(
                    [
                        (axis, at, a0 - f, a0, 0.0, DOOR_TOP),
                        (axis, at, a1, a1 + f, 0.0, DOOR_TOP),
                        (axis, at, a0 - f, a1 + f, DOOR_TOP, DOOR_TOP + 0.1),
                    ]
                )
        if pieces:
            out.append(("wall", pieces))
        out += [("door", d) for d in doors]
    out += [(category, _box_surfaces(box)) for category, box in spec.furniture]
    for side, a0, a1 in spec.boards:
        axis, at, _, _ = wall_face(spec.rect, side)
        inward = -0.02 if side in ("east", "north") else 0.02
        out.append(("board", [(axis, at + inward, a0, a1, 0.9, 2.0)]))
    return out


def _counts(surface: _Surface, s: float) -> tuple[int, int]:
    """Points along the two directions of a surface at spacing ``s`` (0 for a degenerate surface)."""
    if surface[0] == "h":
        lu, lv = surface[2] - surface[1], surface[4] - surface[3]
    else:
        lu, lv = surface[3] - surface[2], surface[5] - surface[4]
    if lu <= 1e-9 or lv <= 1e-9:
        return 0, 0
    return max(1, int(round(lu / s))), max(1, int(round(lv / s)))


def _total(layout: list[list[tuple[str, list[_Surface]]]], s: float) -> int:
    return sum(nu * nv for room in layout for _, surfaces in room for nu, nv in map(lambda f: _counts(f, s), surfaces))


def _surface_points(surface: _Surface, s: float) -> np.ndarray:
    """Shape (n, 3): the points of a surface on its square pattern (cell centres), before jitter."""
    nu, nv = _counts(surface, s)
    if nu == 0:
        return np.empty((0, 3))
    if surface[0] == "h":
        _, u0, u1, v0, v1, z = surface
    else:
        _, at, u0, u1, v0, v1 = surface
    us = u0 + (np.arange(nu) + 0.5) * ((u1 - u0) / nu)
    vs = v0 + (np.arange(nv) + 0.5) * ((v1 - v0) / nv)
    uu, vv = np.meshgrid(us, vs)
    uu, vv = uu.ravel(), vv.ravel()
    if surface[0] == "h":
        return np.column_stack([uu, vv, np.full(uu.size, z)])
    const = np.full(uu.size, at)
    return np.column_stack([const, uu, vv] if surface[0] == "x" else [uu, const, vv])


def _spacing_for(layout: list[list[tuple[str, list[_Surface]]]], points: int) -> float:
    """The spacing whose point count is closest to ``points`` (a few secant steps on the area)."""
    area = sum(
        (f[2] - f[1]) * (f[4] - f[3]) if f[0] == "h" else (f[3] - f[2]) * (f[5] - f[4])
        for room in layout
        for _, surfaces in room
        for f in surfaces
    )
    s = math.sqrt(area / points)
    best = (abs(_total(layout, s) - points), s)
    for _ in range(6):
        s *= math.sqrt(_total(layout, s) / points)
        best = min(best, (abs(_total(layout, s) - points), s))
    return best[1]


def _encode(xyz: np.ndarray, rgb: np.ndarray) -> bytes:
    """The rows ``x y z r g b`` as S3DIS text: coordinates with 3 decimals, integer colours, one row a line.

    Vectorised: the characters of every row go into a fixed-width byte matrix whose unused places (leading
    zeros, absent signs) are 0, then the zeros are dropped.
    """
    n = len(xyz)
    if n == 0:
        return b""
    mm = np.rint(xyz * 1000.0).astype(np.int64)
    whole = np.abs(mm) // 1000
    digits = max(1, len(str(int(whole.max()))))
    width = 3 * (digits + 6) + 3 * 4
    out = np.zeros((n, width), dtype=np.uint8)
    pos = 0
    for j in range(3):
        a = np.abs(mm[:, j])
        ip = a // 1000
        out[:, pos] = np.where(mm[:, j] < 0, ord("-"), 0)
        for k in range(digits):
            d = (ip // 10 ** (digits - 1 - k)) % 10 + ord("0")
            shown = ip >= 10 ** (digits - 1 - k) if k < digits - 1 else np.ones(n, dtype=bool)
            out[:, pos + 1 + k] = np.where(shown, d, 0)
        pos += 1 + digits
        out[:, pos] = ord(".")
        fp = a % 1000
        out[:, pos + 1] = fp // 100 + ord("0")
        out[:, pos + 2] = (fp // 10) % 10 + ord("0")
        out[:, pos + 3] = fp % 10 + ord("0")
        out[:, pos + 4] = ord(" ")
        pos += 5
    for j in range(3):
        c = rgb[:, j].astype(np.int64)
        out[:, pos] = np.where(c >= 100, c // 100 + ord("0"), 0)
        out[:, pos + 1] = np.where(c >= 10, (c // 10) % 10 + ord("0"), 0)
        out[:, pos + 2] = c % 10 + ord("0")
        out[:, pos + 3] = ord(" ") if j < 2 else ord("\n")
        pos += 4
    flat = out.ravel()
    return flat[flat != 0].tobytes()


def _sample(
    surfaces: list[_Surface], category: str, s: float, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """The points (n, 3) of one instance, jittered by at most 0.1 ``s`` per coordinate, and their colours (n, 3)."""
    pts = [_surface_points(f, s) for f in surfaces]
    xyz = np.concatenate(pts) if pts else np.empty((0, 3))
    xyz += rng.uniform(-0.1 * s, 0.1 * s, size=xyz.shape)
    base = np.asarray(COLORS[category], dtype=float)
    rgb = np.clip(np.rint(base + rng.uniform(-6.0, 6.0, size=xyz.shape)), 0, 255).astype(np.uint8)
    return xyz, rgb


def _adjust(xyz: np.ndarray, rgb: np.ndarray, rect: _Rect, z: float, extra: int, rng: np.random.Generator) -> tuple:
    """Add ``extra`` random points to a ceiling (or drop ``-extra`` of its points, chosen at random)."""
    if extra < 0:
        keep = np.sort(rng.choice(len(xyz), size=len(xyz) + extra, replace=False))
        return xyz[keep], rgb[keep]
    x0, x1, y0, y1 = rect
    more = np.column_stack([rng.uniform(x0, x1, extra), rng.uniform(y0, y1, extra), np.full(extra, z)])
    return np.concatenate([xyz, more]), np.concatenate([rgb, np.broadcast_to(rgb[:1], (extra, 3))])


def write_building(
    folder: str | Path,
    *,
    rooms: int = 56,
    points: int = 40_000_000,
    seed: int = 0,
    area: str = "Area_5",
    spacing: float | None = None,
) -> Path:
    """Write a building-size S3DIS area: a long hallway with ``rooms - 2`` rooms along it and a lobby.

    The plan is in the module docstring. Each room folder holds
    ``Annotations/<category>_<k>.txt`` (ceiling, floor, one wall per side,
    doors, tables, chairs, bookcases, a sofa, boards, clutter) and
    ``<room>.txt``, the concatenation of its Annotations files in the order
    of :func:`~fairaudit.experiments.navigation.s3dis.read_room` (category,
    then number). Rows are ``x y z r g b``: metres with exactly 3 decimals,
    integer colours, single spaces, as in S3DIS. Points lie on the surfaces
    on square patterns of side ``spacing`` (derived from ``points`` unless
    given), moved by a seeded jitter of at most 0.1 ``spacing`` per
    coordinate; colours are per category with a seeded ±6 noise. With
    ``spacing`` None the count is exactly ``points``: the hallway's ceiling
    takes the few points the patterns are short of (or gives up the few too
    many). The HR offices are ``office_1`` (north of the hallway) and
    ``office_2`` (south), the rooms next to the lobby (``lobby_1``), mirror
    images of each other.

    Each room is written into a hidden temporary folder (``.<room>.*.tmp``,
    ignored by :func:`~fairaudit.experiments.navigation.s3dis.read_area`) and
    renamed into place once complete, so an interrupted run never leaves a
    half-written file or room. About 5 s per 10^7 points (2.5 GB of text
    for 4·10^7, written in about 20 s on 2 cores).

    Parameters
    ----------
    folder : str or pathlib.Path
        An existing folder; the area is written to ``folder / area``, which
        must not exist or be empty.
    rooms : int
        Number of rooms, the lobby and the hallway included (>= 4; the
        default gives the 56 rooms of :func:`building_rooms`).
    points : int
        Total number of points (>= 10,000), spread over every surface with
        the same density; ignored when ``spacing`` is given.
    seed : int
        Seed of the layout, the furniture, the jitter and the colours: the
        same arguments write the same bytes.
    area : str
        The area folder's name (letters, digits, ``_``, ``.``, ``-``).
    spacing : float, optional
        Distance between neighbouring points on a surface, metres, in
        [0.005, 0.5]. Every room is reachable from the lobby on the maps when
        it is below about 0.8 times their resolution (10^6 points over the
        default 56 rooms give about 0.1 m; 4·10^7 about 0.015 m).

    Returns
    -------
    pathlib.Path
        The area folder (``folder / area``).

    Raises
    ------
    InputError
        Naming ``folder`` (does not exist, cannot be written, or
        ``folder / area`` exists and is not empty), ``rooms``, ``points``
        (the spacing it gives would exceed 0.5 m), ``seed``, ``area`` or
        ``spacing``.

    Examples
    --------
    >>> import tempfile
    >>> from fairaudit.experiments.navigation import read_area
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = write_building(tmp, rooms=6, points=20_000)
    ...     area = read_area(path)
    ...     first = (path / "office_1" / "office_1.txt").read_text().splitlines()[0]
    >>> area.name, area.room_names
    ('Area_5', ('conferenceRoom_1', 'hallway_1', 'lobby_1', 'office_1', 'office_2', 'office_3'))
    >>> sum(len(r.points) for r in area.rooms), len(first.split()), len(first.split()[0].split(".")[1])
    (20000, 6, 3)
    """
    base, out = _check_target(folder, area)
    n_rooms = _check_int("rooms", rooms, 4)
    _check_int("seed", seed, 0)
    specs = _layout(n_rooms, int(seed))
    layout = [_instances(spec) for spec in specs]
    if spacing is None:
        n_points = _check_int("points", points, 10_000)
        s = _spacing_for(layout, n_points)
        if s > 0.5:
            raise InputError("points", f"too few for {n_rooms} rooms (spacing {s:.2f} m > 0.5 m)", points)
        extra = n_points - _total(layout, s)
    else:
        s = _check_spacing(spacing)
        extra = 0
    try:
        out.mkdir(exist_ok=True)
    except OSError as exc:
        raise InputError("folder", f"cannot write there ({exc.strerror})", str(out)) from None
    for index, (spec, instances) in enumerate(zip(specs, layout)):
        rng = np.random.default_rng([int(seed), 1, index])
        blobs: dict[str, bytes] = {}
        counters: dict[str, int] = {}
        for category, surfaces in instances:
            xyz, rgb = _sample(surfaces, category, s, rng)
            if spec.name == "hallway_1" and category == "ceiling" and extra:
                xyz, rgb = _adjust(xyz, rgb, spec.rect, spec.ceiling, extra, rng)
            if len(xyz) == 0:
                continue
            counters[category] = counters.get(category, 0) + 1
            blobs[f"{category}_{counters[category]}"] = _encode(xyz, rgb)
        _write_room(out, spec.name, blobs)
    return out


def _check_target(folder: str | Path, area: str) -> tuple[Path, Path]:
    out = area_folder(folder, area)
    base = out.parent
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise InputError("folder", f"{area} already exists there and is not empty", str(out))
    return base, out


def _check_spacing(spacing: float) -> float:
    try:
        s = float(spacing)
    except (TypeError, ValueError):
        raise InputError("spacing", "must be a number of metres", spacing) from None
    if not 0.005 <= s <= 0.5:
        raise InputError("spacing", "must lie in [0.005, 0.5] metres", spacing)
    return s


def _instance_order(name: str) -> tuple[str, int]:
    category, _, k = name.rpartition("_")
    return category, int(k)


def _write_room(area_dir: Path, name: str, blobs: dict[str, bytes]) -> None:
    """Write one room into a hidden temporary folder, then rename it into place."""
    with staged_room(area_dir, name) as tmp:
        order = sorted(blobs, key=_instance_order)
        for inst in order:
            (tmp / "Annotations" / f"{inst}.txt").write_bytes(blobs[inst])
        with open(tmp / f"{name}.txt", "wb") as f:
            for inst in order:
                f.write(blobs[inst])
        os.replace(tmp, area_dir / name)
