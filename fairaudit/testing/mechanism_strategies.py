"""Hypothesis strategies for finite privacy mechanisms: any, with an exact ε or (ε, δ), randomized response, products.

Sizes and numbers are read as :mod:`fairaudit.testing.strategies` describes ("Sizes"); each strategy's promise
(an exact ε, an exact δ at ε) is checked by ``tests/testing/test_mechanism_strategies.py``.

Examples
--------
>>> from hypothesis import find
>>> m = find(mechanisms(n_inputs=2, epsilon=0.5), lambda m: True)
>>> m.inputs, abs(m.epsilon - 0.5) <= 1e-9
(('a0', 'a1'), True)
"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import assume
from hypothesis import strategies as st
from hypothesis.errors import InvalidArgument

from fairaudit.base.arrays import FloatArray
from fairaudit.laws.closed_forms import randomized_response
from fairaudit.laws.mechanisms import Mechanism, product
from fairaudit.testing import _draws as draws
from fairaudit.testing._draws import Number, Size

__all__ = [
    "mechanisms",
    "product_mechanisms",
    "randomized_responses",
]

EPSILON_TOLERANCE = 1e-9
"""Largest accepted |ε(M) − requested ε| and |δ(M, ε) − requested δ|."""


def _pure_matrix(draw: st.DrawFn, n_in: int, n_out: int, epsilon: float, allow_zeros: bool) -> FloatArray:
    """A row-stochastic (n_in, n_out) matrix with ε(M) = ``epsilon`` (0 ≤ ε ≤ inf)."""
    need = 1 if epsilon == 0 else 2
    live = draws.alive(draw, n_out, need) if allow_zeros and n_out > need else np.ones(n_out, dtype=bool)
    k = int(live.sum())
    q = draws.rows(draw, (k,), allow_zeros=False)
    if epsilon == 0 or n_in == 1:
        m = np.tile(q, (n_in, 1))
    else:
        # R: random rows with an asymmetric zero so that ε(R) = inf.
        r = draws.weights(draw, (n_in, k), allow_zeros=allow_zeros or math.isinf(epsilon))
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
            gap = r[:, None, :] - t * r[None, :, :]  # x − e^ε y for every pair of rows and output
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
    eps = draws.number(draw, epsilon, "epsilon")
    dlt = draws.number(draw, delta, "delta")
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
    inputs = draws.labels(draw, n_inputs, "a", 2 if positive else 1, "n_inputs")
    outputs = inputs if n_outputs is None else draws.labels(draw, n_outputs, "o", 2 if positive else 1, "n_outputs")
    n_in, n_out = len(inputs), len(outputs)
    if eps is None:
        matrix = draws.rows(draw, (n_in, n_out), allow_zeros)
        return Mechanism(matrix, inputs, outputs, name="random mechanism")
    matrix = _pure_matrix(draw, n_in, n_out, eps, allow_zeros)
    mech = _shuffled(draw, matrix, inputs, outputs, f"random mechanism (epsilon={eps:g})")
    assume(mech.epsilon == eps if math.isinf(eps) else abs(mech.epsilon - eps) <= EPSILON_TOLERANCE)
    return mech


def _shuffled(draw: st.DrawFn, matrix: FloatArray, inputs: tuple, outputs: tuple, name: str) -> Mechanism:
    """The mechanism of ``matrix`` with its columns in a random order (the outputs keep their labels)."""
    perm = draw(st.permutations(range(len(outputs))))
    return Mechanism(matrix[:, perm], inputs, outputs, name=name)


@st.composite
def _delta_mechanisms(
    draw: st.DrawFn, n_inputs: Size, n_outputs: Size | None, eps: float, dlt: float, allow_zeros: bool
) -> Mechanism:
    inputs = draws.labels(draw, n_inputs, "a", 2 if dlt > 0 else 1, "n_inputs")
    n_in = len(inputs)
    if n_outputs is None:
        n_pure = draw(st.integers(1, 2))
        outputs = tuple(f"o{j}" for j in range(n_pure + n_in))
    else:
        outputs = draws.labels(draw, n_outputs, "o", n_in + 1, "n_outputs (n_inputs + 1 at least, with delta)")
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
    mech = _shuffled(draw, matrix, inputs, outputs, f"random mechanism (epsilon={eps:g}, delta={dlt:g})")
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
    values = draws.labels(draw, k, "a", 2, "k")
    eps = draws.number(draw, epsilon, "epsilon")
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
    n = len(draws.labels(draw, n_attributes, "", 1, "n_attributes"))
    eps = draws.number(draw, epsilon, "epsilon")
    if eps is not None and (math.isnan(eps) or eps < 0 or math.isinf(eps)):
        raise InvalidArgument(f"epsilon={eps!r} must be a finite non-negative number of nats")
    shares: list[float | None] = [None] * n  # each component's ε (None: arbitrary)
    if eps is not None:
        w = draws.weights(draw, (n,), allow_zeros=True)
        split = [eps * float(wi) / float(w.sum()) for wi in w[:-1]]
        shares = [*split, max(eps - sum(split), 0.0)]  # (the last share: ε less the others')
    components = []
    for i in range(n):
        values = draws.labels(draw, n_values, f"v{i}_", 2, "n_values")
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
