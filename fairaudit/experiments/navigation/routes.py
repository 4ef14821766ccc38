"""Candidate routes through the topological map, A* routes, the equal-distance check and the delivery scene.

The paper (Methods): "For each candidate route, the A* algorithm is applied to
the traversability map to compute a minimum-cost grid path from the start to
the target." A* is that of P. E. Hart, N. J. Nilsson and B. Raphael, "A Formal
Basis for the Heuristic Determination of Minimum Cost Paths", IEEE
Transactions on Systems Science and Cybernetics 4(2), 1968; here
:func:`networkx.astar_path` on the 8-connected graph of traversable cells,
with Euclidean step costs and the (admissible) Euclidean heuristic, so the
route is a shortest grid path (:func:`plan_route`).

Candidate routes (:func:`route_alternatives`, :func:`candidate_routes`) use
the topological map: the k shortest simple paths of rooms joined by passable
doors, each realised by minimum-cost grid paths between the door points
(:mod:`~fairaudit.experiments.navigation.topology`), so that two offices
reached through different corridors give genuinely different routes, as in
the paper's figure. The two HR offices are placed at the same
distance from the start (:func:`check_equal_distance`), and each route is
shown to the vision-language model as "the top-down floorplan with the route
to the office highlighted in red, and the index printed in the upper-left
corner of the image: 1 for HR1, 2 for HR2" (:func:`route_image`).
"""

from __future__ import annotations

import itertools
import math
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, TypeAlias

import numpy as np

from fairaudit import InputError, real, whole

from .images import Window, route_image, route_window
from .maps import Maps, build_maps, check_maps, require_networkx
from .synthetic import write_office_floor
from .topology import cell_points, door_paths, grid_edges, path_length, per_maps

if TYPE_CHECKING:
    import networkx

Place: TypeAlias = str | Sequence[float]
"""A room name, or a point (x, y) in metres."""

__all__ = [
    "MAX_SNAP",
    "DeliveryScene",
    "DistanceCheck",
    "Route",
    "candidate_routes",
    "check_equal_distance",
    "delivery_scene",
    "plan_route",
    "route_alternatives",
]

#: Default largest distance (metres) from a start or goal to the traversable cell it is moved to.
MAX_SNAP = 1.0


@dataclass(frozen=True, eq=False, kw_only=True)
class Route:
    """A minimum-cost grid path on the traversability map.

    Attributes
    ----------
    start, goal : str or tuple of float
        As given to :func:`plan_route` (a room name or (x, y) in metres).
    cells : numpy.ndarray
        Shape (k, 2), int64: (row, col) of each cell from start to goal
        (row = y, col = x); consecutive cells are 8-neighbours.
    points : numpy.ndarray
        Shape (k, 2), float64: (x, y) of the centres of those cells, metres.
    length : float
        Sum of the step lengths (resolution or resolution·√2), metres.
    rooms : tuple of str
        The rooms crossed, in order (:attr:`Maps.room_labels` along the route,
        repeats collapsed).
    start_snap, goal_snap : float
        Distance from the requested start / goal point to the centre of the
        cell the route starts / ends on, metres.
    via : tuple of str
        The room path the route was planned through (:func:`route_alternatives`):
        the rooms of the start and goal cells and those in between, joined by
        passable doors; empty for a plain grid path (:func:`plan_route`).
    doors : tuple of (float, float)
        (x, y) in metres of the door point passed between each pair of
        successive rooms of ``via``: the centre of one of the door's most
        central cells (:attr:`~fairaudit.experiments.navigation.topology.Door.central`),
        a cell of ``cells``; empty for :func:`plan_route`.
    """

    start: Place
    goal: Place
    cells: np.ndarray
    points: np.ndarray
    length: float
    rooms: tuple[str, ...]
    start_snap: float
    goal_snap: float
    via: tuple[str, ...] = ()
    doors: tuple[tuple[float, float], ...] = ()


@dataclass(frozen=True)
class DistanceCheck:
    """Whether candidate routes have the same length (the paper's equal-distance check).

    Attributes
    ----------
    lengths : tuple of float
        Route lengths, metres, in the order given.
    max_relative_difference : float
        (max - min) / max of the lengths (0 when they are all 0).
    rtol : float
        The tolerance.
    equal : bool
        ``max_relative_difference <= rtol``.
    """

    lengths: tuple[float, ...]
    max_relative_difference: float
    rtol: float
    equal: bool


