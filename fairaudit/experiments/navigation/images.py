"""Route images: the top view with a route in red, its index in the upper-left corner, markers and a scale bar.

Each route is shown to the vision-language model as "the top-down floorplan with the route to the office
highlighted in red, and the index printed in the upper-left corner of the image: 1 for HR1, 2 for HR2" (the
paper's Methods): :func:`route_image`. The start and the goal are marked with discs
(:data:`START_RGB`, :data:`GOAL_RGB`) and a scale bar gives the metres in the lower-left corner. An image shows
the whole grid or a window of it: :func:`route_window` frames a scene's routes, so that the images of a building
show the rooms the routes cross, all of them in the same frame.
"""

from __future__ import annotations

import io
import math
from collections.abc import Sequence
from types import ModuleType
from typing import TYPE_CHECKING, Any

import numpy as np

from fairaudit import InputError, optional_modules, real, whole

from .maps import Maps, check_maps

if TYPE_CHECKING:
    from .routes import Route  # routes imports this module: for the annotations only


__all__ = ["GOAL_RGB", "ROUTE_MARGIN", "ROUTE_RGB", "START_RGB", "route_image", "route_window"]

#: Colour of the route in :func:`route_image` (pure red; never used by the background).
ROUTE_RGB = (255, 0, 0)

#: Colour of the start marker in :func:`route_image` (pure green; never used by the background).
START_RGB = (0, 255, 0)

#: Colour of the goal marker in :func:`route_image` (pure blue; never used by the background).
GOAL_RGB = (0, 0, 255)

#: Default margin of :func:`route_window` around the routes, metres.
ROUTE_MARGIN = 2.0

Window = tuple[int, int, int, int]
"""A grid window (row0, row1, col0, col1): rows row0 .. row1 - 1 and columns col0 .. col1 - 1."""

_NICE = (1.0, 2.0, 5.0)  # the scale bar's lengths: 1, 2 or 5 times a power of ten, metres


def _pillow() -> tuple[ModuleType, ...]:
    problem = "needs pillow, which is not installed: pip install 'fairness-certify[navigation]'"
    return optional_modules("navigation", problem, "PIL.Image", "PIL.ImageDraw", "PIL.ImageFont")


def _background(maps: Maps) -> np.ndarray:
    """(rows, cols, 3) uint8, grid orientation: traversable cells light, obstacles dark, empty cells near black.

    With c in [0, 255] a channel of the top colour, each channel of a cell is, rounded:

    * traversable: 0.35 c + 0.65 * 255, in [165.75, 255], so every channel >= 166;
    * free but too close to an obstacle: 0.35 c + 0.65 * 200, in [130, 219.25], so every channel >= 130;
    * obstacles with points: 0.45 c, in [0, 114.75], so every channel <= 115;
    * no point: (28, 28, 28).

    A light cell has no channel 0 and a dark cell no channel 255, and grey 28 has neither, so no cell has a
    channel at 0 and another at 255: the background is never pure red :data:`ROUTE_RGB`, pure green
    :data:`START_RGB` or pure blue :data:`GOAL_RGB`.
    """
    c = maps.top_color.astype(float)
    kinds = (maps.traversable, maps.free & ~maps.traversable, ~np.isnan(maps.top_height))  # the first that holds
    shades = (0.35 * c + 0.65 * 255.0, 0.35 * c + 0.65 * 200.0, 0.45 * c)  # light, margin, dark
    return np.rint(np.select([k[..., None] for k in kinds], shades, 28.0)).astype(np.uint8)


