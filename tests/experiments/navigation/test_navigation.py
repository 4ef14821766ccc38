"""Tests of the navigation plug-in: S3DIS reading, the synthetic floor, maps, A* routes and route images.

Expected values come from hand-made S3DIS folders (a few dozen points on a
1 m grid whose maps are worked out by hand below), from exact octile
distances, and from an independent shortest-path computation
(scipy.sparse.csgraph.dijkstra on a grid graph built here).
"""

from __future__ import annotations

import io
import math
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("networkx")
pytest.importorskip("PIL")

from PIL import Image  # noqa: E402
from scipy.sparse import coo_matrix  # noqa: E402
from scipy.sparse.csgraph import dijkstra  # noqa: E402

from fairaudit.base.errors import InputError  # noqa: E402
from fairaudit.experiments.navigation import (  # noqa: E402
    CATEGORIES,
    ROUTE_RGB,
    UNLABELLED,
    Maps,
    build_maps,
    candidate_routes,
    check_equal_distance,
    delivery_scene,
    plan_route,
    read_area,
    read_points,
    read_room,
    room_kind,
    route_image,
    write_office_floor,
)

SQ2 = math.sqrt(2.0)
NAN = math.nan


# -- helpers ----------------------------------------------------------------------------------------------


def _rows(points, rgb=(100, 100, 100)) -> str:
    return "".join(f"{x} {y} {z} {rgb[0]} {rgb[1]} {rgb[2]}\n" for x, y, z in points)


def _write_room(area: Path, name: str, files: dict[str, str], whole: str | None = None) -> None:
    room = area / name
    (room / "Annotations").mkdir(parents=True) if files else room.mkdir(parents=True)
    for inst, text in files.items():
        (room / "Annotations" / f"{inst}.txt").write_text(text)
    if whole is not None:
        (room / f"{name}.txt").write_text(whole)


def _cells(cols, rows, z):
    """Points at the centres of 1 m cells (col, row) at height z."""
    return [(c + 0.5, r + 0.5, z) for c in cols for r in rows]


@pytest.fixture(scope="module")
def toy(tmp_path_factory) -> Path:
    """Three rooms on a 1 m grid, 3 rows (y) x 10 cols (x)::

    row 2   A A A W | B T B W | C C       A lobby_1 (cols 0-3), B office_1 (cols 4-6),
    row 1   A A A d | B B B . | C C       C storage_1 (cols 8-9, no Annotations)
    row 0   L A A W | B B B W | C X       W wall (to 2.0 m), d door: floor + lintel at 2.1 m,
                                          . no point at all (a gap in the scan), T table (0.7 m),
                                          L lamp at 2.2 m over the floor, X box (1.0 m);
                                          ceilings at 2.5 m everywhere.
    """
    area = tmp_path_factory.mktemp("toy") / "Area_9"
    area.mkdir()
    lamp_rgb = (250, 240, 10)
    _write_room(
        area,
        "lobby_1",
        {
            "ceiling_1": _rows(_cells(range(4), range(3), 2.5)),
            "floor_1": _rows(_cells(range(4), range(3), 0.0), (200, 190, 180)),
            "wall_1": _rows(
                _cells([3], [0, 2], 0.5) + _cells([3], [0, 2], 1.5) + _cells([3], [0, 2], 2.0) + _cells([3], [1], 2.1)
            ),
            "clutter_1": _rows(_cells([0], [0], 2.2), lamp_rgb),
        },
    )
    _write_room(
        area,
        "office_1",
        {
            "ceiling_1": _rows(_cells(range(4, 8), range(3), 2.5)),
            "floor_1": _rows(_cells(range(4, 8), [0, 2], 0.0) + _cells(range(4, 7), [1], 0.0)) + "4.5 1.5 0.0 1 2\n",
            "wall_1": _rows(_cells([7], [0, 2], 1.0) + _cells([7], [0, 2], 2.0)),
            "table_1": _rows(_cells([5], [2], 0.7), (90, 60, 30)) + "5.5 2.5 0.7x 90 60 30\n",
        },
    )
    _write_room(
        area,
        "storage_1",
        {},
        whole=_rows(_cells([8, 9], range(3), 0.0) + _cells([8, 9], range(3), 2.5) + _cells([9], [0], 1.0)),
    )
    return area


