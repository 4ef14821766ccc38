"""Tests of the building-size area (write_building, the benchmarks' fixture), the streamed maps and the room-by-room reader.

Independent routes: the files are parsed here with a regular expression and
Python's float; reachability is decided by scipy.sparse.csgraph.connected_components
on a grid graph built here from the traversability map; route lengths by
scipy.sparse.csgraph.dijkstra; the streamed maps are compared with the
in-memory route array for array.
"""

from __future__ import annotations

import hashlib
import math
import re
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("networkx")

from scipy.sparse import coo_matrix  # noqa: E402
from scipy.sparse.csgraph import connected_components, dijkstra  # noqa: E402

from fairaudit.base.errors import InputError  # noqa: E402
from fairaudit.experiments.navigation import build_maps, iter_rooms, read_area, read_points, write_office_floor  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "benchmarks"))  # the fixture is a benchmark's
from s3dis_building import DEPTH, HALLWAY_WIDTH, LOBBY_WIDTH, building_rooms, write_building  # noqa: E402

ROW = re.compile(rb"^-?\d+\.\d{3} -?\d+\.\d{3} -?\d+\.\d{3} \d{1,3} \d{1,3} \d{1,3}$")
GRID_FIELDS = ("top_height", "top_color", "top_category", "free", "traversable", "room_labels", "ceiling_z")
Y_MID = DEPTH + HALLWAY_WIDTH / 2
POINTS = 200_000


@pytest.fixture(scope="module")
def small(tmp_path_factory) -> Path:
    """8 rooms, 200,000 points (spacing about 0.07 m), seed 3."""
    return write_building(tmp_path_factory.mktemp("building"), rooms=8, points=POINTS, seed=3)


@pytest.fixture(scope="module")
def small_maps(small):
    return build_maps(small, resolution=0.1, robot_radius=0.2)


def _instance_key(path: Path) -> tuple[str, int]:
    category, _, k = path.stem.rpartition("_")
    return category, int(k)


def _grid_graph(traversable: np.ndarray, res: float):
    """8-neighbour graph of the traversable cells (flat indices), edge weights in metres."""
    rows, cols = traversable.shape
    idx = np.arange(rows * cols).reshape(rows, cols)
    src, dst, w = [], [], []
    for dr, dc in ((0, 1), (1, 0), (1, 1), (1, -1)):
        a = traversable[max(0, -dr) : rows - max(0, dr), max(0, -dc) : cols - max(0, dc)]
        b = traversable[max(0, dr) :, max(0, dc) : cols + min(0, dc) or None][: a.shape[0], : a.shape[1]]
        ia = idx[max(0, -dr) : rows - max(0, dr), max(0, -dc) : cols - max(0, dc)]
        ib = idx[max(0, dr) :, max(0, dc) : cols + min(0, dc) or None][: a.shape[0], : a.shape[1]]
        m = a & b
        src.append(ia[m])
        dst.append(ib[m])
        w.append(np.full(m.sum(), res * math.hypot(dr, dc)))
    s, d, ww = np.concatenate(src), np.concatenate(dst), np.concatenate(w)
    n = rows * cols
    return coo_matrix((np.r_[ww, ww], (np.r_[s, d], np.r_[d, s])), shape=(n, n)).tocsr()


def _same_maps(a, b) -> None:
    for f in GRID_FIELDS:
        assert np.array_equal(getattr(a, f), getattr(b, f), equal_nan=f == "top_height"), f
        assert getattr(a, f).dtype == getattr(b, f).dtype, f
    assert (a.origin, a.shape, a.rooms, a.floor_z) == (b.origin, b.shape, b.rooms, b.floor_z)
    na, nb = dict(a.topology.nodes(data=True)), dict(b.topology.nodes(data=True))
    assert list(na) == list(nb)
    for k in na:
        assert na[k]["category"] == nb[k]["category"] and na[k]["free_cells"] == nb[k]["free_cells"]
        np.testing.assert_allclose(na[k]["centre"], nb[k]["centre"], rtol=0, atol=1e-9)
        np.testing.assert_allclose(na[k]["bbox"], nb[k]["bbox"], rtol=0, atol=1e-9)
        np.testing.assert_allclose(na[k]["ceiling_z"], nb[k]["ceiling_z"], rtol=0, atol=1e-9)
    assert sorted(a.topology.edges(data=True)) == sorted(b.topology.edges(data=True))


