"""Hypothesis strategies for fairaudit's objects: populations, mechanisms, kernels, utilities, laws.

Every strategy draws a validated fairaudit object whose arrays follow the
layout of docs/design.md, **[x, a, u]** (context, sensitive group, decision), and
keeps a stated promise (an exact ε, an exact δ at ε, an exact range of a
utility, a dependent population, ...), so a property test can rely on it. The
promises are themselves checked by ``tests/testing/test_strategies.py``.

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
from collections.abc import Hashable, Sequence
from typing import TypeAlias, overload

import numpy as np
from hypothesis import assume
from hypothesis import strategies as st
from hypothesis.errors import InvalidArgument
from hypothesis.extra import numpy as hnp

from fairaudit.base.arrays import FloatArray
from fairaudit.laws.closed_forms import randomized_response
from fairaudit.laws.mechanisms import Mechanism, product
from fairaudit.laws.tables import Kernel, Law, Population
from fairaudit.laws.utilities import Utility

__all__ = [
    # populations and mechanisms
    "mechanisms",
    "populations",
    "product_mechanisms",
    "randomized_responses",
    # decision models and their laws
    "kernels",
    "laws",
    # utilities
    "utilities",
]

_MAX_WEIGHT = 50
"""Largest integer weight drawn before normalising a probability row."""

EPSILON_TOLERANCE = 1e-9
"""Largest accepted |ε(M) − requested ε| and |δ(M, ε) − requested δ|."""

Size: TypeAlias = int | range | Sequence[Hashable]
"""A size argument: a fixed size, a range to draw it from, or the labels themselves."""
Number: TypeAlias = float | st.SearchStrategy[float]
"""A number argument: a float, or a strategy of floats drawn once per example."""


# --------------------------------------------------------------------------- helpers


def _labels(draw: st.DrawFn, spec: Size, prefix: str, minimum: int, what: str) -> tuple:
    """Resolve a size spec (int, range, or labels) into a tuple of labels of length ≥ ``minimum``."""
    if isinstance(spec, bool):
        raise InvalidArgument(f"{what}={spec!r}: give an int, a range or a sequence of labels")
    if isinstance(spec, int):
        if spec < minimum:
            raise InvalidArgument(f"{what}={spec} must be at least {minimum}")
        n = spec
    elif isinstance(spec, range):
        sizes = [n for n in spec if n >= minimum]
        if not sizes:
            raise InvalidArgument(f"{what}={spec!r} has no size of at least {minimum}")
        n = draw(st.sampled_from(sizes))
    elif isinstance(spec, Sequence) and not isinstance(spec, (str, bytes)):
        labels = tuple(spec)
        if len(labels) < minimum:
            raise InvalidArgument(f"{what} needs at least {minimum} labels, got {len(labels)}")
        return labels
    else:
        raise InvalidArgument(f"{what}={spec!r}: give an int, a range or a sequence of labels")
    return tuple(f"{prefix}{i}" for i in range(n))


@overload
def _number(draw: st.DrawFn, value: Number, what: str) -> float: ...
@overload
def _number(draw: st.DrawFn, value: Number | None, what: str) -> float | None: ...
def _number(draw: st.DrawFn, value: Number | None, what: str) -> float | None:
    """A float, or one draw of a strategy of floats; None stays None."""
    if value is None:
        return None
    if isinstance(value, st.SearchStrategy):
        value = draw(value)
    try:
        return float(value)
    except (TypeError, ValueError):
        raise InvalidArgument(f"{what}={value!r} must be a number or a strategy of numbers") from None


def _weights(draw: st.DrawFn, shape: tuple[int, ...], allow_zeros: bool) -> FloatArray:
    """Integer weights of ``shape``; every row along the last axis has a positive sum."""
    low = 0 if allow_zeros else 1
    w = draw(hnp.arrays(np.int64, shape, elements=st.integers(low, _MAX_WEIGHT))).astype(float)
    if w.size:
        rows = w.reshape(-1, shape[-1])
        dead = rows.sum(axis=1) == 0
        rows[dead, 0] = 1.0
        w = rows.reshape(shape)
    return w


def _between(draw: st.DrawFn, shape: tuple[int, ...], low: float, high: float) -> FloatArray:
    """Floats in [low, high] (low ≤ high up to rounding) of ``shape``, drawn as fractions of the interval."""
    n = int(np.prod(shape))
    f = np.array(draw(st.lists(st.floats(0.0, 1.0), min_size=n, max_size=n)), dtype=float).reshape(shape)
    lo, hi = min(low, high), max(low, high)
    return np.clip(lo + f * (hi - lo), lo, hi)


def _rows(draw: st.DrawFn, shape: tuple[int, ...], allow_zeros: bool) -> FloatArray:
    """Random probability rows along the last axis (each sums to 1)."""
    w = _weights(draw, shape, allow_zeros)
    return w / w.sum(axis=-1, keepdims=True)


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
    if independent is False:
        xs = _labels(draw, contexts, "x", 2, "contexts")
        gs = _labels(draw, groups, "a", 2, "groups")
    else:
        xs = _labels(draw, contexts, "x", 1, "contexts")
        gs = _labels(draw, groups, "a", 1, "groups")
    nx, na = len(xs), len(gs)
    if independent is None:
        independent = True if (nx < 2 or na < 2) else draw(st.booleans())
    live = np.ones(nx, dtype=bool)
    if allow_zero_contexts and nx > 1:
        live = ~np.array(draw(st.lists(st.booleans(), min_size=nx, max_size=nx)))
        need = 1 if independent else 2
        for i in range(nx):
            if live.sum() >= need:
                break
            live[i] = True
    if independent:
        px = _weights(draw, (nx,), allow_zeros=False) * live
        pa = _weights(draw, (na,), allow_zeros=False)
        return Population.independent(px / px.sum(), pa / pa.sum(), xs, gs)
    w = _weights(draw, (nx, na), allow_zeros=True) * live[:, None]
    # columns must keep positive mass among live contexts
    rows = np.flatnonzero(live)
    for j in range(na):
        if w[rows, j].sum() == 0:
            w[rows[0], j] = 1.0
    p = w / w.sum()
    pop = Population(p, xs, gs)
    if pop.independence().max_deviation < 1e-6:
        total = w.sum() + 1.0
        w[rows[0], 0] += total
        w[rows[1], 1] += total
        pop = Population(w / w.sum(), xs, gs)
    assert pop.independence().max_deviation >= 1e-6
    return pop


# --------------------------------------------------------------------------- mechanisms


def _pure_matrix(draw: st.DrawFn, n_in: int, n_out: int, epsilon: float, allow_zeros: bool) -> FloatArray:
    """A row-stochastic (n_in, n_out) matrix with ε(M) = ``epsilon`` (0 ≤ ε ≤ inf)."""
    live = np.ones(n_out, dtype=bool)
    need = 1 if epsilon == 0 else 2
    if allow_zeros and n_out > need:
        live = ~np.array(draw(st.lists(st.booleans(), min_size=n_out, max_size=n_out)))
        for j in range(n_out):
            if live.sum() >= need:
                break
            live[j] = True
    k = int(live.sum())
    q = _rows(draw, (k,), allow_zeros=False)
    if epsilon == 0 or n_in == 1:
        m = np.tile(q, (n_in, 1))
    else:
        # R: random rows with an asymmetric zero so that ε(R) = inf.
        r = _weights(draw, (n_in, k), allow_zeros=allow_zeros or math.isinf(epsilon))
        star = draw(st.integers(0, k - 1))
        r[0, star] = max(r[0, star], 1.0)
        r[1, star] = 0.0
        if r[1].sum() == 0:
            r[1, (star + 1) % k] = 1.0
        r = r / r.sum(axis=1, keepdims=True)
        if math.isinf(epsilon):
            m = r
        else:
            # M(s) = (q + s R) / (1 + s): every ratio (q_o + s x)/(q_o + s y) is monotone in s,
            # so ε(M(s)) rises continuously from 0 to inf; it reaches ε at the smallest crossing
            # s = q_o (e^ε − 1) / (x − e^ε y) over triples with x > e^ε y.
            t = math.exp(epsilon)
            x = r[:, None, :]
            y = r[None, :, :]
            gap = x - t * y
            with np.errstate(divide="ignore", invalid="ignore"):
                s = np.where(gap > 0, q * (t - 1.0) / gap, np.inf)
            s_star = float(s.min())
            m = (q + s_star * r) / (1.0 + s_star)
    full = np.zeros((n_in, n_out))
    full[:, live] = m
    return full


@st.composite
def mechanisms(
    draw: st.DrawFn,
    n_inputs: Size = range(2, 4),
    n_outputs: Size | None = None,
    epsilon: Number | None = None,
    delta: Number | None = None,
    allow_zeros: bool = False,
) -> Mechanism:
    """Finite mechanisms M[a, o] = P(output = o | input = a), optionally with an exact ε or (ε, δ).

    Parameters
    ----------
    n_inputs : int, range or sequence of labels
        The inputs (rows); default 2 or 3, labelled ``"a0", ...``.
    n_outputs : int, range, sequence of labels or None
        The outputs (columns). None: the inputs' own labels (a square
        mechanism), except with ``delta`` (see below). Otherwise labelled
        ``"o0", ...``.
    epsilon : float, strategy of floats, or None
        Without ``delta``: the exact pure budget ε(M) in nats (0, positive or
        ``math.inf``). With ``delta``: the ε at which δ(M, ε) is prescribed.
        None: an arbitrary random mechanism.
    delta : float, strategy of floats, or None
        With ``epsilon``: the exact hockey-stick divergence δ(M, ε) ∈ [0, 1].
    allow_zeros : bool
        Allow zero entries (with ``epsilon=None`` this allows ε = inf; with a
        finite ε only outputs that no input produces can be zero).

    Returns
    -------
    Mechanism
        Shape (n_inputs, n_outputs); rows sum to 1.

    Guarantees
    ----------
    * ``epsilon`` alone: |ε(M) − ε| ≤ 1e-9 (``Mechanism.epsilon``; ε = inf
      exactly). Construction: M = (q + s R) / (1 + s) with q a random positive
      row (ε = 0) and R random rows with an asymmetric zero (ε = inf); every
      likelihood ratio of M is monotone in s, so ε(M) is continuous and
      increasing in s, and s is the closed-form smallest crossing of e^ε.
      Outputs are then permuted at random. Needs ≥ 2 inputs and outputs for ε > 0.
    * ``epsilon`` and ``delta``: |δ(M, ε) − δ| ≤ 1e-9 (``Mechanism.delta``)
      and every pair of inputs has the same divergence δ at ε.
      Construction ("pure part plus leak"): with c ≥ 0 drawn and
      m = δ + (e^ε + n − 1) c ≤ 1, row a is (1 − m) P[a] on a pure mechanism P
      with ε(P) ≤ ε (n_outputs − n_inputs columns, at least 1), followed by
      n_inputs leak columns where input a puts δ + e^ε c on its own leak column
      and c on each other one. The pure part contributes nothing to the
      hockey-stick at ε; each pair (a, a') gains exactly δ on leak column a.
      So ε(M) = log((δ + e^ε c)/c) (inf when c = 0 and δ > 0). With
      ``n_outputs=None`` the pure part has 1 or 2 columns.

    Raises
    ------
    hypothesis.errors.InvalidArgument
        On ``delta`` without ``epsilon``, a negative ε, δ outside [0, 1], or
        sizes that cannot carry the requested budget.

    Examples
    --------
    >>> import math
    >>> from hypothesis import find
    >>> m = find(mechanisms(n_inputs=3, epsilon=1.0), lambda m: True)
    >>> m.matrix.shape, abs(m.epsilon - 1.0) <= 1e-9
    ((3, 3), True)
    >>> m = find(mechanisms(n_inputs=2, epsilon=0.5, delta=0.1), lambda m: True)
    >>> abs(m.delta(0.5) - 0.1) <= 1e-9
    True
    """
    eps = _number(draw, epsilon, "epsilon")
    dlt = _number(draw, delta, "delta")
    if eps is not None and (math.isnan(eps) or eps < 0 or 700.0 < eps < math.inf):
        raise InvalidArgument(f"epsilon={eps!r} must be a number of nats in [0, 700] or math.inf")
    if dlt is not None:
        if eps is None:
            raise InvalidArgument("delta needs epsilon: the ε at which δ(M, ε) is prescribed")
        if not (0.0 <= dlt <= 1.0):
            raise InvalidArgument(f"delta={dlt!r} must lie in [0, 1]")
        if math.isinf(eps) and dlt > 0:
            raise InvalidArgument("δ(M, inf) > 0 at ε = inf: give a finite epsilon with a positive delta")
        return draw(_delta_mechanisms(n_inputs, n_outputs, eps, dlt, allow_zeros))
    positive = eps is not None and eps > 0
    inputs = _labels(draw, n_inputs, "a", 2 if positive else 1, "n_inputs")
    if n_outputs is None:
        outputs = inputs
    else:
        outputs = _labels(draw, n_outputs, "o", 2 if positive else 1, "n_outputs")
    n_in, n_out = len(inputs), len(outputs)
    if eps is None:
        matrix = _rows(draw, (n_in, n_out), allow_zeros)
        return Mechanism(matrix, inputs, outputs, name="random mechanism")
    matrix = _pure_matrix(draw, n_in, n_out, eps, allow_zeros)
    perm = draw(st.permutations(range(n_out)))
    mech = Mechanism(matrix[:, perm], inputs, outputs, name=f"random mechanism (epsilon={eps:g})")
    assume(mech.epsilon == eps if math.isinf(eps) else abs(mech.epsilon - eps) <= EPSILON_TOLERANCE)
    return mech


@st.composite
def _delta_mechanisms(
    draw: st.DrawFn, n_inputs: Size, n_outputs: Size | None, eps: float, dlt: float, allow_zeros: bool
) -> Mechanism:
    inputs = _labels(draw, n_inputs, "a", 2 if dlt > 0 else 1, "n_inputs")
    n_in = len(inputs)
    if n_outputs is None:
        n_pure = draw(st.integers(1, 2))
        outputs = tuple(f"o{j}" for j in range(n_pure + n_in))
    else:
        outputs = _labels(draw, n_outputs, "o", n_in + 1, "n_outputs (n_inputs + 1 at least, with delta)")
        n_pure = len(outputs) - n_in
    t = math.exp(eps)
    c_max = (1.0 - dlt) / (t + n_in - 1)
    c = c_max * draw(st.sampled_from([0.0, 0.25, 0.5, 1.0]) | st.floats(0.0, 1.0))
    mass = dlt + (t + n_in - 1) * c
    if mass > 1.0:  # rounding at c = c_max
        c = max(0.0, (1.0 - dlt) / (t + n_in - 1) * (1 - 1e-15))
        mass = dlt + (t + n_in - 1) * c
    eps_pure = eps * draw(st.sampled_from([0.0, 1.0]) | st.floats(0.0, 1.0))
    if n_pure < 2 or n_in < 2:
        eps_pure = 0.0
    pure = _pure_matrix(draw, n_in, n_pure, eps_pure, allow_zeros)
    leak = np.full((n_in, n_in), c)
    np.fill_diagonal(leak, dlt + t * c)
    matrix = np.hstack([(1.0 - mass) * pure, leak])
    perm = draw(st.permutations(range(len(outputs))))
    mech = Mechanism(matrix[:, perm], inputs, outputs, name=f"random mechanism (epsilon={eps:g}, delta={dlt:g})")
    assume(abs(mech.delta(eps) - dlt) <= EPSILON_TOLERANCE)
    return mech


@st.composite
def randomized_responses(draw: st.DrawFn, k: Size = range(2, 5), epsilon: Number = st.floats(0.0, 5.0)) -> Mechanism:
    """k-ary randomized response (:func:`fairaudit.laws.closed_forms.randomized_response`).

    Parameters
    ----------
    k : int, range or sequence of labels
        Alphabet size (or the values); default 2 to 4, labelled ``"a0", ...``.
    epsilon : float or strategy of floats
        Budget in nats; default drawn from [0, 5]. ``math.inf`` gives the identity.

    Returns
    -------
    Mechanism
        Square (k, k) with inputs = outputs; ε(M) = ``epsilon`` exactly and
        keep probability e^ε / (e^ε + k − 1).

    Raises
    ------
    hypothesis.errors.InvalidArgument
        When the strategy is drawn from: a size that is not an int, a range or a
        sequence of labels, a size below the minimum, or a request the
        construction cannot meet.

    Examples
    --------
    >>> from hypothesis import find
    >>> m = find(randomized_responses(k=3, epsilon=1.0), lambda m: True)
    >>> m.epsilon, m.inputs
    (1.0, ('a0', 'a1', 'a2'))
    """
    values = _labels(draw, k, "a", 2, "k")
    eps = _number(draw, epsilon, "epsilon")
    if eps is None or math.isnan(eps) or eps < 0:
        raise InvalidArgument(f"epsilon={eps!r} must be a non-negative number of nats")
    return randomized_response(values, eps)


@st.composite
def product_mechanisms(
    draw: st.DrawFn,
    n_attributes: Size = range(2, 4),
    n_values: Size = range(2, 4),
    epsilon: Number | None = None,
    kind: str | None = None,
) -> Mechanism:
    """Product mechanisms on tuples of attributes (:func:`fairaudit.laws.mechanisms.product`).

    Parameters
    ----------
    n_attributes : int or range
        Number of components; default 2 or 3.
    n_values : int or range
        Values per attribute (drawn per attribute); default 2 or 3. Attribute i
        has values ``"v{i}_0", "v{i}_1", ...``.
    epsilon : float, strategy of floats, or None
        The product's exact ε: split at random among the components, each
        drawn with that exact budget. None: arbitrary components.
    kind : {"randomized_response", "matrix"} or None
        Component type; None mixes both (drawn per component).

    Returns
    -------
    Mechanism
        Square; inputs = outputs = tuples of component labels in
        ``itertools.product`` order; the matrix is the Kronecker product.

    Guarantees
    ----------
    With ``epsilon``: |ε(product) − ε| ≤ 1e-9 (ε of the product is the sum
    of the components' ε, every pair of tuples adjacent).

    Raises
    ------
    hypothesis.errors.InvalidArgument
        When the strategy is drawn from: a size that is not an int, a range or a
        sequence of labels, a size below the minimum, or a request the
        construction cannot meet.

    Examples
    --------
    >>> from hypothesis import find
    >>> m = find(product_mechanisms(n_attributes=2, n_values=2, epsilon=1.5), lambda m: True)
    >>> m.inputs[0], abs(m.epsilon - 1.5) <= 1e-9
    (('v0_0', 'v1_0'), True)
    """
    n = len(_labels(draw, n_attributes, "", 1, "n_attributes"))
    eps = _number(draw, epsilon, "epsilon")
    if eps is not None and (math.isnan(eps) or eps < 0 or math.isinf(eps)):
        raise InvalidArgument(f"epsilon={eps!r} must be a finite non-negative number of nats")
    shares: list[float | None] = [None] * n  # each component's ε (None: arbitrary)
    if eps is not None:
        w = _weights(draw, (n,), allow_zeros=True)
        split = [eps * float(wi) / float(w.sum()) for wi in w]
        split[-1] = eps - sum(split[:-1])
        split[-1] = max(split[-1], 0.0)
        shares = [*split]
    components = []
    for i in range(n):
        values = _labels(draw, n_values, f"v{i}_", 2, "n_values")
        which = kind or draw(st.sampled_from(["randomized_response", "matrix"]))
        if which == "randomized_response":
            e = shares[i] if shares[i] is not None else draw(st.floats(0.0, 3.0))
            components.append(randomized_response(values, e))
        elif which == "matrix":
            components.append(draw(mechanisms(n_inputs=values, epsilon=shares[i])))
        else:
            raise InvalidArgument(f"kind={kind!r} must be 'randomized_response', 'matrix' or None")
    mech = product(*components)
    if eps is not None:
        assume(abs(mech.epsilon - eps) <= EPSILON_TOLERANCE)
    return mech


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
    xs = _labels(draw, contexts, "x", 1, "contexts")
    gs = _labels(draw, groups, "a", 1, "groups")
    us = _labels(draw, decisions, "u", 1, "decisions")
    shape = (len(xs), len(gs), len(us))
    if deterministic is None:
        deterministic = draw(st.booleans())
    if deterministic:
        choice = draw(hnp.arrays(np.int64, shape[:2], elements=st.integers(0, shape[2] - 1)))
        probs = np.zeros(shape)
        np.put_along_axis(probs, choice[..., None], 1.0, axis=-1)
    else:
        probs = _rows(draw, shape, allow_zeros)
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
    xs = _labels(draw, n_contexts, "x", 1, "n_contexts")
    gs = _labels(draw, n_groups, "a", 1, "n_groups")
    us = _labels(draw, n_decisions, "u", 1, "n_decisions")
    shape = (len(xs), len(gs), len(us))
    if counts:
        c = draw(hnp.arrays(np.int64, shape, elements=st.integers(0, _MAX_WEIGHT))).astype(float)
        if c.sum() == 0:
            c[(0,) * len(shape)] = 1.0
        return Law.from_counts(c, xs, gs, us)
    return Law(_rows(draw, shape, zero_cells), xs, gs, us)


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
    gam = _number(draw, gamma, "gamma")
    low = _number(draw, lower, "lower")
    lip = _number(draw, lipschitz, "lipschitz")
    if not (math.isfinite(gam) and math.isfinite(low) and 0.0 <= low <= gam):
        raise InvalidArgument(f"need 0 <= lower <= gamma (finite); got lower={low!r}, gamma={gam!r}")
    if lip is not None:
        if not (0.0 <= lip <= gam - low):
            raise InvalidArgument(f"lipschitz={lip!r} must lie in [0, gamma - lower] = [0, {gam - low!r}]")
        if lip > 0:
            depends_on_group = True
    us = _labels(draw, decisions, "u", 1, "decisions")
    full = depends_on_group or contexts is not None or groups is not None
    if not full:
        return Utility(_vector_values(draw, len(us), gam, low), us, name="drawn utility")
    xs = _labels(draw, contexts if contexts is not None else 1, "x", 1, "contexts")
    gs = _labels(draw, groups if groups is not None else 2, "a", 2 if depends_on_group else 1, "groups")
    shape = (len(xs), len(gs), len(us))
    if depends_on_group:
        values = _group_dependent_values(draw, shape, gam, low, lip)
    else:
        values = _group_free_values(draw, shape, gam, low)
    return Utility(values, us, xs, gs, name="drawn utility")


def _vector_values(draw: st.DrawFn, nu: int, gam: float, low: float) -> FloatArray:
    """g(u) over ``nu`` decisions in [low, γ], with one decision at γ and another at lower."""
    if nu < 2 and gam != low:
        raise InvalidArgument("a utility over one decision cannot have gamma != lower")
    values = _between(draw, (nu,), low, gam)
    hi, lo = draw(st.sampled_from([(i, j) for i in range(nu) for j in range(nu) if i != j] or [(0, 0)]))
    values[hi], values[lo] = gam, low
    return values


def _group_free_values(draw: st.DrawFn, shape: tuple[int, int, int], gam: float, low: float) -> FloatArray:
    """g[x, a, u] = h[x, u] in [low, γ] (the same for every group), attaining γ and lower."""
    nx, na, nu = shape
    slots = [(x, u) for x in range(nx) for u in range(nu)]
    if len(slots) < 2 and gam != low:
        raise InvalidArgument("one (context, decision) pair cannot carry both gamma and lower")
    h = _between(draw, (nx, nu), low, gam)
    pair = [(i, j) for i in range(len(slots)) for j in range(len(slots)) if i != j] or [(0, 0)]
    top, bottom = draw(st.sampled_from(pair))
    h[slots[top]] = gam
    h[slots[bottom]] = low
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
    slots = [(x, u) for x in range(nx) for u in range(nu)]
    if len(slots) < 2 and L < gam - low:
        raise InvalidArgument("with one (context, decision) pair the Lipschitz constant must be gamma - lower")
    h = _between(draw, (nx, nu), low, top_h)
    d = _between(draw, (nx, na, nu), 0.0, L)
    pair = [(i, j) for i in range(len(slots)) for j in range(len(slots)) if i != j] or [(0, 0)]
    top, bottom = draw(st.sampled_from(pair))
    tx, tu = slots[top]
    bx, bu = slots[bottom]
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
