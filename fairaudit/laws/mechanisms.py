"""Finite privacy mechanisms: matrices, products, identity.

A mechanism on a finite alphabet is a row-stochastic matrix ``M`` of shape
``(n_inputs, n_outputs)`` with ``M[a, o] = P(output = o | input = a)``. Every
pair of inputs is adjacent (the paper's SI A, Definition of
(ε, δ)-differential privacy), so

* ``ε(M) = max over a, a', o of log M[a, o] / M[a', o]`` (nats; +inf when some
  output has positive probability under one input and zero under another);
* ``δ(M, ε) = max over a ≠ a' of Σ_o [M[a, o] − e^ε M[a', o]]₊``, the
  hockey-stick divergence of order e^ε (Balle et al., "Hypothesis testing
  interpretations and Rényi differential privacy", AISTATS 2020).

k-ary randomized response, whose ε, δ(ε) and keep probability are closed forms, is in
:mod:`fairaudit.laws.closed_forms`; one-parameter families ε ↦ M_ε in :mod:`fairaudit.laws.families`.

Proof of the facts used here: ``proofs/privacy.md``.
"""

from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Hashable, Iterable, Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, overload

import numpy as np
import numpy.typing as npt

from fairaudit.base.arrays import BoolArray, FloatArray, as_float_array, check_probabilities, check_shape
from fairaudit.base.checks import epsilon as check_epsilon
from fairaudit.base.checks import real
from fairaudit.base.errors import InputError, UnderflowError
from fairaudit.base.json_values import Report, number
from fairaudit.base.labels import as_labels
from fairaudit.base.outward import exp_down, fraction_up, log_up, sum_ends, up, widen_up
from fairaudit.base.pairs import PairPass

__all__ = [
    "EXACT_PAIRS",
    "Mechanism",
    "PrivacyProfile",
    "exact_hockey_stick",
    "exp_factors",
    "from_matrix",
    "hockey_stick",
    "identity",
    "largest_hockey_stick",
    "log_ratio_up",
    "product",
]

EXACT_PAIRS = 64
"""How many candidate pairs (or outputs) a certified maximum re-evaluates in exact rationals; beyond, the widened
floating-point value is the certified one (sound, less tight)."""

_U = 2.0**-53
"""The unit roundoff of a double."""


def exp_factors(epsilon: float) -> tuple[float, float]:
    """Two floats t₁, t₂ ≥ 1 with t₁·t₂ ≤ e^ε (exactly, as rationals) and within 2 units of it, for ε ≥ 0 finite.

    t₁ = e^min(ε, 700) rounded down, t₂ = e^(ε − 700) rounded down (1 when ε ≤ 700): no overflow for any ε
    below 1400 nats, and the product is a lower end of e^ε (``proofs/outward.md`` §5).

    Parameters
    ----------
    epsilon : float
        ε in nats, finite and ≥ 0 (at most 1400 for a finite t₂).

    Returns
    -------
    tuple of float
        (t₁, t₂).

    Examples
    --------
    >>> t1, t2 = exp_factors(1.0)
    >>> t2, t1 <= math.e
    (1.0, True)
    """
    if epsilon <= 700.0:
        return exp_down(epsilon), 1.0
    return exp_down(700), exp_down(Fraction(epsilon) - 700)


def hockey_stick(p: FloatArray, q: FloatArray, t1: float, t2: float = 1.0) -> tuple[FloatArray, FloatArray]:
    """Σ_o [p_o − t q_o]₊ over the last axis in floating point with t = t₁·t₂, and a bound on its error.

    Returns ``(value, error)`` with ``|value − exact| ≤ error`` (``proofs/outward.md`` §5): each term
    p − fl(fl(q t₁) t₂) is within 4u(p + t q) of p − t q (three roundings), a term whose computed value is below
    −8u(p + t q) is ≤ 0 exactly (it adds 0 both ways), and the sum of m terms adds (m + 1)u of its value. The
    bound itself is computed with a factor 2 to spare for its own roundings.

    Parameters
    ----------
    p, q : numpy.ndarray, shape (..., m)
        Rows of a mechanism (probabilities; broadcast against each other), the last axis its m outputs.
    t1, t2 : float
        The two factors of t (:func:`exp_factors`), each ≥ 1.

    Returns
    -------
    tuple of numpy.ndarray
        ``(value, error)``, each of the broadcast shape without the last axis.

    Examples
    --------
    >>> value, error = hockey_stick(np.array([0.7, 0.3]), np.array([0.3, 0.7]), 2.0)
    >>> bool(abs(value - 0.1) <= error < 1e-14)
    True
    """
    with np.errstate(over="ignore"):
        tq = q * t1 if t2 == 1.0 else (q * t1) * t2
        x = p - tq
        scale = p + tq
    slack = 8 * _U * scale
    per_term = np.where(x > -slack, slack, 0.0)
    per_term = np.where(np.isfinite(per_term), per_term, 0.0)  # tq = inf: the term is −inf, 0 both ways
    value = np.clip(x, 0.0, None).sum(axis=-1)
    m = p.shape[-1]
    error = per_term.sum(axis=-1) * 2.0 + 2.0 * (m + 1) * _U * value
    return value, error