@pytest.fixture(scope="module")
def toy_maps(toy) -> Maps:
    return build_maps(read_area(toy), resolution=1.0, robot_radius=0.0)


@pytest.fixture(scope="module")
def floor(tmp_path_factory):
    """The synthetic office floor at 0.1 m spacing, its area and maps (0.1 m cells)."""
    path = write_office_floor(tmp_path_factory.mktemp("floor"), spacing=0.1)
    area = read_area(path)
    return path, area, build_maps(area, resolution=0.1)


def _dijkstra_lengths(traversable: np.ndarray, res: float, source: tuple[int, int]) -> np.ndarray:
    """Shortest 8-connected path lengths (no corner cutting) from ``source`` to every cell, built independently."""
    rows, cols = traversable.shape
    r, c = np.nonzero(traversable)
    src, dst, w = [], [], []
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            if dr == dc == 0:
                continue
            r2, c2 = r + dr, c + dc
            ok = (r2 >= 0) & (r2 < rows) & (c2 >= 0) & (c2 < cols)
            ok[ok] &= traversable[r2[ok], c2[ok]]
            if dr and dc:  # both cells beside a diagonal step must be free
                side1 = np.zeros_like(ok)
                side2 = np.zeros_like(ok)
                side1[ok] = traversable[r2[ok], c[ok]]
                side2[ok] = traversable[r[ok], c2[ok]]
                ok &= side1 & side2
            src.append(r[ok] * cols + c[ok])
            dst.append(r2[ok] * cols + c2[ok])
            w.append(np.full(ok.sum(), res * math.hypot(dr, dc)))
    n = rows * cols
    graph = coo_matrix((np.concatenate(w), (np.concatenate(src), np.concatenate(dst))), shape=(n, n)).tocsr()
    return dijkstra(graph, indices=source[0] * cols + source[1]).reshape(rows, cols)


def _png(data: bytes) -> np.ndarray:
    img = Image.open(io.BytesIO(data))
    assert img.format == "PNG" and img.mode == "RGB"
    return np.asarray(img)


# -- S3DIS reading ----------------------------------------------------------------------------------------


def test_read_room_categories_instances_and_skipped_rows(toy):
    room = read_room(toy / "office_1")
    assert room.name == "office_1" and room_kind(room.name) == "office" and room.instances
    assert room.instances == ("ceiling_1", "floor_1", "table_1", "wall_1")
    # floor: 8 + 3 good rows, one row with 5 fields; table: one good row, one "0.7x"
    assert room.skipped_rows == 2
    counts = {
        name: int(np.sum(room.categories == CATEGORIES.index(name))) for name in ("ceiling", "floor", "table", "wall")
    }
    assert counts == {"ceiling": 12, "floor": 11, "table": 1, "wall": 4}
    assert len(room.points) == 28 and room.points.dtype == np.float64 and room.colors.dtype == np.uint8
    table = room.categories == CATEGORIES.index("table")
    np.testing.assert_array_equal(room.points[table], [[5.5, 2.5, 0.7]])
    np.testing.assert_array_equal(room.colors[table], [[90, 60, 30]])
    assert set(room.instance_ids.tolist()) == {0, 1, 2, 3}
    with pytest.raises(ValueError):
        room.points[0, 0] = 1.0  # read-only


def test_read_room_without_annotations_is_unlabelled(toy):
    room = read_room(toy / "storage_1")
    assert room.instances == () and room.skipped_rows == 0
    assert (room.categories == UNLABELLED).all() and len(room.points) == 13
    assert (room.instance_ids == -1).all()


def test_read_points_skips_and_counts_malformed_rows(tmp_path):
    f = tmp_path / "clutter_1.txt"
    f.write_text(
        "1.0 2.0 3.0 10 20 30\n"
        "1.0 2.0 3.\x100 10 20 30\n"  # the stray character of Area_5/hallway_6
        "1.0 2.0 3.0 10 20\n"  # 5 fields
        "1.0 2.0 3.0 10 20 30 40\n"  # 7 fields
        "nan 2.0 3.0 10 20 30\n"
        "\n"  # blank: ignored, not counted
        "4.0 5.0 6.0 300 -2 7.6\n"
    )
    rows, skipped = read_points(f)
    assert skipped == 4
    np.testing.assert_array_equal(rows, [[1, 2, 3, 10, 20, 30], [4, 5, 6, 300, -2, 7.6]])
    clean = tmp_path / "floor_1.txt"
    clean.write_text("1 2 3 4 5 6\n7 8 9 10 11 12\n")
    rows, skipped = read_points(clean)
    assert skipped == 0 and rows.shape == (2, 6)


