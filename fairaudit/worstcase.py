"""Exact worst cases over every decision model behind a privacy filter.

Black-box certificate, box class. Behind M_A (and any M_X), a decision model
K and a utility g(u) whose values lie in [lower, γ] give

    E[g | x, a] = Σ_ã M_A[a, ã] H_x(ã),   H_x(ã) = Σ_x̃ M_X[x, x̃] Σ_u K[x̃, ã, u] g(u),

and as K ranges over all kernels, H_x ranges over the whole box
[lower, γ]^{n_released}. So the exact maximum of L over every model is, for
the worst pair (a, a'), the linear-fractional program

    max over h ∈ [lower, γ]^n of (p·h) / (q·h),   p = M_A[a, :], q = M_A[a', :].

Its optimum is a threshold vector: h = γ on the outputs with the largest
likelihood ratios p_o / q_o, h = lower elsewhere (at the optimum λ*, h
maximises Σ_o (p_o − λ* q_o) h_o). Sorting each pair's outputs by ratio and
scanning the prefixes finds it exactly, vectorised over all pairs. M_X drops
out, and under X ⊥ A the same value bounds L̄ (H(ã) = Σ_x P(x) H_x(ã) ranges
over the same box).

The general program (τ constraints, utilities that depend on the group) is
solved by linear programming via the Charnes–Cooper transform in a later
release. Proof: ``proofs/black_box.md``.
"""

from __future__ import annotations

import math
from collections.abc import Hashable
from dataclasses import dataclass

import numpy as np

from ._errors import InputError
from .bounds import Assumption, _sorted_pairs, check_assumptions
from .laws import Population
from .privacy import Mechanism

__all__ = ["BlackBoxCertificate", "black_box_bound"]


@dataclass(frozen=True, eq=False)
class BlackBoxCertificate:
    """The exact maximum of L over every decision model, for g in [lower, γ].

    Attributes
    ----------
    value : float
        max over kernels of L, in nats (+inf when some released value is
        possible for one group and impossible for another while lower = 0).
    ratio : float
        exp(value).
    group, other_group : hashable or None
        The maximising pair of true groups.
    released : tuple
        The released values ã on which the worst model gives utility γ (it
        gives ``lower`` on the others): a concrete worst decision model.
    lower, gamma : float
        The utility class [lower, γ].
    mechanism : Mechanism
        M_A.
    method : str
        "threshold" (sorted likelihood ratios, exact).
    assumptions : tuple of Assumption
    """

    value: float
    ratio: float
    group: Hashable | None
    other_group: Hashable | None
    released: tuple
    lower: float
    gamma: float
    mechanism: Mechanism
    method: str
    assumptions: tuple

    @property
    def form(self) -> str:
        """Always ``"black_box"``, like :attr:`fairaudit.bounds.Bound.form`."""
        return "black_box"

    def __repr__(self) -> str:
        return (f"BlackBoxCertificate(value={self.value:.6g} nats, ratio={self.ratio:.6g}, "
                f"pair={self.group!r} vs {self.other_group!r}, class [{self.lower:g}, {self.gamma:g}])")


def black_box_bound(mechanism: Mechanism, *, lower: float = 0.0, gamma: float = 1.0,
                    population: Population | None = None) -> BlackBoxCertificate:
    """Exact max of local g-fairness over every decision model behind M_A.

    Parameters
    ----------
    mechanism : Mechanism
        M_A, shape (n_groups, n_released_groups).
    lower, gamma : float
        The class of utilities: g(u) ∈ [lower, γ], 0 ≤ lower ≤ γ, with g
        depending on the decision (and context) only. Only the ratio
        lower / γ matters.
    population : Population, optional
        When given, X ⊥ A is checked on it (needed for the global bound only).

    Returns
    -------
    BlackBoxCertificate
        The value in nats, the maximising pair, and the released values on
        which the worst model gives γ.

    Raises
    ------
    InputError
        If ``lower`` or ``gamma`` is negative or not finite, or lower > γ.

    Notes
    -----
    With lower = 0 the value is ε(M_A) (the corollary is attained). It is
    never larger than the tight and paper bounds when their τ ≤ lower.
    ``proofs/black_box.md``.

    Examples
    --------
    >>> from fairaudit.privacy import randomized_response
    >>> m = randomized_response(["a", "b"], keep=0.7)
    >>> round(black_box_bound(m, lower=0.0, gamma=1.0).ratio, 12)
    2.333333333333
    >>> c = black_box_bound(m, lower=0.5, gamma=1.0)   # (0.5 + 0.5·0.7) / (0.5 + 0.5·0.3)
    >>> round(c.ratio, 12), c.group, c.released
    (1.307692307692, 'a', ('a',))
    """
    if not isinstance(mechanism, Mechanism):
        raise InputError("mechanism", "must be a Mechanism", type(mechanism).__name__)
    for name, v in (("lower", lower), ("gamma", gamma)):
        try:
            ok = math.isfinite(float(v)) and float(v) >= 0
        except (TypeError, ValueError):
            ok = False
        if not ok:
            raise InputError(name, "must be a finite non-negative number", v)
    lower, gamma = float(lower), float(gamma)
    if lower > gamma:
        raise InputError("lower", f"cannot exceed gamma = {gamma:g}", lower)
    assumptions = check_assumptions(mechanism, tau=None, gamma=None, population=population) + (
        Assumption("g depends on the decision (and context) only, within [lower, gamma]", "vouched",
                   f"class [{lower:g}, {gamma:g}]; X independent of A is needed for the global bound only"),
    )
    n = len(mechanism.inputs)
    if n < 2 or gamma == 0 or lower == gamma:
        return BlackBoxCertificate(0.0, 1.0, None, None, (), float(lower), float(gamma), mechanism, "threshold",
                                   assumptions)
    rho = lower / gamma
    _, p, q, order = _sorted_pairs(mechanism.matrix)
    zeros = np.zeros(p.shape[:-1] + (1,))
    big_p = np.concatenate([zeros, np.cumsum(p, axis=-1)], axis=-1)
    big_q = np.concatenate([zeros, np.cumsum(q, axis=-1)], axis=-1)
    num = rho + (1 - rho) * big_p
    den = rho + (1 - rho) * big_q
    with np.errstate(divide="ignore", invalid="ignore"):
        value = np.where(den > 0, num / np.where(den > 0, den, 1.0), np.where(num > 0, np.inf, 1.0))
    best_k = value.argmax(axis=-1)
    best = np.take_along_axis(value, best_k[..., None], -1)[..., 0]
    np.fill_diagonal(best, -np.inf)
    a, b = np.unravel_index(int(best.argmax()), best.shape)
    k = int(best_k[a, b])
    released = tuple(mechanism.outputs[o] for o in order[a, b, :k])
    r = float(best[a, b])
    return BlackBoxCertificate(float(np.log(r)) if np.isfinite(r) else math.inf, r, mechanism.inputs[a],
                               mechanism.inputs[b], released, float(lower), float(gamma), mechanism, "threshold",
                               assumptions)