def exact_hockey_stick(p: FloatArray, q: FloatArray, t: Fraction) -> Fraction:
    """Σ_o [p_o − t q_o]₊ of two rows in exact rational arithmetic (each float is a rational).

    Parameters
    ----------
    p, q : numpy.ndarray, shape (m,)
        Two rows of a mechanism.
    t : Fraction
        e^ε, ≥ 1.

    Returns
    -------
    Fraction
        The hockey-stick divergence of order t, exactly.

    Examples
    --------
    >>> exact_hockey_stick(np.array([0.75, 0.25]), np.array([0.25, 0.75]), Fraction(2))
    Fraction(1, 4)
    """
    terms = (Fraction(po) - t * Fraction(qo) for po, qo in zip(p.tolist(), q.tolist()))
    return sum((x for x in terms if x > 0), Fraction(0))


def largest_hockey_stick(matrix: FloatArray, t1: float, t2: float = 1.0) -> float:
    """An upper end of max over ordered pairs a ≠ a' of Σ_o [M[a, o] − t M[a', o]]₊, t = t₁·t₂ (exact rational).

    One pass over the pairs in floating point with :func:`hockey_stick`'s error bound; the pairs whose upper
    end reaches the largest lower end are re-evaluated exactly (up to :data:`EXACT_PAIRS` of them), so the
    result is the exact maximum rounded up, or the largest widened value when more pairs tie.

    Parameters
    ----------
    matrix : numpy.ndarray, shape (n_inputs, n_outputs)
        The mechanism's matrix.
    t1, t2 : float
        The two factors of t (:func:`exp_factors`).

    Returns
    -------
    float
        An upper end of δ(ε) for e^ε ≥ t₁·t₂ (0 with fewer than two inputs).

    Examples
    --------
    >>> largest_hockey_stick(np.array([[0.75, 0.25], [0.25, 0.75]]), 2.0)
    0.25
    """
    n = matrix.shape[0]
    if n < 2:
        return 0.0
    high, low = np.full((n, n), -np.inf), np.full((n, n), -np.inf)
    for rows, cols in PairPass(matrix).tiles():
        value, error = hockey_stick(matrix[rows, None, :], matrix[None, cols, :], t1, t2)
        high[rows, cols], low[rows, cols] = value + error, value - error
    np.fill_diagonal(high, -np.inf)
    np.fill_diagonal(low, -np.inf)
    a, b = np.nonzero(high >= low.max())
    if a.size > EXACT_PAIRS:
        return float(widen_up(high.max(), 0.0))
    t = Fraction(t1) * Fraction(t2)
    return fraction_up(max(exact_hockey_stick(matrix[i], matrix[j], t) for i, j in zip(a.tolist(), b.tolist())))


def log_ratio_up(top: FloatArray, bottom: FloatArray) -> float:
    """An upper end of ln max_i top_i / bottom_i over positive entries (≥ 1 each), +inf when some bottom is 0.

    The float ratios are each within one rounding; those that may be the largest are re-evaluated exactly
    (up to :data:`EXACT_PAIRS`), and ln is :func:`~fairaudit.base.outward.log_up` of the exact rational.

    Parameters
    ----------
    top, bottom : array_like
        Nonnegative numerators and denominators, paired elementwise (flattened); 0/0 counts as 1.

    Returns
    -------
    float
        An upper end of the largest log ratio, in nats.

    Examples
    --------
    >>> log_ratio_up([0.75, 0.25], [0.25, 0.75]) >= math.log(3)
    True
    """
    top, bottom = np.asarray(top, dtype=float).ravel(), np.asarray(bottom, dtype=float).ravel()
    if not top.size:
        return 0.0
    if np.any((bottom == 0) & (top > 0)):
        return math.inf
    # a ratio above the float range is inf here, then read exactly below
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        ratio = np.where(bottom > 0, top / np.where(bottom > 0, bottom, 1.0), 1.0)
    best = float(ratio.max())
    near = np.flatnonzero(up(ratio) >= float(np.nextafter(best, -np.inf)))
    if near.size > EXACT_PAIRS:
        return log_up(up(best))
    exact = max(Fraction(top[i]) / Fraction(bottom[i]) if bottom[i] > 0 else Fraction(1) for i in near.tolist())
    return log_up(max(exact, Fraction(1)))


