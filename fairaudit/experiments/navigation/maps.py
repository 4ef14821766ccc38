"""Top-view, traversability and topological maps of an S3DIS area.

The pipeline of the paper (Methods): "ceiling points are first removed from
the raw point cloud, and the remaining environmental points are projected onto
a 2D grid according to their heights. For each grid cell, the highest point is
retained. The traversability map is then constructed by identifying grid cells
containing points within a specified height range as traversable, while cells
absent from the top-view map are designated as obstacles. Both maps use a
shared coordinate system and resolution. A topological map is derived from the
annotated point cloud, providing room-level location information."

:func:`build_maps` returns all of them on one grid (:class:`Maps`), in four steps:

1. **Ceiling removal.** Points of category ``ceiling`` are dropped, and
   so are the points of a room higher than its ceiling cut: ``ceiling``
   when given (every room), else the median height of the room's ceiling
   points minus :data:`CEILING_MARGIN` (0.1 m), else for a room without
   Annotations the :data:`CEILING_QUANTILE` (0.99) quantile of its z minus
   that margin; an annotated room without ceiling points keeps all its
   points.
2. **Top view.** Points are binned on the grid (below); each cell keeps its
   highest point (``top_height``, ``top_color``, ``top_category``); per room,
   one lexsort by cell, then z, merged room by room (ties: the later room).
3. **Traversability.** The floor height ``floor_z`` is the median z of
   the floor-category points, else the :data:`FLOOR_QUANTILE` (0.02)
   quantile of all remaining z. A cell is ``free`` when it has points and
   the highest of its points at most ``clearance`` above the floor lies in
   [floor_z - floor_band, floor_z + floor_band]: nothing the robot could
   hit stands there (points above the clearance, such as door lintels or
   lamps, do not block). Cells without points are obstacles. Obstacles
   are inflated by the robot: a free cell is ``traversable`` when the
   centre of every non-free cell is more than ``robot_radius`` from its
   centre (Euclidean distance transform).
4. **Topology.** One node per room, keyed by its name, with attributes
   ``centre`` (x, y mean of its floor-category points, else of its points
   in the floor band, else its bounding-box centre; metres), ``category``
   (the name without ``_<k>``: ``"office"``), ``bbox`` (x_min, y_min,
   x_max, y_max of its points), ``free_cells`` (number of free cells
   labelled with it) and ``ceiling_z``. An edge joins two rooms whose
   free cells touch (8-neighbours, attribute ``via="adjacent"`` and
   ``contact``, the number of touching cell pairs), or, failing that, are
   joined through at most ``door_gap`` metres of cells without any point
   (a door gap in the scan; ``via="gap"``).

Grid convention
---------------
Cell ``(row, col)`` covers x in [ox + col·res, ox + (col + 1)·res) and y in
[oy + row·res, oy + (row + 1)·res), where ``(ox, oy)`` is :attr:`Maps.origin`
(the south-west corner of cell (0, 0)) and ``res`` is :attr:`Maps.resolution`:
**row = y, col = x**, both increasing (row 0 is the southernmost row). Arrays
are indexed ``[row, col]``. Images (:func:`~fairaudit.experiments.navigation.images.route_image`)
are drawn north up: image row 0 is grid row ``rows - 1``.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from fairaudit import InputError, optional_modules, real

from .s3dis import CATEGORIES, UNLABELLED, Area, Room, iter_rooms, room_kind

if TYPE_CHECKING:
    import networkx

__all__ = ["CEILING_MARGIN", "CEILING_QUANTILE", "FLOOR_QUANTILE", "Maps", "build_maps"]

#: Points higher than (estimated ceiling height - CEILING_MARGIN) metres are removed.
CEILING_MARGIN = 0.1
#: Without floor-category points, the floor height is this quantile of z.
FLOOR_QUANTILE = 0.02
#: In a room without Annotations, the ceiling height is this quantile of its z.
CEILING_QUANTILE = 0.99
#: Largest grid accepted by :func:`build_maps`, in cells.
MAX_CELLS = 50_000_000

_CEILING = CATEGORIES.index("ceiling")
_FLOOR = CATEGORIES.index("floor")


def require_networkx() -> ModuleType:
    """The networkx module, or an :class:`InputError` naming the extra that installs it."""
    problem = "needs networkx, which is not installed: pip install 'fairness-certify[navigation]'"
    return optional_modules("navigation", problem, "networkx")[0]


@dataclass(frozen=True, eq=False, kw_only=True)
class Maps:
    """Top-view, traversability and topological maps on one grid.

    Every grid array has shape ``shape`` = (rows, cols) and is indexed
    ``[row, col]`` with row = y and col = x (see the module docstring); all
    arrays are read-only.

    Attributes
    ----------
    origin : tuple of float
        (x, y) of the south-west corner of cell (0, 0), metres; a multiple of
        the resolution.
    resolution : float
        Side of a cell, metres.
    shape : tuple of int
        (rows, cols).
    top_height : numpy.ndarray
        float64: z of the highest point of the cell after ceiling removal
        (metres), NaN where the cell has no point (the top-view map).
    top_color : numpy.ndarray
        Shape (rows, cols, 3), uint8: colour of that point; 0 where no point.
    top_category : numpy.ndarray
        uint8: its category code (:data:`~fairaudit.experiments.navigation.s3dis.CATEGORIES`);
        255 where no point.
    free : numpy.ndarray
        bool: the cell has points and the highest of those at most
        ``clearance`` above the floor lies in the floor band.
    traversable : numpy.ndarray
        bool: ``free`` cells farther than ``robot_radius`` from every
        non-free cell (centre to centre; outside the grid counts as non-free).
    room_labels : numpy.ndarray
        int16: index into :attr:`rooms` of the room whose point decides the
        cell (the highest point at most ``clearance`` above the floor, else
        the highest point); -1 where no point.
    rooms : tuple of str
        Room names, in the area's order (sorted).
    topology : networkx.Graph
        Frozen; one node per room (see :func:`build_maps`).
    floor_z : float
        Floor height, metres.
    ceiling_z : numpy.ndarray
        Shape (n_rooms,): the height above which each room's points were
        removed, metres (+inf: nothing removed by height).
    floor_band, clearance, robot_radius : float
        The arguments of :func:`build_maps` (``clearance`` is +inf for None).
    """

    origin: tuple[float, float]
    resolution: float
    shape: tuple[int, int]
    top_height: np.ndarray
    top_color: np.ndarray
    top_category: np.ndarray
    free: np.ndarray
    traversable: np.ndarray
    room_labels: np.ndarray
    rooms: tuple[str, ...]
    topology: networkx.Graph
    floor_z: float
    ceiling_z: np.ndarray
    floor_band: float
    clearance: float
    robot_radius: float

    def world_to_cell(self, x: npt.ArrayLike, y: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """The (row, col) of the cell that contains the point (x, y).

        Parameters
        ----------
        x, y : float or array_like
            Metres; broadcast together.

        Returns
        -------
        row, col : numpy.ndarray of int64
            ``floor((y - oy) / res)`` and ``floor((x - ox) / res)``; may lie
            outside the grid (check with :meth:`contains`). :func:`build_maps` has examples.
        """
        return _row_col(x, y, self.origin, self.resolution)

    def cell_to_world(self, row: npt.ArrayLike, col: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """The (x, y) of the centre of cell (row, col), metres (:func:`build_maps` has examples)."""
        row = np.asarray(row, dtype=float)
        col = np.asarray(col, dtype=float)
        return self.origin[0] + (col + 0.5) * self.resolution, self.origin[1] + (row + 0.5) * self.resolution

    def contains(self, row: npt.ArrayLike, col: npt.ArrayLike) -> np.ndarray:
        """Whether (row, col) lies on the grid (element-wise)."""
        row = np.asarray(row)
        col = np.asarray(col)
        return (row >= 0) & (row < self.shape[0]) & (col >= 0) & (col < self.shape[1])


def check_maps(maps: object) -> None:
    """Raise an InputError naming ``maps`` and the type given unless ``maps`` is :class:`Maps`."""
    if not isinstance(maps, Maps):
        raise InputError("maps", "must be Maps from build_maps", type(maps).__name__)


def _metres(name: str, value: float, *, allow_zero: bool = False) -> float:
    """``value`` as a float, a finite number of metres > 0 (>= 0 with ``allow_zero``), or an error naming ``name``."""
    what = "a finite number of metres " + (">= 0" if allow_zero else "> 0")
    return real(value, name, low=0.0, low_open=not allow_zero, what=what)


def _highest(flat: np.ndarray, z: np.ndarray, keep: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(cells, index of the highest point in each cell) over the points in ``keep``; ties: the later point."""
    idx = np.arange(len(flat)) if keep is None else np.flatnonzero(keep)
    if len(idx) == 0:
        return np.empty(0, np.int64), np.empty(0, np.int64)
    order = idx[np.lexsort((z[idx], flat[idx]))]
    f = flat[order]
    last = np.r_[f[1:] != f[:-1], True]
    return f[last], order[last]