def test_colours_are_rounded_and_clipped(tmp_path):
    _write_room(tmp_path, "office_3", {"stairs_1": "4.0 5.0 6.0 300 -2 7.6\n"})
    room = read_room(tmp_path / "office_3")
    assert room.colors.tolist() == [[255, 0, 8]]
    assert room.categories.tolist() == [CATEGORIES.index("clutter")]  # categories outside the 13 count as clutter


def test_read_errors_name_the_path(tmp_path):
    with pytest.raises(InputError, match="area_dir: folder not found") as e:
        read_area(tmp_path / "nope")
    assert str(tmp_path / "nope") in str(e.value)
    (tmp_path / "Area_2").mkdir()
    with pytest.raises(InputError, match="area has no room folders") as e:
        read_area(tmp_path / "Area_2")
    assert str(tmp_path / "Area_2") in str(e.value)
    (tmp_path / "Area_2" / "office_1").mkdir()
    with pytest.raises(InputError, match="neither office_1.txt nor Annotations") as e:
        read_area(tmp_path / "Area_2")
    assert str(tmp_path / "Area_2" / "office_1") in str(e.value)
    bad = tmp_path / "Area_2" / "office_1" / "office_1.txt"
    bad.write_text("1 2 3\n4 5 6\n7 8 9\n")
    with pytest.raises(InputError, match="rows must have 6 columns") as e:
        read_area(tmp_path / "Area_2")
    assert str(bad) in str(e.value) and "3 columns" in str(e.value)
    bad.write_text("a b c d e f\n")
    with pytest.raises(InputError, match="no row has six numbers") as e:
        read_room(bad.parent)
    assert str(bad) in str(e.value)


def test_read_area_sorts_rooms_and_ignores_files(toy):
    (toy / "Area_9_alignmentAngle.txt").write_text("0\n")
    area = read_area(toy)
    assert area.name == "Area_9"
    assert area.room_names == ("lobby_1", "office_1", "storage_1")
    assert sum(r.skipped_rows for r in area.rooms) == 2


# -- maps on the hand-made area ---------------------------------------------------------------------------


def test_toy_grid_and_top_view(toy_maps):
    m = toy_maps
    assert m.origin == (0.0, 0.0) and m.resolution == 1.0 and m.shape == (3, 10)
    assert m.rooms == ("lobby_1", "office_1", "storage_1")
    assert m.floor_z == 0.0
    np.testing.assert_allclose(m.ceiling_z, [2.4, 2.4, 2.4])  # median ceiling 2.5 (C: 0.99 quantile) - 0.1
    expected = np.array(
        [
            [2.2, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 2.0, 0.0, 1.0],
            [0.0, 0.0, 0.0, 2.1, 0.0, 0.0, 0.0, NAN, 0.0, 0.0],
            [0.0, 0.0, 0.0, 2.0, 0.0, 0.7, 0.0, 2.0, 0.0, 0.0],
        ]
    )
    np.testing.assert_allclose(m.top_height, expected)
    assert m.top_color[0, 0].tolist() == [250, 240, 10]  # the lamp
    assert m.top_color[2, 5].tolist() == [90, 60, 30]  # the table
    assert m.top_color[1, 1].tolist() == [200, 190, 180]  # lobby floor
    assert m.top_color[1, 7].tolist() == [0, 0, 0]
    assert m.top_category[2, 5] == CATEGORIES.index("table") and m.top_category[1, 7] == 255
    assert not (m.top_category == CATEGORIES.index("ceiling")).any()


def test_toy_traversability(toy_maps):
    t = np.array(
        [
            [1, 1, 1, 0, 1, 1, 1, 0, 1, 0],  # lamp above clearance: free; walls and box: not
            [1, 1, 1, 1, 1, 1, 1, 0, 1, 1],  # door under a lintel: free; the gap without points: obstacle
            [1, 1, 1, 0, 1, 0, 1, 0, 1, 1],  # table: obstacle
        ],
        dtype=bool,
    )
    np.testing.assert_array_equal(toy_maps.free, t)
    np.testing.assert_array_equal(toy_maps.traversable, t)  # robot_radius = 0
    labels = np.array([[0, 0, 0, 0, 1, 1, 1, 1, 2, 2], [0, 0, 0, 0, 1, 1, 1, -1, 2, 2], [0, 0, 0, 0, 1, 1, 1, 1, 2, 2]])
    np.testing.assert_array_equal(toy_maps.room_labels, labels)