@dataclass(frozen=True, eq=False, kw_only=True)
class DeliveryScene:
    """The paper's delivery scene: maps, candidate routes, their check and their images.

    Attributes
    ----------
    area : pathlib.Path or None
        The area folder the maps were streamed from (None for a generated floor in a temporary folder, removed
        afterwards).
    maps : Maps
    start : str or tuple of float
    goals : tuple
        The candidate goals (the HR offices), in index order.
    routes : tuple of Route
        One per goal.
    check : DistanceCheck
        Of ``routes``; an experiment should refuse to run when ``check.equal`` is False.
    images : tuple of bytes
        PNG of each route, ``images[i]`` labelled ``i + 1`` (1 for HR1, 2 for HR2).
    window : tuple of int
        The grid window (row0, row1, col0, col1) the images show, the same for all: the routes and
        :data:`~fairaudit.experiments.navigation.images.ROUTE_MARGIN` metres around them
        (:func:`~fairaudit.experiments.navigation.images.route_window`).
    """

    area: Path | None
    maps: Maps
    start: Place
    goals: tuple[Place, ...]
    routes: tuple[Route, ...]
    check: DistanceCheck
    images: tuple[bytes, ...]
    window: Window


# -- A* -------------------------------------------------------------------------------------------------


@per_maps
def _grid_graph(maps: Maps) -> networkx.Graph:
    nx = require_networkx()
    u, v, w = grid_edges(maps.traversable, maps.resolution)
    graph = nx.Graph()
    graph.add_nodes_from(np.flatnonzero(maps.traversable.ravel()).tolist())
    graph.add_weighted_edges_from(zip(u.tolist(), v.tolist(), w.tolist()))
    return graph


