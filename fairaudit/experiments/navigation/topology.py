"""Doors and room-level paths through the topological map, realised on the traversability grid.

The paper's delivery scene shows candidate routes that go through different
rooms (two offices reached through different corridors). The topological map
of :func:`~fairaudit.experiments.navigation.maps.build_maps` has one node per
room; this module finds where the robot can actually pass from one room to
the next (:func:`find_doors`), the graph of those passable doors
(:func:`passable_graph`), and realises room paths on the grid
(:func:`door_paths`): the k shortest simple paths of rooms
(:func:`networkx.shortest_simple_paths`), each turned into a minimum-cost
8-connected grid path from the start cell through one door point per pair of
successive rooms to the goal cell.

Grid moves and costs are those of
:func:`~fairaudit.experiments.navigation.routes.plan_route`
(:func:`grid_edges`): a straight step costs the resolution, a diagonal one
resolution·√2 and needs all four cells of its 2 x 2 block traversable.
"""

from __future__ import annotations

import functools
import itertools
import math
import weakref
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING, TypeVar

import numpy as np

from fairaudit import InputError, whole

from .maps import Maps, check_maps, require_networkx

if TYPE_CHECKING:
    import networkx

__all__ = ["Door", "DoorPath", "cell_points", "door_paths", "find_doors", "grid_edges", "passable_graph", "path_length"]

#: Room paths tried per requested candidate before giving up (some may not be realisable on the grid).
TRIES_PER_CANDIDATE = 4

_SEARCHES: weakref.WeakKeyDictionary[Maps, dict[tuple[int, int], _Search]] = weakref.WeakKeyDictionary()


@dataclass(frozen=True, eq=False, kw_only=True)
class Door:
    """One opening through which the robot can pass from one room to another.

    Attributes
    ----------
    rooms : tuple of str
        The two rooms, in the order of :attr:`Maps.rooms`.
    cell : tuple of int
        (row, col) of the door point: the cell of the opening nearest to the
        opening's centroid (ties: a cell of ``rooms[0]``, then the smallest
        (row, col), so that mirror-image doors between alike-named rooms get
        mirror-image points).
    point : tuple of float
        (x, y) of the centre of that cell, metres.
    cells : numpy.ndarray
        Shape (n, 2), int64: (row, col) of every cell of the opening, in
        row-major order: the traversable cells of either room joined by a
        grid move (:func:`grid_edges`) to a traversable cell of the other.
    central : numpy.ndarray
        Shape (m, 2), int64, 1 <= m <= 4: the opening cells tied nearest to
        its centroid (``cell`` first, then row-major). An opening an even
        number of cells wide has no middle cell; a route may pass through
        any of these (:func:`door_paths` takes the one that makes it
        shortest), so that mirror-image floors give routes of equal length.
    """

    rooms: tuple[str, str]
    cell: tuple[int, int]
    point: tuple[float, float]
    cells: np.ndarray
    central: np.ndarray


@dataclass(frozen=True, eq=False, kw_only=True)
class DoorPath:
    """A room path realised on the grid (see :func:`door_paths`).

    Attributes
    ----------
    via : tuple of str
        The room path, from the start cell's room to the goal cell's room.
    doors : tuple of Door
        The door passed between each pair of successive rooms of ``via``
        (``len(via) - 1`` of them).
    door_cells : tuple of tuple of int
        (row, col) of the cell by which the path passes each door: one of its
        :attr:`Door.central` cells.
    cells : numpy.ndarray
        Shape (k, 2), int64: (row, col) of each cell from start to goal;
        consecutive cells are 8-neighbours; the door cells are among them.
    length : float
        Sum of the step costs, metres.
    """

    via: tuple[str, ...]
    doors: tuple[Door, ...]
    door_cells: tuple[tuple[int, int], ...]
    cells: np.ndarray
    length: float


_T = TypeVar("_T")