def build_maps(
    area: Area | str | os.PathLike[str],
    *,
    resolution: float = 0.05,
    ceiling: float | None = None,
    floor_band: float = 0.1,
    clearance: float | None = 1.8,
    robot_radius: float = 0.2,
    door_gap: float = 0.3,
) -> Maps:
    """Top-view, traversability and topological maps of an area (the paper's Methods; steps 1-4 of the module docstring).

    Parameters
    ----------
    area : Area or str or pathlib.Path
        From :func:`~fairaudit.experiments.navigation.s3dis.read_area`, or an S3DIS area folder, whose rooms are
        then read one at a time (:func:`~fairaudit.experiments.navigation.s3dis.iter_rooms`), twice, so that only
        one room's points are in memory (docs/design.md, "Streaming"); the maps are those of
        ``build_maps(read_area(area))``, array for array.
    resolution : float
        Side of a grid cell, metres (> 0).
    ceiling : float, optional
        Ceiling cut height, metres (overrides the estimate).
    floor_band : float
        Half-width of the floor band, metres (> 0).
    clearance : float or None
        Height above the floor up to which points block the robot, metres
        (> floor_band); None: every point blocks (only the top view counts).
    robot_radius : float
        Obstacle inflation, metres (>= 0).
    door_gap : float
        Widest scan gap bridged in the topology, metres (>= 0).

    Returns
    -------
    Maps

    Raises
    ------
    InputError
        Naming the argument: not an Area or a folder, no points, a non-positive or
        non-finite length, ``clearance`` not above ``floor_band``, or a grid
        of more than 50 million cells (``resolution`` too fine); naming
        ``navigation`` when networkx is missing; as
        :func:`~fairaudit.experiments.navigation.s3dis.read_area` for a
        folder that cannot be read.

    Examples
    --------
    >>> import tempfile
    >>> from fairaudit.experiments.navigation import read_area, write_office_floor
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     area = read_area(write_office_floor(tmp, spacing=0.2))
    >>> maps = build_maps(area, resolution=0.2)
    >>> maps.shape, maps.origin, round(maps.floor_z, 2)
    ((40, 60), (0.0, 0.0), 0.0)
    >>> cell = maps.world_to_cell(2.0, 6.5)
    >>> maps.rooms[maps.room_labels[cell]], bool(maps.traversable[cell]), bool(maps.contains(*maps.world_to_cell(-1.0, 0.0)))
    ('office_1', True, False)
    >>> [int(v) for v in maps.world_to_cell(2.5, 0.3)], maps.cell_to_world([1, 0], [12, 0])
    ([1, 12], (array([2.5, 0.1]), array([0.3, 0.1])))
    >>> sorted(maps.topology.neighbors("hallway_1"))
    ['WC_1', 'conferenceRoom_1', 'lobby_1', 'office_1', 'office_2', 'storage_1']
    >>> maps.topology.nodes["office_2"]["centre"], maps.topology.nodes["office_2"]["category"]
    ((10.0, 6.5), 'office')
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     streamed = build_maps(write_office_floor(tmp, spacing=0.2), resolution=0.2)
    >>> bool(np.array_equal(streamed.top_height, maps.top_height, equal_nan=True))
    True
    """
    if not isinstance(area, (Area, str, os.PathLike)):
        raise InputError("area", "must be an Area from read_area or an area folder", type(area).__name__)
    res = _metres("resolution", resolution)
    band = _metres("floor_band", floor_band)
    clear = math.inf if clearance is None else _metres("clearance", clearance)
    if clear <= band:
        raise InputError("clearance", "must be larger than floor_band", clearance)
    radius = _metres("robot_radius", robot_radius, allow_zero=True)
    gap = _metres("door_gap", door_gap, allow_zero=True)
    cut = None if ceiling is None else real(ceiling, "ceiling", what="a finite height in metres")
    nx = require_networkx()
    g = _grids(area if isinstance(area, Area) else Path(area), res, resolution, cut, band, clear)

    # 3. traversability
    with np.errstate(invalid="ignore"):
        free = (g.low_height >= g.floor_z - band) & (g.low_height <= g.floor_z + band)
    shape = g.shape
    free = free.reshape(shape)
    traversable = _inflate(free, radius / res)
    labels = g.labels.reshape(shape)
    graph = _topology(nx, g, np.where(free, labels, -1), int(math.ceil(gap / res - 1e-9)))

    arrays = dict(
        top_height=g.top_height.reshape(shape),
        top_color=g.top_color.reshape(shape + (3,)),
        top_category=g.top_category.reshape(shape),
        free=free,
        traversable=traversable,
        room_labels=labels,
        ceiling_z=g.ceiling_z,
    )
    for array in arrays.values():
        array.setflags(write=False)
    return Maps(
        origin=g.origin,
        resolution=res,
        shape=shape,
        rooms=g.names,
        topology=graph,
        floor_z=g.floor_z,
        floor_band=band,
        clearance=clear,
        robot_radius=radius,
        **arrays,
    )


