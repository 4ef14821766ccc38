"""Route images: the top view with a route in red and its index in the upper-left corner.

Each route is shown to the vision-language model as "the top-down floorplan with the route to the office
highlighted in red, and the index printed in the upper-left corner of the image: 1 for HR1, 2 for HR2" (the
paper's Methods): :func:`route_image`, :func:`save_route_image`.
"""

from __future__ import annotations

import io
import math
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING

import numpy as np

from ..._errors import InputError
from .maps import Maps

if TYPE_CHECKING:
    from .routes import Route  # noqa: F401

__all__ = ["ROUTE_RGB", "route_image", "save_route_image"]

#: Colour of the route in :func:`route_image` (pure red; never used by the background).
ROUTE_RGB = (255, 0, 0)


def _pillow() -> tuple[ModuleType, ModuleType, ModuleType]:
    try:
        from PIL import Image, ImageDraw, ImageFont
    except ImportError:
        raise InputError(
            "navigation", "needs pillow, which is not installed: pip install 'fairaudit[navigation]'"
        ) from None
    return Image, ImageDraw, ImageFont


def _background(maps: Maps) -> np.ndarray:
    """(rows, cols, 3) uint8, grid orientation: traversable cells light, obstacles dark, empty cells near black.

    Traversable: 35 % the top colour + 65 % white (every channel >= 166).
    Free but too close to an obstacle: 35 % colour + 65 % light grey 200.
    Obstacles with points: 45 % of the top colour (every channel <= 115).
    No point: (28, 28, 28). None of these can be pure red.
    """
    c = maps.top_color.astype(float)
    out = np.full(c.shape, 28.0)
    has = ~np.isnan(maps.top_height)
    light = 0.35 * c + 0.65 * 255.0
    margin = 0.35 * c + 0.65 * 200.0
    dark = 0.45 * c
    out[has] = dark[has]
    m = maps.free & ~maps.traversable
    out[m] = margin[m]
    out[maps.traversable] = light[maps.traversable]
    return np.rint(out).astype(np.uint8)


def _scale(maps: Maps, scale: int | None) -> int:
    if scale is None:
        return max(1, math.ceil(800 / max(maps.shape)))
    if isinstance(scale, bool) or not isinstance(scale, (int, np.integer)) or not 1 <= scale <= 64:
        raise InputError("scale", "must be an integer number of pixels per cell in [1, 64]", scale)
    return int(scale)