def per_maps(build: Callable[[Maps], _T]) -> Callable[[Maps], _T]:
    """``build(maps)`` made once per :class:`Maps`, after :func:`check_maps`, and kept as long as the maps are.

    A decorator: the doors, the passable graph and the A* grid graph are each computed once per map.

    Parameters
    ----------
    build : callable
        ``build(maps)``, a pure function of the maps.

    Returns
    -------
    callable
        ``build`` with the same name and docstring, whose results are held in a
        :class:`weakref.WeakKeyDictionary` keyed by the maps.

    Raises
    ------
    InputError
        (When called) naming ``maps`` when it is not a :class:`Maps`.
    """
    made: weakref.WeakKeyDictionary[Maps, _T] = weakref.WeakKeyDictionary()

    @functools.wraps(build)
    def cached(maps: Maps) -> _T:
        check_maps(maps)
        if maps not in made:
            made[maps] = build(maps)
        return made[maps]

    return cached


def path_length(cells: np.ndarray, resolution: float) -> float:
    """The length of a grid path: the sum of its step costs, those of :func:`grid_edges`.

    Parameters
    ----------
    cells : numpy.ndarray
        int, shape (k, 2): (row, col) of each cell of the path; consecutive cells are 8-neighbours.
    resolution : float
        Side of a cell, metres.

    Returns
    -------
    float
        Metres: ``resolution`` per straight step, ``resolution``·√2 per diagonal one.

    Examples
    --------
    >>> round(path_length(np.array([[0, 0], [0, 1], [1, 2]]), 0.5), 6)
    1.207107
    """
    steps = np.abs(np.diff(cells, axis=0)).sum(axis=1)
    return float(resolution * (np.sum(steps == 1) + math.sqrt(2.0) * np.sum(steps == 2)))


def cell_points(maps: Maps, cells: Iterable[tuple[int, int]]) -> tuple[tuple[float, float], ...]:
    """The centres of grid cells in world coordinates, as :attr:`Door.point` writes them.

    Parameters
    ----------
    maps : Maps
    cells : iterable of (int, int)
        (row, col) of each cell.

    Returns
    -------
    tuple of (float, float)
        (x, y) of each cell's centre, metres, rounded to 1e-9 m.
    """
    centres = (maps.cell_to_world(r, c) for r, c in cells)
    return tuple((round(float(x), 9), round(float(y), 9)) for x, y in centres)