# -- the layout -------------------------------------------------------------------------------------------


def test_default_layout_has_56_rooms_hallway_lobby_and_offices():
    names = building_rooms()
    assert len(names) == 56 == len(set(names))
    assert {"hallway_1", "lobby_1", "office_1", "office_2"} <= set(names)
    kinds = {n.rpartition("_")[0] for n in names}
    assert kinds <= {"hallway", "lobby", "office", "conferenceRoom", "WC", "storage", "pantry", "copyRoom"}
    assert len(kinds) >= 5
    assert len(building_rooms(71)) == 71 and building_rooms(56, seed=1) != names


def test_files_are_s3dis_text_and_room_files_concatenate_annotations(small):
    rooms = sorted(p.name for p in small.iterdir())
    assert rooms == list(building_rooms(8, seed=3))
    total = 0
    for name in rooms:
        ann = sorted((small / name / "Annotations").glob("*.txt"), key=_instance_key)
        whole = (small / name / f"{name}.txt").read_bytes()
        assert whole == b"".join(f.read_bytes() for f in ann)
        lines = whole.split(b"\n")
        assert lines[-1] == b""  # every row ends with a newline
        assert all(ROW.match(line) for line in lines[:-1]), name
        total += len(lines) - 1
        categories = {f.stem.rpartition("_")[0] for f in ann}
        assert {"ceiling", "floor", "wall"} <= categories, name
        if name not in ("hallway_1", "lobby_1"):
            assert "door" in categories and "clutter" in categories, name
    assert total == POINTS
    assert not any(p.name.startswith(".") for p in small.iterdir())  # no temporary folder left


def test_reader_agrees_with_python_floats_on_a_room_file(small):
    f = small / "hallway_1" / "hallway_1.txt"
    rows, skipped = read_points(f)
    expected = np.array([[float(v) for v in line.split()] for line in f.read_text().splitlines()])
    assert skipped == 0 and rows.shape == expected.shape and rows.shape[1] == 6
    np.testing.assert_allclose(rows, expected, rtol=0, atol=1e-12)


def test_iter_rooms_streams_the_rooms_of_read_area(small):
    area = read_area(small)
    streamed = list(iter_rooms(small))
    assert [r.name for r in streamed] == list(area.room_names)
    for a, b in zip(streamed, area.rooms):
        assert np.array_equal(a.points, b.points) and np.array_equal(a.categories, b.categories)
    with pytest.raises(InputError, match="area_dir: folder not found"):
        iter_rooms(small / "nope")