def route_image(maps: Maps, route: Route, index: int | str, *, scale: int | None = None) -> bytes:
    """PNG of the top view with ``route`` in red and ``index`` in the upper-left corner.

    The paper's route image: "the top-down floorplan with the route to the
    office highlighted in red, and the index printed in the upper-left corner
    of the image: 1 for HR1, 2 for HR2". Each grid cell is a ``scale`` x
    ``scale`` block of pixels, north up (image row 0 is the northernmost grid
    row; image column 0 the westernmost grid column). Traversable cells are
    their top colour blended 65 % towards white, free cells within the robot
    radius of an obstacle 65 % towards grey 200, obstacles are their top
    colour darkened to 45 %, and cells without points are near black (28, 28,
    28). The route is a polyline through its cell centres in pure red
    :data:`ROUTE_RGB` (no anti-aliasing, max(3, scale) pixels wide, round
    joints), a colour the background never takes. ``str(index)`` is printed
    in black on a white box with a black border in the upper-left corner,
    with a height of about a sixth of the image. The same input gives the
    same bytes.

    Parameters
    ----------
    maps : Maps
    route : Route
        Planned on ``maps``.
    index : int or str
        The label, usually 1 for HR1 and 2 for HR2.
    scale : int, optional
        Pixels per grid cell, in [1, 64]; default ``ceil(800 / max(rows, cols))``
        (the longer side about 800 pixels).

    Returns
    -------
    bytes
        PNG, ``cols * scale`` pixels wide and ``rows * scale`` high, RGB.

    Raises
    ------
    InputError
        Naming ``maps``, ``route``, ``index`` (empty) or ``scale``, or
        ``navigation`` when pillow is missing.

    Examples
    --------
    >>> import io, tempfile
    >>> from PIL import Image
    >>> from fairaudit.experiments.navigation import build_maps, plan_route, read_area, write_office_floor
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     maps = build_maps(read_area(write_office_floor(tmp, spacing=0.2)), resolution=0.2)
    >>> png = route_image(maps, plan_route(maps, "lobby_1", "office_2"), 2, scale=5)
    >>> png[:8], Image.open(io.BytesIO(png)).size
    (b'\\x89PNG\\r\\n\\x1a\\n', (300, 200))
    """
    if not isinstance(maps, Maps):
        raise InputError("maps", "must be Maps from build_maps", type(maps).__name__)
    from .routes import Route  # (routes imports this module)

    if not isinstance(route, Route):
        raise InputError("route", "must be a Route from plan_route", type(route).__name__)
    if route.cells.size and not bool(maps.contains(route.cells[:, 0], route.cells[:, 1]).all()):
        raise InputError("route", "has cells off this map's grid", route.goal)
    label = str(index)
    if not label.strip():
        raise InputError("index", "must not be empty", index)
    k = _scale(maps, scale)
    Image, ImageDraw, ImageFont = _pillow()
    rows, cols = maps.shape
    rgb = np.repeat(np.repeat(_background(maps)[::-1], k, axis=0), k, axis=1)
    img = Image.fromarray(np.ascontiguousarray(rgb))
    draw = ImageDraw.Draw(img)
    width = max(3, k)
    xy = [((c + 0.5) * k, (rows - r - 0.5) * k) for r, c in route.cells.tolist()]
    if len(xy) == 1:
        (px, py), rad = xy[0], width / 2
        draw.ellipse([px - rad, py - rad, px + rad, py + rad], fill=ROUTE_RGB)
    elif xy:
        draw.line(xy, fill=ROUTE_RGB, width=width, joint="curve")
    size = max(12, (rows * k) // 6)
    font = ImageFont.load_default(size=size)
    pad = max(2, size // 6)
    left, top, right, bottom = draw.textbbox((0, 0), label, font=font)
    box = (0, 0, (right - left) + 4 * pad, (bottom - top) + 4 * pad)
    draw.rectangle(box, fill=(255, 255, 255), outline=(0, 0, 0), width=max(1, pad // 2))
    draw.text((2 * pad - left, 2 * pad - top), label, fill=(0, 0, 0), font=font)
    buf = io.BytesIO()
    img.save(buf, format="PNG")
    return buf.getvalue()


def save_route_image(path: str | Path, maps: Maps, route: Route, index: int | str, *, scale: int | None = None) -> None:
    """Write :func:`route_image` to ``path`` (``.png``) atomically (:func:`fairaudit.report.write_atomic`).

    Parameters
    ----------
    path : str or pathlib.Path
        Ends in ``.png``; its folder must exist.
    maps, route, index, scale
        As :func:`route_image`.

    Returns
    -------
    None

    Raises
    ------
    InputError
        Naming ``path`` (not ``.png``, folder missing or not writable), or as
        :func:`route_image`.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> from fairaudit.experiments.navigation import build_maps, plan_route, read_area, write_office_floor
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     maps = build_maps(read_area(write_office_floor(tmp, spacing=0.25)), resolution=0.25)
    ...     route = plan_route(maps, "lobby_1", "office_1")
    ...     save_route_image(Path(tmp, "hr1.png"), maps, route, 1, scale=2)
    ...     Path(tmp, "hr1.png").read_bytes() == route_image(maps, route, 1, scale=2)
    True
    """
    from ...report import write_atomic

    if Path(path).suffix.lower() != ".png":
        raise InputError("path", "must end in .png", str(path))
    write_atomic(path, route_image(maps, route, index, scale=scale), field="path")
