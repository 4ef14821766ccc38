"""Plots of fairness–privacy curves (matplotlib, imported only when a plot is made).

:func:`plot_curve` draws a :class:`~fairaudit.certification.curves.PrivacyCurve`: the
paper, tight and black-box bounds and the observed L and L̄ against the
privacy budget ε, both in nats. :func:`save_figure` writes a figure as PNG or
SVG atomically. Install the plotting extra with ``pip install
"fairness-certify[plot]"``.
"""

from __future__ import annotations

import math
import textwrap
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal, TypeAlias

import numpy as np
import numpy.typing as npt

from fairaudit.base.arrays import BoolArray, FloatArray
from fairaudit.base.errors import InputError, optional_modules
from fairaudit.base.files import write_atomic
from fairaudit.reports.figures import AXIS_LIMIT, coincide, mark_infinite, on_scale

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure, SubFigure

    from fairaudit.certification.curves import PrivacyCurve

_Scale: TypeAlias = Callable[[npt.ArrayLike], npt.ArrayLike]
"""A vectorised monotone function of a secondary axis (ε ↦ value or value ↦ ε)."""
SecondaryAxis: TypeAlias = "Literal['keep'] | tuple[str, _Scale, _Scale] | None"
"""The ``secondary_axis`` of :func:`plot_curve`: ``"keep"``, (label, forward, inverse) or None."""

__all__ = ["FORMATS", "check_plot_path", "load_matplotlib", "plot_curve", "save_figure"]

#: File suffixes :func:`save_figure` understands, and the format each means.
FORMATS = {".png": "png", ".svg": "svg"}


def load_matplotlib() -> type[Figure]:
    """matplotlib's :class:`~matplotlib.figure.Figure` class (figures made without pyplot).

    Raises
    ------
    InputError
        Naming ``path`` (the file a plot was to be written to) when matplotlib is not installed.
    """
    problem = "needs matplotlib, which is not installed: pip install 'fairness-certify[plot]'"
    figure: type[Figure] = optional_modules("path", problem, "matplotlib.figure")[0].Figure
    return figure


def check_plot_path(path: str | Path) -> str:
    """The format of ``path`` (``"png"`` or ``"svg"``, by its suffix), after checking it can be written.

    Parameters
    ----------
    path : str or pathlib.Path

    Returns
    -------
    {"png", "svg"}

    Raises
    ------
    InputError
        Naming ``path`` and the value: a suffix other than .png or .svg, a
        folder that does not exist, or matplotlib not installed.

    Examples
    --------
    >>> check_plot_path("curve.SVG")
    'svg'
    >>> check_plot_path("curve.pdf")
    Traceback (most recent call last):
    ...
    fairaudit.base.errors.InputError: path: must end in .png or .svg (got 'curve.pdf')
    """
    p = Path(path)
    fmt = FORMATS.get(p.suffix.lower())
    if fmt is None:
        raise InputError("path", "must end in .png or .svg", str(path))
    folder = p.parent if str(p.parent) else Path(".")
    if not folder.is_dir():
        raise InputError("path", "folder does not exist", str(folder))
    load_matplotlib()
    return fmt


def save_figure(fig: Figure, path: str | Path) -> None:
    """Save a matplotlib figure as PNG or SVG (by the suffix), atomically.

    The figure is written to a temporary file in the same folder and renamed
    over ``path`` once complete; on error ``path`` is left untouched. SVGs are
    written reproducibly (no date, fixed element ids) with text kept as text.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    path : str or pathlib.Path
        Ends in ``.png`` (150 dpi) or ``.svg``.

    Returns
    -------
    None

    Raises
    ------
    InputError
        As :func:`check_plot_path`, or when the folder cannot be written.

    Examples
    --------
    >>> import os, tempfile
    >>> from fairaudit import UtilityClass, privacy_curve, randomized_response_family
    >>> family = randomized_response_family(["a", "b"])
    >>> fig = plot_curve(privacy_curve(family=family, utility_class=UtilityClass(tau=0.2)))
    >>> path = os.path.join(tempfile.mkdtemp(), "curve.svg")
    >>> save_figure(fig, path)
    >>> open(path, encoding="utf-8").read(5)
    '<?xml'
    """
    fmt = check_plot_path(path)
    import matplotlib

    def save(tmp: str) -> None:
        if fmt == "svg":
            with matplotlib.rc_context({"svg.hashsalt": "fairaudit", "svg.fonttype": "none"}):
                fig.savefig(tmp, format="svg", metadata={"Date": None})
        else:
            fig.savefig(tmp, format="png", dpi=150, metadata={"Software": None})

    write_atomic(path, save, field="path")