def route_window(maps: Maps, routes: Sequence[Route], *, margin: float = ROUTE_MARGIN) -> Window:
    """The grid window around every cell of ``routes``, ``margin`` metres wider on each side, clipped to the grid.

    The common frame of a scene's route images (:func:`route_image`'s ``window``): the routes and what lies
    around them, the same for every image, so that images differ only by their route.

    Parameters
    ----------
    maps : Maps
    routes : sequence of Route
        Planned on ``maps``; at least one cell in all.
    margin : float
        Metres (>= 0); rounded up to whole cells.

    Returns
    -------
    tuple of int
        (row0, row1, col0, col1), half-open: rows row0 .. row1 - 1, columns col0 .. col1 - 1.

    Raises
    ------
    InputError
        Naming ``maps``, ``routes`` (no cell, or cells off the grid) or ``margin``.

    Examples
    --------
    >>> import tempfile
    >>> from fairaudit.experiments.navigation import build_maps, candidate_routes, write_office_floor
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     maps = build_maps(write_office_floor(tmp, spacing=0.2), resolution=0.2)
    >>> routes = candidate_routes(maps, "lobby_1", ["office_1", "office_2"])
    >>> maps.shape, route_window(maps, routes, margin=0.0)  # the routes' cells: rows 7-32, columns 10-50
    ((40, 60), (7, 33, 10, 51))
    >>> route_window(maps, routes)  # 2 m (10 cells) more on each side: the whole floor
    (0, 40, 0, 60)
    """
    check_maps(maps)
    m = real(margin, "margin", low=0.0, what="a finite number of metres >= 0")
    cells = [_route_cells(maps, r, "routes") for r in routes] if isinstance(routes, Sequence) else []
    every = np.concatenate(cells) if cells else np.empty((0, 2), dtype=np.int64)
    if len(every) == 0:
        raise InputError("routes", "must hold at least one route cell", type(routes).__name__)
    pad = math.ceil(m / maps.resolution - 1e-9)
    (r0, c0), (r1, c1) = every.min(axis=0), every.max(axis=0)
    rows, cols = maps.shape
    return (max(0, int(r0) - pad), min(rows, int(r1) + pad + 1), max(0, int(c0) - pad), min(cols, int(c1) + pad + 1))


def _route_cells(maps: Maps, route: Route, field: str) -> np.ndarray:
    """The route's cells (k, 2), checked: a Route planned on ``maps``."""
    cells = getattr(route, "cells", None)
    if not (isinstance(cells, np.ndarray) and cells.ndim == 2 and cells.shape[1] == 2 and hasattr(route, "goal")):
        raise InputError(field, "must be a Route from plan_route", type(route).__name__)
    if cells.size and not bool(maps.contains(cells[:, 0], cells[:, 1]).all()):
        raise InputError(field, "has cells off this map's grid", route.goal)
    return cells


def _window(maps: Maps, window: Window | None, cells: np.ndarray) -> Window:
    """``window`` checked (whole grid for None): integers, inside the grid, not empty, holding every route cell."""
    rows, cols = maps.shape
    if window is None:
        return (0, rows, 0, cols)
    try:
        r0, r1, c0, c1 = (int(v) for v in window)
        ok = all(float(v) == int(v) and not isinstance(v, bool) for v in window)
    except (TypeError, ValueError):
        ok = False
    if not ok or not (0 <= r0 < r1 <= rows and 0 <= c0 < c1 <= cols):
        raise InputError("window", f"must be (row0, row1, col0, col1) inside the grid of {rows} x {cols} cells", window)
    if cells.size and not bool(
        ((cells[:, 0] >= r0) & (cells[:, 0] < r1) & (cells[:, 1] >= c0) & (cells[:, 1] < c1)).all()
    ):
        raise InputError("window", "must hold every cell of the route", window)
    return (r0, r1, c0, c1)


