"""The results of the worst cases over models or utilities: :class:`WorstCase` and :class:`WorstModel`.

:class:`WorstCase` is the maximiser of one search (local or global), returned by
:func:`~fairaudit.worstcase.known_utility.worst_model` (with its worst kernel) and by
:func:`~fairaudit.worstcase.known_law.worst_utility` (with its worst utility); its constructors say how it was
found (the threshold solution or a closed form, the pair search, an infeasible or trivial problem).
:class:`WorstModel` is the result of the known-utility certificate. ``proofs/black_box.md`` §6.
"""

from __future__ import annotations

import math
from collections.abc import Hashable
from dataclasses import dataclass, replace
from fractions import Fraction
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from fairaudit.base.arrays import FloatArray
from fairaudit.base.checks import choice
from fairaudit.base.json_values import Report, label, number, pair_dict
from fairaudit.base.labels import format_label
from fairaudit.base.outward import gap_between, log_down, log_up
from fairaudit.laws.mechanisms import Mechanism
from fairaudit.laws.tables import Kernel, Population
from fairaudit.laws.utilities import Utility
from fairaudit.metrics.assumptions import Assumption

if TYPE_CHECKING:
    from fairaudit.worstcase.pair_search import SearchResult

METHODS = ("auto", "threshold", "lp")
"""The worst-case searches' methods: the threshold solution where it applies, else the LP ("auto"), or one of them."""

EXACT_CROSSOVER = "then solved exactly"
"""What ``solver_status`` adds when the program was solved again on exact coefficients (``dual`` is then empty),
followed by why (:mod:`fairaudit.worstcase.known_utility_exact`: the rounded coefficients' witness did not meet the
value)."""


def check_method(method: str) -> str:
    """``method`` if it is one of :data:`METHODS` ("auto", "threshold", "lp")."""
    return choice(method, "method", METHODS)


def nats_up(ratio: float) -> float:
    """ln of a ratio that is an upper bound, rounded up (ln inf = inf, ln 0 = −inf; NaN stays NaN).

    Examples
    --------
    >>> nats_up(1.0), nats_up(math.inf), math.isnan(nats_up(math.nan))
    (0.0, inf, True)
    """
    return math.nan if math.isnan(ratio) else log_up(ratio)


def nats_down(ratio: float) -> float:
    """ln of a ratio that is a lower end, rounded down (the mirror of :func:`nats_up`).

    Examples
    --------
    >>> nats_down(1.0), nats_down(2.0) <= math.log(2.0)
    (0.0, True)
    """
    return math.nan if math.isnan(ratio) else log_down(ratio)


def exact_number(v: float | Fraction) -> float | str:
    """A multiplier as a certificate records it: a float where it is one exactly, else the exact rational "n/d"
    (to nearest where that would exceed 4,000 characters, the most ``fairaudit verify`` reads: any ν ≥ 0 is valid, a
    rounded one only proves less).

    Examples
    --------
    >>> exact_number(0.5), exact_number(Fraction(1, 2)), exact_number(Fraction(1, 3))
    (0.5, 0.5, '1/3')
    """
    if isinstance(v, Fraction):
        f = float(v)
        if Fraction(f) == v or max(v.numerator.bit_length(), v.denominator.bit_length()) > 6_500:  # (~1,960 digits)
            return f
        return f"{v.numerator}/{v.denominator}"
    return float(v)


@dataclass(frozen=True, eq=False, kw_only=True)
class ProgramDual:
    """The dual point that bounds one program of a worst-case search: the multipliers of its floors, or the one-floor
    threshold θ of its screen.

    With ν ≥ 0 on the floors E[g | x, b] ≥ τ, weak duality bounds the program's ratio by the smallest λ with
    B(λ) = Σ_x [Σ_i max over the box of (p − λq + Σ_b ν[x, b] M_A[b])_i h_i − τ Σ_b ν[x, b]] ≤ 0
    (``proofs/verification.md`` §4e), which anyone can check in exact arithmetic.

    Attributes
    ----------
    context : hashable or None
        The program's context (L); None for L̄'s programs, which span every context.
    group, other_group : hashable
        The program's pair: the ratio is E[g | group] over E[g | other_group].
    floors : numpy.ndarray
        ν, shape (n_groups,) for L (the floors of ``context``), (n_contexts, n_groups) for L̄ and, behind a context
        mechanism other than the identity, for L (contexts in the population's order; zeros where P(X = x) = 0);
        None for a screen.
    theta : float or Fraction or None
        A screen's threshold θ (a Fraction where exact: recorded as "n/d" where it is not a float): the multiplier λ − θ on the denominator's floor (E[g | x, other_group] ≥ τ for L,
        E[g | other_group] ≥ τ for L̄) bounds the ratio by θ + max(R(θ), 0)/τ, R(θ) = max over the model's tables of
        (numerator − θ · denominator) (``proofs/verification.md`` §4f); None for an LP's multipliers.
    """

    context: Hashable | None
    group: Hashable
    other_group: Hashable
    floors: FloatArray | None
    theta: float | Fraction | None = None

    def to_dict(self) -> Report:
        """The report dictionary: the program's context (L only), its pair and ν."""
        out: Report = {} if self.context is None else {"context": label(self.context)}
        out.update(group=label(self.group), other_group=label(self.other_group))
        if self.floors is not None:
            out["floors"] = np.vectorize(exact_number, otypes=[object])(self.floors).tolist()
        if self.theta is not None:
            out["theta"] = exact_number(self.theta)
        return out


