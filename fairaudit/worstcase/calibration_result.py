"""The result of a calibration: :class:`Calibration`, the largest ε of a family meeting a target, and its report.

:class:`Common` holds the inputs every calibration repeats, whatever its method finds; :class:`Calibration` adds
what was found (ε, the keep probability, the bound there, the family's member) and builds the report dictionary
of ``fairaudit calibrate`` (:meth:`Calibration.to_dict`). The procedure is
:func:`~fairaudit.worstcase.calibration.calibrate`.
"""

from __future__ import annotations

from collections.abc import Hashable
from dataclasses import dataclass

from fairaudit.base.json_values import Report, label, number
from fairaudit.laws.mechanisms import Mechanism

__all__ = ["Calibration", "Common"]


@dataclass(frozen=True, eq=False, kw_only=True)
class Common:
    """The fields of a :class:`Calibration` that repeat its inputs, whatever the method finds (see its attributes)."""

    target: float
    kind: str
    groups: int
    gamma: float
    lower: float
    tau: float
    delta: float
    lipschitz: float
    diameter: float


@dataclass(frozen=True, eq=False, kw_only=True)
class Calibration(Common):
    """The largest ε of a family of mechanisms meeting a fairness target; repeats its inputs.

    Attributes
    ----------
    target : float
        The target on L (``kind="local"``) or L̄ (``"global"``), nats.
    kind : {"local", "global"}
    epsilon : float
        The largest ε (nats) that meets the target: +inf when every ε does,
        NaN when no ε does (``feasible`` is False).
    keep_probability : float
        The family's keep probability at ε (e^ε / (e^ε + k − 1) for k-ary
        randomized response): the price of the guarantee. NaN when infeasible.
    method : {"paper", "tight", "black_box", "white_box"}
    bound : float
        The certificate (``white_box``: the exact L or L̄ of the model) at ε,
        nats; equal to the target (up to rounding: the RR closed form may
        land 1e-16 above it, white-box allows 1e-13) unless every ε meets
        it. When infeasible,
        the smallest value any ε reaches (the floor), or +inf when nothing is
        certified.
    feasible : bool
    reason : str
        Why the target cannot be met, or which form gives ε.
    family : str
        The family's name, e.g. ``"8-ary randomized response"``.
    mechanism : Mechanism or None
        The family's member at ε (the identity when ε = +inf); None when infeasible.
    groups : int
        k, the number of groups.
    gamma, lower : float
        The utility class [lower, γ].
    tau : float
        τ, or NaN when not given.
    delta : float
        δ of an arbitrary (ε, δ)-DP mechanism (``paper`` and ``tight``); 0 otherwise.
    lipschitz, diameter : float
        L_A and diam(A) (1 under the discrete metric).
    unparsed_decision : hashable or None
        ``white_box`` with ``unparsed_decision``: that decision's label. ε and
        ``bound`` are then the upper end over every utility of it in
        ``unparsed_range``, chosen per kernel cell. None otherwise.
    unparsed_range : tuple of float or None
        (min g, max g), the interval of that decision's utility; None without it.
    target_impact_ratio : float or None
        The target given as a worst impact ratio r (``target_impact_ratio``):
        ``target`` is then −ln r nats (:func:`~fairaudit.worstcase.calibration.impact_ratio_target`). None
        when the target was given in nats.
    """

    epsilon: float
    keep_probability: float
    method: str
    bound: float
    feasible: bool
    reason: str
    family: str
    mechanism: Mechanism | None
    unparsed_decision: Hashable | None = None
    unparsed_range: tuple[float, float] | None = None
    target_impact_ratio: float | None = None

    def __repr__(self) -> str:
        ratio = "" if self.target_impact_ratio is None else f" (impact ratio {self.target_impact_ratio:.6g})"
        head = f"Calibration({self.method}, {self.kind}, target={self.target:.6g}{ratio}"
        if not self.feasible:
            return f"{head}: infeasible, {self.reason})"
        return f"{head}: epsilon={self.epsilon:.6g} nats, keep={self.keep_probability:.6g}, bound={self.bound:.6g})"

    def to_dict(self) -> Report:
        """The report dictionary (the JSON of ``fairaudit calibrate``).

        Contract keys: ``epsilon`` (``"inf"`` when every ε meets the target,
        ``null`` when none does), ``keep_probability``, ``method``, ``bound``;
        then ``feasible``, ``reason``, ``target``, ``kind``, ``mechanism`` (the
        family member's name, or the family's when infeasible), ``family`` and
        the inputs ``groups``, ``gamma``, ``lower``, ``tau`` (``null`` when not
        given), ``delta``, ``lipschitz``, ``diameter``; ``target_impact_ratio``
        (the target as a worst impact ratio, ``target`` = −ln of it; ``null``
        when the target was given in nats); with an unparsed
        decision, ``unparsed``: its ``decision`` and ``range`` [min g, max g]
        (ε and ``bound`` are the upper end over its utility).

        Examples
        --------
        >>> from fairaudit.worstcase.calibration import calibrate_randomized_response
        >>> c = calibrate_randomized_response(0.5, groups=2)
        >>> {k: c.to_dict()[k] for k in ("epsilon", "method", "feasible")}
        {'epsilon': 0.5, 'method': 'black_box', 'feasible': True}
        """
        return {
            "epsilon": number(self.epsilon),
            "keep_probability": number(self.keep_probability),
            "method": self.method,
            "bound": number(self.bound),
            "feasible": bool(self.feasible),
            "reason": self.reason,
            "target": number(self.target),
            "kind": self.kind,
            "mechanism": self.mechanism.name if self.mechanism is not None else self.family,
            "family": self.family,
            "groups": self.groups,
            "gamma": number(self.gamma),
            "lower": number(self.lower),
            "tau": number(self.tau),
            "delta": number(self.delta),
            "lipschitz": number(self.lipschitz),
            "diameter": number(self.diameter),
            "target_impact_ratio": number(self.target_impact_ratio),
        } | self._unparsed_dict()

    def _unparsed_dict(self) -> Report:
        """``{"unparsed": {"decision": ..., "range": [min g, max g]}}`` with an unparsed decision, else empty."""
        if self.unparsed_decision is None or self.unparsed_range is None:
            return {}
        return {
            "unparsed": {"decision": label(self.unparsed_decision), "range": [number(v) for v in self.unparsed_range]}
        }