def test_toy_topology(toy_maps):
    g = toy_maps.topology
    assert set(g.nodes) == {"lobby_1", "office_1", "storage_1"}
    assert g.nodes["lobby_1"]["centre"] == (2.0, 1.5)
    assert g.nodes["storage_1"]["centre"] == (9.0, 1.5)  # unlabelled: points in the floor band
    assert g.nodes["office_1"]["category"] == "office"
    assert g.nodes["lobby_1"]["bbox"] == (0.5, 0.5, 3.5, 2.5)
    assert g.nodes["lobby_1"]["free_cells"] == 10 and g.nodes["storage_1"]["free_cells"] == 5
    edges = {tuple(sorted(e[:2])): e[2] for e in g.edges(data=True)}
    assert edges == {
        ("lobby_1", "office_1"): {"via": "adjacent", "contact": 3},
        ("office_1", "storage_1"): {"via": "gap", "contact": 0},
    }


def test_toy_office_centre_exact(toy_maps):
    # floor points of office_1: cols 4-7 in rows 0 and 2 (8) and cols 4-6 in row 1 (3)
    xs = [4.5, 5.5, 6.5, 7.5] * 2 + [4.5, 5.5, 6.5]
    assert toy_maps.topology.nodes["office_1"]["centre"] == pytest.approx((np.mean(xs), 1.5))


def test_toy_options(toy):
    area = read_area(toy)
    no_gap = build_maps(area, resolution=1.0, robot_radius=0.0, door_gap=0.0)
    assert set(map(frozenset, no_gap.topology.edges)) == {frozenset({"lobby_1", "office_1"})}
    # no clearance: the lintel blocks the door, the lamp blocks its cell
    strict = build_maps(area, resolution=1.0, robot_radius=0.0, clearance=None)
    assert not strict.free[1, 3] and not strict.free[0, 0]
    assert not strict.topology.has_edge("lobby_1", "office_1")
    # a lower ceiling cut removes the lamp (2.2 m) but keeps the lintel (2.1 m)
    low = build_maps(area, resolution=1.0, robot_radius=0.0, ceiling=2.15)
    assert low.top_height[0, 0] == 0.0 and low.top_height[1, 3] == 2.1
    # a coarser grid: origin stays at a multiple of the resolution
    coarse = build_maps(area, resolution=2.0, robot_radius=0.0)
    assert coarse.origin == (0.0, 0.0) and coarse.shape == (2, 5)


def test_robot_radius_inflation(tmp_path):
    _write_room(tmp_path, "hallway_1", {"floor_1": _rows(_cells(range(7), range(5), 0.0))})
    area = read_area(tmp_path)
    assert build_maps(area, resolution=1.0, robot_radius=0.0).traversable.all()
    inner = build_maps(area, resolution=1.0, robot_radius=1.0).traversable
    expected = np.zeros((5, 7), bool)
    expected[1:4, 1:6] = True  # off-grid counts as obstacle: the border ring goes
    np.testing.assert_array_equal(inner, expected)
    two = build_maps(area, resolution=1.0, robot_radius=2.0).traversable
    expected = np.zeros((5, 7), bool)
    expected[2, 2:5] = True
    np.testing.assert_array_equal(two, expected)


def test_floor_height_without_floor_category(tmp_path):
    pts = _cells(range(4), range(2), 0.3) + _cells(range(4), range(2), 3.0) + _cells([0], [0], 1.0)
    _write_room(tmp_path, "lobby_1", {}, whole=_rows(pts))
    m = build_maps(read_area(tmp_path), resolution=1.0, robot_radius=0.0)
    assert m.floor_z == pytest.approx(0.3)
    assert m.ceiling_z[0] == pytest.approx(2.9)
    assert np.nanmax(m.top_height) == pytest.approx(1.0)
    assert m.free.sum() == 7


