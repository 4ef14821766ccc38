"""The known-utility certificate: the decision models that maximise L and L̄ for a given utility.

:func:`worst_model`, whose result is a :class:`~fairaudit.worstcase.worst_cases.WorstModel`
(``proofs/black_box.md`` §6). It checks its arguments (:mod:`~fairaudit.worstcase.known_utility_problem`) and
chooses a route for each maximum: the closed forms behind k-ary randomized response or the threshold solution
(:mod:`~fairaudit.worstcase.known_utility_closed_forms`), else the pair search over linear-fractional programs
(:mod:`~fairaudit.worstcase.known_utility_search`).
"""

from __future__ import annotations

import numpy as np

from fairaudit.base.errors import InputError
from fairaudit.laws.closed_forms import RandomizedResponse
from fairaudit.laws.mechanisms import Mechanism
from fairaudit.laws.tables import Population
from fairaudit.laws.utilities import Utility
from fairaudit.worstcase.known_utility_closed_forms import (
    boxes_by_range,
    global_threshold,
    local_threshold,
    randomized_response_cases,
)
from fairaudit.worstcase.known_utility_problem import model_problem
from fairaudit.worstcase.worst_cases import WorstCase, WorstModel


def worst_model(
    mechanism: Mechanism,
    utility: Utility,
    *,
    context_mechanism: Mechanism | None = None,
    population: Population | None = None,
    tau: float | None = None,
    method: str = "auto",
) -> WorstModel:
    """The decision models behind M_A (and M_X) that maximise L and L̄, for a known utility.

    Over every kernel K[x̃, ã, u] (rows on the probability simplex of the
    utility's decisions) with E[g | x, a] ≥ τ in every context of positive
    probability and every group: maximise
    E[g | x, a] / E[g | x, a'] (local) and E[g | a] / E[g | a'] (global, with
    E[g | a] = Σ_x P(x | a) E[g | x, a]).

    Parameters
    ----------
    mechanism : Mechanism
        M_A, shape (n_groups, n_released_groups).
    utility : Utility
        g(u) (shape (n_decisions,)) or g[x, a, u] labelled with the true
        contexts and groups.
    context_mechanism : Mechanism, optional
        M_X, shape (n_contexts, n_released_contexts); default the identity on
        the contexts of ``population`` (or of the utility; one context
        ``"all"`` when neither has any).
    population : Population, optional
        P(X, A); default uniform and independent.
    tau : float, optional
        Lower bound on E[g | x, a] that the models must meet.
    method : {"auto", "threshold", "lp"}
        ``auto`` uses the threshold solution where it applies (g does not
        depend on the group and τ ≤ min_u g(u, x); for L̄ also X ⊥ A), the
        Charnes–Cooper LP elsewhere; ``lp`` forces the LP.

    Returns
    -------
    WorstModel
        ``local_fairness`` and ``global_fairness``, each with the maximising pair (and context)
        and the worst kernel; composing the kernel with the mechanisms and
        auditing it reproduces the value.

    Raises
    ------
    InputError
        On mismatched labels, a negative or non-finite τ, or an unknown method.

    Notes
    -----
    The variables are G[x̃, ã] = Σ_u K[x̃, ã, u] g(u) ∈ [min g, max g] when
    g depends on the decision only, the kernel itself otherwise. Without a
    binding τ and for g free of the group, the local program at x is the box
    program over [min_u g(u, x), max_u g(u, x)]^{n_released} (M_X drops out).
    ``proofs/black_box.md`` (known utility). Behind k-ary randomized
    response, for a utility free of the group, both maxima are closed forms
    (§3 Propositions 3 and 3b per context; with a binding τ when M_X is the
    identity or g depends on the decision only), without the k x k matrix.

    Examples
    --------
    >>> from fairaudit.laws.closed_forms import randomized_response
    >>> from fairaudit.laws.utilities import indicator
    >>> m = randomized_response(["Tom", "Mary"], keep=0.7)
    >>> w = worst_model(m, indicator("chosen", ["chosen", "not chosen"]))
    >>> round(w.local_fairness.ratio, 12), w.local_fairness.group, w.local_fairness.kernel.probabilities[0, :, 0].tolist()
    (2.333333333333, 'Tom', [1.0, 0.0])
    >>> w = worst_model(m, indicator("chosen", ["chosen", "not chosen"]), tau=0.5)   # 11/7, as black_box_bound
    >>> round(w.local_fairness.ratio, 12), w.local_fairness.method, w.local_fairness.kernel.probabilities[0, :, 0].round(6).tolist()
    (1.571428571429, 'threshold', [1.0, 0.285714])
    >>> round(worst_model(m, indicator("chosen", ["chosen", "not chosen"]), tau=0.5, method="lp").local_fairness.ratio, 7)
    1.5714286
    """
    problem = model_problem(mechanism, utility, context_mechanism, population, tau, method)
    g, live, binding, group_free = problem.g, problem.live, problem.binding, problem.group_free
    nX, nA, nU = g.shape
    if nA < 2 or not live.any():
        uniform = problem.kernel(np.ones((problem.n_released_contexts, problem.n_released_groups, nU)) / nU)
        reason = "fewer than two groups" if nA < 2 else "no context has positive probability"
        return problem.result(*(WorstCase.trivial(kind, kernel=uniform, reason=reason) for kind in ("local", "global")))
    method = problem.method
    if method == "threshold" and (not group_free or binding):
        raise InputError("method", "the threshold solution needs a utility free of the group and tau <= min g", method)

    # k-ary randomized response: closed forms, one pair of groups decides (every pair is alike); behind the identity
    # on the context only and short of the identity, where the certificate needs no proof per pair (verify reduces the
    # programs to three cells; the identity's it bounds over the model's table, from the proofs of the search)
    rr_local: WorstCase | None = None
    rr_global: WorstCase | None = None
    if isinstance(mechanism, RandomizedResponse) and not mechanism.is_identity and method != "lp" and group_free:
        if problem.same_x:
            rr_local, rr_global = randomized_response_cases(problem, mechanism.rr)
    general = rr_local is None or rr_global is None
    if general:  # (the search's modules load only where it runs)
        from fairaudit.worstcase.known_utility_search import global_search, local_search
    MA = mechanism.matrix if general else np.zeros((0, 0))
    pairs = np.argwhere(~np.eye(nA, dtype=bool)) if general else np.zeros((0, 2), dtype=np.intp)  # (a, b), a != b
    boxes = boxes_by_range(problem, MA) if group_free and rr_local is None else None
    if rr_local is not None:
        local = rr_local
    elif group_free and not binding and method != "lp":
        assert boxes is not None  # (g is free of the group)
        local = local_threshold(problem, MA, boxes)
    else:
        local = local_search(problem, MA, pairs, boxes)
    present = problem.population.p_group > 0  # L-bar compares the groups with P(A = a) > 0 only
    if np.count_nonzero(present) < 2:
        uniform = problem.kernel(np.ones((problem.n_released_contexts, problem.n_released_groups, nU)) / nU)
        global_ = WorstCase.trivial("global", kernel=uniform, reason="fewer than two groups with P(A = a) > 0")
    elif rr_global is not None:
        global_ = rr_global
    elif group_free and not binding and problem.independent and method != "lp":
        global_ = global_threshold(problem, MA)
    else:
        global_ = global_search(problem, MA, pairs[present[pairs[:, 0]] & present[pairs[:, 1]]])
    return problem.result(local, global_)