@dataclass(frozen=True, eq=False, kw_only=True)
class _Grids:
    """The per-cell results of steps 1-3 of :func:`build_maps` (flat arrays of ``shape[0] * shape[1]`` cells)."""

    names: tuple[str, ...]
    origin: tuple[float, float]
    shape: tuple[int, int]
    top_height: np.ndarray  # float64, NaN where no point
    top_color: np.ndarray  # (ncell, 3) uint8
    top_category: np.ndarray  # uint8, 255 where no point
    labels: np.ndarray  # int16: room of the highest point at most clearance above the floor, else of the highest
    low_height: np.ndarray  # float64: that point's height, NaN where none
    floor_z: float
    ceiling_z: np.ndarray  # (n_rooms,)
    centres: list[tuple[float, float]]
    bboxes: list[tuple[float, float, float, float]]


def _topology(nx: ModuleType, g: _Grids, free_labels: np.ndarray, steps: int) -> networkx.Graph:
    """Step 4 of :func:`build_maps`: the frozen graph of the rooms and their passages."""
    graph = nx.Graph()
    counts = np.bincount(free_labels[free_labels >= 0].astype(np.int64), minlength=len(g.names))
    for i, name in enumerate(g.names):
        graph.add_node(
            name,
            centre=g.centres[i],
            category=room_kind(name),
            bbox=g.bboxes[i],
            free_cells=int(counts[i]),
            ceiling_z=float(g.ceiling_z[i]),
        )
    _add_passages(graph, g.names, free_labels, np.isnan(g.top_height.reshape(g.shape)), steps)
    return nx.freeze(graph)