def test_build_maps_errors(toy):
    area = read_area(toy)
    with pytest.raises(InputError, match="area: must be an Area"):
        build_maps(42)  # (a folder is streamed: tests/experiments/navigation/test_building.py)
    for kwargs, field in [
        ({"resolution": 0}, "resolution"),
        ({"resolution": math.nan}, "resolution"),
        ({"floor_band": -1}, "floor_band"),
        ({"robot_radius": -0.1}, "robot_radius"),
        ({"clearance": 0.05}, "clearance"),
        ({"ceiling": "high"}, "ceiling"),
        ({"resolution": 1e-4}, "resolution"),
    ]:
        with pytest.raises(InputError, match=f"^{field}: ") as e:
            build_maps(area, **kwargs)
        assert repr(list(kwargs.values())[0])[:6] in str(e.value)


def test_world_cell_round_trip(floor):
    m = floor[2]
    rows, cols = np.meshgrid(np.arange(m.shape[0]), np.arange(m.shape[1]), indexing="ij")
    x, y = m.cell_to_world(rows, cols)
    r2, c2 = m.world_to_cell(x, y)
    np.testing.assert_array_equal(r2, rows)
    np.testing.assert_array_equal(c2, cols)
    assert [m.rooms[m.room_labels[m.world_to_cell(x, 6.5)]] for x in (2.0, 10.0)] == ["office_1", "office_2"]


# -- routes -----------------------------------------------------------------------------------------------


def test_toy_routes_by_hand(toy_maps):
    m = toy_maps
    r = plan_route(m, (0.5, 1.5), (6.5, 0.5))
    assert r.length == pytest.approx(5 + SQ2)
    assert r.rooms == ("lobby_1", "office_1")
    assert r.cells[0].tolist() == [1, 0] and r.cells[-1].tolist() == [0, 6]
    np.testing.assert_allclose(r.points[0], [0.5, 1.5])
    # no corner cutting: (0, 2) -> (0, 4) around the wall cell (0, 3) takes 4 straight steps, not 2 diagonals
    assert plan_route(m, (2.5, 0.5), (4.5, 0.5)).length == pytest.approx(4.0)
    # room names mean their centres
    r = plan_route(m, "lobby_1", "office_1")
    assert r.start == "lobby_1" and r.cells[0].tolist() == [1, 2] and r.cells[-1].tolist() == [1, 5]
    assert r.length == pytest.approx(3.0)
    single = plan_route(m, (1.2, 1.2), (1.7, 1.9))
    assert single.length == 0.0 and single.cells.tolist() == [[1, 1]]


def test_toy_route_snapping_and_errors(toy_maps):
    m = toy_maps
    r = plan_route(m, (3.5, 0.5), (4.5, 1.5))  # start on the wall cell (0, 3)
    assert r.cells[0].tolist() == [0, 2] and r.start_snap == pytest.approx(1.0)
    assert r.start == (3.5, 0.5)
    with pytest.raises(InputError, match=r"^start: no traversable cell within 0.5 m of \(3.5, 0.5\)"):
        plan_route(m, (3.5, 0.5), (4.5, 1.5), max_snap=0.5)
    with pytest.raises(InputError, match=r"^goal: cannot be reached from start 'lobby_1' \(got 'storage_1'\)"):
        plan_route(m, "lobby_1", "storage_1")
    with pytest.raises(InputError, match=r"^goal: no such room .*\(got 'office_9'\)"):
        plan_route(m, "lobby_1", "office_9")
    with pytest.raises(InputError, match=r"^start: no traversable cell within 1 m .*\(got \(50.0, 50.0\)\)"):
        plan_route(m, (50.0, 50.0), "office_1")
    with pytest.raises(InputError, match=r"^start: must be a room name or \(x, y\)"):
        plan_route(m, 3, "office_1")
    with pytest.raises(InputError, match=r"^goals: must be a non-empty sequence"):
        candidate_routes(m, "lobby_1", "office_1")
    with pytest.raises(InputError, match="^maps: must be Maps"):
        plan_route(None, "lobby_1", "office_1")


def test_octile_distance_on_an_empty_rectangle(tmp_path):
    _write_room(tmp_path, "hallway_1", {"floor_1": _rows(_cells(range(9), range(6), 0.0))})
    m = build_maps(read_area(tmp_path), resolution=1.0, robot_radius=0.0)
    for (c0, r0), (c1, r1) in [((0, 0), (8, 5)), ((0, 5), (3, 0)), ((2, 2), (2, 4)), ((7, 1), (1, 3))]:
        dx, dy = abs(c1 - c0), abs(r1 - r0)
        octile = max(dx, dy) - min(dx, dy) + SQ2 * min(dx, dy)
        route = plan_route(m, (c0 + 0.5, r0 + 0.5), (c1 + 0.5, r1 + 0.5))
        assert route.length == pytest.approx(octile, abs=1e-12)
        steps = np.abs(np.diff(route.cells, axis=0))
        assert steps.max() == 1 and (steps.sum(axis=1) >= 1).all()
        assert len(route.cells) == max(dx, dy) + 1


