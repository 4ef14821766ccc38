"""Hypothesis strategies for fairaudit's objects: populations, kernels, laws, utilities (mechanisms: see below).

Every strategy draws a validated fairaudit object whose arrays follow the
layout of docs/design.md, **[x, a, u]** (context, sensitive group, decision), and
keeps a stated promise (an exact ε, an exact δ at ε, an exact range of a
utility, a dependent population, ...), so a property test can rely on it. The
promises are themselves checked by ``tests/testing/test_strategies.py``.
The strategies of mechanisms (``mechanisms``, ``randomized_responses``,
``product_mechanisms``) are in :mod:`fairaudit.testing.mechanism_strategies`,
checked by ``tests/testing/test_mechanism_strategies.py``; import them all
from :mod:`fairaudit.testing`.

Sizes
-----
Each size argument takes an ``int`` (a fixed size), a ``range`` (the size is
drawn from it; hypothesis shrinks towards its start) or a list or tuple of
labels (the size is its length and the labels are used as given). The default
sizes are small so that properties stay fast. Default labels are strings:
contexts ``"x0", "x1", ...``, groups and mechanism inputs ``"a0", ...``,
decisions ``"u0", ...``, mechanism outputs ``"o0", ...`` when they are not the
inputs.

Numbers such as ``epsilon``, ``delta``, ``gamma`` and ``lower`` take a float or
a hypothesis strategy of floats (drawn once per example).

Usage
-----
This module imports hypothesis; ``import fairaudit`` does not import it.

```
from hypothesis import given
from fairaudit.testing import mechanisms, utilities

@given(mechanisms(n_inputs=3, epsilon=1.0))
def test_epsilon(m):
    assert abs(m.epsilon - 1.0) <= 1e-9
```

Examples
--------
>>> from hypothesis import find
>>> pop = find(populations(independent=False), lambda p: True)
>>> pop.independence().independent
False
"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import strategies as st
from hypothesis.errors import InvalidArgument

from fairaudit.base.arrays import FloatArray
from fairaudit.laws.tables import Kernel, Law, Population
from fairaudit.laws.utilities import Utility
from fairaudit.testing import _draws as draws
from fairaudit.testing._draws import Number, Size

__all__ = [
    # populations
    "populations",
    # decision models and their laws
    "kernels",
    "laws",
    # utilities
    "utilities",
]


# --------------------------------------------------------------------------- populations


@st.composite
def populations(
    draw: st.DrawFn,
    contexts: Size = range(1, 4),
    groups: Size = range(2, 4),
    independent: bool | None = None,
    allow_zero_contexts: bool = False,
) -> Population:
    """Populations P(X = x, A = a), independent or not.

    Parameters
    ----------
    contexts, groups : int, range or sequence of labels
        Sizes (or labels) of the two axes; default 1 to 3 contexts and 2 to 3
        groups, labelled ``"x0", ...`` and ``"a0", ...``.
    independent : bool or None
        True: the outer product P(x) P(a) of two random marginals.
        False: a random joint that is *not* independent (needs at least two
        contexts with P(x) > 0 and two groups). None: either, drawn (always
        independent when the sizes leave no room for dependence).
    allow_zero_contexts : bool
        Allow contexts with P(X = x) = 0 (whole zero rows); at least one
        context (two, for a dependent population) keeps positive mass.

    Returns
    -------
    Population
        Shape (n_contexts, n_groups), indexed [x, a]; every group has
        P(A = a) > 0.

    Guarantees
    ----------
    ``independent=True``: ``independence().independent`` is True (tolerance
    1e-9). ``independent=False``: max |P(x, a) − P(x) P(a)| ≥ 1e-6, so
    ``independence().independent`` is False. Construction of a dependent
    joint: integer weights W ≥ 0; when W is (nearly) a product, add
    T = ΣW + 1 to the cells (first positive context, a0) and (second positive
    context, a1), which makes the 2×2 minor at least T² − W₀₁W₁₀ > 0, so W has
    rank ≥ 2 and X, A are dependent.

    Raises
    ------
    hypothesis.errors.InvalidArgument
        When the strategy is drawn from: a size that is not an int, a range or a
        sequence of labels, a size below the minimum, or a request the
        construction cannot meet.

    Examples
    --------
    >>> from hypothesis import find
    >>> pop = find(populations(contexts=2, groups=3, independent=True), lambda p: True)
    >>> pop.probabilities.shape, pop.independence().independent
    ((2, 3), True)
    """
    least = 2 if independent is False else 1
    xs = draws.labels(draw, contexts, "x", least, "contexts")
    gs = draws.labels(draw, groups, "a", least, "groups")
    nx, na = len(xs), len(gs)
    if independent is None:
        independent = True if (nx < 2 or na < 2) else draw(st.booleans())
    live = draws.alive(draw, nx, 1 if independent else 2) if allow_zero_contexts and nx > 1 else np.ones(nx, bool)
    if independent:
        px = draws.weights(draw, (nx,), allow_zeros=False) * live
        pa = draws.weights(draw, (na,), allow_zeros=False)
        return Population.independent(px / px.sum(), pa / pa.sum(), xs, gs)
    w = draws.weights(draw, (nx, na), allow_zeros=True) * live[:, None]
    # columns must keep positive mass among live contexts
    rows = np.flatnonzero(live)
    w[rows[0], w[rows].sum(axis=0) == 0] = 1.0
    pop = Population(w / w.sum(), xs, gs)
    if pop.independence().max_deviation < 1e-6:
        total = w.sum() + 1.0
        w[rows[0], 0] += total
        w[rows[1], 1] += total
        pop = Population(w / w.sum(), xs, gs)
    assert pop.independence().max_deviation >= 1e-6
    return pop


# --------------------------------------------------------------------------- kernels and laws


@st.composite
def kernels(
    draw: st.DrawFn,
    contexts: Size = range(1, 3),
    groups: Size = range(1, 4),
    decisions: Size = range(1, 4),
    deterministic: bool | None = None,
    allow_zeros: bool = False,
) -> Kernel:
    """Decision kernels K[x̃, ã, u] = P(U = u | X̃ = x̃, Ã = ã).

    Parameters
    ----------
    contexts, groups, decisions : int, range or sequence of labels
        The kernel's axes; pass a mechanism's ``outputs`` as ``groups`` to
        compose with it. Defaults: 1–2 contexts, 1–3 groups, 1–3 decisions,
        labelled ``"x0"``, ``"a0"``, ``"u0"``, ...
    deterministic : bool or None
        True: every row is one-hot (a deterministic model). False: random rows
        (strictly positive unless ``allow_zeros``). None: either, drawn.
    allow_zeros : bool
        Allow zero-probability decisions in random rows.

    Returns
    -------
    Kernel
        Shape (n_contexts, n_groups, n_decisions), indexed [x̃, ã, u]; rows
        sum to 1.

    Raises
    ------
    hypothesis.errors.InvalidArgument
        When the strategy is drawn from: a size that is not an int, a range or a
        sequence of labels, a size below the minimum, or a request the
        construction cannot meet.

    Examples
    --------
    >>> from hypothesis import find
    >>> k = find(kernels(contexts=1, groups=2, decisions=2, deterministic=True), lambda k: True)
    >>> k.shape, sorted(set(k.probabilities.ravel().tolist()))
    ((1, 2, 2), [0.0, 1.0])
    """
    xs, gs, us = draws.table_labels(draw, (contexts, groups, decisions), ("contexts", "groups", "decisions"))
    shape = (len(xs), len(gs), len(us))
    if deterministic is None:
        deterministic = draw(st.booleans())
    if deterministic:
        probs = np.eye(shape[2])[draws.integers(draw, shape[:2], 0, shape[2] - 1)]  # (one-hot rows)
    else:
        probs = draws.rows(draw, shape, allow_zeros)
    return Kernel(probs, xs, gs, us)


@st.composite
def laws(
    draw: st.DrawFn,
    n_contexts: Size = range(1, 3),
    n_groups: Size = range(1, 4),
    n_decisions: Size = range(1, 4),
    zero_cells: bool = False,
    counts: bool = False,
) -> Law:
    """Laws Q[x, a, u] = P(U = u | X = x, A = a), with the edge cases.

    Parameters
    ----------
    n_contexts, n_groups, n_decisions : int, range or sequence of labels
        Defaults 1–2 contexts, 1–3 groups and 1–3 decisions, so laws with one
        context, one group or one decision are drawn (and are what hypothesis
        shrinks to). Labels ``"x0"``, ``"a0"``, ``"u0"``, ...
    zero_cells : bool
        Allow probability-zero decisions (zero entries Q[x, a, u] = 0).
    counts : bool
        Build with :meth:`Law.from_counts` from integer counts in [0, 50]:
        cells (x, a) may be *empty* (a zero row, NaN in the law, listed in
        ``empty_cells``); at least one cell is observed.

    Returns
    -------
    Law
        Shape (n_contexts, n_groups, n_decisions); every observed row sums
        to 1; with ``zero_cells=False`` (and without counts) every entry is
        positive.

    Raises
    ------
    hypothesis.errors.InvalidArgument
        When the strategy is drawn from: a size that is not an int, a range or a
        sequence of labels, a size below the minimum, or a request the
        construction cannot meet.

    Examples
    --------
    >>> from hypothesis import find
    >>> law = find(laws(counts=True), lambda q: len(q.empty_cells) > 0)
    >>> law.counts is not None, bool(law.observed.any())
    (True, True)
    """
    xs, gs, us = draws.table_labels(
        draw, (n_contexts, n_groups, n_decisions), ("n_contexts", "n_groups", "n_decisions")
    )
    shape = (len(xs), len(gs), len(us))
    if counts:
        c = draws.integers(draw, shape, 0, draws.MAX_WEIGHT).astype(float)
        if c.sum() == 0:
            c[(0,) * len(shape)] = 1.0
        return Law.from_counts(c, xs, gs, us)
    return Law(draws.rows(draw, shape, zero_cells), xs, gs, us)


# --------------------------------------------------------------------------- utilities


@st.composite
def utilities(
    draw: st.DrawFn,
    decisions: Size = range(2, 4),
    gamma: Number = 1.0,
    lower: Number = 0.0,
    contexts: Size | None = None,
    groups: Size | None = None,
    depends_on_group: bool = False,
    lipschitz: Number | None = None,
) -> Utility:
    """Utilities g ≥ 0 with an exact range [lower, γ] (and optionally an exact L_A).

    Parameters
    ----------
    decisions : int, range or sequence of labels
        Decisions (last axis); default 2 or 3, labelled ``"u0", ...``.
    gamma, lower : float or strategy of floats
        The exact max and min of g; 0 ≤ lower ≤ gamma.
    contexts, groups : int, range, sequence of labels, or None
        Give both for a full table g[x, a, u] (shape (n_contexts, n_groups,
        n_decisions)); with both None and no group dependence, g = g(u) is a
        vector of shape (n_decisions,). With ``depends_on_group`` and no
        labels, 1 context and 2 groups are used.
    depends_on_group : bool
        Draw a g that depends on the group (``Utility.depends_on_group`` is
        True; needs γ > lower and ≥ 2 groups). False: g[x, a, u] = h[x, u].
    lipschitz : float, strategy of floats, or None
        The exact L_A (discrete metric) of a group-dependent g; needs
        0 < L_A ≤ γ − lower, and L_A = γ − lower when there is only one
        (x, u) pair. Implies ``depends_on_group`` when positive.

    Returns
    -------
    Utility
        ``gamma`` and ``lower`` equal the requested values exactly (both are
        entries of the table); ``lipschitz()`` equals the requested L_A
        up to the rounding of γ − L_A (a few ulp of γ), 0 without group
        dependence.

    Construction: g = h + d with h ∈ [lower, γ − L_A] depending on (x, u),
    d ∈ [0, L_A] depending on (x, a, u); one (x, u) has h = γ − L_A with
    d = L_A for group 0 and d = 0 for group 1 (attaining γ and L_A), another
    has h = lower and d = 0 for every group (attaining lower).

    Raises
    ------
    hypothesis.errors.InvalidArgument
        When the strategy is drawn from: a size that is not an int, a range or a
        sequence of labels, a size below the minimum, or a request the
        construction cannot meet.

    Examples
    --------
    >>> from hypothesis import find
    >>> g = find(utilities(decisions=3, gamma=2.0, lower=0.5), lambda g: True)
    >>> g.values.shape, g.gamma, g.lower
    ((3,), 2.0, 0.5)
    >>> g = find(utilities(decisions=2, gamma=1.0, lipschitz=0.25, contexts=2, groups=3), lambda g: True)
    >>> g.values.shape, g.gamma, g.lower, g.lipschitz()
    ((2, 3, 2), 1.0, 0.0, 0.25)
    """
    gam = draws.number(draw, gamma, "gamma")
    low = draws.number(draw, lower, "lower")
    lip = draws.number(draw, lipschitz, "lipschitz")
    if not (math.isfinite(gam) and math.isfinite(low) and 0.0 <= low <= gam):
        raise InvalidArgument(f"need 0 <= lower <= gamma (finite); got lower={low!r}, gamma={gam!r}")
    if lip is not None:
        if not (0.0 <= lip <= gam - low):
            raise InvalidArgument(f"lipschitz={lip!r} must lie in [0, gamma - lower] = [0, {gam - low!r}]")
        if lip > 0:
            depends_on_group = True
    us = draws.labels(draw, decisions, "u", 1, "decisions")
    full = depends_on_group or contexts is not None or groups is not None
    if not full:
        return Utility(_group_free_values(draw, (1, 1, len(us)), gam, low)[0, 0], us, name="drawn utility")
    xs = draws.labels(draw, contexts if contexts is not None else 1, "x", 1, "contexts")
    gs = draws.labels(draw, groups if groups is not None else 2, "a", 2 if depends_on_group else 1, "groups")
    shape = (len(xs), len(gs), len(us))
    if depends_on_group:
        return Utility(_group_dependent_values(draw, shape, gam, low, lip), us, xs, gs, name="drawn utility")
    return Utility(_group_free_values(draw, shape, gam, low), us, xs, gs, name="drawn utility")


def _group_free_values(draw: st.DrawFn, shape: tuple[int, int, int], gam: float, low: float) -> FloatArray:
    """g[x, a, u] = h[x, u] in [low, γ] (the same for every group), attaining γ and lower: at two distinct (x, u)
    (a vector g(u) is the table of one context and one group)."""
    nx, na, nu = shape
    if nx * nu < 2 and gam != low:
        raise InvalidArgument("a utility with one (context, decision) pair cannot have gamma != lower")
    h = draws.between(draw, (nx, nu), low, gam)
    top, bottom = draws.distinct_pair(draw, nx * nu)  # (flat indices of (x, u), row-major)
    h.flat[top], h.flat[bottom] = gam, low
    return np.repeat(h[:, None, :], na, axis=1)


def _group_dependent_values(
    draw: st.DrawFn, shape: tuple[int, int, int], gam: float, low: float, lip: float | None
) -> FloatArray:
    """g = h + d with range exactly [lower, γ] and L_A exactly ``lip`` (drawn when None); see :func:`utilities`."""
    nx, na, nu = shape
    if gam == low:
        raise InvalidArgument("a utility with gamma == lower cannot depend on the group")
    L = lip if lip is not None else (gam - low) * draw(st.sampled_from([1.0, 0.5]) | st.floats(0.01, 1.0))
    top_h = max(low, gam - L)
    if gam - top_h <= 0:
        raise InvalidArgument(f"lipschitz={L!r} is lost in the rounding of gamma={gam!r}")
    if nx * nu < 2 and L < gam - low:
        raise InvalidArgument("with one (context, decision) pair the Lipschitz constant must be gamma - lower")
    h = draws.between(draw, (nx, nu), low, top_h)
    d = draws.between(draw, (nx, na, nu), 0.0, L)
    top, bottom = draws.distinct_pair(draw, nx * nu)
    (tx, tu), (bx, bu) = divmod(top, nu), divmod(bottom, nu)
    h[bx, bu] = low
    d[bx, :, bu] = 0.0
    h[tx, tu] = top_h
    d[tx, :, tu] = np.clip(d[tx, :, tu], 0.0, L)
    d[tx, 0, tu] = L
    d[tx, 1, tu] = 0.0
    values = np.clip(h[:, None, :] + d, low, gam)
    values[tx, 0, tu] = gam  # exactly, whatever the rounding of (γ − L) + L
    if L == gam - low:
        values[tx, 1, tu] = low
    return values