@dataclass
class _Scan:
    """What the first pass over an area's rooms keeps (see :func:`_grids`)."""

    names: list[str]
    ceiling_z: list[float]
    bboxes: list[tuple[float, float, float, float]]
    centres: list[tuple[float, float] | None]  # None: no floor point, decided in the second pass
    floor: list[np.ndarray]  # heights of the kept floor-category points (float64: the median must be exact)
    fallback: list[np.ndarray]  # heights of every kept point, only while no floor point has been seen
    points: int = 0
    kept: int = 0


def _rooms(source: Area | Path) -> Iterator[Room]:
    """An Area's rooms, or a folder's read one at a time."""
    return iter(source.rooms) if isinstance(source, Area) else iter_rooms(source)


def _scan(source: Area | Path, cut: float | None) -> _Scan:
    """First pass: per room its name, ceiling cut, bounding box and floor centre; the floor points' heights."""
    scan = _Scan(names=[], ceiling_z=[], bboxes=[], centres=[], floor=[], fallback=[])
    for r in _rooms(source):
        z = r.points[:, 2]
        cz = _ceiling(r, cut)
        keep = (r.categories != _CEILING) & (z <= cz)
        is_floor = keep & (r.categories == _FLOOR)
        centre, bbox = _room_summary(r.points[:, 0], r.points[:, 1], is_floor)
        scan.names.append(r.name)
        scan.ceiling_z.append(cz)
        scan.bboxes.append(bbox)
        scan.centres.append(centre if is_floor.any() else None)
        scan.points += len(z)
        scan.kept += int(keep.sum())
        if is_floor.any():
            scan.floor.append(z[is_floor])
            scan.fallback = []
        elif not scan.floor:
            scan.fallback.append(z[keep])
    return scan