def route_image(
    maps: Maps, route: Route, index: int | str, *, scale: int | None = None, window: Window | None = None
) -> bytes:
    """PNG of the top view with ``route`` in red, start and goal markers, ``index`` and a scale bar.

    The paper's route image: "the top-down floorplan with the route to the
    office highlighted in red, and the index printed in the upper-left corner
    of the image: 1 for HR1, 2 for HR2". The image shows the grid's cells in
    ``window`` (default all; :func:`route_window` frames a scene's routes).
    Each cell is a ``scale`` x ``scale`` block of pixels, north up (image row
    0 is the window's northernmost grid row; image column 0 its westernmost
    grid column); with the window (row0, row1, col0, col1) and rows = row1 -
    row0, the centre of cell (row, col) is at pixel coordinates (x, y) =
    ((col - col0 + 0.5) * scale, (rows - (row - row0) - 0.5) * scale), pixel
    (i, j) covering [i, i + 1) x [j, j + 1).
    Drawn in this order:

    1. The background: traversable cells are their top colour blended 65 %
       towards white, free cells within the robot radius of an obstacle 65 %
       towards grey 200, obstacles are their top colour darkened to 45 %, and
       cells without points are near black (28, 28, 28).
    2. The route: a polyline through its cell centres in pure red
       :data:`ROUTE_RGB` (no anti-aliasing, max(3, scale) pixels wide, round
       joints).
    3. The scale bar, in the lower-left corner: a black bar, max(2, f // 4)
       pixels thick, with the label "N m" above it in black, on a white box
       with a grey (128) border; f = max(10, height // 28) is the label's font
       size in pixels. N metres is the largest length 1, 2 or 5 times a power
       of ten (... 0.5, 1, 2, 5, 10, 20, 50 ...) whose bar fits in a quarter of
       the image width; the bar is round(N * scale / resolution) pixels long.
    4. The index: ``str(index)`` in black on a white box with a black border
       in the upper-left corner, with a height of about a sixth of the image.
    5. The markers, over everything (a start or goal under a box stays
       visible): a filled disc in pure green :data:`START_RGB` at the centre
       of the route's first cell and one in pure blue :data:`GOAL_RGB` at the
       centre of its last cell (the goal's over the start's when they meet).
       A disc is every pixel whose centre lies within max(3, 1.5 * scale)
       pixels of the cell's centre, so its centroid is that centre unless
       the image edge cuts it.

    None of the background's colours is pure red, green or blue (a channel
    at 0 and another at 255), so the route and the markers can be found by
    their exact colours; the text is black and grey only. The same input
    gives the same bytes.

    Parameters
    ----------
    maps : Maps
    route : Route
        Planned on ``maps``.
    index : int or str
        The label, usually 1 for HR1 and 2 for HR2.
    scale : int, optional
        Pixels per grid cell, in [1, 64]; default ``ceil(800 / max(rows, cols))``
        of the window (the longer side about 800 pixels).
    window : tuple of int, optional
        (row0, row1, col0, col1): the rows row0 .. row1 - 1 and columns
        col0 .. col1 - 1 of the grid shown; it must hold every route cell.
        Default: the whole grid.

    Returns
    -------
    bytes
        PNG, ``cols * scale`` pixels wide and ``rows * scale`` high (of the
        window), RGB.

    Raises
    ------
    InputError
        Naming ``maps``, ``route``, ``index`` (empty), ``scale`` or
        ``window``, or ``navigation`` when pillow is missing.

    Examples
    --------
    >>> import io, tempfile
    >>> import numpy as np
    >>> from PIL import Image
    >>> from fairaudit.experiments.navigation import build_maps, plan_route, read_area, write_office_floor
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     maps = build_maps(read_area(write_office_floor(tmp, spacing=0.2)), resolution=0.2)
    >>> png = route_image(maps, plan_route(maps, "lobby_1", "office_2"), 2, scale=5)
    >>> png[:8], Image.open(io.BytesIO(png)).size
    (b'\\x89PNG\\r\\n\\x1a\\n', (300, 200))
    >>> rgb = np.asarray(Image.open(io.BytesIO(png)))
    >>> int((rgb == START_RGB).all(axis=-1).sum()), int((rgb == GOAL_RGB).all(axis=-1).sum())  # 7.5-pixel discs
    (177, 177)
    """
    check_maps(maps)
    cells = _route_cells(maps, route, "route")
    label = str(index)
    if not label.strip():
        raise InputError("index", "must not be empty", index)
    r0, r1, c0, c1 = _window(maps, window, cells)
    rows = r1 - r0
    k = max(1, math.ceil(800 / max(rows, c1 - c0))) if scale is None else whole(scale, "scale", low=1, high=64)
    Image, ImageDraw, ImageFont = _pillow()
    rgb = np.repeat(np.repeat(_background(maps)[r0:r1, c0:c1][::-1], k, axis=0), k, axis=1)
    img = Image.fromarray(np.ascontiguousarray(rgb))
    draw = ImageDraw.Draw(img)
    width = max(3, k)
    xy = [((c - c0 + 0.5) * k, (rows - (r - r0) - 0.5) * k) for r, c in cells.tolist()]
    if len(xy) == 1:
        (px, py), rad = xy[0], width / 2
        draw.ellipse([px - rad, py - rad, px + rad, py + rad], fill=ROUTE_RGB)
    elif xy:
        draw.line(xy, fill=ROUTE_RGB, width=width, joint="curve")
    _scale_bar(draw, ImageFont, img.size, maps.resolution, k)
    _index_box(draw, ImageFont, label, max(12, (rows * k) // 6))
    if xy:  # last: a start or goal under a box stays visible
        radius = max(3.0, 1.5 * k)
        for (px, py), colour in ((xy[0], START_RGB), (xy[-1], GOAL_RGB)):
            img.paste(colour, mask=Image.fromarray(_disc(img.size, px, py, radius)))
    buf = io.BytesIO()
    img.save(buf, format="PNG")
    return buf.getvalue()


def _index_box(draw: Any, ImageFont: ModuleType, label: str, size: int) -> None:
    """Draw the index in the upper-left corner, ``size`` pixels high (see :func:`route_image`, step 4)."""
    font = ImageFont.load_default(size=size)
    pad = max(2, size // 6)
    left, top, right, bottom = draw.textbbox((0, 0), label, font=font)
    box = (0, 0, (right - left) + 4 * pad, (bottom - top) + 4 * pad)
    draw.rectangle(box, fill=(255, 255, 255), outline=(0, 0, 0), width=max(1, pad // 2))
    draw.text((2 * pad - left, 2 * pad - top), label, fill=(0, 0, 0), font=font)


def _disc(size: tuple[int, int], x: float, y: float, radius: float) -> np.ndarray:
    """(height, width) uint8 mask, 255 on the pixels whose centres lie within ``radius`` of (x, y)."""
    w, h = size
    cx = np.arange(w) + 0.5
    cy = np.arange(h)[:, None] + 0.5
    return np.where((cx - x) ** 2 + (cy - y) ** 2 <= radius * radius, 255, 0).astype(np.uint8)


def _bar_metres(width: int, resolution: float, k: int) -> float:
    """The scale bar's length, metres: the largest 1, 2 or 5 times a power of ten whose bar fits in width / 4 pixels."""
    fits = width / 4 * resolution / k  # metres
    e = math.floor(math.log10(fits))
    lengths = [round(f * 10.0**p, 12) for p in (e - 1, e, e + 1) for f in _NICE]
    return max(n for n in lengths if n * k / resolution <= width / 4 + 1e-9)


def _scale_bar(draw: Any, ImageFont: ModuleType, size: tuple[int, int], resolution: float, k: int) -> None:
    """Draw the scale bar in the lower-left corner (see :func:`route_image`, step 3)."""
    w, h = size
    metres = _bar_metres(w, resolution, k)
    length = max(1, round(metres * k / resolution))
    text = f"{metres:g} m"
    fs = max(10, h // 28)
    font = ImageFont.load_default(size=fs)
    thick = pad = max(2, fs // 4)
    left, top, right, bottom = draw.textbbox((0, 0), text, font=font)
    box_w = max(length, right - left) + 2 * pad
    y0 = h - ((bottom - top) + thick + 3 * pad)
    draw.rectangle((0, y0, box_w - 1, h - 1), fill=(255, 255, 255), outline=(128, 128, 128))
    draw.text((pad - left, y0 + pad - top), text, fill=(0, 0, 0), font=font)
    bar_y = h - pad - thick
    draw.rectangle((pad, bar_y, pad + length - 1, bar_y + thick - 1), fill=(0, 0, 0))