@dataclass(frozen=True, eq=False)
class PrivacyProfile:
    """The privacy profile δ(ε) of a mechanism on a grid of ε.

    Attributes
    ----------
    epsilons : numpy.ndarray, shape (n,)
        The grid of ε, in nats.
    deltas : numpy.ndarray, shape (n,)
        δ(ε) at each grid point (hockey-stick divergence, all pairs adjacent).
    mechanism : Mechanism
        The mechanism the profile belongs to.
    """

    epsilons: FloatArray
    deltas: FloatArray
    mechanism: Mechanism


@dataclass(frozen=True, eq=False)
class Mechanism:
    """A finite randomized mechanism: a row-stochastic matrix with labels.

    Parameters
    ----------
    matrix : array_like, shape (n_inputs, n_outputs)
        ``matrix[a, o] = P(output = o | input = a)``; rows sum to 1 within 1e-9.
    inputs : sequence of hashable
        Labels of the inputs (rows), distinct.
    outputs : sequence of hashable, optional
        Labels of the outputs (columns); default: the inputs.
    name : str
        A short description, used in reports.

    Raises
    ------
    InputError
        When the matrix is not finite, has a negative entry, a row that does
        not sum to 1, or a shape that does not match the labels.

    Examples
    --------
    >>> from fairaudit.laws.closed_forms import randomized_response
    >>> m = randomized_response(["Tom", "Mary"], keep=0.7)
    >>> round(m.epsilon, 6), round(math.log(7 / 3), 6)
    (0.847298, 0.847298)
    >>> round(m.delta(0.5), 5)
    0.20538
    """

    matrix: FloatArray
    inputs: tuple
    outputs: tuple
    name: str = "matrix"

    def __init__(
        self,
        matrix: npt.ArrayLike,
        inputs: Sequence[Hashable],
        outputs: Sequence[Hashable] | None = None,
        name: str = "matrix",
    ) -> None:
        inputs = as_labels(inputs, f"mechanism '{name}' inputs")
        outputs = inputs if outputs is None else as_labels(outputs, f"mechanism '{name}' outputs")
        array = as_float_array(matrix, f"mechanism '{name}'", ndim=2)
        check_shape(array, (len(inputs), len(outputs)), f"mechanism '{name}'", ("inputs", "outputs"))
        check_probabilities(array, f"mechanism '{name}'", (inputs, outputs), ("input", "output"))
        array = array.copy()
        array.setflags(write=False)
        vars(self).update(matrix=array, inputs=inputs, outputs=outputs, name=name)  # (frozen: as object.__setattr__)

    def __repr__(self) -> str:
        return f"Mechanism({self.name!r}, {len(self.inputs)} inputs -> {len(self.outputs)} outputs, epsilon={self.epsilon:.6g})"

    @functools.cached_property
    def is_identity(self) -> bool:
        """True when the mechanism releases its input unchanged (same labels, identity matrix)."""
        m = self.matrix
        return bool(self.inputs == self.outputs and m.shape[0] == m.shape[1] and np.array_equal(m, np.eye(m.shape[0])))

    @property
    def matrix_roundings(self) -> int:
        """How many roundings :attr:`matrix`'s floats may carry relative to the mechanism's exact law: 0, the matrix
        being the law (randomized response computes its entries from e^ε, and says how far they may be)."""
        return 0

    @functools.cached_property
    def row_sums(self) -> tuple[FloatArray, FloatArray]:
        """(upper, lower) ends of the row sums of the mechanism's exact law, shape (n_inputs,): 1 for the identity and
        where the floats approximate a stochastic law (:attr:`matrix_roundings` > 0: randomized response); a matrix is
        its own law, whose rows sum to 1 only within 1e-9 (:func:`~fairaudit.base.outward.sum_ends`). A bound that
        takes E[g] ≤ max g must scale by the upper end."""
        n = len(self.inputs)
        return (np.ones(n), np.ones(n)) if self.matrix_roundings or self.is_identity else sum_ends(self.matrix)

    @property
    def support(self) -> BoolArray:
        """Where the exact matrix is positive, shape (n_inputs, n_outputs): the matrix's own positive floats, except for
        a closed form (randomized response) whose exact entries may be too small for a float."""
        return self.matrix > 0

    @functools.cached_property
    def epsilon(self) -> float:
        """Pure-DP ε(M) in nats: max log M[a, o] / M[a', o] over all pairs.

        Proof: ``proofs/privacy.md``.

        +inf when one input reaches an output that another cannot; 0 for a
        mechanism whose rows are all equal (or with one input). A certified
        upper bound, rounded up: the largest ratio of each output's extremes,
        re-evaluated exactly where it may be the largest, and
        :func:`~fairaudit.base.outward.log_up` of it (``proofs/outward.md`` §5).
        """
        m = self.matrix
        return 0.0 if m.shape[0] < 2 else log_ratio_up(m.max(axis=0), m.min(axis=0))

    def pairwise_delta(self, epsilon: float) -> FloatArray:
        """Hockey-stick divergence of every ordered pair of inputs.

        Proof: ``proofs/privacy.md`` (hockey-stick divergence, attained at S = {o: M[a,o] > e^ε M[a',o]}).

        Parameters
        ----------
        epsilon : float
            ε ≥ 0 in nats (may be +inf, giving δ of the inputs' disjoint mass).

        Returns
        -------
        numpy.ndarray, shape (n_inputs, n_inputs)
            ``out[a, a'] = Σ_o [M[a, o] − e^ε M[a', o]]₊``; the diagonal is 0.
            Each entry is an upper end, rounded up: e^ε rounded down
            (:func:`exp_factors`) and the sum widened by its error bound
            (:func:`hockey_stick`, ``proofs/outward.md`` §5); 0 exactly at
            ε ≥ ε(M).
        """
        eps = check_epsilon(epsilon)
        m = self.matrix
        n = m.shape[0]
        out = np.zeros((n, n))
        if math.isfinite(self.epsilon) and eps >= self.epsilon:  # ε ≥ ε(M) rounded up: M[a, o] ≤ e^ε M[a', o]
            return out
        t1, t2 = exp_factors(eps) if math.isfinite(eps) else (math.inf, 1.0)
        for rows, cols in PairPass(m).tiles():  # (rows, cols, m) at a time: O(nm) memory, not (n, n, m)
            p, q = m[rows, None, :], m[None, cols, :]
            if math.isinf(eps):  # the mass where q = 0, to the sum's rounding
                value = np.where(q == 0, p, 0.0).sum(axis=-1)
                error = 2 * (m.shape[1] + 1) * _U * value
            else:
                value, error = hockey_stick(p, q, t1, t2)
            total = value + error
            out[rows, cols] = np.where(total > 0, up(total), 0.0)  # (an exact 0 stays 0)
        np.fill_diagonal(out, 0.0)
        return out

    @overload
    def delta(self, epsilon: float) -> float: ...
    @overload
    def delta(self, epsilon: npt.ArrayLike) -> float | FloatArray: ...
    def delta(self, epsilon: npt.ArrayLike) -> float | FloatArray:
        """δ(M, ε): the largest hockey-stick divergence over pairs of inputs.

        Proof: ``proofs/privacy.md`` (non-increasing, convex in e^ε).

        Parameters
        ----------
        epsilon : float or array_like of float
            ε ≥ 0 in nats.

        Returns
        -------
        float or numpy.ndarray
            δ at each ε, same shape as ``epsilon``; 0 for one input. A
            certified upper bound, rounded up (``proofs/outward.md`` §5).

        Raises
        ------
        InputError
            If some ε is negative or NaN.
        """
        eps = np.asarray(epsilon, dtype=float)
        flat = np.array([self._largest_delta(e) for e in eps.ravel().tolist()])
        return float(flat[0]) if eps.ndim == 0 else flat.reshape(eps.shape)

    def _largest_delta(self, epsilon: float) -> float:
        """δ(M, ε) at one ε (checked here), rounded up: the largest hockey-stick divergence over pairs, exact
        where several may be the largest (:func:`largest_hockey_stick`)."""
        eps = check_epsilon(epsilon)
        if len(self.inputs) < 2 or (math.isfinite(self.epsilon) and eps >= self.epsilon):
            return 0.0
        if math.isinf(eps):
            return float(self.pairwise_delta(eps).max(initial=0.0))
        return largest_hockey_stick(self.matrix, *exp_factors(eps))

    def profile(self, epsilons: Iterable[float] | None = None) -> PrivacyProfile:
        """The privacy profile δ(ε) on a grid.

        Parameters
        ----------
        epsilons : iterable of float, optional
            Grid of ε ≥ 0 in nats. Default: 101 points from 0 to
            ``min(ε(M), 10)`` (or to 10 when ε(M) is infinite).
        """
        if epsilons is None:
            top = self.epsilon if np.isfinite(self.epsilon) and self.epsilon > 0 else 10.0
            grid = np.linspace(0.0, min(top, 10.0), 101)
        else:
            grid = np.asarray(list(epsilons), dtype=float)
        return PrivacyProfile(epsilons=grid, deltas=np.atleast_1d(self.delta(grid)), mechanism=self)

    def epsilon_for_delta(self, delta: float) -> float:
        """Smallest ε ≥ 0 with δ(M, ε) ≤ ``delta`` (nats).

        δ(M, ε) is non-increasing in ε, so the answer is the ε where the
        profile crosses ``delta``, found by bisection to 1e-13 relative
        precision (in closed form for k-ary randomized response,
        :class:`~fairaudit.laws.closed_forms.RandomizedResponse`); ε(M) itself
        for ``delta = 0``. An upper end: the bisection keeps an ε whose
        δ(ε), rounded up, is ≤ ``delta``.

        Raises
        ------
        InputError
            If ``delta`` is not in [0, 1].
        """
        delta = real(delta, "delta", low=0.0, high=1.0, what="a number in [0, 1]")
        if delta == 0.0:
            return self.epsilon
        if self.delta(0.0) <= delta:
            return 0.0
        return self._epsilon_for_positive_delta(delta)

    def _epsilon_for_positive_delta(self, delta: float) -> float:
        """:meth:`epsilon_for_delta` where 0 < ``delta`` < δ(M, 0): +inf, or the bisection."""
        if self.pairwise_delta(math.inf).max(initial=0.0) > delta:
            return math.inf
        lo, hi = 0.0, 1.0
        while self.delta(hi) > delta:
            lo, hi = hi, 2 * hi
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            if self.delta(mid) > delta:
                lo = mid
            else:
                hi = mid
            if hi - lo <= 1e-13 * max(1.0, hi):
                break
        return hi

    @property
    def keep_probability(self) -> float | None:
        """Smallest probability that the input is released unchanged.

        Defined when inputs and outputs are the same labels; None otherwise.
        For k-ary randomized response it is e^ε / (e^ε + k − 1).
        """
        if set(self.inputs) != set(self.outputs):
            return None
        cols = [self.outputs.index(a) for a in self.inputs]
        return float(self.matrix[np.arange(len(self.inputs)), cols].min())

    def then(self, other: Mechanism) -> Mechanism:
        """Post-process this mechanism's output with ``other`` (matrix product).

        Proof: ``proofs/privacy.md`` (post-processing).

        Raises
        ------
        InputError
            If ``other``'s inputs are not this mechanism's outputs.
        """
        if tuple(other.inputs) != tuple(self.outputs):
            raise InputError(
                f"mechanism '{other.name}' inputs", f"must equal the outputs of '{self.name}'", other.inputs
            )
        return Mechanism(self.matrix @ other.matrix, self.inputs, other.outputs, name=f"{self.name} then {other.name}")

    def describe(self) -> str:
        """One line: name, alphabet size, ε and keep probability."""
        keep = self.keep_probability
        # (:.6g writes an infinite epsilon as "inf")
        text = f"{self.name} on {len(self.inputs)} values, epsilon = {self.epsilon:.6g} nats"
        if keep is not None:
            text += f", keep probability {keep:.6g}"
        return text

    def to_dict(self) -> Report:
        """The report dictionary: name, ε (δ = 0 when ε is finite), keep probability, alphabet sizes.

        Examples
        --------
        >>> from fairaudit.laws.closed_forms import randomized_response
        >>> randomized_response(["Tom", "Mary"], keep=0.75).to_dict()
        {'mechanism': '2-ary randomized response', 'epsilon': 1.0986122886681098, 'delta': 0.0, 'keep_probability': 0.75, 'inputs': 2, 'outputs': 2}
        """
        eps = self.epsilon
        return {
            "mechanism": self.name,
            "epsilon": number(eps),
            "delta": 0.0 if math.isfinite(eps) else None,
            "keep_probability": number(self.keep_probability),
            "inputs": len(self.inputs),
            "outputs": len(self.outputs),
        }


