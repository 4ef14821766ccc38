"""Drawing helpers shared by the figures (:mod:`fairaudit.reports.plots`, the experiment's figures): matplotlib is imported by the caller.

:func:`coincide` tells whether two series would be drawn one over the other;
:func:`mark_infinite` marks +inf values on the top edge of an axes.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

if TYPE_CHECKING:
    from matplotlib.axes import Axes

__all__ = ["AXIS_LIMIT", "INFINITY_LABEL", "coincide", "mark_infinite", "on_scale"]


def coincide(a: npt.ArrayLike, b: npt.ArrayLike) -> bool:
    """Whether two series are equal at every point: NaN and ±inf at the same places, finite values to 1e-9.

    Examples
    --------
    >>> coincide([0.0, 1.0, np.inf], [0.0, 1.0 + 1e-13, np.inf]), coincide([0.0, 1.0], [0.0, 1.1])
    (True, False)
    """
    x, y = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if x.shape != y.shape or not np.array_equal(np.isnan(x), np.isnan(y)):
        return False
    fx, fy = np.isfinite(x), np.isfinite(y)
    if not np.array_equal(fx, fy) or not np.array_equal(x[~fx & ~np.isnan(x)], y[~fy & ~np.isnan(y)]):
        return False
    return bool(np.allclose(x[fx], y[fy], rtol=1e-9, atol=1e-12))


AXIS_LIMIT = 1e300
"""The largest value a figure puts on an axis: matplotlib's tick locator overflows (a RuntimeWarning, then an
OverflowError) when an axis reaches toward the largest float, 1.8e308."""


def on_scale(values: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """``values`` as floats, those above :data:`AXIS_LIMIT` as +inf: drawn at the top edge, as +inf is.

    Examples
    --------
    >>> on_scale([0.5, 1e308, np.inf]).tolist()
    [0.5, inf, inf]
    """
    v = np.array(values, dtype=float)
    v[v > AXIS_LIMIT] = np.inf
    return v


INFINITY_LABEL = "+∞ (drawn at the top edge)"
"""Label of the legend entry that :func:`mark_infinite` adds once per axes."""


def mark_infinite(ax: Axes, x: npt.ArrayLike, color: Any, **style: Any) -> None:
    """Mark +inf values at ``x`` with ▲ on the top edge of ``ax``, whatever its y limits.

    The markers sit just inside the top edge (y in axes coordinates, so they
    stay there when the y limits change; not clipped). The
    first call on an axes also writes "+∞" at the right end of the top edge
    and adds a legend entry ``INFINITY_LABEL``.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
    x : array_like
        Data x of the +inf values (nothing is drawn when empty).
    color
        The marker's colour (that of the series).
    **style
        Further :meth:`~matplotlib.axes.Axes.plot` keywords (e.g. ``ms``).

    Examples
    --------
    >>> from matplotlib.figure import Figure
    >>> ax = Figure().add_subplot()
    >>> mark_infinite(ax, [1.0, 2.0], "tab:red")
    >>> mark_infinite(ax, [3.0], "tab:blue")  # the label and the legend entry once per axes
    >>> [t.get_text() for t in ax.texts], ax.get_legend_handles_labels()[1]
    (['+∞'], ['+∞ (drawn at the top edge)'])
    """
    xs = np.asarray(x, dtype=float)
    if xs.size == 0:
        return
    from matplotlib.transforms import ScaledTranslation

    opts: dict[str, Any] = {"ls": "none", "marker": "^", "ms": 7, "mec": "white", "mew": 0.5, "zorder": 6}
    opts |= style
    # y = 1 in axes coordinates, lowered by half the marker: its tip touches the edge from inside
    lower = ScaledTranslation(0.0, -opts["ms"] / 2 / 72, ax.figure.dpi_scale_trans)
    ax.plot(xs, np.ones_like(xs), color=color, transform=ax.get_xaxis_transform() + lower, clip_on=False, **opts)
    if not any(t.get_gid() == "fairaudit-infinity" for t in ax.texts):
        ax.annotate(
            "+∞",
            xy=(1.0, 1.0),
            xycoords="axes fraction",
            xytext=(4, 0),
            textcoords="offset points",
            ha="left",
            va="center",
            fontsize=9,
            gid="fairaudit-infinity",
        )
        ax.plot([], [], ls="none", marker="^", ms=7, color="0.3", label=INFINITY_LABEL)[0].set_in_layout(False)
