"""Searching along ε for calibration: the largest ε whose bound meets a target, and the white-box scan grid.

:func:`largest_meeting` refines a bracket of a non-decreasing function (Illinois regula falsi safeguarded by
bisection), :func:`bracket` grows one, and :func:`keep_grid` is the white-box scan of a family. Proofs:
``proofs/calibration.md``.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable

import numpy as np

from fairaudit.base.arrays import FloatArray
from fairaudit.laws.families import MechanismFamily

__all__ = ["ATOL", "EPS_MAX", "GRID", "GRID_CAP", "RTOL", "bracket", "keep_grid", "largest_meeting"]

RTOL = 1e-11  # relative tolerance in ε of the root finder
ATOL = 1e-13  # absolute tolerance (for answers at or near ε = 0)
EPS_MAX = 500.0  # largest finite ε tried (e^500 is a finite double)
GRID = 64  # white-box scan: number of grid points
GRID_CAP = 50.0  # white-box scan: largest ε of the grid (or where keep ≥ 1 − 1e-12)


def largest_meeting(
    f: Callable[[float], float], target: float, lo: float, f_lo: float, hi: float, f_hi: float
) -> tuple[float, float]:
    """Largest ε in [lo, hi) with f(ε) ≤ target, for f non-decreasing on [lo, hi], f(lo) ≤ target < f(hi).

    Keeps the bracket f(lo) ≤ target < f(hi) and stops when
    hi − lo ≤ 1e-11·lo + 1e-13: Illinois regula falsi, with a bisection step
    whenever two steps did not halve the bracket (so never much slower than
    bisection). Returns (lo, f(lo)).
    """
    g_lo, g_hi = f_lo - target, f_hi - target  # g_lo <= 0 < g_hi
    last = 0  # +1: the last step moved lo, -1: it moved hi
    checkpoint, count, probed = hi - lo, 0, False
    while hi - lo > (tol := RTOL * lo + ATOL):
        bisect = False
        if count >= 2:
            bisect = hi - lo > 0.5 * checkpoint
            checkpoint, count = hi - lo, 0
        count += 1
        if g_lo == 0.0 and not probed:  # lo meets the target exactly: is it the end already?
            x, probed = lo + 0.5 * tol, True
        elif bisect or g_lo == 0.0 or not math.isfinite(g_hi):
            x = 0.5 * (lo + hi)
        else:
            x = lo + (hi - lo) * (-g_lo) / (g_hi - g_lo)
            x = min(max(x, lo + 0.25 * tol), hi - 0.25 * tol)
        fx = f(x)
        if fx <= target:
            lo, f_lo, g_lo = x, fx, fx - target
            if last == 1:
                g_hi *= 0.5  # Illinois: the same end moved twice
            last = 1
        else:
            hi, g_hi = x, fx - target
            if last == -1:
                g_lo *= 0.5
            last = -1
    return lo, f_lo


def bracket(
    f: Callable[[float], float], target: float, lo: float, f_lo: float, start: float
) -> tuple[float, float, float, float] | None:
    """Grow hi from ``start`` (doubling) until f(hi) > target; None when f stays ≤ target up to ε = 500."""
    hi = max(start, lo + 1.0 if lo == 0 else 2 * lo)
    while True:
        f_hi = f(hi)
        if not f_hi <= target:
            return lo, f_lo, hi, f_hi
        lo, f_lo = hi, f_hi
        if hi >= EPS_MAX:
            return None
        hi = min(2 * hi, EPS_MAX)


@functools.lru_cache(maxsize=8)
def keep_grid(family: MechanismFamily) -> FloatArray:
    """The white-box scan: 32 values of ε evenly spaced in [0, cap], 32 more evenly spaced in keep probability.

    cap is 50 nats, or less: where the keep probability reaches 1 − 1e-12. The grid (read-only) is kept for the last
    8 families (by identity): a certificate calibrates L and L̄ along the same one.
    """

    def keep(e: float) -> float:
        # what family.keep_probability(e) returns, without checking e again: a float in [0, cap] thousands of times
        return float(family.keep(e))

    def reaching(level: float, cap: float, steps: int) -> float:
        """The upper end of a bisection in [0, cap], ``steps`` halvings, for where keep reaches ``level``."""
        lo, hi = 0.0, cap
        for _ in range(steps):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if keep(mid) < level else (lo, mid)
        return hi

    cap = reaching(1 - 1e-12, GRID_CAP, 100) if keep(GRID_CAP) >= 1 - 1e-12 else GRID_CAP
    half = GRID // 2
    points = set(np.linspace(0.0, cap, half).tolist())
    points.update(reaching(p, cap, 80) for p in np.linspace(keep(0.0), keep(cap), half + 2)[1:-1])
    grid = np.array(sorted(points))
    grid.flags.writeable = False
    return grid