def identity(values: Sequence[Hashable], name: str = "identity") -> Mechanism:
    """The identity mechanism (no privacy): ε = +inf when there are ≥ 2 values.

    Examples
    --------
    >>> identity(["x", "y"]).epsilon
    inf
    """
    labels = as_labels(values, "identity values")
    return _Identity(labels, name)


class _Identity(Mechanism):
    """The identity on ``labels``: its n x n matrix is made only when asked for.

    The core (composition, metrics, intervals, worst models) never asks: an
    identity filter on a million contexts costs its labels, not 10^12 cells.
    """

    def __init__(self, labels: tuple, name: str) -> None:
        vars(self).update(inputs=labels, outputs=labels, name=name, is_identity=True)  # (frozen; is_identity cached)

    @functools.cached_property
    def matrix(self) -> FloatArray:
        m = np.eye(len(self.inputs))
        m.setflags(write=False)
        return m

    @property
    def epsilon(self) -> float:
        return math.inf if len(self.inputs) >= 2 else 0.0


def from_matrix(
    rows: npt.ArrayLike, inputs: Sequence[Hashable], outputs: Sequence[Hashable] | None = None, name: str = "matrix"
) -> Mechanism:
    """A mechanism from its matrix of rows P(output | input).

    Parameters
    ----------
    rows : array_like, shape (n_inputs, n_outputs)
        Row-stochastic matrix.
    inputs, outputs : sequence of hashable
        Labels; ``outputs`` defaults to ``inputs``.

    Examples
    --------
    The paper's X-privacy mechanism (SI C, Example) is (log 3)-DP:

    >>> m = from_matrix([[0.9, 0.1], [0.7, 0.3]], [0, 1])
    >>> round(m.epsilon, 12) == round(math.log(3), 12)
    True
    """
    return Mechanism(rows, inputs, outputs, name=name)


