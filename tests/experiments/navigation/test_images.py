"""Route images: the start and goal markers, the scale bar and the background's colours, read from the PNG's pixels.

Independent routes: the expected marker centres are the route's first and last cells put through the image's
geometry by hand ((col + 0.5) * scale, (rows - row - 0.5) * scale); the scale bar's length is worked out here
from the resolution and the scale (the largest 1, 2 or 5 times a power of ten metres in a quarter of the width),
and checked against a hand value for the floor used; the discs' pixels are counted by a double loop over pixel
offsets.
"""

from __future__ import annotations

import dataclasses
import io
import math

import numpy as np
import pytest

pytest.importorskip("networkx")
Image = pytest.importorskip("PIL.Image")

from fairaudit.experiments.navigation import build_maps, plan_route, read_area, write_office_floor  # noqa: E402
from fairaudit.experiments.navigation.images import GOAL_RGB, ROUTE_RGB, START_RGB, route_image  # noqa: E402

RES = 0.2


@pytest.fixture(scope="module")
def maps(tmp_path_factory):
    """The synthetic office floor at 0.2 m spacing on 0.2 m cells: 40 rows x 60 columns (8 m x 12 m)."""
    return build_maps(read_area(write_office_floor(tmp_path_factory.mktemp("floor"), spacing=RES)), resolution=RES)


def _rgb(png: bytes) -> np.ndarray:
    img = Image.open(io.BytesIO(png))
    assert img.format == "PNG" and img.mode == "RGB"
    return np.asarray(img)


def _mask(img: np.ndarray, colour: tuple[int, int, int]) -> np.ndarray:
    return (img == colour).all(axis=-1)


def _centre(cell, rows: int, scale: int) -> tuple[float, float]:
    """Image coordinates (x, y) of a grid cell's centre: north up, pixel (i, j) covering [i, i + 1) x [j, j + 1)."""
    row, col = (int(v) for v in cell)
    return (col + 0.5) * scale, (rows - row - 0.5) * scale


def _centroid(mask: np.ndarray) -> tuple[float, float]:
    ys, xs = np.nonzero(mask)
    return float(xs.mean() + 0.5), float(ys.mean() + 0.5)


def _disc_pixels(x: float, y: float, radius: float, size: tuple[int, int]) -> set[tuple[int, int]]:
    """The pixels (row, col) whose centres lie within ``radius`` of (x, y), by a loop over the pixels near it."""
    w, h = size
    out = set()
    for j in range(max(0, math.floor(y - radius) - 1), min(h, math.ceil(y + radius) + 1)):
        for i in range(max(0, math.floor(x - radius) - 1), min(w, math.ceil(x + radius) + 1)):
            if (i + 0.5 - x) ** 2 + (j + 0.5 - y) ** 2 <= radius**2:
                out.add((j, i))
    return out


def _bar_pixels(width: int, resolution: float, scale: int) -> int:
    """The scale bar's length in pixels: the largest 1, 2 or 5 x 10^n metres whose bar fits in width / 4 pixels."""
    metres = [m * 10.0**e for e in range(-3, 4) for m in (1, 2, 5)]
    best = max(m for m in metres if m * scale / resolution <= width / 4 + 1e-9)
    return round(best * scale / resolution)


def _longest_black_run(img: np.ndarray) -> tuple[int, int]:
    """(length, row) of the longest horizontal run of pure black pixels."""
    black = _mask(img, (0, 0, 0))
    best = (0, -1)
    for r, line in enumerate(black):
        run = 0
        for v in line:
            run = run + 1 if v else 0
            if run > best[0]:
                best = (run, r)
    return best


