"""The Bayesian method of :func:`fairaudit.intervals.fairness_intervals`: Dirichlet posteriors, a simultaneous band.

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

from .intervals import _log


def _ratio_per_draw(E: np.ndarray):
    """max over the leading map axis and pairs of E_a / E_a'; E shape (D, M, A) > 0. Returns (value, m, fav, other)."""
    D, M, A = E.shape
    hi, lo = E.max(-1), E.min(-1)
    r = hi / lo
    m = r.argmax(-1)
    rows = np.arange(D)
    return r[rows, m], m, E.argmax(-1)[rows, m], E.argmin(-1)[rows, m]


def _sup_per_draw(P: np.ndarray):
    """max over maps, decisions and pairs of P[a, u] / P[a', u]; P shape (D, M, A, K)."""
    D, M, A, K = P.shape
    r = (P.max(2) / P.min(2)).reshape(D, M * K)
    j = r.argmax(-1)
    rows = np.arange(D)
    m, u = j // K, j % K
    return r[rows, j], m, P.argmax(2)[rows, m, u], P.argmin(2)[rows, m, u]


def _tv_per_draw(P: np.ndarray):
    """max over maps and pairs of TV(P_a, P_a'); P shape (D, M, A, K)."""
    D, M, A, K = P.shape
    tv = 0.5 * np.abs(P[:, :, :, None, :] - P[:, :, None, :, :]).sum(-1).reshape(D, M * A * A)
    j = tv.argmax(-1)
    rows = np.arange(D)
    return tv[rows, j], j // (A * A), (j // A) % A, j % A


def _dirichlet(rng, alpha: np.ndarray, draws: int) -> np.ndarray:
    x = rng.gamma(alpha, size=(draws,) + alpha.shape)
    x = np.maximum(x, np.finfo(float).tiny)   # tiny shapes can underflow to 0; keep every probability positive
    return x / x.sum(-1, keepdims=True)


def _metrics(Kd, Gd, g, g_group, fold, ctx_keep, filtered, m_a, m_x, w):
    """Every metric per draw. Kd: (D, X̃, Ã, K) cells; Gd: pooled groups (D, A, C) or None."""
    if filtered:
        Q = np.einsum("xy,ab,dybu->dxau", m_x.matrix, m_a.matrix, Kd, optimize=True)
    else:
        Q = Kd
    Qk = Q[:, ctx_keep]
    E = (Qk * g[ctx_keep]).sum(-1)                                   # (D, X, A)
    out = {"local": _ratio_per_draw(E), "sup_local": _sup_per_draw(Qk), "equalized_odds": _tv_per_draw(Qk)}
    if Gd is not None:
        Eg = (Gd * g_group).sum(-1)                                  # (D, A)
        Pg = Gd if fold is None else Gd @ fold.T                     # (D, A, K)
    else:
        Eg = np.einsum("xa,dxa->da", w, (Q * g).sum(-1))
        Pg = np.einsum("xa,dxak->dak", w, Q)
    out["global"] = _ratio_per_draw(Eg[:, None, :])
    out["sup_global"] = _sup_per_draw(Pg[:, None])
    out["demographic_parity"] = _tv_per_draw(Pg[:, None])
    return out, (Q * g).sum(-1), Eg


def _band(coords: np.ndarray, confidence: float) -> np.ndarray:
    """Mask of the draws inside Besag's simultaneous rank band; coords shape (D, n)."""
    D = coords.shape[0]
    varying = coords.std(0) > 0
    if not varying.any():
        return np.ones(D, bool)
    r = np.argsort(np.argsort(coords[:, varying], axis=0, kind="stable"), axis=0, kind="stable")
    extreme = np.maximum(r, D - 1 - r).max(-1)                      # how far out the draw's most extreme rank is
    keep = int(math.ceil(confidence * D))
    threshold = np.sort(extreme)[keep - 1]
    return extreme <= threshold


def band_sets(concentration: float, draws: int, seed: int):
    """The set maker of ``method="bayes"`` for :func:`fairaudit.intervals._frequentist`.

    Returns a function (cell_counts (X, A, K), group_counts (A, C), use_groups, alpha) -> (cell lower, cell upper,
    group lower, group upper, 0): the Besag band at level 1 − α over every cell (and pooled group) probability.
    """

    def sets(cell_counts, group_counts, use_groups: bool, alpha: float):
        rng = np.random.default_rng(seed)
        K = cell_counts.shape[-1]
        Kd = _dirichlet(rng, cell_counts + concentration / K, draws)
        parts = [Kd.reshape(draws, -1)]
        if use_groups:
            C = group_counts.shape[-1]
            Gd = _dirichlet(rng, group_counts + concentration / C, draws)
            parts.append(Gd.reshape(draws, -1))
        inside = _band(np.concatenate(parts, 1), 1.0 - alpha)
        c_lo, c_hi = Kd[inside].min(0), Kd[inside].max(0)
        if not use_groups:
            return c_lo, c_hi, None, None, 0
        return c_lo, c_hi, Gd[inside].min(0), Gd[inside].max(0), 0

    return sets


def posterior_mean_estimates(counts, g, contexts, groups, ctx_keep, filtered, m_a, m_x, population,
                             concentration) -> dict:
    """Every metric at the posterior mean (n + c/K)/(N + c) of the cells (and of the pooled groups): AIF360's smoothing."""
    X, A, K = counts.shape
    g = np.broadcast_to(g, (X, A, K)) if not filtered else np.broadcast_to(g[0, 0], (len(contexts), len(groups), K))
    mean_k = (counts + concentration / K) / (counts.sum(-1, keepdims=True) + concentration)
    mean_g = fold = g_group = w = None
    if population is None:
        joint = bool(X > 1 and not np.all(g == g[:1]))
        if joint:
            gc = counts.transpose(1, 0, 2).reshape(A, X * K)
            g_group = g.transpose(1, 0, 2).reshape(A, X * K)
            fold = np.tile(np.eye(K), (1, X))
        else:
            gc, g_group = counts.sum(0), g[0]
        C = gc.shape[-1]
        mean_g = mean_k[:, 0][None] if X == 1 else ((gc + concentration / C) / (gc.sum(-1, keepdims=True) + concentration))[None]
    else:
        w = population.context_given_group()
        w = np.where(np.isnan(w), 0.0, w)
    at_mean, _, _ = _metrics(mean_k[None], mean_g, g, g_group, fold, ctx_keep, filtered, m_a, m_x, w)
    out = {}
    for name, (val, _, _, _) in at_mean.items():
        v = float(val[0])
        out[name] = v if name in ("demographic_parity", "equalized_odds") else _log(v)
    return out