def test_synthetic_routes_equal_and_shortest(floor):
    _, area, m = floor
    routes = candidate_routes(m, "lobby_1", ("office_1", "office_2"))
    for r in routes:
        assert m.traversable[r.cells[:, 0], r.cells[:, 1]].all()  # avoid obstacles
        assert r.rooms == ("lobby_1", "hallway_1", r.goal)
        steps = np.abs(np.diff(r.cells, axis=0))
        assert steps.max() == 1 and steps.sum(axis=1).min() >= 1
        np.testing.assert_allclose(np.hypot(*np.diff(r.points, axis=0).T).sum(), r.length)
        dist = _dijkstra_lengths(m.traversable, m.resolution, tuple(r.cells[0]))
        # through the door points (the middle of the lobby's 2 m opening): never shorter than the free grid path
        assert dist[tuple(r.cells[-1])] - 1e-9 <= r.length < 1.1 * dist[tuple(r.cells[-1])]
        assert plan_route(m, "lobby_1", r.goal).length == pytest.approx(dist[tuple(r.cells[-1])], rel=1e-12)
        assert 6.5 < r.length < 7.5  # octile from (6, 1.5) to (2, 6.5) is 6.66 m; doors add a little
    check = check_equal_distance(routes)
    assert check.equal and check.max_relative_difference < 0.02 and check.rtol == 0.05
    assert check.lengths == (routes[0].length, routes[1].length)


def test_astar_matches_dijkstra_on_random_pairs(floor):
    m = floor[2]
    free = np.argwhere(m.traversable)
    rng = np.random.default_rng(7)
    source = tuple(free[rng.integers(len(free))])
    dist = _dijkstra_lengths(m.traversable, m.resolution, source)
    sx, sy = m.cell_to_world(*source)
    for target in free[rng.integers(len(free), size=8)]:
        tx, ty = m.cell_to_world(*target)
        route = plan_route(m, (float(sx), float(sy)), (float(tx), float(ty)))
        assert route.length == pytest.approx(dist[tuple(target)], rel=1e-12)


def test_every_room_is_reachable_from_the_lobby(floor):
    m = floor[2]
    for name in m.rooms:
        r = plan_route(m, "lobby_1", name)
        assert r.rooms[-1] == name
    assert plan_route(m, "lobby_1", "conferenceRoom_1").goal_snap > 0  # its centre is on the table


def test_check_equal_distance_values_and_errors():
    c = check_equal_distance([10.0, 8.0], rtol=0.2)
    assert c.max_relative_difference == pytest.approx(0.2) and c.equal
    assert not check_equal_distance([10.0, 8.0], rtol=0.19).equal
    assert check_equal_distance([0.0, 0.0]).equal
    for bad, field in [([], "routes"), ([1.0, -1.0], "routes"), (["x"], "routes")]:
        with pytest.raises(InputError, match=f"^{field}: "):
            check_equal_distance(bad)
    with pytest.raises(InputError, match=r"^rtol: must be a relative difference in \[0, 1\] \(got 2\)"):
        check_equal_distance([1.0], rtol=2)


# -- the synthetic floor ----------------------------------------------------------------------------------