@dataclass(frozen=True, eq=False, kw_only=True)
class WorstCase:
    """The maximiser of one worst-case search (local or global).

    Attributes
    ----------
    kind : {"local", "global"}
    value : float
        The maximum, in nats (+inf when unbounded; NaN when no model or
        utility meets the constraints).
    ratio : float
        exp(value).
    context : hashable or None
        The maximising context (local only).
    group, other_group : hashable or None
        The maximising pair; ``group`` gets more utility.
    kernel : Kernel or None
        The worst decision model (from :func:`~fairaudit.worstcase.known_utility.worst_model`).
    utility : Utility or None
        The worst utility (from :func:`~fairaudit.worstcase.known_law.worst_utility`).
    expected_utility : numpy.ndarray or None
        E[g | x, a] of the worst case, shape (n_contexts, n_groups) (local),
        or E[g | a], shape (n_groups,) (global).
    method : {"threshold", "lp"}
    status : {"optimal", "unbounded", "infeasible", "trivial", "error"}
        "error": the LP route could not solve a program (a vertex with q·h < 0; NaN, ``reason`` says so).
    solver_status : str
        How the maximiser's program was solved (the LP route's "HiGHS simplex, exact basis (...)", and how it is
        proved; "threshold" or "closed form" when no LP decided it).
    reason : str
    programs_solved : int
    certified : bool
        Whether ``value`` is proven an upper bound (the threshold rule's error bound, the LP route's exact basis
        and the duals it records, or the exact solve on exact coefficients); False with the reason in
        ``reason`` otherwise.
    witness : float
        A certified lower end in nats, from the maximiser's point (NaN when the point is not exactly feasible).
    gap : float
        ``value − witness`` in nats, rounded up (NaN without a witness).
    duals : tuple of ProgramDual
        The dual point of every program with binding floors the search bounded by a linear program (not behind
        randomized response and the identity on the context for a utility free of the group), for a third party to
        check the bound with.
    witness_point : numpy.ndarray or None
        The maximiser's point h[x, ã] = E[g | context x, released group ã] of the witness model (where ``duals``
        are recorded): shape (n_released_groups,) for L (its context), (n_contexts, n_released_groups) for L̄. For a
        utility that depends on the group, the witness model's table K[x, ã, u] instead: shape
        (n_released_groups, n_decisions) for L, (n_contexts, n_released_groups, n_decisions) for L̄. Behind a context
        mechanism other than the identity, the table over every released context, shape (n_released_contexts,
        n_released_groups, n_decisions), for L and L̄. Exact (Fractions, recorded as "n/d" where not a float) where
        it is the vertex of the maximiser's basis, which attains ``witness``; else floats.
    """

    kind: str
    value: float
    ratio: float
    context: Hashable | None = None
    group: Hashable | None = None
    other_group: Hashable | None = None
    kernel: Kernel | None = None
    utility: Utility | None = None
    expected_utility: FloatArray | None = None
    method: str
    status: str
    solver_status: str
    reason: str
    programs_solved: int
    certified: bool = True
    witness: float = math.nan
    gap: float = math.nan
    duals: tuple[ProgramDual, ...] = ()
    witness_point: npt.NDArray[Any] | None = None

    @classmethod
    def infeasible(cls, kind: str, solver_status: str, reason: str, programs_solved: int) -> WorstCase:
        """No model (or utility) of the class meets the constraints: NaN value, no maximiser, status "infeasible"."""
        return cls(
            kind=kind,
            value=math.nan,
            ratio=math.nan,
            method="lp",
            status="infeasible",
            solver_status=solver_status,
            reason=reason,
            programs_solved=programs_solved,
            certified=False,
        )

    @classmethod
    def trivial(cls, kind: str, *, kernel: Kernel | None, reason: str) -> WorstCase:
        """Nothing to compare (fewer than two groups, no live context): value 0, ratio 1, no pair, status "trivial"."""
        return cls(
            kind=kind,
            value=0.0,
            ratio=1.0,
            kernel=kernel,
            method="threshold",
            status="trivial",
            solver_status="threshold",
            reason=reason,
            programs_solved=0,
        )

    @classmethod
    def threshold(cls, kind: str, ratio: float, value: float, **fields: Any) -> WorstCase:
        """A maximum decided without an LP (the threshold solution or a closed form): "unbounded" when ``value`` is inf.

        ``fields``: the maximiser's ``context``, ``group`` and ``other_group``, and where known its
        ``kernel``, ``utility``, ``expected_utility``, ``solver_status`` (default "threshold") and ``reason``.
        """
        fields.setdefault("solver_status", "threshold")
        fields.setdefault("reason", "")
        status = "unbounded" if math.isinf(value) else "optimal"
        return cls(kind=kind, value=value, ratio=ratio, method="threshold", status=status, programs_solved=0, **fields)

    @classmethod
    def searched(cls, kind: str, found: SearchResult, **fields: Any) -> WorstCase:
        """The maximiser the pair search found: its program's value, status and reason; "lp" when an LP was solved.

        ``fields``: the maximiser's ``context``, ``group`` and ``other_group``, and where known its
        ``kernel``, ``utility``, ``expected_utility``, ``duals`` and ``witness_point``.
        """
        r = found.result
        assert r is not None  # a maximiser was found
        value, witness = nats_up(r.value), nats_down(r.witness)
        return cls(
            kind=kind,
            value=value,
            ratio=r.value,
            method="lp" if found.solved else "threshold",
            status=r.status,
            solver_status=r.solver_status,
            reason=r.reason,
            programs_solved=found.solved,
            certified=r.certified,
            witness=witness,
            gap=gap_between(value, witness),
            **fields,
        )

    @classmethod
    def unmet(cls, kind: str, found: SearchResult, reason: str) -> WorstCase:
        """The pair search gave no maximum: no program's constraints can be met (``reason``, :meth:`infeasible`),
        or the solver failed on one (status "error", NaN, its reason: nothing is claimed about the constraints)."""
        r = found.result
        if r is not None and r.status == "error":
            failed = cls.infeasible(kind, r.solver_status, f"not solved: {r.reason}", found.solved)
            return replace(failed, status="error")
        return cls.infeasible(kind, r.solver_status if r else "", reason, found.solved)

    @property
    def settled(self) -> bool:
        """Whether the value is the worst case itself, not only an upper bound on it: decided without a program (the
        threshold rule, a closed form), or a model's certified value (``witness``) within 1e-12 of it (relative to
        max(1, value)). A program whose rounded coefficients leave its witness below its value, beyond the exact
        solve's size, is not."""
        if self.method != "lp" or self.status != "optimal":
            return True
        return math.isfinite(self.witness) and self.value - self.witness <= 1e-12 * max(1.0, abs(self.value))

    def __repr__(self) -> str:
        where = f", context={format_label(self.context)!r}" if self.context is not None else ""
        return (
            f"WorstCase({self.kind}, value={self.value:.6g} nats{where}, groups "
            f"{format_label(self.group)!r} vs {format_label(self.other_group)!r}, method={self.method})"
        )

    def to_dict(self) -> Report:
        """The report dictionary: value, ratio, (context,) the pair, method, status, programs solved (and reason)."""
        from_dual = self.certified and self.method == "lp" and EXACT_CROSSOVER not in self.solver_status
        if from_dual:  # (only the LP route's module knows its statuses: it is loaded where an LP ran)
            from fairaudit.base.linear_fractional import EXACT_BASIS

            from_dual = EXACT_BASIS not in self.solver_status
        d = pair_dict(self.kind, self.value, self.ratio, self.context, self.group, self.other_group)
        d.update(method=self.method, status=self.status, programs_solved=int(self.programs_solved))
        d.update(
            solver_status=self.solver_status,
            certified=bool(self.certified),
            certified_from_dual=bool(from_dual),
            witness=number(self.witness),
            gap=number(self.gap),
        )
        if self.reason:
            d["reason"] = self.reason
        if any(dual.floors is not None for dual in self.duals):
            d["duals"] = [dual.to_dict() for dual in self.duals if dual.floors is not None]
        if any(dual.theta is not None for dual in self.duals):
            d["screens"] = [dual.to_dict() for dual in self.duals if dual.theta is not None]
        if self.witness_point is not None:
            d["witness_point"] = np.vectorize(exact_number, otypes=[object])(self.witness_point).tolist()
        return d