def _grids(source: Area | Path, res: float, resolution: float, cut: float | None, band: float, clear: float) -> _Grids:
    """Steps 1-3 of :func:`build_maps`, one room at a time, in two passes; ties between rooms go to the later room."""
    scan = _scan(source, cut)
    if scan.points == 0:
        raise InputError("area", "has no points", source.name)
    if scan.kept == 0:
        raise InputError("area", "has no points below the ceiling", source.name)
    if scan.floor:
        floor_z = float(np.median(np.concatenate(scan.floor)))
    else:
        floor_z = float(np.quantile(np.concatenate(scan.fallback), FLOOR_QUANTILE))
    scan.floor, scan.fallback = [], []
    box = np.array([b for b in scan.bboxes if not math.isnan(b[0])])
    origin, shape = _frame(box[:, 0].min(), box[:, 1].min(), box[:, 2].max(), box[:, 3].max(), res, resolution)
    ncell = shape[0] * shape[1]
    top_height, low_height = np.full(ncell, np.nan), np.full(ncell, np.nan)
    top_color = np.zeros((ncell, 3), dtype=np.uint8)
    top_category = np.full(ncell, 255, dtype=np.uint8)
    top_room, low_room = np.full(ncell, -1, dtype=np.int16), np.full(ncell, -1, dtype=np.int16)
    centres = list(scan.centres)
    for i, r in enumerate(_rooms(source)):
        if i >= len(scan.names) or r.name != scan.names[i]:
            raise InputError(str(source), "the area's rooms changed while it was read", r.name)
        x, y, z = r.points[:, 0], r.points[:, 1], r.points[:, 2]
        keep = (r.categories != _CEILING) & (z <= scan.ceiling_z[i])
        row, col = _row_col(x, y, origin, res)
        flat = row * shape[1] + col
        cells, top = _highest(flat, z, keep)
        wins = ~(top_height[cells] > z[top])  # NaN or lower: this room's point wins (ties: the later room)
        won, top_i = cells[wins], top[wins]
        top_height[won], top_color[won] = z[top_i], r.colors[top_i]
        top_category[won], top_room[won] = r.categories[top_i], i
        cells, low = _highest(flat, z, keep & (z <= floor_z + clear))
        better = ~(low_height[cells] > z[low])
        low_height[cells[better]], low_room[cells[better]] = z[low[better]], i
        if centres[i] is None:
            centres[i] = _room_summary(x, y, keep & (np.abs(z - floor_z) <= band))[0]
    labels = np.where(np.isnan(low_height), top_room, low_room).astype(np.int16)
    return _Grids(
        names=tuple(scan.names),
        origin=origin,
        shape=shape,
        top_height=top_height,
        top_color=top_color,
        top_category=top_category,
        labels=labels,
        low_height=low_height,
        floor_z=floor_z,
        ceiling_z=np.array(scan.ceiling_z, dtype=float),
        centres=[c if c is not None else (math.nan, math.nan) for c in centres],
        bboxes=scan.bboxes,
    )


def _ceiling(r: Room, cut: float | None) -> float:
    """The height above which the room's points are removed (+inf: none by height); see :func:`build_maps`."""
    if len(r.points) == 0:
        return math.inf
    if cut is not None:
        return cut
    rz = r.points[:, 2]
    is_ceiling = r.categories == _CEILING
    if is_ceiling.any():
        return float(np.median(rz[is_ceiling])) - CEILING_MARGIN
    if (r.categories == UNLABELLED).all():
        return float(np.quantile(rz, CEILING_QUANTILE)) - CEILING_MARGIN
    return math.inf


def _frame(
    x_min: float, y_min: float, x_max: float, y_max: float, res: float, resolution: float
) -> tuple[tuple[float, float], tuple[int, int]]:
    """The grid of points spanning that bounding box: its origin and its shape (rows, cols).

    The last row and column are those of (x_max, y_max) under :func:`_row_col` (the cell index is monotone in
    the coordinate, so the bounding box alone gives the grid of all the points).
    """
    ox = math.floor(x_min / res + 1e-9) * res
    oy = math.floor(y_min / res + 1e-9) * res
    shape = (math.floor((y_max - oy) / res + 1e-9) + 1, math.floor((x_max - ox) / res + 1e-9) + 1)
    if shape[0] * shape[1] > MAX_CELLS:
        raise InputError(
            "resolution", f"gives a grid of {shape[0]} x {shape[1]} cells, more than {MAX_CELLS}", resolution
        )
    return (float(ox), float(oy)), shape