def test_synthetic_floor_layout(floor):
    path, area, m = floor
    assert path.name == "Area_1"
    assert area.room_names == ("WC_1", "conferenceRoom_1", "hallway_1", "lobby_1", "office_1", "office_2", "storage_1")
    assert sum(r.skipped_rows for r in area.rooms) == 0
    office = area.rooms[area.room_names.index("office_1")]
    assert {"door_1", "floor_1", "ceiling_1", "table_1", "chair_1", "bookcase_1", "window_1"} <= set(office.instances)
    doors = office.points[office.categories == CATEGORIES.index("door")]
    assert len(doors) and doors[:, 1].min() > 4.9 and doors[:, 1].max() < 5.2  # on the south wall's frame
    ceiling = np.concatenate([r.points[r.categories == 0, 2] for r in area.rooms])
    assert abs(np.median(ceiling) - 2.7) < 0.01
    # the offices mirror each other about x = 6
    g = m.topology
    (x1, y1), (x2, y2) = g.nodes["office_1"]["centre"], g.nodes["office_2"]["centre"]
    assert x1 + x2 == pytest.approx(12.0, abs=0.01) and y1 == pytest.approx(y2, abs=0.01)
    assert {frozenset(e) for e in g.edges} == {frozenset({"hallway_1", r}) for r in area.room_names if r != "hallway_1"}
    # ceiling removed from the top view; walls remain obstacles; room centres free
    assert not (m.top_category == 0).any() and np.nanmax(m.top_height) < 2.65
    assert m.floor_z == pytest.approx(0.0, abs=0.01)
    for name in ("lobby_1", "office_1", "office_2", "hallway_1"):
        assert m.traversable[m.world_to_cell(*g.nodes[name]["centre"])]
    assert not m.free[m.world_to_cell(4.0, 6.5)]  # wall between office_1 and the conference room
    assert m.traversable[m.world_to_cell(3.0, 5.0)]  # office_1's door


def test_synthetic_floor_is_deterministic(tmp_path):
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    pa = write_office_floor(tmp_path / "a", spacing=0.4, seed=3)
    pb = write_office_floor(tmp_path / "b", spacing=0.4, seed=3)
    files = sorted(p.relative_to(pa) for p in pa.rglob("*.txt"))
    assert files == sorted(p.relative_to(pb) for p in pb.rglob("*.txt")) and len(files) > 40
    assert all((pa / f).read_bytes() == (pb / f).read_bytes() for f in files)
    pc = write_office_floor(tmp_path / "a", area="Area_1", spacing=0.4, seed=4)  # replaces the rooms
    assert (pc / "office_1" / "office_1.txt").read_bytes() != (pb / "office_1" / "office_1.txt").read_bytes()
    assert not [p for p in pc.iterdir() if p.name.startswith(".")]  # no temporary folders left
    room = read_room(pc / "office_1")
    whole = read_points(pc / "office_1" / "office_1.txt")[0]
    assert len(whole) == len(room.points)


def test_write_office_floor_errors(tmp_path):
    with pytest.raises(InputError, match="^folder: folder does not exist") as e:
        write_office_floor(tmp_path / "missing")
    assert str(tmp_path / "missing") in str(e.value)
    with pytest.raises(InputError, match=r"^spacing: must be a number of metres in \[0.02, 0.5\] \(got 0.001\)"):
        write_office_floor(tmp_path, spacing=0.001)
    with pytest.raises(InputError, match="^area: "):
        write_office_floor(tmp_path, area="../x")
    with pytest.raises(InputError, match="^seed: "):
        write_office_floor(tmp_path, seed=-1)


# -- images -----------------------------------------------------------------------------------------------