@pytest.mark.parametrize(
    "goal, scale",
    [("office_2", 5), ("office_1", 5), ("office_2", 3), ("office_2", 1), ("office_1", 1)],  # (office_1 at scale 1:
)  # its goal lies under the index box, and the marker is drawn over it)
def test_markers_sit_on_the_routes_first_and_last_cells(maps, goal, scale):
    route = plan_route(maps, "lobby_1", goal)
    img = _rgb(route_image(maps, route, 1, scale=scale))
    rows, cols = maps.shape
    assert img.shape == (rows * scale, cols * scale, 3)
    radius = max(3.0, 1.5 * scale)
    for cell, colour in ((route.cells[0], START_RGB), (route.cells[-1], GOAL_RGB)):
        x, y = _centre(cell, rows, scale)
        found = _mask(img, colour)
        cx, cy = _centroid(found)
        assert math.hypot(cx - x, cy - y) <= 1.0, (colour, (cx, cy), (x, y))
        # exactly the disc: every pixel of that colour, and no other, has its centre within the radius
        assert set(zip(*np.nonzero(found))) == _disc_pixels(x, y, radius, (cols * scale, rows * scale))
    # the route is still red between the markers
    red = _mask(img, ROUTE_RGB)
    mid = route.cells[len(route.cells) // 2]
    x, y = _centre(mid, rows, scale)
    assert red[int(y), int(x)]


def test_disc_sizes_by_hand(maps):
    # radius 7.5 pixels at scale 5: the pixel centres lie at whole offsets from the cell centre, and
    # #{(i, j) integers: i^2 + j^2 <= 56.25} = 177 (the Gauss circle count N(7.5), counted in _disc_pixels)
    route = plan_route(maps, "lobby_1", "office_2")
    img = _rgb(route_image(maps, route, 2, scale=5))
    assert int(_mask(img, START_RGB).sum()) == 177 == int(_mask(img, GOAL_RGB).sum())
    # radius max(3, 1.5) = 3 at scale 1: 29 pixels: the centre, 4 x 3 on the axes, 4 x 4 off them ((1, 1), (1, 2),
    # (2, 1), (2, 2) in each quadrant)
    img = _rgb(route_image(maps, route, 2, scale=1))
    assert (
        int(_mask(img, START_RGB).sum())
        == 29
        == sum(1 for i in range(-3, 4) for j in range(-3, 4) if i * i + j * j <= 9)
    )


@pytest.mark.parametrize("scale, expected", [(5, 50), (3, 30), (1, 10), (8, 80)])
def test_scale_bar_length(maps, scale, expected):
    # the floor is 60 x 0.2 = 12 m wide: a quarter is 3 m, so the bar is 2 m = 10 cells = 10 * scale pixels
    rows, cols = maps.shape
    assert (rows, cols) == (40, 60)
    assert _bar_pixels(cols * scale, RES, scale) == expected
    img = _rgb(route_image(maps, plan_route(maps, "lobby_1", "office_2"), 1, scale=scale))
    h, w = img.shape[:2]
    corner = img[h - h // 4 :, : w // 2]  # the lower-left corner
    length, row = _longest_black_run(corner)
    assert length == expected
    # one such run in that row, on the white box: white just left and just right of it, white or the border below
    line = corner[row]
    starts = [i for i in range(len(line) - expected + 1) if _mask(line[i : i + expected][None], (0, 0, 0)).all()]
    assert len(starts) == 1
    i = starts[0]
    assert tuple(line[i - 1]) == (255, 255, 255) and tuple(line[i + expected]) == (255, 255, 255)
    assert tuple(img[h - 1, i]) in {(255, 255, 255), (128, 128, 128)}
    # the label "2 m" above the bar: dark (anti-aliased black) glyph pixels on the box
    assert (corner[:row, : i + expected + 2].max(axis=-1) < 128).sum() > 5


def test_scale_bar_rule_by_hand():
    assert _bar_pixels(1000, 0.1, 10) == 200  # 1000 px = 10 m; a quarter 2.5 m -> 2 m = 200 px
    assert _bar_pixels(400, 0.05, 4) == 80  # 400 px = 5 m; a quarter 1.25 m -> 1 m = 80 px
    assert _bar_pixels(100, 1.0, 1) == 20  # 100 m; a quarter 25 m -> 20 m = 20 px
    assert _bar_pixels(40, 0.01, 4) == 8  # 0.1 m; a quarter 0.025 m -> 0.02 m = 8 px


def test_same_input_same_bytes_and_the_index_box(maps):
    route = plan_route(maps, "lobby_1", "office_2")
    a = route_image(maps, route, 2, scale=5)
    assert route_image(maps, route, 2, scale=5) == a
    img = _rgb(a)
    rows, cols = maps.shape
    corner = img[: rows * 5 // 4, : cols * 5 // 6]
    assert (corner == 255).all(axis=-1).sum() > 100 and (corner == 0).all(axis=-1).sum() > 50
    assert not _mask(corner, START_RGB).any() and not _mask(corner, GOAL_RGB).any()


def test_background_never_takes_the_marker_or_route_colours(maps):
    rng = np.random.default_rng(7)
    rows, cols = maps.shape
    colours = rng.integers(0, 256, size=(rows, cols, 3), dtype=np.uint8)
    # the extremes too, in every kind of cell (traversable, margin, obstacle): pure colours, white, black
    extremes = np.array([START_RGB, GOAL_RGB, ROUTE_RGB, (255, 255, 255), (0, 0, 0), (0, 255, 255)], dtype=np.uint8)
    colours.reshape(-1, 3)[::7] = extremes[np.arange(len(colours.reshape(-1, 3)[::7])) % len(extremes)]
    painted = dataclasses.replace(maps, top_color=colours)
    route = plan_route(maps, "lobby_1", "office_2")
    scale = 1
    img = _rgb(route_image(painted, route, 1, scale=scale))
    size = (cols * scale, rows * scale)
    start = _disc_pixels(*_centre(route.cells[0], rows, scale), 3.0, size)
    goal = _disc_pixels(*_centre(route.cells[-1], rows, scale), 3.0, size)
    assert set(zip(*np.nonzero(_mask(img, START_RGB)))) == start - goal
    assert set(zip(*np.nonzero(_mask(img, GOAL_RGB)))) == goal
    # the red pixels all lie within the route's line (half of max(3, scale) plus a pixel from a cell centre)
    ys, xs = np.nonzero(_mask(img, ROUTE_RGB))
    centres = np.array([_centre(c, rows, scale) for c in route.cells])
    d = np.hypot(xs[:, None] + 0.5 - centres[:, 0], ys[:, None] + 0.5 - centres[:, 1]).min(axis=1)
    assert len(d) and d.max() <= 3.0
    # and across all the random colours, no pixel of a pure red, green or blue outside those
    pure = (img.min(axis=-1) == 0) & (img.max(axis=-1) == 255)
    drawn = _mask(img, START_RGB) | _mask(img, GOAL_RGB) | _mask(img, ROUTE_RGB)
    assert not (pure & ~drawn).any()


def test_a_window_shows_that_part_of_the_grid_with_the_markers_moved_by_hand(maps):
    from fairaudit.experiments.navigation.images import route_window

    route = plan_route(maps, "lobby_1", "office_1")
    cells = route.cells
    (lo_r, lo_c), (hi_r, hi_c) = cells.min(axis=0), cells.max(axis=0)
    # by hand: the route's cells, then 1 m = 5 cells more on each side, clipped to the 40 x 60 grid
    want = (max(0, lo_r - 5), min(40, hi_r + 6), max(0, lo_c - 5), min(60, hi_c + 6))
    window = route_window(maps, [route], margin=1.0)
    assert window == tuple(int(v) for v in want)
    assert route_window(maps, [route], margin=0.0) == (lo_r, hi_r + 1, lo_c, hi_c + 1)
    r0, r1, c0, c1 = window
    scale = 4
    img = _rgb(route_image(maps, route, 1, scale=scale, window=window))
    assert img.shape == ((r1 - r0) * scale, (c1 - c0) * scale, 3)
    for cell, colour in ((cells[0], START_RGB), (cells[-1], GOAL_RGB)):
        x, y = _centre((cell[0] - r0, cell[1] - c0), r1 - r0, scale)  # the window's own rows and columns
        cx, cy = _centroid(_mask(img, colour))
        assert abs(cx - x) <= 1 and abs(cy - y) <= 1, (colour, (cx, cy), (x, y))
    # the window is that block of the whole image, wherever neither image draws anything over the background
    whole = _rgb(route_image(maps, route, 1, scale=scale))
    block = whole[(40 - r1) * scale : (40 - r0) * scale, c0 * scale : c1 * scale]
    drawn = np.zeros(img.shape[:2], dtype=bool)
    for colour in (ROUTE_RGB, START_RGB, GOAL_RGB):
        drawn |= _mask(img, colour) | _mask(block, colour)
    h, w = img.shape[:2]
    drawn[: h // 3, : w // 3] = drawn[-(h // 4) :, : w // 2] = True  # the index box and the scale bar
    assert (~drawn).sum() > 0.3 * drawn.size and np.array_equal(img[~drawn], block[~drawn])


def test_a_window_must_hold_the_route_and_lie_on_the_grid(maps):
    from fairaudit.base.errors import InputError
    from fairaudit.experiments.navigation.images import route_window

    route = plan_route(maps, "lobby_1", "office_1")
    r0, r1, c0, c1 = route_window(maps, [route], margin=0.0)
    for bad in ((r0 + 1, r1, c0, c1), (0, 41, 0, 60), (5, 5, 0, 60), (0, 40, 0, 60.5), "all"):
        with pytest.raises(InputError, match="window"):
            route_image(maps, route, 1, window=bad)
    with pytest.raises(InputError, match="routes"):
        route_window(maps, [])
    with pytest.raises(InputError, match="margin"):
        route_window(maps, [route], margin=-1)
