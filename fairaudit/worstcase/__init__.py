"""Worst case and calibration: exact worst cases by linear-fractional programming, the largest ε meeting a target.

Behind M_A (and any M_X), a decision kernel K and a utility g give

    E[g | x, b] = Σ_{x̃, ã, u} M_X[x, x̃] M_A[b, ã] K[x̃, ã, u] g(u, x, b),

linear in K (and, for a fixed K, linear in g). Each maximum below is, for one
ordered pair of groups (a, a') (and one context x for local g-fairness), a
linear-fractional program max (p·h)/(q·h) over a polytope, solved by the
likelihood-ratio threshold rule of :mod:`fairaudit.base.threshold_rule` (vectorised over pairs) when only
per-cell bounds constrain h, or those and one floor on q·h, and by Dinkelbach's method over linear programs solved
by HiGHS's simplex and proved exactly (:mod:`fairaudit.base.linear_fractional`, :mod:`fairaudit.base.exact_lp`)
otherwise.

* :func:`~fairaudit.worstcase.black_box.black_box_bound` — the **class certificate**: the exact maximum of L
  over every kernel and every utility in the class g ∈ [lower, γ],
  E[g | x, a] ≥ τ, |g(u, x, a) − g(u, x, a')| ≤ L_A d(a, a'). The reachable
  vectors are h[b, ã] (the expected utility of a group-b member released as
  ã) in the polytope {lower ≤ h ≤ γ, Lipschitz in b, M_A[b]·h[b] ≥ τ}; with
  L_A = 0, h[b] = h for every b, and without a binding τ the polytope is the
  box [lower, γ]^n (threshold solution). M_X drops out; under X ⊥ A the same
  value is the exact maximum of L̄.
* :func:`~fairaudit.worstcase.known_utility.worst_model` — the **known-utility certificate**: the exact maximum
  of L and of L̄ over every kernel, for the utility table given, with τ; it
  returns the maximising kernel, a concrete worst decision model.
* :func:`~fairaudit.worstcase.known_law.worst_utility` — the **worst-case utility** of a known law: the
  utility g(u) ∈ [lower, γ] (with E[g | x, a] ≥ τ) that shows the largest
  local or global disparity. Without constraints it equals Lemma 1's sup.

Pairs are searched in decreasing order of an upper bound (the box value
without τ, γ/τ, and the per-pair tight form) and the search stops when no
remaining pair can beat the best value found, so the LP runs only where the
fast path does not decide. Proofs: ``proofs/black_box.md``,
``proofs/linear_fractional.md``, ``proofs/worst_case_utility.md``.
"""
