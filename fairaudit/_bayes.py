"""The Bayesian method of :func:`fairaudit.intervals.fairness_intervals`: Dirichlet posteriors, a simultaneous band.

Every cell's decision distribution has the posterior Dirichlet(n + c/K)
(independent cells; pooled groups likewise). ``draws`` samples (numpy's
Generator with ``seed``; Dirichlet draws as normalised Gamma draws) give every
metric per draw, vectorised over the draws. The simultaneous credible set is
the rank band of Besag, Green, Higdon and Mengersen (1995, "Bayesian
computation and stochastic systems", Statist. Sci. 10, sec. 4.3): a draw is
inside when each of its cell probabilities ranks between k and D + 1 − k
among the D draws, with the largest k that keeps ≥ (1 − α) D draws inside.
Each metric's interval is its range over the draws inside.
"""

from __future__ import annotations

import math

import numpy as np

from .intervals import FairnessIntervals, Interval, _log


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


def bayes_intervals(counts, g, alpha, method, estimate, contexts, groups, ctx_keep, filtered, m_a, m_x, population,
                    concentration, draws, seed, common) -> FairnessIntervals:
    """The ``method="bayes"`` branch of :func:`fairaudit.intervals.fairness_intervals` (arguments checked there)."""
    rng = np.random.default_rng(seed)
    X, A, K = counts.shape
    g = np.broadcast_to(g, (X, A, K)) if not filtered else np.broadcast_to(g[0, 0], (len(contexts), len(groups), K))
    Kd = _dirichlet(rng, counts + concentration / K, draws)
    mean_k = (counts + concentration / K) / (counts.sum(-1, keepdims=True) + concentration)
    pooled = population is None
    Gd = fold = g_group = mean_g = None
    w = None
    if pooled:
        joint = bool(X > 1 and not np.all(g == g[:1]))
        if joint:
            gc = counts.transpose(1, 0, 2).reshape(A, X * K)
            g_group = g.transpose(1, 0, 2).reshape(A, X * K)
            fold = np.tile(np.eye(K), (1, X))
        else:
            gc = counts.sum(0)
            g_group = g[0]
        C = gc.shape[-1]
        Gd = Kd[:, 0] if X == 1 else _dirichlet(rng, gc + concentration / C, draws)   # one context: groups are cells
        mean_g = ((gc + concentration / C) / (gc.sum(-1, keepdims=True) + concentration))[None]
    else:
        w = population.context_given_group()
        w = np.where(np.isnan(w), 0.0, w)
    per_draw, E_cells, E_groups = _metrics(Kd, Gd, g, g_group, fold, ctx_keep, filtered, m_a, m_x, w)
    at_mean, _, _ = _metrics(mean_k[None], mean_g, g, g_group, fold, ctx_keep, filtered, m_a, m_x, w)
    coords = Kd.reshape(draws, -1) if Gd is None or X == 1 else np.concatenate([Kd.reshape(draws, -1),
                                                                                   Gd.reshape(draws, -1)], 1)
    inside = _band(coords, 1.0 - alpha)
    conf = 1.0 - alpha
    kept_ctx = np.flatnonzero(ctx_keep)
    made = {}
    for name, (val, m, fav, oth) in per_draw.items():
        v = val[inside]
        j = int(np.argmax(v))
        ratio = name not in ("demographic_parity", "equalized_odds")
        lo, hi = (float(v.min()), float(v.max()))
        est = float(at_mean[name][0][0])
        if ratio:
            lo, hi, est = _log(lo), _log(hi), _log(est)
        local = name in ("local", "sup_local", "equalized_odds")
        made[name] = Interval(lo, hi, est, conf, method, contexts[kept_ctx[int(m[inside][j])]] if local else None,
                              groups[int(fav[inside][j])], groups[int(oth[inside][j])])
    cell_lo, cell_hi = E_cells[inside].min(0), E_cells[inside].max(0)
    kernel_lo = kernel_hi = None
    if filtered:
        Ek = (Kd[inside] * np.broadcast_to(g[0, 0], (K,))).sum(-1)
        kernel_lo, kernel_hi = Ek.min(0), Ek.max(0)
    return FairnessIntervals(method, conf, made["local"], made["global"], made["sup_local"], made["sup_global"],
                             made["demographic_parity"], made["equalized_odds"], cell_lo, cell_hi,
                             E_groups[inside].min(0), E_groups[inside].max(0), kernel_lo, kernel_hi, 0,
                             concentration=float(concentration), draws=int(draws), seed=int(seed), **common)