def test_doors_open_on_the_hallway_without_wall_and_with_floor(small):
    for name in building_rooms(8, seed=3):
        if name in ("hallway_1", "lobby_1"):
            continue
        ann = small / name / "Annotations"
        door = read_points(ann / "door_1.txt")[0]
        north = door[:, 1].mean() > Y_MID  # the room lies north of the hallway
        face = DEPTH + HALLWAY_WIDTH + 0.05 if north else DEPTH - 0.05
        assert np.all(np.abs(door[:, 1] - face) < 0.02)
        jambs = door[door[:, 2] < 2.05]
        centre = (jambs[:, 0].min() + jambs[:, 0].max()) / 2
        west, east = jambs[jambs[:, 0] < centre, 0].max(), jambs[jambs[:, 0] > centre, 0].min()
        assert east - west >= 0.9  # the opening, between the jambs
        walls = np.concatenate([read_points(f)[0] for f in ann.glob("wall_*.txt")])
        on_face = walls[(np.abs(walls[:, 1] - face) < 0.02) & (walls[:, 2] < 2.0)]
        assert not np.any((on_face[:, 0] > west + 0.02) & (on_face[:, 0] < east - 0.02))
        floor = read_points(ann / "floor_1.txt")[0]
        under = floor[(floor[:, 0] > west) & (floor[:, 0] < east) & (np.abs(floor[:, 1] - face) < 0.1)]
        assert len(under) > 0
        hall = read_points(small / "hallway_1" / "Annotations" / "floor_1.txt")[0]
        hall_face = DEPTH + HALLWAY_WIDTH if north else DEPTH
        assert np.any((hall[:, 0] > west) & (hall[:, 0] < east) & (np.abs(hall[:, 1] - hall_face) < 0.1))


def test_deterministic_from_seed(tmp_path):
    def digest(folder: Path) -> str:
        h = hashlib.sha256()
        for f in sorted(folder.rglob("*.txt")):
            h.update(str(f.relative_to(folder)).encode() + f.read_bytes())
        return h.hexdigest()

    out = []
    for name, seed in (("a", 7), ("b", 7), ("c", 8)):
        (tmp_path / name).mkdir()
        out.append(digest(write_building(tmp_path / name, rooms=5, points=20_000, seed=seed)))
    assert out[0] == out[1] != out[2]


def test_bad_arguments_name_the_parameter(tmp_path):
    for kwargs, field in [
        ({"rooms": 1}, "rooms"),
        ({"rooms": 3}, "rooms"),
        ({"rooms": 5.0}, "rooms"),
        ({"points": 100}, "points"),
        ({"points": 20_000, "rooms": 56}, "points"),  # spacing would exceed 0.5 m
        ({"seed": -1}, "seed"),
        ({"spacing": 1.0}, "spacing"),
        ({"spacing": "dense"}, "spacing"),
        ({"area": "../x"}, "area"),
    ]:
        with pytest.raises(InputError, match=f"^{field}: ") as e:
            write_building(tmp_path, **kwargs)
        assert repr(list(kwargs.values())[0])[:4] in str(e.value)
    with pytest.raises(InputError, match="^folder: folder does not exist"):
        write_building(tmp_path / "missing", points=20_000, rooms=4)
    (tmp_path / "Area_5" / "office_1").mkdir(parents=True)
    with pytest.raises(InputError, match="^folder: Area_5 already exists there and is not empty"):
        write_building(tmp_path, points=20_000, rooms=4)
    assert [p.name for p in (tmp_path / "Area_5").iterdir()] == ["office_1"]  # nothing written


# -- maps: reachability, the HR offices, streamed == in memory ---------------------------------------------


def _reachable_share(maps) -> dict[str, float]:
    """Per room, the share of its traversable cells in the lobby's connected component (csgraph)."""
    trav = maps.traversable
    _, comp = connected_components(_grid_graph(trav, maps.resolution), directed=False)
    comp = comp.reshape(trav.shape)
    lobby = maps.rooms.index("lobby_1")
    own = comp[trav & (maps.room_labels == lobby)]
    target = np.bincount(own).argmax()
    out = {}
    for i, name in enumerate(maps.rooms):
        cells = trav & (maps.room_labels == i)
        out[name] = float((comp[cells] == target).mean()) if cells.any() else 0.0
    return out


def test_every_room_is_reachable_from_the_lobby(small_maps):
    share = _reachable_share(small_maps)
    assert set(share) == set(building_rooms(8, seed=3))
    assert min(share.values()) >= 0.9, share


