"""Tests of candidate routes through the topological map: doors, room paths, their realisation on the grid.

Expected values come from a hand-made S3DIS area on a 1 m grid (doors and
route lengths worked out by hand below), from counts of simple room paths
made by hand on the two-corridor floor, and from an independent shortest-path
computation (scipy.sparse.csgraph.dijkstra on a grid graph built here, with
the same restriction of each segment to one room).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("networkx")

from scipy.sparse import coo_matrix  # noqa: E402
from scipy.sparse.csgraph import dijkstra  # noqa: E402

from fairaudit.base.errors import InputError  # noqa: E402
from fairaudit.experiments.navigation import (  # noqa: E402
    build_maps,
    candidate_routes,
    check_equal_distance,
    plan_route,
    read_area,
    write_office_floor,
)
from fairaudit.experiments.navigation.routes import route_alternatives  # noqa: E402
from fairaudit.experiments.navigation.topology import door_paths, find_doors, passable_graph  # noqa: E402

SQ2 = math.sqrt(2.0)


# -- helpers ----------------------------------------------------------------------------------------------


def _rows(points) -> str:
    return "".join(f"{x} {y} {z} 100 100 100\n" for x, y, z in points)


def _cells(cols, rows, z):
    """Points at the centres of 1 m cells (col, row) at height z."""
    return [(c + 0.5, r + 0.5, z) for c in cols for r in rows]


def _write_room(area: Path, name: str, files: dict[str, str]) -> None:
    (area / name / "Annotations").mkdir(parents=True)
    for inst, text in files.items():
        (area / name / "Annotations" / f"{inst}.txt").write_text(text)


@pytest.fixture(scope="module")
def two_doors(tmp_path_factory):
    """Two rooms sharing two doors, on a 1 m grid of 7 rows (y) x 8 cols (x)::

    row 6   A A A W | B B B B       A lobby_1 (cols 0-3), B office_1 (cols 4-7)
    row 5   A A A . | B B B B       W lobby_1's wall in col 3 (rows 0, 4, 6), 1.5 m high
    row 4   A A A W | B B B B       . floor: a 3 m door (rows 1-3) and a 1 m door (row 5)
    row 3   A A A . | B B B B
    row 2   A A A . | B B B B
    row 1   A A A . | B B B B
    row 0   A A A W | B B B B
    """
    area = tmp_path_factory.mktemp("doors") / "Area_8"
    area.mkdir()
    walls = [0, 4, 6]
    _write_room(
        area,
        "lobby_1",
        {
            "floor_1": _rows(_cells(range(4), range(7), 0.0)),
            "wall_1": _rows(_cells([3], walls, 0.5) + _cells([3], walls, 1.5)),
        },
    )
    _write_room(area, "office_1", {"floor_1": _rows(_cells(range(4, 8), range(7), 0.0))})
    return read_area(area)


@pytest.fixture(scope="module")
def two(tmp_path_factory):
    """The two-corridor floor at 0.1 m spacing and its maps (0.1 m cells, robot radius 0.2 m)."""
    path = write_office_floor(tmp_path_factory.mktemp("two"), spacing=0.1, layout="two-corridors")
    return build_maps(read_area(path), resolution=0.1)


def _cell(m, point) -> tuple[int, int]:
    r, c = m.world_to_cell(*point)
    return int(r), int(c)


def _restricted_length(m, room: str, p: tuple[int, int], q: tuple[int, int]) -> float:
    """Shortest grid path p -> q (8 moves, no corner cutting) whose intermediate cells are traversable cells of room.

    Built independently of the package: every move between traversable 8-neighbours, a diagonal only when both
    cells beside it are traversable; a move a -> b is kept when a is p or in the room and b is q or in the room.
    """
    t = m.traversable
    rows, cols = t.shape
    inside = t & (m.room_labels == m.rooms.index(room))
    leave = inside.copy()
    leave[p] = True
    enter = inside.copy()
    enter[q] = True
    r, c = np.nonzero(leave)
    src, dst, w = [], [], []
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            if dr == dc == 0:
                continue
            r2, c2 = r + dr, c + dc
            ok = (r2 >= 0) & (r2 < rows) & (c2 >= 0) & (c2 < cols)
            ok[ok] &= enter[r2[ok], c2[ok]]
            if dr and dc:
                ok[ok] &= t[r2[ok], c[ok]] & t[r[ok], c2[ok]]
            src.append(r[ok] * cols + c[ok])
            dst.append(r2[ok] * cols + c2[ok])
            w.append(np.full(int(ok.sum()), m.resolution * math.hypot(dr, dc)))
    n = rows * cols
    graph = coo_matrix((np.concatenate(w), (np.concatenate(src), np.concatenate(dst))), shape=(n, n)).tocsr()
    return float(dijkstra(graph, directed=True, indices=p[0] * cols + p[1])[q[0] * cols + q[1]])


def _check_route(m, route) -> None:
    """Grid validity, doors on the route in order, and the length against the independent restricted Dijkstra."""
    cells = route.cells
    assert m.traversable[cells[:, 0], cells[:, 1]].all()
    steps = np.abs(np.diff(cells, axis=0))
    assert steps.max() == 1 and steps.sum(axis=1).min() >= 1
    assert len(route.doors) == len(route.via) - 1
    where = [int(np.flatnonzero((cells == _cell(m, d)).all(axis=1))[0]) for d in route.doors]
    assert where == sorted(where) and len(set(where)) == len(where)  # each door point on the route, in order
    assert route.rooms == route.via
    waypoints = [tuple(cells[0])] + [_cell(m, d) for d in route.doors] + [tuple(cells[-1])]
    expected = sum(_restricted_length(m, room, p, q) for room, p, q in zip(route.via, waypoints, waypoints[1:]))
    assert route.length == pytest.approx(expected, abs=1e-9)
    np.testing.assert_allclose(np.hypot(*np.diff(route.points, axis=0).T).sum(), route.length)


# -- doors ------------------------------------------------------------------------------------------------


def test_two_doors_between_two_rooms(two_doors):
    m = build_maps(two_doors, resolution=1.0, robot_radius=0.0)
    assert m.shape == (7, 8) and m.rooms == ("lobby_1", "office_1")
    doors = find_doors(m)
    assert len(doors) == 2 and all(d.rooms == ("lobby_1", "office_1") for d in doors)
    # the 3 m door: cols 3 and 4 of rows 1-3 (diagonals within it are allowed); centroid (2, 3.5): tie broken
    # towards lobby_1, the first room; the 1 m door: the two cells of row 5
    assert [d.cell for d in doors] == [(2, 3), (5, 3)]
    assert [d.point for d in doors] == [(3.5, 2.5), (3.5, 5.5)]
    assert doors[0].cells.tolist() == [[1, 3], [1, 4], [2, 3], [2, 4], [3, 3], [3, 4]]
    assert doors[1].cells.tolist() == [[5, 3], [5, 4]]
    # both openings are an even number of cells wide: two cells tie for the middle, the door cell first
    assert doors[0].central.tolist() == [[2, 3], [2, 4]] and doors[1].central.tolist() == [[5, 3], [5, 4]]
    assert find_doors(m) is doors  # cached per Maps
    assert passable_graph(m).edges["lobby_1", "office_1"]["doors"] == doors


def test_the_nearer_door_is_taken(two_doors):
    m = build_maps(two_doors, resolution=1.0, robot_radius=0.0)
    # (6, 0) -> (5, 1) -> (5, 2) -> (5, 3) | (5, 4) -> (5, 5) -> (5, 6) -> (6, 7): 5 + 2√2 through the 1 m door
    (route,) = route_alternatives(m, (0.5, 6.5), (7.5, 6.5))
    assert route.via == ("lobby_1", "office_1") and route.doors == ((3.5, 5.5),)
    assert route.length == pytest.approx(5 + 2 * SQ2, abs=1e-12)
    assert route.length == pytest.approx(plan_route(m, (0.5, 6.5), (7.5, 6.5)).length, abs=1e-12)
    (low,) = route_alternatives(m, (0.5, 0.5), (7.5, 0.5))  # (0, 0) -> (1, 1) -> (2, 2) -> (2, 3): the wide door
    assert low.doors == ((3.5, 2.5),)
    # (0,0)->(1,1)->(2,2)->(2,3) is 2√2 + 1; (2,3)->(2,4)->(1,5)->(0,6)->(0,7) is 1 + 2√2 + 1
    assert low.length == pytest.approx(3 + 4 * SQ2, abs=1e-12)
    _check_route(m, route)
    _check_route(m, low)
    (path,) = door_paths(m, (6, 0), (6, 7), k=2)
    assert path.door_cells in (((5, 3),), ((5, 4),)) and path.doors == (find_doors(m)[1],)
    np.testing.assert_array_equal(path.cells, route.cells)


def test_a_route_along_the_door_row(two_doors):
    m = build_maps(two_doors, resolution=1.0, robot_radius=0.0)
    # (5, 5) -> (5, 4) -> (5, 3) -> (5, 2) -> (5, 1) -> (6, 0): 4 + √2, through both middle cells of the 1 m door
    (r,) = route_alternatives(m, (5.5, 5.5), (0.5, 6.5))
    assert r.length == pytest.approx(4 + SQ2, abs=1e-12) and r.doors in (((3.5, 5.5),), ((4.5, 5.5),))
    assert r.rooms == r.via == ("office_1", "lobby_1")
    _check_route(m, r)


def test_a_door_narrower_than_the_robot_is_no_door(two_doors):
    m = build_maps(two_doors, resolution=1.0, robot_radius=1.0)
    # the 1 m door's cell has walls 1 m away: not traversable; of the 3 m door only its middle row remains
    (door,) = find_doors(m)
    assert door.cell == (2, 3) and door.cells.tolist() == [[2, 3], [2, 4]]
    assert m.topology.has_edge("lobby_1", "office_1")


# -- the two-corridor floor -------------------------------------------------------------------------------


def test_two_corridor_floor_layout(two):
    m = two
    assert m.rooms == (
        "WC_1",
        "conferenceRoom_1",
        "hallway_1",
        "hallway_2",
        "lobby_1",
        "office_1",
        "office_2",
        "storage_1",
    )
    pairs = {d.rooms for d in find_doors(m)}
    assert pairs == {
        ("WC_1", "hallway_2"),
        ("conferenceRoom_1", "hallway_1"),
        ("conferenceRoom_1", "hallway_2"),
        ("hallway_1", "lobby_1"),
        ("hallway_2", "lobby_1"),
        ("hallway_1", "office_1"),
        ("hallway_2", "office_2"),
    }
    assert len(find_doors(m)) == 7  # one door per pair
    # storage_1 touches hallway_1 (free cells meet under its 0.3 m gap) but the robot cannot pass
    assert m.topology.has_edge("hallway_1", "storage_1")
    assert not passable_graph(m).has_edge("hallway_1", "storage_1")
    assert (m.traversable & (m.room_labels == m.rooms.index("storage_1"))).any()


def test_offices_are_reached_through_different_corridors(two):
    m = two
    r1, r2 = candidate_routes(m, "lobby_1", ("office_1", "office_2"))
    assert r1.rooms == r1.via == ("lobby_1", "hallway_1", "office_1")
    assert r2.rooms == r2.via == ("lobby_1", "hallway_2", "office_2")
    assert check_equal_distance([r1, r2], rtol=0.05).equal
    # mirror images about x = 6: the door points mirror each other
    assert [12.0 - x for x, _ in r1.doors] == pytest.approx([x for x, _ in r2.doors])
    assert [y for _, y in r1.doors] == [y for _, y in r2.doors]
    for r in (r1, r2):
        _check_route(m, r)
        assert 10.5 < r.length < 12.5  # lobby centre (6, 1.2) -> x = 2 -> up to y = 5.8 -> office centre (4, 6.5)
        assert r.length >= plan_route(m, "lobby_1", r.goal).length - 1e-9


def test_alternatives_sorted_distinct_and_realised(two):
    m = two
    nx = pytest.importorskip("networkx")
    for goal, corridor in (("office_1", "hallway_1"), ("office_2", "hallway_2")):
        alts = route_alternatives(m, "lobby_1", goal, k=3)
        # by hand: lobby -> own corridor -> office, and lobby -> other corridor -> conference room -> own corridor
        simple = list(nx.all_simple_paths(passable_graph(m), "lobby_1", goal))
        assert len(simple) == 2 and len(alts) == 2
        assert {a.via for a in alts} == {tuple(p) for p in simple}
        assert [a.length for a in alts] == sorted(a.length for a in alts)
        assert alts[0].via == ("lobby_1", corridor, goal)
        assert "conferenceRoom_1" in alts[1].via and alts[1].length > alts[0].length + 5
        for a in alts:
            _check_route(m, a)
        (first,) = route_alternatives(m, "lobby_1", goal, k=1)
        assert first.via == alts[0].via and first.length == alts[0].length
        np.testing.assert_array_equal(first.cells, alts[0].cells)


def test_unreachable_room_and_bad_arguments(two):
    m = two
    with pytest.raises(InputError, match=r"^goal: cannot be reached from start 'lobby_1' .*\(got 'storage_1'\)"):
        route_alternatives(m, "lobby_1", "storage_1")
    with pytest.raises(InputError, match=r"^goal: .*\(got 'storage_1'\)"):
        candidate_routes(m, "lobby_1", ("office_1", "storage_1"))
    with pytest.raises(InputError, match="^goal: cannot be reached"):
        plan_route(m, "lobby_1", "storage_1")  # the plain grid agrees: no traversable way in
    for k in (0, 1.5, True, "2"):
        with pytest.raises(InputError, match="^k: must be a whole number >= 1"):
            route_alternatives(m, "lobby_1", "office_1", k=k)
    with pytest.raises(InputError, match="^goal: no such room"):
        route_alternatives(m, "lobby_1", "office_9")
    with pytest.raises(InputError, match="^maps: "):
        route_alternatives(None, "lobby_1", "office_1")
    with pytest.raises(InputError, match="^start: must be a traversable"):
        door_paths(m, (0, 0), (10, 10))
    with pytest.raises(InputError, match="^layout: must be one of one-hallway, two-corridors"):
        write_office_floor(Path("."), layout="three-corridors")


def test_start_and_goal_in_one_room(two):
    m = two
    (r,) = route_alternatives(m, (3.0, 1.2), (9.0, 1.2))
    assert r.via == ("lobby_1",) and r.doors == ()
    assert r.length == pytest.approx(plan_route(m, (3.0, 1.2), (9.0, 1.2)).length, abs=1e-9)
    _check_route(m, r)
