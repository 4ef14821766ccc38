"""The problem of the known-utility certificate: the checked inputs of :func:`~fairaudit.worstcase.known_utility.worst_model`.

:func:`model_problem` checks the arguments, fills in the defaults and tabulates g; :class:`ModelProblem` holds them
with what every route of the certificate needs (the closed forms of
:mod:`~fairaudit.worstcase.known_utility_closed_forms`, the search of
:mod:`~fairaudit.worstcase.known_utility_search`): the worst kernel of a table, its audit, and the result.
``proofs/black_box.md`` §6.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, SupportsIndex

import numpy as np
import numpy.typing as npt

from fairaudit.base.arrays import BoolArray, FloatArray, IntArray
from fairaudit.base.checks import nonnegative
from fairaudit.base.errors import InputError, UnderflowError
from fairaudit.base.labels import format_label
from fairaudit.base.outward import down, up
from fairaudit.laws.closed_forms import RandomizedResponse
from fairaudit.laws.composition import compose
from fairaudit.laws.independence import exactly_independent
from fairaudit.laws.mechanisms import Mechanism, identity
from fairaudit.laws.tables import Kernel, Population
from fairaudit.laws.utilities import Utility
from fairaudit.metrics.assumptions import Assumption, check_assumptions
from fairaudit.worstcase.randomized_response import rr_law
from fairaudit.worstcase.worst_cases import ProgramDual, WorstCase, WorstModel, check_method


@dataclass(frozen=True, eq=False, kw_only=True)
class ModelProblem:
    """The checked inputs of :func:`~fairaudit.worstcase.known_utility.worst_model` and what every route of it needs."""

    mechanism: Mechanism  # M_A
    context_mechanism: Mechanism  # M_X
    utility: Utility
    population: Population
    tau: float | None
    method: str
    g: FloatArray  # g[x, a, u], (n_contexts, n_groups, n_decisions)
    live: BoolArray  # P(X = x) > 0
    excluded: tuple[str, ...]
    floor: float  # τ, or -inf without one
    group_free: bool  # g does not depend on the group
    decision_only: bool  # g depends on the decision only
    binding: bool  # τ > E[g | x, a]'s least value (reach) in some live context and group
    independent: bool  # X ⊥ A in the population, exactly (its fast paths use one weight P(x) per context)
    assumptions: tuple[Assumption, ...]

    @property
    def groups(self) -> tuple:
        return self.mechanism.inputs

    @property
    def contexts(self) -> tuple:
        return self.context_mechanism.inputs

    @property
    def same_x(self) -> bool:
        """M_X is the identity (then it is never materialised: a million contexts would be 10^12 cells)."""
        return self.context_mechanism.is_identity

    @property
    def reach(self) -> tuple[FloatArray, FloatArray]:
        """Bounds on E[g | x, a] over every model, shape (n_contexts, n_groups): at most Σ_x̃ M_X[x, x̃] Σ_ã M_A[a, ã]
        max_u g(u, x, a) and at least the same with min_u, rounded outward (the rows' sums are 1 except for a
        matrix's floats: :attr:`~fairaudit.laws.mechanisms.Mechanism.row_sums`)."""
        return utility_reach(self.g, self.mechanism, self.context_mechanism)

    @property
    def n_released_contexts(self) -> int:
        return len(self.context_mechanism.outputs)

    @property
    def n_released_groups(self) -> int:
        return len(self.mechanism.outputs)

    def kernel(self, table: FloatArray, exact: bool = False) -> Kernel:
        """The worst model of a table K[x̃, ã, u]; ``exact``: a table of one-hot rows made here, no rounding to clean."""
        if not exact:
            table = np.clip(table, 0.0, None)
            table = table / table.sum(axis=-1, keepdims=True)
        released_contexts, released_groups = self.context_mechanism.outputs, self.mechanism.outputs
        return Kernel(
            table, released_contexts, released_groups, self.utility.decisions, name="worst model", _owned=True
        )

    def audit(self, kernel: Kernel, kind: str) -> FloatArray | None:
        """E[g | x, a] (local) or E[g | a] (global) of the law behind ``kernel``; None where that law has a cell of
        positive probability below the float range (randomized response above about 708 nats), which floats cannot
        hold (the worst case's value does not rest on it)."""
        from fairaudit.metrics.fairness import global_fairness
        from fairaudit.metrics.reductions import expected_utility

        try:
            if isinstance(self.mechanism, RandomizedResponse):  # (no k x k matrix)
                law = rr_law(kernel, self.mechanism.rr, self.groups, self.context_mechanism)
            else:
                law = compose(kernel, self.mechanism, self.context_mechanism)
        except UnderflowError:
            return None
        if kind == "local":
            return expected_utility(law, self.utility)
        with np.errstate(over="ignore"):  # (ratios of utilities as small as e^-710 overflow; only E[g | a] is kept)
            return global_fairness(law, self.utility, self.population).expected_utility

    def dual(
        self, x: int | None, a: int, b: int, floors: FloatArray | None = None, theta: float | Fraction | None = None
    ) -> ProgramDual:
        """The proof of the program at context x (None for L̄) for the pair (a, b): the floors' ν or a screen's θ."""
        context = None if x is None else self.contexts[x]
        return ProgramDual(
            context=context, group=self.groups[a], other_group=self.groups[b], floors=floors, theta=theta
        )

    def result(self, local: WorstCase, global_: WorstCase) -> WorstModel:
        return WorstModel(
            local_fairness=local,
            global_fairness=global_,
            mechanism=self.mechanism,
            context_mechanism=self.context_mechanism,
            utility=self.utility,
            tau=self.tau,
            population=self.population,
            excluded=self.excluded,
            assumptions=self.assumptions,
        )


def model_problem(
    mechanism: Mechanism,
    utility: Utility,
    context_mechanism: Mechanism | None,
    population: Population | None,
    tau: float | None,
    method: str,
) -> ModelProblem:
    """Check the arguments of :func:`~fairaudit.worstcase.known_utility.worst_model`, fill in the defaults, and tabulate g."""
    if not isinstance(mechanism, Mechanism):
        raise InputError("mechanism", "must be a Mechanism", type(mechanism).__name__)
    if not isinstance(utility, Utility):
        raise InputError("utility", "must be a Utility", type(utility).__name__)
    method = check_method(method)
    if tau is not None:
        tau = nonnegative(tau, "tau")
    groups = mechanism.inputs
    if context_mechanism is None:
        default = ("all",) if utility.contexts is None else utility.contexts
        contexts = population.contexts if population is not None else default
        context_mechanism = identity(contexts, name="identity on contexts")
    if not isinstance(context_mechanism, Mechanism):
        raise InputError("context_mechanism", "must be a Mechanism", type(context_mechanism).__name__)
    contexts = context_mechanism.inputs
    if population is None:
        population = Population.uniform(contexts, groups, source="assumed")
    if not isinstance(population, Population):
        raise InputError("population", "must be a Population", type(population).__name__)
    if tuple(population.contexts) != tuple(contexts) or tuple(population.groups) != tuple(groups):  # (a range too)
        raise InputError(
            "population",
            "must have the context mechanism's inputs as contexts and M_A's inputs as groups",
            (list(map(format_label, population.contexts)), list(map(format_label, population.groups))),
        )
    g = np.asarray(utility.table(contexts, groups, utility.decisions), dtype=float)  # (nX, nA, nU), a view for g(u)
    live = population.p_context > 0
    floor = -math.inf if tau is None else tau
    assumptions = check_assumptions(mechanism, population=population) + (
        Assumption("g is the given utility", "checked", f"{utility!r}"),
    )
    if tau is not None:
        assumptions += (Assumption("E[g | x, a] >= tau for every model", "vouched", f"tau = {tau:g}"),)
    return ModelProblem(
        mechanism=mechanism,
        context_mechanism=context_mechanism,
        utility=utility,
        population=population,
        tau=tau,
        method=method,
        g=g,
        live=live,
        excluded=tuple(f"context {format_label(contexts[i])!r}: P(X = x) = 0" for i in np.flatnonzero(~live)),
        floor=floor,
        group_free=not utility.depends_on_group,
        decision_only=utility.values.ndim == 1 or not (utility.depends_on_group or utility.depends_on_context),
        binding=bool(np.any(floor > utility_reach(g, mechanism, context_mechanism)[1][live])),
        independent=exactly_independent(population.probabilities),
        assumptions=assumptions,
    )


def coefficient_factors(
    MA: npt.NDArray[Any], MX: npt.NDArray[Any], g: npt.NDArray[Any], u_only: bool, x: SupportsIndex, b: SupportsIndex
) -> tuple[npt.NDArray[Any], ...]:
    """The factors, broadcast together, whose product is the coefficients of E[g | x, b] in the programs' variables:
    M_X[x, x̃] M_A[b, ã] in G-space (``u_only``), times g(u, x, b) in kernel space. Floats or exact Fractions.

    Examples
    --------
    >>> MA, MX, g = np.array([[0.7, 0.3], [0.3, 0.7]]), np.eye(1), np.array([[[1.0, 0.0], [1.0, 0.0]]])
    >>> [f.shape for f in coefficient_factors(MA, MX, g, True, 0, 1)], len(coefficient_factors(MA, MX, g, False, 0, 1))
    ([(1, 1), (1, 2)], 3)
    """
    if u_only:
        return MX[x][:, None], MA[b][None, :]
    return MX[x][:, None, None], MA[b][None, :, None], g[x, b][None, None, :]


def utility_reach(g: FloatArray, mechanism: Mechanism, context_mechanism: Mechanism) -> tuple[FloatArray, FloatArray]:
    """:attr:`ModelProblem.reach` for the utility table g (n_contexts, n_groups, n_decisions)."""
    a_hi, a_lo = mechanism.row_sums
    ones = np.ones(g.shape[0])
    x_hi, x_lo = (ones, ones) if context_mechanism.is_identity else context_mechanism.row_sums
    high = _scaled(x_hi[:, None], a_hi[None, :], upward=True)
    low = _scaled(x_lo[:, None], a_lo[None, :], upward=False)
    return _scaled(g.max(-1), high, upward=True), _scaled(g.min(-1), low, upward=False)


def _scaled(values: FloatArray, factor: FloatArray, upward: bool) -> FloatArray:
    """values × factor (broadcast), rounded up (or down), left exact where the factor is 1."""
    product = values * factor
    return np.where(factor == 1.0, values, up(product) if upward else down(product))


def onehot(idx: IntArray, n: int) -> FloatArray:
    """The one-hot rows of the indices ``idx`` over ``n`` values, shape ``idx.shape + (n,)``."""
    return np.eye(n)[idx]


def weighted_utility(problem: ModelProblem) -> FloatArray:
    """w[x̃, u] = Σ_x P(x) M_X[x, x̃] g(u, x), shape (n_released_contexts, n_decisions) (g free of the group)."""
    p_context, g = problem.population.p_context, problem.g
    if problem.same_x:
        return p_context[:, None] * g[:, 0, :]
    return np.einsum("x,xy,xu->yu", p_context, problem.context_mechanism.matrix, g[:, 0, :])
