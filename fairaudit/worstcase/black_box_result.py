"""The result of the class certificate: :class:`BlackBoxCertificate`, the exact maximum of L over every decision model
and every utility of a class, and a model that attains it (:meth:`BlackBoxCertificate.worst_model`).

The procedure is :func:`~fairaudit.worstcase.black_box.black_box_bound` (``proofs/black_box.md`` §1–5).
"""

from __future__ import annotations

import math
from collections.abc import Hashable
from dataclasses import dataclass

import numpy as np

from fairaudit.base.arrays import FloatArray
from fairaudit.base.errors import InputError
from fairaudit.laws.mechanisms import Mechanism
from fairaudit.laws.tables import Kernel
from fairaudit.laws.utilities import Utility
from fairaudit.metrics.assumptions import Assumption

__all__ = ["BlackBoxCertificate"]


@dataclass(frozen=True, eq=False, kw_only=True)
class BlackBoxCertificate:
    """The exact maximum of L over every decision model and every utility in a class.

    Attributes
    ----------
    value : float
        max L in nats (+inf when the class allows E[g | x, a'] → 0 with
        E[g | x, a] > 0; NaN when the class is empty).
    ratio : float
        exp(value).
    group, other_group : hashable or None
        The maximising pair of true groups (``group`` gets more utility).
    released : tuple
        The released values ã on which the worst model gives utility γ.
    utility_by_release : numpy.ndarray
        The worst case's expected utility given the release: shape
        (n_released,) when g does not depend on the group (L_A = 0),
        (n_groups, n_released) otherwise (row b for a member of group b).
    lower, gamma : float
        The class of utilities [lower, γ].
    tau : float or None
        The lower bound on E[g | x, a] (None: only lower).
    lipschitz : float
        L_A (0: g does not depend on the group).
    mechanism : Mechanism
        M_A.
    method : {"threshold", "lp"}
        ``threshold``: decided in closed form (the threshold solution, or
        with a binding τ the floor relaxation whose point met every
        constraint); ``lp``: at least one Charnes–Cooper LP was solved.
    status : {"optimal", "unbounded", "infeasible", "trivial", "error"}
    solver_status : str
    reason : str
        Why the value is +inf or NaN, or which shortcut decided it.
    programs_solved : int
        LPs solved (0 on the threshold path).
    assumptions : tuple of Assumption
    certified : bool
        Whether ``value`` is proven an upper bound (closed forms and the threshold rule rounded up, or the LP's
        dual checked exactly); False, with the reason, when only the solver's word stands behind it.
    witness : float
        A certified lower end of the ratio (not nats) from the maximiser's point, when it is exactly feasible;
        NaN otherwise, on the closed-form routes, and for a class whose bounds γ does not divide exactly (it is
        solved on the scale γ = 1, rounded outward).
    gap : float
        ``ratio − witness``, rounded up (NaN without a witness).
    """

    value: float
    ratio: float
    group: Hashable | None
    other_group: Hashable | None
    released: tuple
    utility_by_release: FloatArray
    lower: float
    gamma: float
    tau: float | None
    lipschitz: float
    mechanism: Mechanism
    method: str
    status: str
    solver_status: str
    reason: str
    programs_solved: int
    assumptions: tuple[Assumption, ...]
    certified: bool = True
    witness: float = math.nan
    gap: float = math.nan

    @property
    def form(self) -> str:
        """Always ``"black_box"``, like :attr:`fairaudit.metrics.bounds.Bound.form`."""
        return "black_box"

    def worst_model(self) -> tuple[Kernel, Utility]:
        """A concrete decision model and utility that attain the value.

        Returns
        -------
        kernel : Kernel
            One context ``"any"``, the mechanism's outputs as groups,
            decisions ``("high", "low")``: P(high | ã) = (h(ã) − lower)/(γ − lower).
        utility : Utility
            g(high) = γ, g(low) = lower.

        Raises
        ------
        InputError
            When g depends on the group (L_A > 0: the worst model then needs
            a utility per group) or when there is no maximiser.
        """
        h = self.utility_by_release
        if h.ndim != 1 or self.status not in ("optimal", "trivial"):
            raise InputError(
                "worst_model",
                "is available for utilities that do not depend on the group, with a finite optimum",
                self.status,
            )
        span = self.gamma - self.lower
        high = np.clip((h - self.lower) / span, 0.0, 1.0) if span > 0 else np.ones_like(h)
        table = np.stack([high, 1.0 - high], axis=-1)[None, :, :]
        kernel = Kernel(table, ["any"], self.mechanism.outputs, ["high", "low"], name="worst model")
        return kernel, Utility([self.gamma, self.lower], ["high", "low"], name="worst utility")

    def __repr__(self) -> str:
        tau = "" if self.tau is None else f", tau={self.tau:g}"
        return (
            f"BlackBoxCertificate(value={self.value:.6g} nats, ratio={self.ratio:.6g}, "
            f"pair={self.group!r} vs {self.other_group!r}, class [{self.lower:g}, {self.gamma:g}]{tau}, "
            f"method={self.method})"
        )