def product(*mechanisms: Mechanism, name: str | None = None) -> Mechanism:
    """The product mechanism on a tuple of attributes, each randomized independently.

    Proof: ``proofs/privacy.md`` (ε of a product is the sum; the paper's error 2).

    Inputs and outputs are tuples of the components' labels in
    ``itertools.product`` order; the matrix is the Kronecker product. With
    every pair of tuples adjacent, ε(product) = Σ ε(component) (for example
    3 ln(7/3) = 2.542 nats for three binary attributes kept with p = 0.7; the
    seed paper's error 2).

    Examples
    --------
    >>> from fairaudit.laws.closed_forms import randomized_response
    >>> rr = [randomized_response(v, keep=0.7) for v in (["Tom", "Mary"], [25, 55], ["Asian", "American"])]
    >>> m = product(*rr)
    >>> m.inputs[:2]
    (('Tom', 25, 'Asian'), ('Tom', 25, 'American'))
    >>> round(m.epsilon, 6), round(3 * math.log(7 / 3), 6)
    (2.541894, 2.541894)
    """
    if not mechanisms:
        raise InputError("product", "needs at least one mechanism", ())
    matrix: npt.NDArray[np.floating[Any]] = np.ones((1, 1))
    support: BoolArray = np.ones((1, 1), dtype=bool)
    for mech in mechanisms:
        if not isinstance(mech, Mechanism):
            raise InputError("product", "components must be Mechanism objects", mech)
        matrix, support = np.kron(matrix, mech.matrix), np.kron(support, mech.support)
    if np.any(support & ~(matrix >= np.finfo(float).tiny)):
        raise UnderflowError(
            "product",
            "an entry of the product is positive but below the smallest normal float (2.2e-308): floating point "
            "cannot hold it (give the components smaller epsilons)",
            [m.name for m in mechanisms],
        )
    inputs = [tuple(t) for t in itertools.product(*(m.inputs for m in mechanisms))]
    outputs = [tuple(t) for t in itertools.product(*(m.outputs for m in mechanisms))]
    label = name or " x ".join(m.name for m in mechanisms)
    return Mechanism(matrix, inputs, outputs, name=label)
