"""The Bayesian method of :func:`fairaudit.statistics.intervals.fairness_intervals`: Dirichlet posteriors, a simultaneous band.

Every cell's decision distribution has the posterior Dirichlet(n + c/K)
(independent cells; pooled groups likewise). ``draws`` samples (numpy's
Generator with ``seed``; Dirichlet draws as normalised Gamma draws) give a
simultaneous credible band: the rank band of Besag, Green, Higdon and
Mengersen (1995, "Bayesian computation and stochastic systems", Statist.
Sci. 10, sec. 4.3). A draw is inside when each of its cell probabilities
ranks between k and D + 1 − k among the D draws, with the largest k that
keeps ≥ (1 − α) D draws inside; the band is the box spanned by those draws,
one interval per cell and decision. That box (intersected with the simplex)
is the set C the metrics are projected onto, exactly as for the exact
methods, so a fair law inside the band gives a lower end of 0. Point
estimates are the plug-in of the posterior mean (n + c/K) / (N + c).
"""

from __future__ import annotations

import math

import numpy as np

from fairaudit.base.arrays import BoolArray, FloatArray
from fairaudit.base.errors import InputError
from fairaudit.statistics.confidence_sets import CellSets, SetMaker


def _dirichlet(rng: np.random.Generator, alpha: FloatArray, draws: int) -> FloatArray:
    x = rng.gamma(alpha, size=(draws,) + alpha.shape)
    x = np.maximum(x, np.finfo(float).tiny)  # tiny shapes can underflow to 0; keep every probability positive
    return x / x.sum(-1, keepdims=True)


def _band(coords: FloatArray, confidence: float) -> BoolArray:
    """Mask of the draws inside Besag's simultaneous rank band; coords shape (D, n)."""
    D = coords.shape[0]
    varying = coords.std(0) > 0
    if not varying.any():
        return np.ones(D, bool)
    r = np.argsort(np.argsort(coords[:, varying], axis=0, kind="stable"), axis=0, kind="stable")
    extreme = np.maximum(r, D - 1 - r).max(-1)  # how far out the draw's most extreme rank is
    keep = int(math.ceil(confidence * D))
    threshold = np.sort(extreme)[keep - 1]
    return extreme <= threshold


def band_sets(concentration: float, draws: int, seed: int) -> SetMaker:
    """The set maker of ``method="bayes"`` for :func:`fairaudit.statistics.projection.project_sets`.

    Returns a :data:`~fairaudit.statistics.confidence_sets.SetMaker`: (cell_counts (X, A, K), group_counts (A, C), use_groups,
    alpha) -> :class:`~fairaudit.statistics.confidence_sets.CellSets` with ``n_sets`` 0, the Besag band at level 1 − α over
    every cell (and pooled group) probability.
    """

    def sets(cell_counts: FloatArray, group_counts: FloatArray, use_groups: bool, alpha: float) -> CellSets:
        try:
            rng = np.random.default_rng(seed)
            Kd = _dirichlet(rng, cell_counts + concentration / cell_counts.shape[-1], draws)
            Gd = _dirichlet(rng, group_counts + concentration / group_counts.shape[-1], draws) if use_groups else None
            inside = _band(np.concatenate([d.reshape(draws, -1) for d in (Kd, Gd) if d is not None], 1), 1.0 - alpha)
            g_lo, g_hi = (None, None) if Gd is None else (Gd[inside].min(0), Gd[inside].max(0))
            return CellSets(Kd[inside].min(0), Kd[inside].max(0), g_lo, g_hi, 0)
        except MemoryError:  # numpy's refusal to allocate the draws: say what they need and what to change
            n = cell_counts.size + (group_counts.size if use_groups else 0)
            need = draws * n * 8 * 3  # bytes: the draws, their ranks and their order, 8 bytes each
            size = f"{need / 2**30:,.1f} GiB" if need >= 2**30 else f"{need / 2**20:,.1f} MiB"
            raise InputError(
                "draws",
                f"{draws} posterior draws of {n:,} probabilities need about {size}, more than this machine"
                " can allocate; use fewer `draws`, leave out small cells with `min_count`, or `method` multinomial",
                draws,
            ) from None

    return sets