def _row_col(
    x: npt.ArrayLike, y: npt.ArrayLike, origin: tuple[float, float], res: float
) -> tuple[np.ndarray, np.ndarray]:
    """(row, col) of the cell holding each point (x, y) on the grid of ``origin`` and ``res`` (may lie off it)."""
    row = np.floor((np.asarray(y, dtype=float) - origin[1]) / res + 1e-9).astype(np.int64)
    col = np.floor((np.asarray(x, dtype=float) - origin[0]) / res + 1e-9).astype(np.int64)
    return row, col


def _room_summary(
    rx: np.ndarray, ry: np.ndarray, sel: np.ndarray
) -> tuple[tuple[float, float], tuple[float, float, float, float]]:
    """A room's centre (mean x, y of its points in ``sel``, else its bounding box's centre) and bounding box."""
    if sel.any():
        centre = (float(rx[sel].mean()), float(ry[sel].mean()))
    elif len(rx):
        centre = (float((rx.min() + rx.max()) / 2), float((ry.min() + ry.max()) / 2))
    else:
        centre = (math.nan, math.nan)
    bbox = (float(rx.min()), float(ry.min()), float(rx.max()), float(ry.max())) if len(rx) else (math.nan,) * 4
    return centre, bbox


def _add_passages(
    graph: networkx.Graph, names: tuple[str, ...], free_labels: np.ndarray, empty: np.ndarray, steps: int
) -> None:
    """Edges between rooms whose free cells touch (``via="adjacent"``), else joined by a gap of ``steps`` cells."""
    for (a, b), n in _touching(free_labels).items():
        graph.add_edge(names[a], names[b], via="adjacent", contact=n)
    if steps > 0:
        for a, b in _gap_pairs(free_labels, empty, steps):
            if not graph.has_edge(names[a], names[b]):
                graph.add_edge(names[a], names[b], via="gap", contact=0)


def _inflate(free: np.ndarray, radius_cells: float) -> np.ndarray:
    """Free cells whose distance (in cells, centre to centre) to every non-free cell exceeds ``radius_cells``."""
    from scipy import ndimage

    padded = np.pad(free, 1, constant_values=False)
    dist = ndimage.distance_transform_edt(padded)[1:-1, 1:-1]
    return free & (dist > radius_cells + 1e-9)


def _touching(labels: np.ndarray) -> dict[tuple[int, int], int]:
    """Pairs (a < b) of labels >= 0 on 8-neighbouring cells, with the number of such cell pairs."""
    pairs = []
    for sa, sb in (
        ((slice(None), slice(None, -1)), (slice(None), slice(1, None))),
        ((slice(None, -1), slice(None)), (slice(1, None), slice(None))),
        ((slice(None, -1), slice(None, -1)), (slice(1, None), slice(1, None))),
        ((slice(None, -1), slice(1, None)), (slice(1, None), slice(None, -1))),
    ):
        a, b = labels[sa].ravel(), labels[sb].ravel()
        m = (a >= 0) & (b >= 0) & (a != b)
        pairs.append(np.column_stack([np.minimum(a[m], b[m]), np.maximum(a[m], b[m])]))
    allp = np.concatenate(pairs).astype(np.int64)
    if len(allp) == 0:
        return {}
    uniq, n = np.unique(allp, axis=0, return_counts=True)
    return {(int(a), int(b)): int(k) for (a, b), k in zip(uniq, n)}


def _gap_pairs(labels: np.ndarray, empty: np.ndarray, steps: int) -> set[tuple[int, int]]:
    """Pairs of rooms whose free cells are joined through at most ``steps`` cells without points."""
    from scipy import ndimage

    structure = np.ones((3, 3), dtype=bool)
    out = set()
    for r in np.unique(labels[labels >= 0]):
        own = labels == r
        rows, cols = np.nonzero(own)
        lo_r, hi_r = max(rows.min() - steps - 1, 0), min(rows.max() + steps + 2, labels.shape[0])
        lo_c, hi_c = max(cols.min() - steps - 1, 0), min(cols.max() + steps + 2, labels.shape[1])
        win = (slice(lo_r, hi_r), slice(lo_c, hi_c))
        grown = ndimage.binary_dilation(own[win], structure, iterations=steps, mask=own[win] | empty[win])
        reach = ndimage.binary_dilation(grown, structure) & ~own[win]
        other = labels[win][reach]
        for o in np.unique(other[other >= 0]):
            out.add((int(min(r, o)), int(max(r, o))))
    return out