@dataclass(frozen=True, eq=False, kw_only=True)
class WorstModel:
    """The exact maxima of L and L̄ over every decision model, for one utility (:func:`~fairaudit.worstcase.known_utility.worst_model`).

    Attributes
    ----------
    local_fairness, global_fairness : WorstCase
        The maxima of L and L̄, each with its maximising kernel.
    mechanism, context_mechanism : Mechanism
        M_A and M_X.
    utility : Utility
    tau : float or None
    population : Population
    excluded : tuple of str
        Contexts left out (P(X = x) = 0).
    assumptions : tuple of Assumption
    """

    local_fairness: WorstCase
    global_fairness: WorstCase
    mechanism: Mechanism
    context_mechanism: Mechanism
    utility: Utility
    tau: float | None
    population: Population
    excluded: tuple[str, ...]
    assumptions: tuple[Assumption, ...]

    def to_dict(self, reason: str = "") -> Report:
        """The report dictionary: the worst case for L, ``global`` for L̄ and ``worst_model``, the kernel for L.

        Parameters
        ----------
        reason : str
            Why this bound is reported as it is (a certificate's
            ``omitted["black_box"]``, or what its bound is); replaces the local worst case's own ``reason``.
        """
        out = self.local_fairness.to_dict()
        out["reason"] = reason
        out["global"] = self.global_fairness.to_dict()
        out["worst_model"] = None if self.local_fairness.kernel is None else self.local_fairness.kernel.to_dict()
        return out