def _secondary(curve: PrivacyCurve, spec: SecondaryAxis) -> tuple[str, _Scale, _Scale] | None:
    if spec is None:
        return None
    if spec == "keep":
        eps, keep = np.asarray(curve.epsilon, float), np.asarray(curve.keep_probability, float)
        if eps.size < 2 or np.any(np.diff(keep) <= 0):
            raise InputError("secondary_axis", "'keep' needs a keep probability that increases along the grid")
        return (
            "keep probability",
            lambda e: np.interp(np.asarray(e, dtype=float), eps, keep),
            lambda k: np.interp(np.asarray(k, dtype=float), keep, eps),
        )
    if isinstance(spec, tuple) and len(spec) == 3 and callable(spec[1]) and callable(spec[2]):
        return (str(spec[0]), spec[1], spec[2])
    raise InputError("secondary_axis", "must be None, 'keep' or (label, forward, inverse)", spec)


def plot_curve(
    curve: PrivacyCurve,
    path: str | Path | None = None,
    *,
    ax: Axes | None = None,
    title: str | None = None,
    secondary_axis: SecondaryAxis = None,
    ymax: float | None = None,
) -> Figure | SubFigure:
    """Draw a fairness–privacy curve; optionally save it as PNG or SVG.

    x axis: privacy budget ε (nats); y axis: local g-fairness L (nats).
    Lines: the paper, tight and black-box bounds (any model behind the
    filter) and the corollary's ε; markers: the observed L and L̄ of the
    curve's kernel. A vertical line marks the curve's ``spec_epsilon``; grey
    bands mark where the observed model breaks τ (the paper and tight bounds
    do not apply to it there). +inf values are drawn at the top edge, marked
    ▲, with a "+∞" label at the right end of that edge and a legend entry.
    Two bounds (or the two observed values) equal at every ε are drawn
    once, with one legend entry naming both. Quantities that are NaN throughout are left out and named in a note.

    Parameters
    ----------
    curve : PrivacyCurve
        From :func:`fairaudit.certification.curves.privacy_curve`.
    path : str or pathlib.Path, optional
        Where to save, by suffix ``.png`` or ``.svg`` (atomic write).
    ax : matplotlib.axes.Axes, optional
        Draw on these axes; default a new 7 × 4.5 inch figure (made without
        pyplot, so no interactive backend is touched).
    title : str, optional
        Default: the curve's title and family.
    secondary_axis : None, "keep" or (label, forward, inverse)
        A top axis: ``"keep"`` for the family's keep probability, or a label
        and two vectorised monotone functions (ε ↦ value, value ↦ ε).
    ymax : float, optional
        Top of the y axis (nats), where +inf is drawn; default 1.15 × the
        largest finite value drawn (at least 0.1).

    Returns
    -------
    matplotlib.figure.Figure
        The figure drawn on (the :class:`~matplotlib.figure.SubFigure` of ``ax`` when it is in one; the
        file then holds the whole figure).

    Raises
    ------
    InputError
        When matplotlib is missing (``pip install "fairness-certify[plot]"``), or on
        a bad ``path`` (naming it) or ``secondary_axis``.

    Examples
    --------
    >>> from fairaudit.certification.curves import privacy_curve
    >>> from fairaudit.laws.families import randomized_response_family
    >>> from fairaudit.laws.utilities import UtilityClass
    >>> family = randomized_response_family(["a", "b"])
    >>> fig = plot_curve(privacy_curve(family=family, utility_class=UtilityClass(tau=0.2)))
    >>> ax = fig.axes[0]
    >>> ax.get_xlabel(), ax.get_ylabel()
    ('privacy budget ε (nats)', 'local g-fairness L (nats)')
    >>> [t.get_text() for t in ax.get_legend().get_texts()][:3]  # the paper and tight bounds coincide here
    ['black-box bound (all models, exact)', 'paper bound (main theorem)\\n= tight bound (its proof, per pair)', 'ε (corollary, g independent of a)']
    """
    figure_class = load_matplotlib()
    if path is not None:
        check_plot_path(path)
    fig: Figure | SubFigure
    if ax is None:
        fig = figure_class(figsize=(7.0, 4.5), layout="constrained")
        ax = fig.add_subplot()
    else:
        fig = ax.figure
    eps = _drawable_epsilons(curve)
    series = [(key, on_scale(v), label, style) for key, v, label, style in _series(curve, step=max(1, len(eps) // 30))]
    finite = np.concatenate([np.asarray(v, float)[np.isfinite(v)] for _, v, _, _ in series] + [np.zeros(1)])
    top = max(1.15 * float(finite.max()), 0.1) if ymax is None else float(ymax)
    missing = _draw_series(ax, eps, series, top)
    _mark_tau_and_spec(ax, curve, eps)
    ax.set_xlim(float(eps.min()), float(eps.max()) if eps.max() > eps.min() else float(eps.min()) + 1.0)
    ax.set_ylim(0.0, top)
    ax.set_xlabel("privacy budget ε (nats)")
    ax.set_ylabel("local g-fairness L (nats)")
    ax.grid(True, color="0.9", lw=0.6)
    sec = _secondary(curve, secondary_axis)
    if sec is not None:
        top_ax = ax.secondary_xaxis("top", functions=(sec[1], sec[2]))
        top_ax.set_xlabel(sec[0])
    if title is None:
        title = f"{curve.title}\n{curve.family}" if curve.title else curve.family
    # a secondary top axis is not seen by the title's automatic placement: lift the title over it
    ax.set_title(
        "\n".join(textwrap.fill(line, 90) for line in title.splitlines()),
        fontsize=10,
        pad=36 if sec is not None else None,
    )
    if missing:
        _note_left_out(ax, curve, missing)
    ax.legend(loc="upper left", fontsize=8, framealpha=0.9)
    if path is not None:
        save_figure(fig if isinstance(fig, figure_class) else fig.figure, path)  # a subfigure cannot be saved alone
    return fig


def _drawable_epsilons(curve: PrivacyCurve) -> FloatArray:
    """The curve's grid of ε, refused (field ``epsilons``) when an axis cannot show it: beyond ``AXIS_LIMIT``."""
    eps = np.asarray(curve.epsilon, dtype=float)
    if eps.size and not (np.all(np.isfinite(eps)) and eps.max() <= AXIS_LIMIT):
        top_eps = float(eps.max())
        spec_own = curve.spec_epsilon is not None and float(curve.spec_epsilon) == top_eps
        raise InputError(
            "epsilons",
            f"the curve's grid of epsilon reaches {top_eps:.6g} nats"
            + (" (the spec's own epsilon, always on it)" if spec_own else "")
            + f", beyond what a figure's axis can show ({AXIS_LIMIT:g} nats): "
            + ("no figure of this spec's curve" if spec_own else "draw it on a smaller grid"),
        )
    return eps


def _note_left_out(ax: Axes, curve: PrivacyCurve, missing: list[str]) -> None:
    """The note, bottom right, naming the bounds left out (NaN throughout) and why."""
    why = "need τ (not given)" if curve.tau is None else "do not apply to this utility"
    ax.text(
        0.99,
        0.02,
        f"{', '.join(missing)} bound{'s' if len(missing) > 1 else ''}: {why}",
        transform=ax.transAxes,
        ha="right",
        va="bottom",
        fontsize=8,
        color="0.3",
        zorder=7,
        bbox=dict(facecolor="white", edgecolor="none", alpha=0.85, pad=1.5),
    )


_Series: TypeAlias = tuple[str, FloatArray, str, dict[str, Any]]
"""One line of :func:`plot_curve`: (key, values, label, matplotlib style)."""


def _series(curve: PrivacyCurve, step: int) -> list[_Series]:
    """The lines of a curve's plot, drawn in this order; observed values get a marker every ``step`` points.

    Lines that coincide in places stay visible: wide pale black-box underneath, a wide dashed paper
    bound under a thin dash-dotted tight bound, observed values as sparse markers (L and L-bar
    staggered); lines equal everywhere are merged by :func:`_draw_series`.
    """
    observed = {"ls": "none", "zorder": 4, "clip_on": False}
    return [
        (key, getattr(curve, key), label, style)
        for key, label, style in (
            ("black_box", "black-box bound (all models, exact)", dict(color="tab:blue", lw=4.0, alpha=0.45, zorder=2)),
            ("paper", "paper bound (main theorem)", dict(color="tab:red", ls="--", lw=2.4, zorder=3)),
            ("tight", "tight bound (its proof, per pair)", dict(color="tab:orange", ls="-.", lw=1.2, zorder=3)),
            ("corollary", "ε (corollary, g independent of a)", dict(color="0.35", ls=":", lw=1.2, zorder=3)),
            (
                "observed_local",
                "observed L (local)",
                dict(color="black", marker="o", ms=4, markevery=(0, step), **observed),
            ),
            (
                "observed_global",
                "observed L̄ (global)",
                dict(color="tab:green", marker="x", ms=6, markevery=(step // 2, step), **observed),
            ),
        )
    ]


def _draw_series(ax: Axes, eps: FloatArray, series: list[_Series], top: float) -> list[str]:
    """Draw each line (+inf at ``top``, marked ▲); return the bounds left out for being NaN throughout.

    A bound equal at every ε to a bound drawn before it is not drawn again
    (nor an observed value to an observed value): the earlier one's legend
    entry names both, one per line (``"A\\n= B"``). Observed markers on a bound stay visible.
    """
    missing = []
    drawn: list[tuple[str, FloatArray, Any, str]] = []  # (kind, values, line, label)
    for key, values, label, style in series:
        v = np.asarray(values, dtype=float)
        if np.all(np.isnan(v)):
            if key in ("paper", "tight", "black_box"):
                missing.append(key.replace("_", "-"))
            continue
        kind = "observed" if key.startswith("observed") else "bound"
        inf = np.isposinf(v)
        suffix = " (+∞ at top)" if inf.any() else ""
        same = next((i for i, (k, w, _, _) in enumerate(drawn) if k == kind and coincide(v, w)), None)
        if same is not None:
            k, w, line, first = drawn[same]
            drawn[same] = (k, w, line, f"{first}\n= {label}")
            line.set_label(drawn[same][3] + suffix)
            continue
        (line,) = ax.plot(eps, np.where(inf, top, v), label=label + suffix, **style)
        drawn.append((kind, v, line, label))
        mark_infinite(ax, eps[inf], style["color"])
    return missing


def _mark_tau_and_spec(ax: Axes, curve: PrivacyCurve, eps: FloatArray) -> None:
    """Grey bands where the observed model breaks τ; a vertical line at the spec's ε."""
    holds = np.asarray(curve.tau_holds, dtype=bool)
    if curve.tau is not None and not holds.all():
        for i, (lo, hi) in enumerate(_runs(eps, ~holds)):
            ax.axvspan(
                lo,
                hi,
                color="0.85",
                zorder=0,
                label=f"observed model has E[g|x,a] < τ = {curve.tau:g}" if i == 0 else None,
            )
    if curve.spec_epsilon is not None and math.isfinite(curve.spec_epsilon):
        note = "" if curve.spec_on_family in (None, True) else " (its mechanism is not in this family)"
        ax.axvline(
            curve.spec_epsilon,
            color="tab:purple",
            lw=1.0,
            ls=(0, (4, 2)),
            label=f"spec's ε = {curve.spec_epsilon:.4g} nats{note}",
        )


def _runs(x: FloatArray, mask: BoolArray) -> list[tuple[float, float]]:
    """Intervals of x (midpoints between neighbours as edges) where mask is True."""
    edges = np.diff(np.concatenate([[0], np.asarray(mask, dtype=np.int8), [0]]))
    first, last = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
    lo = np.where(first == 0, x[first], 0.5 * (x[first - 1] + x[first]))
    hi = np.where(last == len(x) - 1, x[last], 0.5 * (x[last] + x[np.minimum(last + 1, len(x) - 1)]))
    return [(float(a), float(b)) for a, b in zip(lo, hi)]