def _distance_to_polyline(px: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Distance of each pixel (n, 2) to the polyline (k, 2), in pixels."""
    if len(poly) == 1:
        return np.hypot(*(px - poly[0]).T)
    a, b = poly[:-1][None], poly[1:][None]
    p = px[:, None].astype(float)
    ab = b - a
    t = np.clip(((p - a) * ab).sum(-1) / np.maximum((ab * ab).sum(-1), 1e-12), 0, 1)
    return np.hypot(*(p - a - t[..., None] * ab).transpose(2, 0, 1)).min(axis=1)


def test_route_image_size_red_route_and_index(floor):
    m = floor[2]
    route = plan_route(m, "lobby_1", "office_2")
    scale = 4
    data = route_image(m, route, 2, scale=scale)
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    img = _png(data)
    rows, cols = m.shape
    assert img.shape == (rows * scale, cols * scale, 3)
    red = (img == ROUTE_RGB).all(axis=-1)
    from fairaudit.experiments.navigation.images import GOAL_RGB, START_RGB

    marked = (img == START_RGB).all(axis=-1) | (img == GOAL_RGB).all(axis=-1)
    # every route cell's centre pixel is red, or under the start or goal marker drawn over the route's ends
    # (north up: grid row r is image row rows - 1 - r)
    cy = (rows - 1 - route.cells[:, 0]) * scale + scale // 2
    cx = route.cells[:, 1] * scale + scale // 2
    assert (red | marked)[cy, cx].all() and red[cy, cx].mean() > 0.8
    # and every red pixel lies on the drawn line (half its width plus a pixel from the polyline)
    poly = np.column_stack([(route.cells[:, 1] + 0.5) * scale, (rows - route.cells[:, 0] - 0.5) * scale])
    ys, xs = np.nonzero(red)
    assert _distance_to_polyline(np.column_stack([xs + 0.5, ys + 0.5]), poly).max() <= max(3, scale) / 2 + 1.5
    # the index: a white box with black glyph pixels in the upper-left corner, nothing red there
    corner = img[: rows * scale // 4, : cols * scale // 6]
    assert (corner == 255).all(axis=-1).sum() > 100 and (corner == 0).all(axis=-1).sum() > 50
    # only that corner changes with the index
    other = _png(route_image(m, route, 1, scale=scale))
    diff = np.argwhere((other != img).any(axis=-1))
    assert len(diff) and diff[:, 0].max() < rows * scale // 4 and diff[:, 1].max() < cols * scale // 6
    assert route_image(m, route, 2, scale=scale) == data  # deterministic


def test_route_image_background(floor):
    m = floor[2]
    route = plan_route(m, "lobby_1", "office_1")
    img = _png(route_image(m, route, 1, scale=1))[::-1]  # back to grid orientation
    red = (img == ROUTE_RGB).all(axis=-1)
    from fairaudit.experiments.navigation.images import GOAL_RGB, START_RGB

    red |= (img == START_RGB).all(axis=-1) | (img == GOAL_RGB).all(axis=-1)  # the route and its end markers
    label = np.zeros(m.shape, bool)
    label[-m.shape[0] // 4 :, : m.shape[1] // 6] = True  # the index box (upper left)
    label[: m.shape[0] // 4, : m.shape[1] // 4] = True  # the scale bar's box (lower left)
    clear = ~red & ~label
    assert (img[m.traversable & clear] >= 166).all()  # free space light
    assert (img[~m.free & ~np.isnan(m.top_height) & clear] <= 115).all()  # obstacles dark
    assert (img[np.isnan(m.top_height) & clear] == 28).all()
    assert red[route.cells[:, 0], route.cells[:, 1]].mean() > 0.9


def test_route_image_default_scale_and_errors(floor, tmp_path):
    m = floor[2]
    route = plan_route(m, "lobby_1", "office_1")
    img = _png(route_image(m, route, 1))
    assert img.shape[:2] == (m.shape[0] * 7, m.shape[1] * 7)  # ceil(800 / 120) pixels per cell
    with pytest.raises(InputError, match="^scale: "):
        route_image(m, route, 1, scale=0)
    with pytest.raises(InputError, match="^index: must not be empty"):
        route_image(m, route, "")
    with pytest.raises(InputError, match="^route: must be a Route"):
        route_image(m, "office_1", 1)


# -- the scene --------------------------------------------------------------------------------------------


def test_delivery_scene_on_an_area_folder(floor):
    path, _, m = floor
    scene = delivery_scene(path)  # streamed from the folder
    assert scene.area == Path(path) and scene.maps.rooms == m.rooms and scene.maps.shape == m.shape
    assert [r.goal for r in scene.routes] == ["office_1", "office_2"] and scene.goals == ("office_1", "office_2")
    assert scene.check.equal and scene.check.lengths == tuple(r.length for r in scene.routes)
    assert len(scene.images) == 2 and all(i[:4] == b"\x89PNG" for i in scene.images)
    assert scene.images[0] == route_image(scene.maps, scene.routes[0], 1)


@pytest.mark.slow
def test_delivery_scene_generates_into_workdir(tmp_path):
    scene = delivery_scene(workdir=tmp_path, resolution=0.2, spacing=0.2, rtol=0.0)
    assert (tmp_path / "Area_1" / "lobby_1" / "lobby_1.txt").is_file() and scene.area == tmp_path / "Area_1"
    assert delivery_scene(resolution=0.25, spacing=0.25).area is None  # a temporary floor, removed
    assert scene.check.rtol == 0.0 and scene.check.equal == (scene.check.max_relative_difference == 0.0)
    lopsided = delivery_scene(tmp_path / "Area_1", goals=("office_1", "WC_1"), resolution=0.2)
    assert not lopsided.check.equal and len(lopsided.images) == 2