@pytest.mark.slow
def test_default_layout_every_room_reachable(tmp_path):
    area = write_building(tmp_path, spacing=0.2)  # 56 rooms, coarse: about 240,000 points
    maps = build_maps(area, resolution=0.25, robot_radius=0.2)
    share = _reachable_share(maps)
    assert len(share) == 56 and min(share.values()) >= 0.9, {k: v for k, v in share.items() if v < 0.9}
    assert maps.topology.number_of_edges() >= 55
    lobby = maps.topology.nodes["lobby_1"]["centre"]
    assert abs(lobby[1] - Y_MID) < 0.01 and abs(lobby[0] - LOBBY_WIDTH / 2) < 0.01


def test_hr_offices_are_mirror_images_at_equal_distance(small_maps):
    m = small_maps
    c1, c2 = m.topology.nodes["office_1"]["centre"], m.topology.nodes["office_2"]["centre"]
    assert c1[1] > Y_MID > c2[1]
    assert abs(c1[0] - c2[0]) < 0.02 and abs((c1[1] + c2[1]) / 2 - Y_MID) < 0.02
    graph = _grid_graph(m.traversable, m.resolution)
    cells = []
    for x, y in (m.topology.nodes["lobby_1"]["centre"], c1, c2):
        r, c = (int(v) for v in m.world_to_cell(x, y))
        assert m.traversable[r, c]
        cells.append(r * m.shape[1] + c)
    dist = dijkstra(graph, indices=cells[0])
    d1, d2 = dist[cells[1]], dist[cells[2]]
    assert np.isfinite(d1) and np.isfinite(d2)
    assert abs(d1 - d2) / max(d1, d2) < 0.03
    assert d1 >= math.hypot(c1[0] - LOBBY_WIDTH / 2, c1[1] - Y_MID)  # no shorter than the straight line


@pytest.mark.slow
@pytest.mark.parametrize("options", [{}, {"resolution": 0.1}, {"ceiling": 2.0, "clearance": None}])
def test_streamed_maps_equal_in_memory_maps_office_floor(tmp_path, options):
    area = write_office_floor(tmp_path, spacing=0.1)
    _same_maps(build_maps(area, **options), build_maps(read_area(area), **options))


def test_streamed_maps_equal_in_memory_maps_building(small, small_maps):
    _same_maps(small_maps, build_maps(read_area(small), resolution=0.1, robot_radius=0.2))
    _same_maps(build_maps(str(small), resolution=0.2), build_maps(read_area(small), resolution=0.2))


def test_streamed_maps_equal_without_floor_points_and_without_annotations(tmp_path):
    area = write_office_floor(tmp_path, spacing=0.2)
    for f in (area / "office_2" / "Annotations").glob("floor_*.txt"):  # a room without floor points
        f.unlink()
    whole = area / "office_2" / "office_2.txt"
    whole.write_bytes(b"".join(f.read_bytes() for f in sorted((area / "office_2" / "Annotations").iterdir())))
    shutil.rmtree(area / "WC_1" / "Annotations")  # a room without Annotations: unlabelled
    _same_maps(build_maps(area, resolution=0.2), build_maps(read_area(area), resolution=0.2))
    for room in area.iterdir():  # no floor category anywhere: floor height from the quantile of all z
        shutil.rmtree(room / "Annotations", ignore_errors=True)
    streamed, in_memory = build_maps(area, resolution=0.2), build_maps(read_area(area), resolution=0.2)
    _same_maps(streamed, in_memory)
    assert abs(streamed.floor_z) < 0.05


def test_streamed_maps_errors(tmp_path):
    with pytest.raises(InputError, match="area_dir: folder not found"):
        build_maps(tmp_path / "nope")
    with pytest.raises(InputError, match="^area: must be an Area"):
        build_maps(42)
    empty = tmp_path / "Area_9" / "office_1" / "Annotations"
    empty.mkdir(parents=True)
    (empty / "floor_1.txt").write_text("")
    with pytest.raises(InputError, match="^area: has no points") as e:
        build_maps(tmp_path / "Area_9")
    assert "Area_9" in str(e.value)