def grid_edges(traversable: np.ndarray, resolution: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The 8-connected grid graph of the traversable cells, as edge lists on flat cell indices.

    A straight move joins two traversable cells sharing a side and costs
    ``resolution``; a diagonal move costs ``resolution``·√2 and exists only
    when the four cells of its 2 x 2 block are traversable (no cutting of
    obstacle corners).

    Parameters
    ----------
    traversable : numpy.ndarray
        bool, shape (rows, cols), indexed [row, col].
    resolution : float
        Side of a cell, metres.

    Returns
    -------
    u, v : numpy.ndarray
        int64, shape (m,): flat indices (``row * cols + col``) of the two ends
        of each undirected edge, each edge once.
    weight : numpy.ndarray
        float64, shape (m,): its cost, metres.

    Examples
    --------
    >>> t = np.array([[True, True], [True, False]])
    >>> u, v, w = grid_edges(t, 1.0)
    >>> sorted(zip(u.tolist(), v.tolist())), w.tolist()
    ([(0, 1), (0, 2)], [1.0, 1.0])
    """
    rows, cols = traversable.shape
    idx = np.arange(rows * cols, dtype=np.int64).reshape(rows, cols)
    t = np.asarray(traversable, dtype=bool)
    block = t[:-1, :-1] & t[1:, 1:] & t[:-1, 1:] & t[1:, :-1]  # the four cells of a 2 x 2 block
    moves = [
        (t[:, :-1] & t[:, 1:], idx[:, :-1], idx[:, 1:], resolution),  # east
        (t[:-1, :] & t[1:, :], idx[:-1, :], idx[1:, :], resolution),  # north
        (block, idx[:-1, :-1], idx[1:, 1:], resolution * math.sqrt(2.0)),  # north-east
        (block, idx[:-1, 1:], idx[1:, :-1], resolution * math.sqrt(2.0)),  # north-west
    ]
    us = [a[m] for m, a, _, _ in moves]
    vs = [b[m] for m, _, b, _ in moves]
    ws = [np.full(int(m.sum()), w) for m, _, _, w in moves]
    return np.concatenate(us), np.concatenate(vs), np.concatenate(ws)


@per_maps
def find_doors(maps: Maps) -> tuple[Door, ...]:
    """The passable openings between rooms, with one door point each.

    For each pair of rooms, the opening cells are the traversable cells of
    either room joined by a grid move (:func:`grid_edges`) to a traversable
    cell of the other; they are grouped into openings by 8-connectivity, so
    two rooms sharing two doors get two :class:`Door` objects. A door's point
    is the opening cell nearest to the opening's centroid (ties: a cell of the
    first of the two rooms in :attr:`Maps.rooms`, then the smallest (row,
    col)). Rooms that touch only through non-traversable cells (a door
    narrower than the robot, after the obstacle inflation of
    :func:`~fairaudit.experiments.navigation.maps.build_maps`) or through a
    scan gap (topology edges ``via="gap"``) have no door: the robot cannot
    pass there. Vectorised over cells; computed once per :class:`Maps`.

    Parameters
    ----------
    maps : Maps

    Returns
    -------
    tuple of Door
        Sorted by the pair of room indices, then by the door cell (row, col).

    Raises
    ------
    InputError
        Naming ``maps`` when it is not a :class:`Maps`.

    Examples
    --------
    >>> import tempfile
    >>> from fairaudit.experiments.navigation import build_maps, read_area, write_office_floor
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     maps = build_maps(read_area(write_office_floor(tmp, spacing=0.2)), resolution=0.2)
    >>> [(d.rooms, d.point) for d in find_doors(maps) if "office_1" in d.rooms]
    [(('hallway_1', 'office_1'), (2.9, 4.9))]
    """
    from scipy import ndimage

    cols = maps.shape[1]
    labels = maps.room_labels.ravel().astype(np.int64)
    u, v, _ = grid_edges(maps.traversable, maps.resolution)
    lu, lv = labels[u], labels[v]
    cross = (lu != lv) & (lu >= 0) & (lv >= 0)
    a, b = np.minimum(lu[cross], lv[cross]), np.maximum(lu[cross], lv[cross])
    table = np.unique(np.concatenate([np.column_stack([a, b, u[cross]]), np.column_stack([a, b, v[cross]])]), axis=0)
    if len(table) == 0:
        return ()
    starts = np.flatnonzero(np.r_[True, (np.diff(table[:, :2], axis=0) != 0).any(axis=1)])
    doors = []
    for lo, hi in zip(starts, np.r_[starts[1:], len(table)]):  # one pair of rooms at a time
        pair = (maps.rooms[int(table[lo, 0])], maps.rooms[int(table[lo, 1])])
        flat = table[lo:hi, 2]
        r, c = flat // cols, flat % cols
        r0, c0 = int(r.min()), int(c.min())
        mask = np.zeros((int(r.max()) - r0 + 1, int(c.max()) - c0 + 1), dtype=bool)
        mask[r - r0, c - c0] = True
        comp, n = ndimage.label(mask, structure=np.ones((3, 3), dtype=bool))
        first = maps.room_labels[r0 : r0 + mask.shape[0], c0 : c0 + mask.shape[1]] == table[lo, 0]
        for k in range(1, n + 1):
            cr, cc = np.nonzero(comp == k)  # row-major
            d2 = np.round((cr - cr.mean()) ** 2 + (cc - cc.mean()) ** 2, 9)
            order = np.lexsort((~first[cr, cc], d2))  # nearest; ties: first room's side, then row-major
            best = int(order[0])
            cell = (int(cr[best]) + r0, int(cc[best]) + c0)
            cells = np.column_stack([cr + r0, cc + c0]).astype(np.int64)
            central = cells[order[d2[order] == d2[best]]]
            for a in (cells, central):
                a.setflags(write=False)
            doors.append(Door(rooms=pair, cell=cell, point=cell_points(maps, [cell])[0], cells=cells, central=central))
    return tuple(sorted(doors, key=lambda d: (maps.rooms.index(d.rooms[0]), maps.rooms.index(d.rooms[1]), d.cell)))


@per_maps
def passable_graph(maps: Maps) -> networkx.Graph:
    """The rooms joined by passable doors (:func:`find_doors`), for room-level path search.

    Parameters
    ----------
    maps : Maps

    Returns
    -------
    networkx.Graph
        Frozen. One node per room of :attr:`Maps.rooms` (rooms without any
        door are isolated), with ``centre`` (x, y, metres: the topology's
        centre; NaN for a room without points, which has no cell). An edge per pair of rooms
        with at least one door, with ``doors`` (tuple of :class:`Door`) and
        ``weight``: the shortest centre -> door point -> centre leg over its
        doors, Euclidean, metres. Edges of the topology through which the
        robot cannot pass (narrow doors, scan gaps) are left out. Cached per
        :class:`Maps`.

    Raises
    ------
    InputError
        Naming ``maps`` when it is not a :class:`Maps`; naming
        ``navigation`` when networkx is missing.

    Examples
    --------
    >>> import tempfile
    >>> from fairaudit.experiments.navigation import build_maps, read_area, write_office_floor
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     maps = build_maps(read_area(write_office_floor(tmp, spacing=0.2)), resolution=0.2)
    >>> g = passable_graph(maps)
    >>> sorted(g.neighbors("office_1")), round(g.edges["hallway_1", "office_1"]["weight"], 2)
    (['hallway_1'], 5.06)
    """
    nx = require_networkx()
    centres = np.array([maps.topology.nodes[name]["centre"] for name in maps.rooms], dtype=float).reshape(-1, 2)
    graph = nx.Graph()
    for i, name in enumerate(maps.rooms):
        graph.add_node(name, centre=(float(centres[i, 0]), float(centres[i, 1])))
    doors = find_doors(maps)
    for (a, b), group in itertools.groupby(doors, key=lambda d: d.rooms):
        ds = tuple(group)
        ca, cb = centres[maps.rooms.index(a)], centres[maps.rooms.index(b)]
        legs = [math.hypot(*(ca - d.point)) + math.hypot(*(cb - d.point)) for d in ds]
        graph.add_edge(a, b, doors=ds, weight=float(np.nan_to_num(min(legs), nan=0.0)))
    return nx.freeze(graph)


# -- segments: shortest grid paths whose intermediate cells lie in one room --------------------------------


@dataclass(frozen=True, eq=False)
class _Search:
    """Dijkstra from one source cell over one room: the bounding box, distances and predecessors."""

    origin: tuple[int, int]  # (row, col) of the box's first cell
    width: int  # columns of the box
    dist: np.ndarray  # (box cells,), metres; inf: unreachable
    pred: np.ndarray  # (box cells,), local predecessor; -9999: none


def _search(maps: Maps, room: int, source: tuple[int, int]) -> _Search:
    """Shortest paths from ``source`` whose intermediate cells are traversable cells of ``room``.

    The graph holds the room's traversable cells, ``source`` and the door
    points of the room's doors; edges are the grid moves of
    :func:`grid_edges` on the whole traversability map (the corner rule sees
    every room), directed so that only the source and the room's cells have
    outgoing moves: a path can end on a door point of a neighbouring room but
    never pass through another room.
    """
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import dijkstra

    cache = _SEARCHES.setdefault(maps, {})
    key = (room, source[0] * maps.shape[1] + source[1])
    if key in cache:
        return cache[key]
    name = maps.rooms[room]
    inner = maps.traversable & (maps.room_labels == room)
    nodes = inner.copy()
    for d in find_doors(maps):
        if name in d.rooms:
            nodes[d.central[:, 0], d.central[:, 1]] = True
    nodes[source] = True
    r, c = np.nonzero(nodes)
    r0, r1, c0, c1 = int(r.min()), int(r.max()) + 1, int(c.min()), int(c.max()) + 1
    width = c1 - c0
    box_inner = inner[r0:r1, c0:c1].ravel().copy()
    box_inner[(source[0] - r0) * width + source[1] - c0] = True  # the source may leave, too
    box_nodes = nodes[r0:r1, c0:c1].ravel()
    u, v, w = grid_edges(maps.traversable[r0:r1, c0:c1], maps.resolution)
    fwd = box_inner[u] & box_nodes[v]
    bwd = box_inner[v] & box_nodes[u]
    n = (r1 - r0) * width
    graph = csr_matrix(
        (np.r_[w[fwd], w[bwd]], (np.r_[u[fwd], v[bwd]], np.r_[v[fwd], u[bwd]])), shape=(n, n), dtype=float
    )
    src = (source[0] - r0) * width + source[1] - c0
    dist, pred = dijkstra(graph, directed=True, indices=src, return_predecessors=True)
    out = _Search(origin=(r0, c0), width=width, dist=dist, pred=pred)
    cache[key] = out
    return out


def _distance(search: _Search, cell: tuple[int, int]) -> float:
    lr, lc = cell[0] - search.origin[0], cell[1] - search.origin[1]
    if not (0 <= lr < len(search.dist) // search.width and 0 <= lc < search.width):
        return math.inf
    return float(search.dist[lr * search.width + lc])


def _cells(search: _Search, cell: tuple[int, int]) -> np.ndarray:
    """(k, 2) cells of the path from the search's source to ``cell`` (reachable), source first."""
    at = (cell[0] - search.origin[0]) * search.width + cell[1] - search.origin[1]
    path = [at]
    while search.pred[at] >= 0:  # one step per path cell
        at = int(search.pred[at])
        path.append(at)
    flat = np.asarray(path[::-1], dtype=np.int64)
    return np.column_stack([flat // search.width + search.origin[0], flat % search.width + search.origin[1]])


def _realise(maps: Maps, via: list[str], start: tuple[int, int], goal: tuple[int, int]) -> DoorPath | None:
    """The shortest realisation of one room path over its door choices (dynamic programming), or None."""
    graph = passable_graph(maps)
    index = {name: i for i, name in enumerate(maps.rooms)}
    layers: list[list[tuple[tuple[int, int], Door | None]]] = [[(start, None)]]
    for a, b in zip(via[:-1], via[1:]):
        layers.append([((int(r), int(c)), d) for d in graph.edges[a, b]["doors"] for r, c in d.central])
    layers.append([(goal, None)])
    cost = [0.0]
    back: list[list[int]] = []
    for i, room in enumerate(via):  # layer i -> layer i + 1 through room via[i]
        searches = [_search(maps, index[room], cell) for cell, _ in layers[i]]
        step = np.array([[_distance(s, cell) for cell, _ in layers[i + 1]] for s in searches])
        total = np.asarray(cost)[:, None] + step
        back.append(np.argmin(total, axis=0).tolist())
        cost = total.min(axis=0).tolist()
    if not math.isfinite(cost[0]):
        return None
    choice = [0]
    for pointers in reversed(back):
        choice.append(pointers[choice[-1]])
    choice = choice[::-1]  # index of the chosen waypoint in each layer
    pieces = []
    for i, room in enumerate(via):
        search = _search(maps, index[room], layers[i][choice[i]][0])
        piece = _cells(search, layers[i + 1][choice[i + 1]][0])
        pieces.append(piece if i == 0 else piece[1:])
    cells = np.concatenate(pieces)
    length = path_length(cells, maps.resolution)
    cells.setflags(write=False)
    doors = tuple(d for i in range(1, len(via)) if (d := layers[i][choice[i]][1]) is not None)
    door_cells = tuple(layers[i][choice[i]][0] for i in range(1, len(via)))
    return DoorPath(via=tuple(via), doors=doors, door_cells=door_cells, cells=cells, length=length)


def door_paths(maps: Maps, start: tuple[int, int], goal: tuple[int, int], *, k: int = 3) -> tuple[DoorPath, ...]:
    """Up to ``k`` grid paths from ``start`` to ``goal`` through different room paths, shortest first.

    1. Room paths: :func:`networkx.shortest_simple_paths` on
       :func:`passable_graph` from the room of the start cell to the room of
       the goal cell, by the Euclidean centre -> door -> centre legs
       (the legs from the start cell to its room's centre and from the goal
       room's centre to the goal cell are the same for every room path).
    2. Each room path is realised on the grid: a segment per room, from the
       start cell or the door point by which the path enters the room to the
       door point by which it leaves (or the goal cell); a segment is a
       minimum-cost path of grid moves (:func:`grid_edges`, those of
       :func:`~fairaudit.experiments.navigation.routes.plan_route`) whose
       intermediate cells are all traversable cells of that room. The
       restriction makes the route really pass through the room path's door
       (a segment cannot take a short cut through a third room) and keeps
       every search on one room's bounding box. When two rooms share several
       doors, the door sequence of least total length is taken (dynamic
       programming over the doors, with the exact segment lengths). A room
       path is skipped when a room's traversable cells do not join its
       entrance and exit (furniture splitting a room). Each search is one
       :func:`scipy.sparse.csgraph.dijkstra` from a waypoint over the room's
       bounding box (the same minimum costs as A*, to every exit of the room
       at once), cached per :class:`Maps`; the whole-grid graph of
       :func:`~fairaudit.experiments.navigation.routes.plan_route` is never built.
    3. Room paths are taken in order until ``k`` are realised (at most
       ``TRIES_PER_CANDIDATE * k`` tried); the realised paths are sorted by
       length (stable: ties keep the search order).

    Parameters
    ----------
    maps : Maps
    start, goal : tuple of int
        (row, col) of traversable cells.
    k : int
        Largest number of paths returned (>= 1).

    Returns
    -------
    tuple of DoorPath
        Distinct room paths, sorted by length; empty when the goal's room
        cannot be reached through passable doors.

    Raises
    ------
    InputError
        Naming ``maps``, ``start`` or ``goal`` (not a traversable cell) or
        ``k``; naming ``navigation`` when networkx is missing.

    Examples
    --------
    >>> import tempfile
    >>> from fairaudit.experiments.navigation import build_maps, read_area, write_office_floor
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     maps = build_maps(read_area(write_office_floor(tmp, spacing=0.2)), resolution=0.2)
    >>> [(p.via, round(p.length, 2)) for p in door_paths(maps, (7, 30), (32, 10))]
    [(('lobby_1', 'hallway_1', 'office_1'), 7.24)]
    """
    check_maps(maps)
    whole(k, "k", low=1)
    cells = []
    for field, cell in (("start", start), ("goal", goal)):
        try:
            rc = (int(cell[0]), int(cell[1]))
        except (TypeError, ValueError, IndexError):
            raise InputError(field, "must be a (row, col) cell", cell) from None
        if not (bool(maps.contains(*rc)) and maps.traversable[rc]):
            raise InputError(field, "must be a traversable (row, col) cell", cell)
        cells.append(rc)
    nx = require_networkx()
    graph = passable_graph(maps)
    ends = [maps.rooms[int(maps.room_labels[c])] for c in cells]
    found: list[DoorPath] = []
    try:
        for via in itertools.islice(nx.shortest_simple_paths(graph, *ends, weight="weight"), TRIES_PER_CANDIDATE * k):
            path = _realise(maps, via, cells[0], cells[1])
            if path is not None:
                found.append(path)
                if len(found) == k:
                    break
    except nx.NetworkXNoPath:
        return ()
    return tuple(sorted(found, key=lambda p: p.length))