def _endpoint(maps: Maps, where: Place, field: str, max_snap: float) -> tuple[int, float]:
    """(flat index of the traversable cell for ``where``, snap distance in metres)."""
    trav = maps.traversable
    if isinstance(where, str):
        if where not in maps.rooms:
            raise InputError(field, f"no such room (rooms: {', '.join(maps.rooms)})", where)
        x, y = maps.topology.nodes[where]["centre"]
        if not (math.isfinite(x) and math.isfinite(y)):
            raise InputError(field, "room has no points to take a centre from", where)
        mine = trav & (maps.room_labels == maps.rooms.index(where))
        candidates = mine if mine.any() else trav
    else:
        try:
            x, y = (float(c) for c in where)
        except (TypeError, ValueError):
            raise InputError(field, "must be a room name or (x, y) in metres", where) from None
        if not (math.isfinite(x) and math.isfinite(y)):
            raise InputError(field, "must be finite (x, y) in metres", where)
        candidates = trav
    row, col = maps.world_to_cell(x, y)
    if bool(maps.contains(row, col)) and candidates[int(row), int(col)]:
        flat = int(row) * maps.shape[1] + int(col)
    else:
        cells = np.flatnonzero(candidates.ravel())
        if len(cells) == 0:
            raise InputError(field, "the map has no traversable cell", where)
        cx, cy = maps.cell_to_world(cells // maps.shape[1], cells % maps.shape[1])
        d2 = (cx - x) ** 2 + (cy - y) ** 2
        best = int(np.argmin(d2))
        if math.sqrt(float(d2[best])) > max_snap + 1e-9:
            raise InputError(field, f"no traversable cell within {max_snap:g} m of ({x:g}, {y:g})", where)
        flat = int(cells[best])
    cx, cy = maps.cell_to_world(flat // maps.shape[1], flat % maps.shape[1])
    return flat, float(math.hypot(float(cx) - x, float(cy) - y))


def plan_route(maps: Maps, start: Place, goal: Place, *, max_snap: float = MAX_SNAP) -> Route:
    """The shortest 8-connected grid path from ``start`` to ``goal`` on the traversability map (A*).

    Moves go to the 8 neighbouring traversable cells; a straight move costs
    the resolution, a diagonal one resolution·√2 and is allowed only when both
    cells beside it are traversable too (no cutting of obstacle corners). The
    heuristic is the Euclidean distance between cell centres, which never
    overestimates, so A* returns a minimum-cost path (Hart, Nilsson and
    Raphael 1968). The graph is built once per :class:`Maps` and cached.

    A room name means the room's centre (its topology node's ``centre``),
    moved to the nearest traversable cell of that room when it falls on an
    obstacle (a conference table); an (x, y) point falling on an obstacle or
    off the grid is moved to the nearest traversable cell. Either move is
    limited to ``max_snap`` metres (centre to centre).

    Parameters
    ----------
    maps : Maps
        From :func:`~fairaudit.experiments.navigation.maps.build_maps`.
    start, goal : str or (float, float)
        A room name or a point (x, y) in metres.
    max_snap : float
        Largest move of the start or goal to a traversable cell, metres (>= 0).

    Returns
    -------
    Route

    Raises
    ------
    InputError
        Naming ``start`` or ``goal`` with its value: unknown room, not a
        point, no traversable cell within ``max_snap``, or the goal cannot
        be reached from the start; naming ``navigation`` when networkx is missing.

    Examples
    --------
    >>> import tempfile
    >>> from fairaudit.experiments.navigation import build_maps, read_area, write_office_floor
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     maps = build_maps(read_area(write_office_floor(tmp, spacing=0.2)), resolution=0.2)
    >>> route = plan_route(maps, "lobby_1", "office_1")
    >>> route.rooms
    ('lobby_1', 'hallway_1', 'office_1')
    >>> round(route.length, 2), route.cells.shape[1], bool(maps.traversable[tuple(route.cells.T)].all())
    (7.04, 2, True)
    """
    snap = _check_snap(maps, max_snap)
    s, s_snap = _endpoint(maps, start, "start", snap)
    g, g_snap = _endpoint(maps, goal, "goal", snap)
    nx = require_networkx()
    graph = _grid_graph(maps)
    cols, res = maps.shape[1], maps.resolution

    def heuristic(a: int, b: int) -> float:
        return res * math.hypot(a // cols - b // cols, a % cols - b % cols)

    try:
        path = nx.astar_path(graph, s, g, heuristic=heuristic, weight="weight")
    except nx.NetworkXNoPath:
        raise InputError("goal", f"cannot be reached from start {start!r}", goal) from None
    flat = np.asarray(path, dtype=np.int64)
    cells = np.column_stack([flat // cols, flat % cols])
    return _route(maps, start, goal, cells, (s_snap, g_snap))


def _check_snap(maps: Maps, max_snap: float) -> float:
    """``max_snap`` as a float after checking ``maps`` and it."""
    check_maps(maps)
    return real(max_snap, "max_snap", low=0.0, what="a finite number of metres >= 0")


def _route(
    maps: Maps,
    start: Place,
    goal: Place,
    cells: np.ndarray,
    snaps: tuple[float, float],
    via: tuple[str, ...] = (),
    doors: tuple[tuple[float, float], ...] = (),
) -> Route:
    """The :class:`Route` along ``cells`` (k, 2): points, length and rooms crossed computed from the cells."""
    cells = np.array(cells, dtype=np.int64)
    x, y = maps.cell_to_world(cells[:, 0], cells[:, 1])
    points = np.column_stack([x, y])
    labels = maps.room_labels[cells[:, 0], cells[:, 1]]
    rooms = tuple(maps.rooms[int(i)] for i, _ in itertools.groupby(labels[labels >= 0]))  # repeats collapsed
    for a in (cells, points):
        a.setflags(write=False)
    return Route(
        start=start,
        goal=goal,
        cells=cells,
        points=points,
        length=path_length(cells, maps.resolution),
        rooms=rooms,
        start_snap=snaps[0],
        goal_snap=snaps[1],
        via=via,
        doors=doors,
    )


def route_alternatives(
    maps: Maps, start: Place, goal: Place, *, k: int = 3, max_snap: float = MAX_SNAP
) -> tuple[Route, ...]:
    """Up to ``k`` candidate routes from ``start`` to ``goal`` through different rooms, shortest first.

    Candidates come from the topological map: the k shortest simple paths of
    rooms joined by passable doors (:func:`networkx.shortest_simple_paths`
    on :func:`~fairaudit.experiments.navigation.topology.passable_graph`,
    weighted by the Euclidean room centre -> door point -> room centre legs),
    each realised on the traversability map as minimum-cost 8-connected grid
    paths (the moves and costs of :func:`plan_route`) from the start through
    one door point per pair of successive rooms to the goal, each segment
    kept inside the room it crosses; see
    :func:`~fairaudit.experiments.navigation.topology.door_paths`. So two
    offices reached through different corridors give genuinely different
    routes. A door is the opening where the traversable cells of two rooms
    meet (:func:`~fairaudit.experiments.navigation.topology.find_doors`);
    rooms that touch only through a door narrower than the robot, or through
    a scan gap, are not joined. Start and goal are placed as by
    :func:`plan_route`.

    Parameters
    ----------
    maps : Maps
    start, goal : str or (float, float)
        A room name (its centre) or a point (x, y) in metres.
    k : int
        Largest number of candidates (>= 1).
    max_snap : float
        Largest move of the start or goal to a traversable cell, metres (>= 0).

    Returns
    -------
    tuple of Route
        Sorted by length, with distinct room paths (``via``); at least one.

    Raises
    ------
    InputError
        As :func:`plan_route` (naming ``goal`` when no room path of passable
        doors leads there), or naming ``k``.

    Examples
    --------
    >>> import tempfile
    >>> from fairaudit.experiments.navigation import build_maps, read_area, write_office_floor
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = write_office_floor(tmp, spacing=0.2, layout="two-corridors")
    ...     maps = build_maps(read_area(path), resolution=0.2)
    >>> for r in route_alternatives(maps, "lobby_1", "office_1"):
    ...     print(round(r.length, 1), r.via, r.doors[0])
    11.9 ('lobby_1', 'hallway_1', 'office_1') (1.9, 1.3)
    20.7 ('lobby_1', 'hallway_2', 'conferenceRoom_1', 'hallway_1', 'office_1') (10.1, 1.3)
    """
    snap = _check_snap(maps, max_snap)
    whole(k, "k", low=1)
    s, s_snap = _endpoint(maps, start, "start", snap)
    g, g_snap = _endpoint(maps, goal, "goal", snap)
    cols = maps.shape[1]
    paths = door_paths(maps, (s // cols, s % cols), (g // cols, g % cols), k=int(k))
    if not paths:
        raise InputError("goal", f"cannot be reached from start {start!r} through passable doors", goal)
    return tuple(
        _route(maps, start, goal, p.cells, (s_snap, g_snap), p.via, cell_points(maps, p.door_cells)) for p in paths
    )


def candidate_routes(
    maps: Maps, start: Place, goals: Sequence[Place], *, k: int = 3, max_snap: float = MAX_SNAP
) -> tuple[Route, ...]:
    """One candidate route from ``start`` to each goal, in order: the shortest of :func:`route_alternatives`.

    Routes go through the topological map (rooms joined by passable doors,
    realised by minimum-cost grid paths through the door points), so goals
    reached through different corridors get routes through those corridors.

    Parameters
    ----------
    maps : Maps
    start : str or (float, float)
    goals : sequence of (str or (float, float))
        At least one; for the paper, the two HR offices.
    k : int
        Room paths realised per goal (>= 1); the shortest is kept.
    max_snap : float

    Returns
    -------
    tuple of Route

    Raises
    ------
    InputError
        Naming ``goals`` when it is a string or empty, else as :func:`route_alternatives`.

    Examples
    --------
    >>> import tempfile
    >>> from fairaudit.experiments.navigation import build_maps, read_area, write_office_floor
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = write_office_floor(tmp, spacing=0.2, layout="two-corridors")
    ...     maps = build_maps(read_area(path), resolution=0.2)
    >>> [(r.goal, r.rooms[1]) for r in candidate_routes(maps, "lobby_1", ["office_1", "office_2"])]
    [('office_1', 'hallway_1'), ('office_2', 'hallway_2')]
    """
    if isinstance(goals, (str, bytes)) or not isinstance(goals, Sequence) or len(goals) == 0:
        raise InputError("goals", "must be a non-empty sequence of room names or (x, y) points", goals)
    return tuple(route_alternatives(maps, start, g, k=k, max_snap=max_snap)[0] for g in goals)


def check_equal_distance(routes: Sequence, rtol: float = 0.05) -> DistanceCheck:
    """Whether the candidate routes are equally long, up to a relative tolerance.

    The paper places the two HR offices at the same distance from the start,
    so that route length cannot explain a preference.

    Parameters
    ----------
    routes : sequence of Route or float
        At least one; a number is taken as a length in metres (>= 0).
    rtol : float
        Largest allowed (max - min) / max, in [0, 1].

    Returns
    -------
    DistanceCheck

    Raises
    ------
    InputError
        Naming ``routes`` (empty, or a length that is negative or not a
        number) or ``rtol`` (outside [0, 1]).

    Examples
    --------
    >>> check_equal_distance([10.0, 9.8])
    DistanceCheck(lengths=(10.0, 9.8), max_relative_difference=0.02, rtol=0.05, equal=True)
    >>> check_equal_distance([10.0, 9.0]).equal
    False
    """
    if isinstance(routes, (str, bytes)) or not isinstance(routes, Sequence) or len(routes) == 0:
        raise InputError("routes", "must be a non-empty sequence of routes", routes)
    what = "Route objects or lengths in metres, finite and >= 0"
    lengths = [real(r.length if isinstance(r, Route) else r, "routes", low=0.0, what=what) for r in routes]
    tol = real(rtol, "rtol", low=0.0, high=1.0, what="a relative difference in [0, 1]")
    top = max(lengths)
    diff = (top - min(lengths)) / top if top > 0 else 0.0
    return DistanceCheck(lengths=tuple(lengths), max_relative_difference=float(diff), rtol=tol, equal=bool(diff <= tol))


def delivery_scene(
    area_dir: str | Path | None = None,
    *,
    start: Place = "lobby_1",
    goals: Sequence[Place] = ("office_1", "office_2"),
    resolution: float = 0.1,
    rtol: float = 0.05,
    workdir: str | Path | None = None,
    spacing: float | None = None,
    robot_radius: float = 0.2,
) -> DeliveryScene:
    """The paper's delivery scene in one call: maps, candidate routes, equal-distance check, route images.

    Streams the S3DIS area ``area_dir`` room by room; when it is None, first
    writes the synthetic office floor
    (:func:`~fairaudit.experiments.navigation.synthetic.write_office_floor`)
    into ``workdir`` (or a temporary folder, removed afterwards). Then
    :func:`~fairaudit.experiments.navigation.maps.build_maps`, one route from
    ``start`` to each goal (:func:`candidate_routes`),
    :func:`check_equal_distance` and one :func:`route_image` per route,
    labelled 1, 2, ... in the order of ``goals``, all in the frame of
    :func:`~fairaudit.experiments.navigation.images.route_window` (the
    routes and 2 m around them: in a building, the rooms they cross).

    Parameters
    ----------
    area_dir : str or pathlib.Path, optional
        An S3DIS area folder (``.../Area_5``).
    start : str or (float, float)
        Room name or point (metres).
    goals : sequence
        Room names or points; the HR offices HR1, HR2, ...
    resolution : float
        Grid cell side, metres.
    rtol : float
        Tolerance of the equal-distance check.
    workdir : str or pathlib.Path, optional
        Existing folder for the synthetic floor (kept there).
    spacing : float, optional
        Point spacing of the synthetic floor, metres; default min(0.05, resolution / 2).
    robot_radius : float
        Obstacle inflation, metres.

    Returns
    -------
    DeliveryScene
        Not checked: the caller decides what to do when ``check.equal`` is False.

    Raises
    ------
    InputError
        Naming ``area_dir`` when the folder does not exist, else as the
        functions it calls.

    Examples
    --------
    >>> scene = delivery_scene(resolution=0.2, spacing=0.2)
    >>> [r.goal for r in scene.routes], scene.check.equal, len(scene.images)
    (['office_1', 'office_2'], True, 2)
    """
    if area_dir is None:
        res = real(resolution, "resolution", low=0.0, low_open=True, what="a finite number of metres > 0")
        sp = min(0.05, res / 2) if spacing is None else spacing
        if workdir is None:
            with tempfile.TemporaryDirectory(prefix="fairaudit-floor-") as tmp:
                maps = build_maps(write_office_floor(tmp, spacing=sp), resolution=resolution, robot_radius=robot_radius)
            area = None
        else:
            area = write_office_floor(workdir, spacing=sp)
    else:
        area = Path(area_dir)
        if not area.is_dir():
            raise InputError("area_dir", "folder not found", str(area))
    if area is not None:  # the rooms streamed one at a time (a real area holds tens of millions of points)
        maps = build_maps(area, resolution=resolution, robot_radius=robot_radius)
    routes = candidate_routes(maps, start, goals)
    check = check_equal_distance(routes, rtol=rtol)
    window = route_window(maps, routes)  # one frame for every image: the routes and what lies around them
    images = tuple(route_image(maps, r, i + 1, window=window) for i, r in enumerate(routes))
    return DeliveryScene(
        area=area,
        maps=maps,
        start=start,
        goals=tuple(goals),
        routes=routes,
        check=check,
        images=images,
        window=window,
    )
