"""Finite privacy mechanisms: randomized response, matrices, products, identity.

A mechanism on a finite alphabet is a row-stochastic matrix ``M`` of shape
``(n_inputs, n_outputs)`` with ``M[a, o] = P(output = o | input = a)``. Every
pair of inputs is adjacent (the paper's SI A, Definition of
(ε, δ)-differential privacy), so

* ``ε(M) = max over a, a', o of log M[a, o] / M[a', o]`` (nats; +inf when some
  output has positive probability under one input and zero under another);
* ``δ(M, ε) = max over a ≠ a' of Σ_o [M[a, o] − e^ε M[a', o]]₊``, the
  hockey-stick divergence of order e^ε (Balle et al., "Hypothesis testing
  interpretations and Rényi differential privacy", AISTATS 2020).

Proof of the facts used here: ``proofs/privacy.md``.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Hashable, Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any, overload

import numpy as np
import numpy.typing as npt

from fairaudit.base.arrays import EXP_SAFE, FloatArray, as_float_array, check_probabilities, check_shape, ratio_extremes
from fairaudit.base.checks import epsilon as check_epsilon
from fairaudit.base.checks import real, whole
from fairaudit.base.errors import InputError
from fairaudit.base.json_values import Report, number
from fairaudit.base.labels import as_labels
from fairaudit.base.pairs import PairPass

__all__ = [
    # mechanisms
    "Mechanism",
    "PrivacyProfile",
    "RandomizedResponse",
    "RandomizedResponseParameters",
    "from_matrix",
    "identity",
    "product",
    "randomized_response",
    # randomized response's keep probability
    "epsilon_from_keep_probability",
    "keep_probability",
    "split_by_keep",
    # families indexed by epsilon
    "MechanismFamily",
    "product_family",
    "randomized_response_family",
]


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
    _cache: dict[str, Any] = field(default_factory=dict, repr=False, compare=False)

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
        object.__setattr__(self, "matrix", array)
        object.__setattr__(self, "inputs", inputs)
        object.__setattr__(self, "outputs", outputs)
        object.__setattr__(self, "name", name)
        object.__setattr__(self, "_cache", {})

    def __repr__(self) -> str:
        return f"Mechanism({self.name!r}, {len(self.inputs)} inputs -> {len(self.outputs)} outputs, epsilon={self.epsilon:.6g})"

    @property
    def is_identity(self) -> bool:
        """True when the mechanism releases its input unchanged (same labels, identity matrix)."""
        if "is_identity" not in self._cache:
            m = self.matrix
            self._cache["is_identity"] = bool(
                self.inputs == self.outputs and m.shape[0] == m.shape[1] and np.array_equal(m, np.eye(m.shape[0]))
            )
        return self._cache["is_identity"]

    @property
    def epsilon(self) -> float:
        """Pure-DP ε(M) in nats: max log M[a, o] / M[a', o] over all pairs.

        Proof: ``proofs/privacy.md``.

        +inf when one input reaches an output that another cannot; 0 for a
        mechanism whose rows are all equal (or with one input).
        """
        if "epsilon" not in self._cache:
            ratio, _, _ = ratio_extremes(self.matrix, axis=0)
            worst = np.nanmax(ratio) if ratio.size and not np.all(np.isnan(ratio)) else 1.0
            self._cache["epsilon"] = float(np.log(worst)) if np.isfinite(worst) else math.inf
        return self._cache["epsilon"]

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
        """
        eps = check_epsilon(epsilon)
        m = self.matrix
        n = m.shape[0]
        out = np.empty((n, n))
        for rows, cols in PairPass(m).tiles():  # (rows, cols, m) at a time: O(nm) memory, not (n, n, m)
            p, q = m[rows, None, :], m[None, cols, :]
            if math.isinf(eps):
                out[rows, cols] = np.where(q == 0, p, 0.0).sum(axis=-1)
            elif eps <= EXP_SAFE:
                out[rows, cols] = np.clip(p - math.exp(eps) * q, 0.0, None).sum(axis=-1)
            else:  # e^ε overflows a double: e^ε q = exp(ε + log q), 0 where q = 0
                with np.errstate(divide="ignore", over="ignore"):
                    out[rows, cols] = np.clip(p - np.exp(eps + np.log(q)), 0.0, None).sum(axis=-1)
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
            δ at each ε, same shape as ``epsilon``; 0 for one input.

        Raises
        ------
        InputError
            If some ε is negative or NaN.
        """
        eps = np.asarray(epsilon, dtype=float)
        flat = np.array([self.pairwise_delta(e).max(initial=0.0) for e in eps.ravel()])
        return float(flat[0]) if eps.ndim == 0 else flat.reshape(eps.shape)

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
        precision; ε(M) itself for ``delta = 0``.

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
        eps = "inf" if math.isinf(self.epsilon) else f"{self.epsilon:.6g}"
        text = f"{self.name} on {len(self.inputs)} values, epsilon = {eps} nats"
        if keep is not None:
            text += f", keep probability {keep:.6g}"
        return text

    def to_dict(self) -> Report:
        """The report dictionary: name, ε (δ = 0 when ε is finite), keep probability, alphabet sizes.

        Examples
        --------
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


def keep_probability(epsilon: float, k: int) -> float:
    """Keep probability e^ε / (e^ε + k − 1) of k-ary randomized response.

    Examples
    --------
    >>> round(keep_probability(math.log(7 / 3), 2), 12)
    0.7
    """
    return _keep(check_epsilon(epsilon), whole(k, "k", low=1))


def _keep(eps: float, k: int) -> float:
    """:func:`keep_probability` of a checked ε ≥ 0 (+inf allowed) and k ≥ 1: what a family's keep evaluates
    thousands of times in a calibration scan, without validating again."""
    if eps == math.inf:
        return 1.0
    return 1.0 / (1.0 + (k - 1) * math.exp(-eps))


def epsilon_from_keep_probability(keep: float, k: int) -> float:
    """ε = log(p (k − 1) / (1 − p)) of k-ary randomized response keeping with p.

    Not ``p / (1 − p)`` (the seed paper's error 1): for k = 2 and p = 0.7 the
    budget is ln(7/3) = 0.847 nats.

    Raises
    ------
    InputError
        If ``keep`` is not in [1/k, 1] (below 1/k the mechanism favours
        other values and is not randomized response).

    Examples
    --------
    >>> round(epsilon_from_keep_probability(0.7, 2), 6), epsilon_from_keep_probability(1.0, 3)
    (0.847298, inf)
    >>> round(keep_probability(epsilon_from_keep_probability(0.6, 3), 3), 12)
    0.6
    """
    k = whole(k, "k", low=2)
    keep = real(
        keep, "keep", low=1.0 / k - 1e-15, high=1.0, what=f"a keep probability in [1/k, 1] = [{1.0 / k:.6g}, 1]"
    )
    if keep >= 1.0:
        return math.inf
    return max(0.0, math.log(keep * (k - 1) / (1.0 - keep)))


def split_by_keep(epsilon: float, sizes: Sequence[int]) -> FloatArray:
    """Each attribute's ε when a profile's budget ``epsilon`` is split so that every attribute keeps its value
    with the same probability p.

    Attribute i, with k_i values, gets k_i-ary randomized response at
    ε_i = max(0, ln(p (k_i − 1) / (1 − p))), so it keeps its value with
    probability p (never less than 1/k_i: an attribute that p would keep less
    often than uniformly is shown uniformly at random, ε_i = 0), and p is the
    one keep probability with Σ_i ε_i = ``epsilon`` (the product's ε, every
    pair of profiles adjacent). With ℓ = ln(p / (1 − p)) and c_i = ln(k_i − 1),
    ε_i = max(0, ℓ + c_i): the sum is piecewise linear and increasing in ℓ,
    so ℓ is found in closed form on the piece where the m attributes with
    the largest c_i are active, ℓ = (ε − Σ_{j ≤ m} c_(j)) / m.

    Proof: ``proofs/privacy.md`` ("A shared keep probability"). Attributes of
    equal size get ε / n each; a keep probability p on an attribute with k
    values is ε = ln(p (k − 1) / (1 − p)), whatever the other attributes' sizes.

    Parameters
    ----------
    epsilon : float
        The profile's privacy budget (nats, ≥ 0; +inf: every attribute shown as is).
    sizes : sequence of int
        k_i ≥ 2, the number of values of each attribute.

    Returns
    -------
    numpy.ndarray, shape (n_attributes,)
        ε_i in nats, in the order of ``sizes``, summing to ``epsilon``.

    Raises
    ------
    InputError
        If ``epsilon`` is negative or NaN, ``sizes`` is empty, or a size is not a whole number ≥ 2.

    Examples
    --------
    Age (3 values), gender (2) and race (3), each kept with p = 0.6: ln 3, ln 1.5 and ln 3.

    >>> eps = split_by_keep(2 * math.log(3) + math.log(1.5), [3, 2, 3])
    >>> [round(float(e), 6) for e in eps]
    [1.098612, 0.405465, 1.098612]
    >>> [round(keep_probability(float(e), k), 12) for e, k in zip(eps, [3, 2, 3])]
    [0.6, 0.6, 0.6]

    A small budget leaves the binary attribute uniform (p would be below 1/2):

    >>> [round(float(e), 6) for e in split_by_keep(0.3, [3, 2])]
    [0.3, 0.0]
    """
    eps = check_epsilon(epsilon)
    if not len(sizes):
        raise InputError("sizes", "needs at least one attribute", list(sizes))
    k = np.array([whole(s, f"sizes[{i}]", low=2) for i, s in enumerate(sizes)], dtype=float)
    if eps == 0.0 or eps == math.inf:
        return np.full(k.size, eps)
    c = np.log(k - 1.0)
    top = np.sort(c)[::-1]
    total = np.cumsum(top)
    # the sum of the ε_i at ℓ = −top[m] (only the m attributes above it active); non-decreasing in m, 0 at m = 0
    breaks = total - np.arange(1, k.size + 1) * top
    m = int(np.searchsorted(breaks, eps, side="left"))  # the active attributes: every break below ε
    ell = (eps - total[m - 1]) / m
    return np.maximum(0.0, ell + c)


def randomized_response(
    values: Sequence[Hashable],
    epsilon: float | None = None,
    *,
    keep: float | None = None,
    name: str | None = None,
) -> Mechanism:
    """k-ary randomized response on ``values``.

    Proof: ``proofs/privacy.md`` (ε = ln(p(k − 1)/(1 − p)); the paper's error 1).

    Keeps the value with probability p = e^ε / (e^ε + k − 1) and moves to each
    of the k − 1 other values with probability 1 / (e^ε + k − 1) (Warner 1965;
    Kairouz, Oh and Viswanath 2014). Give exactly one of ``epsilon`` (nats) and
    ``keep`` (p).

    Parameters
    ----------
    values : sequence of hashable, length k ≥ 1
        The alphabet; inputs and outputs are the same labels.
    epsilon : float, optional
        Privacy budget ε ≥ 0 in nats; +inf gives the identity.
    keep : float, optional
        Keep probability p in [1/k, 1].
    name : str, optional
        Name in reports.

    Returns
    -------
    Mechanism
        Square, shape (k, k); ε(M) = ``epsilon`` exactly, δ(M, ε(M)) = 0.
        Its matrix is built only when asked for: ε, δ(ε), the keep
        probability and the certificates of :mod:`fairaudit.metrics.bounds`,
        :mod:`fairaudit.worstcase` and :mod:`fairaudit.worstcase.calibration` are closed
        forms, so k may be a million. Any ε in [0, +inf] works (above
        700 nats, where e^ε overflows, q = e^−ε/(1 + (k − 1)e^−ε)).

    Raises
    ------
    InputError
        If neither or both of ``epsilon`` and ``keep`` are given, or either is
        out of range.

    Examples
    --------
    >>> m = randomized_response(["a", "b", "c"], epsilon=math.log(4))
    >>> m.matrix.round(6).tolist()
    [[0.666667, 0.166667, 0.166667], [0.166667, 0.666667, 0.166667], [0.166667, 0.166667, 0.666667]]
    """
    labels = as_labels(values, "randomized_response values")
    k = len(labels)
    if (epsilon is None) == (keep is None):
        raise InputError(
            "randomized_response", "give exactly one of epsilon and keep", {"epsilon": epsilon, "keep": keep}
        )
    if keep is not None:
        if k == 1:
            epsilon = 0.0
        else:
            epsilon = epsilon_from_keep_probability(keep, k)
    assert epsilon is not None  # exactly one of epsilon and keep was given
    eps = check_epsilon(epsilon)
    return RandomizedResponse(labels, eps, name or f"{k}-ary randomized response")


def _rr_probabilities(eps: float, k: int) -> tuple[float, float, float, float]:
    """(p, q, log p, log q) of k-ary randomized response: p = t/(t + k − 1), q = 1/(t + k − 1), t = e^ε.

    No overflow for any ε ≥ 0 (+inf gives p = 1, q = 0); p without cancellation for any k.
    """
    if k < 2:
        return 1.0, 0.0, 0.0, -math.inf
    if math.isinf(eps):
        return 1.0, 0.0, 0.0, -math.inf
    if eps <= EXP_SAFE:
        q = 1.0 / (math.exp(eps) + k - 1)
    else:
        small = math.exp(-eps)
        q = small / (1.0 + (k - 1) * small)
    rest = (k - 1) * q
    # 1 − (k − 1) q is exact to an ulp when it is ≥ 1/2; below that, t·q avoids the cancellation
    p = 1.0 - rest if rest <= 0.5 else q * math.exp(eps)
    log_p = -math.log1p((k - 1) * math.exp(-eps))  # −log(1 + (k − 1) e^−ε)
    return p, q, log_p, log_p - eps


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
        object.__setattr__(self, "inputs", labels)
        object.__setattr__(self, "outputs", labels)
        object.__setattr__(self, "name", name)
        object.__setattr__(self, "_cache", {"is_identity": True})

    @property
    def matrix(self) -> FloatArray:
        if "matrix" not in self._cache:
            m = np.eye(len(self.inputs))
            m.setflags(write=False)
            self._cache["matrix"] = m
        return self._cache["matrix"]

    @property
    def epsilon(self) -> float:
        return math.inf if len(self.inputs) >= 2 else 0.0


class RandomizedResponse(Mechanism):
    """k-ary randomized response in closed form: its k x k matrix is made only when asked for.

    Every row keeps its value with p = e^ε/(e^ε + k − 1) and moves to each other
    value with q = 1/(e^ε + k − 1), so ε, δ(ε), the pairwise divergences, the
    keep probability and (in :mod:`fairaudit.metrics.bounds`, :mod:`fairaudit.worstcase`
    and :mod:`fairaudit.worstcase.calibration`) the certificates have closed forms: a
    million groups cost their labels, not 10^12 cells. ``proofs/privacy.md`` §5.
    Made by :func:`randomized_response`; ``rr`` holds its parameters.

    Examples
    --------
    >>> m = randomized_response(["a", "b"], epsilon=math.log(3))
    >>> isinstance(m, RandomizedResponse), round(m.keep_probability, 12), m.rr.k
    (True, 0.75, 2)
    """

    rr: RandomizedResponseParameters

    def __init__(self, labels: tuple, epsilon: float, name: str) -> None:
        k = len(labels)
        p, q, log_p, log_q = _rr_probabilities(epsilon, k)
        object.__setattr__(self, "inputs", labels)
        object.__setattr__(self, "outputs", labels)
        object.__setattr__(self, "name", name)
        object.__setattr__(self, "_cache", {"epsilon": epsilon if k > 1 else 0.0})
        object.__setattr__(self, "rr", RandomizedResponseParameters(k, epsilon if k > 1 else 0.0, p, q, log_p, log_q))

    @property
    def matrix(self) -> FloatArray:
        if "matrix" not in self._cache:
            k, rr = len(self.inputs), self.rr
            m = np.full((k, k), rr.q)
            np.fill_diagonal(m, rr.p)
            m.setflags(write=False)
            self._cache["matrix"] = m
        return self._cache["matrix"]

    @property
    def epsilon(self) -> float:
        return self.rr.epsilon

    @property
    def is_identity(self) -> bool:
        return self.rr.k < 2 or math.isinf(self.rr.epsilon)

    @property
    def keep_probability(self) -> float:
        return self.rr.p

    def _pair_delta(self, epsilon: float) -> float:
        """δ_aa'(ε) = [p − e^ε q]₊, the same for every pair a ≠ a' (proofs/privacy.md, Proposition 5)."""
        rr = self.rr
        if rr.k < 2:
            return 0.0
        if math.isinf(rr.epsilon):  # the identity: a puts all its mass where a' puts none
            return rr.p
        if epsilon >= rr.epsilon:
            return 0.0
        t_q = math.exp(epsilon) * rr.q if epsilon <= EXP_SAFE else math.exp(epsilon + rr.log_q)
        return max(0.0, rr.p - t_q)

    def pairwise_delta(self, epsilon: float) -> FloatArray:
        eps = check_epsilon(epsilon)
        k = len(self.inputs)
        out = np.full((k, k), self._pair_delta(eps))
        np.fill_diagonal(out, 0.0)
        return out

    @overload
    def delta(self, epsilon: float) -> float: ...
    @overload
    def delta(self, epsilon: npt.ArrayLike) -> float | FloatArray: ...
    def delta(self, epsilon: npt.ArrayLike) -> float | FloatArray:
        eps = np.asarray(epsilon, dtype=float)
        flat = np.array([self._pair_delta(check_epsilon(e)) for e in eps.ravel().tolist()])
        return float(flat[0]) if eps.ndim == 0 else flat.reshape(eps.shape)

    def epsilon_for_delta(self, delta: float) -> float:
        """Smallest ε ≥ 0 with δ(ε) ≤ ``delta``: log((p − δ)/q) in closed form (0 when δ ≥ p − q)."""
        delta = real(delta, "delta", low=0.0, high=1.0, what="a number in [0, 1]")
        rr = self.rr
        if delta == 0.0:
            return self.epsilon
        if self.delta(0.0) <= delta:
            return 0.0
        if math.isinf(rr.epsilon):  # the identity: δ = 1 at every ε
            return math.inf
        return max(0.0, math.log(rr.p - delta) - rr.log_q)


@dataclass(frozen=True)
class RandomizedResponseParameters:
    """The closed-form parameters of k-ary randomized response (see :class:`RandomizedResponse`)."""

    k: int
    epsilon: float
    p: float  # keep probability e^ε/(e^ε + k − 1)
    q: float  # probability of each other value, 1/(e^ε + k − 1)
    log_p: float
    log_q: float  # −ε − log(1 + (k − 1) e^−ε): finite for every finite ε, even where q underflows


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
    for mech in mechanisms:
        if not isinstance(mech, Mechanism):
            raise InputError("product", "components must be Mechanism objects", mech)
        matrix = np.kron(matrix, mech.matrix)
    inputs = [tuple(t) for t in itertools.product(*(m.inputs for m in mechanisms))]
    outputs = [tuple(t) for t in itertools.product(*(m.outputs for m in mechanisms))]
    label = name or " x ".join(m.name for m in mechanisms)
    return Mechanism(matrix, inputs, outputs, name=label)


@dataclass(frozen=True, eq=False)
class MechanismFamily:
    """A one-parameter family ε ↦ M_ε of mechanisms on the same alphabet.

    Calibration and fairness–privacy curves move along a family. Each member
    has pure privacy budget ε(M_ε) = ε (nats), and a smaller ε is a
    post-processing of a larger one (true of randomized response and of
    products of randomized responses with a fixed split of ε), so any
    certificate is non-decreasing in ε along the family.

    Attributes
    ----------
    name : str
        Shown in reports, e.g. ``"8-ary randomized response"``.
    inputs : tuple
        The alphabet (the sensitive groups), the inputs of every member.
    build : callable
        ε ↦ :class:`Mechanism`, for ε ≥ 0 (+inf gives the identity).
    keep : callable
        ε ↦ the probability that the true value is released unchanged (the
        price of the guarantee), in [1/k, 1].

    Notes
    -----
    Use :func:`randomized_response_family` or :func:`product_family`.

    Examples
    --------
    >>> fam = randomized_response_family(["a", "b", "c"])
    >>> m = fam(math.log(4))
    >>> round(m.epsilon, 12) == round(math.log(4), 12), round(fam.keep_probability(math.log(4)), 6)
    (True, 0.666667)
    """

    name: str
    inputs: tuple
    build: Callable[[float], Mechanism]
    keep: Callable[[float], float]

    def __call__(self, epsilon: float) -> Mechanism:
        """The member with privacy budget ``epsilon`` (nats)."""
        return self.build(check_epsilon(epsilon))

    def keep_probability(self, epsilon: float) -> float:
        """Probability that the true value is released unchanged at ``epsilon``."""
        return float(self.keep(check_epsilon(epsilon)))

    def __repr__(self) -> str:
        return f"MechanismFamily({self.name!r}, {len(self.inputs)} inputs)"


def randomized_response_family(values: Sequence[Hashable], name: str | None = None) -> MechanismFamily:
    """k-ary randomized response on ``values`` as a family in ε.

    Parameters
    ----------
    values : sequence of hashable, length k ≥ 2
    name : str, optional

    Returns
    -------
    MechanismFamily
        ε ↦ :func:`randomized_response` (values, ε); keep probability
        e^ε / (e^ε + k − 1).

    Raises
    ------
    InputError
        With fewer than 2 values.

    Examples
    --------
    >>> fam = randomized_response_family(["Tom", "Mary"])
    >>> round(fam.keep_probability(math.log(7 / 3)), 12)
    0.7
    """
    # (a range of integers is distinct by construction: k = 10^6 groups need no check of a million labels)
    plain = isinstance(values, range) and len(values) > 0
    labels = tuple(values) if plain else as_labels(values, "randomized_response values")
    k = len(labels)
    if k < 2:
        raise InputError("values", "a randomized response family needs at least 2 values", list(labels))
    label = name or f"{k}-ary randomized response"
    # each member in O(1): the labels are checked once, here, not again for every ε
    return MechanismFamily(label, labels, lambda eps: RandomizedResponse(labels, eps, label), lambda eps: _keep(eps, k))


def product_family(
    *values: Sequence[Hashable], weights: Sequence[float] | None = None, name: str | None = None
) -> MechanismFamily:
    """A product of randomized responses, one per attribute, with ε split by fixed weights.

    Member ε gives component i the budget w_i ε (Σ w_i = 1), so the product's
    ε (every pair of tuples adjacent) is ε; its keep probability is the chance
    that the whole tuple is released unchanged, Π_i e^{w_i ε} / (e^{w_i ε} + k_i − 1).

    Parameters
    ----------
    *values : sequences of hashable
        Each attribute's alphabet (≥ 2 values each).
    weights : sequence of float, optional
        Non-negative shares of ε, normalised to sum to 1; equal by default.
    name : str, optional

    Returns
    -------
    MechanismFamily
        Inputs are tuples in ``itertools.product`` order (as :func:`product`).

    Raises
    ------
    InputError
        With no attribute, an attribute with fewer than 2 values, or weights
        of the wrong length, negative, or all zero.

    Examples
    --------
    Name, age and race, each kept with p = 0.7: ε = 3 ln(7/3), not 0.7/0.3.

    >>> fam = product_family(["Tom", "Mary"], [25, 55], ["Asian", "American"])
    >>> eps = 3 * math.log(7 / 3)
    >>> round(fam(eps).epsilon, 6), round(fam.keep_probability(eps), 6)   # 0.7 ** 3
    (2.541894, 0.343)
    """
    if not values:
        raise InputError("product_family", "needs at least one attribute", ())
    alphabets = [as_labels(v, f"product_family values[{i}]") for i, v in enumerate(values)]
    for i, labels in enumerate(alphabets):
        if len(labels) < 2:
            raise InputError(f"values[{i}]", "each attribute needs at least 2 values", list(labels))
    n = len(alphabets)
    if weights is None:
        w = np.full(n, 1.0 / n)
    else:
        w = as_float_array(weights, "weights", ndim=1)
        if w.size != n:
            raise InputError("weights", f"needs one weight per attribute ({n})", list(w))
        if np.any(w < 0) or not np.all(np.isfinite(w)) or w.sum() <= 0:
            raise InputError("weights", "must be finite, non-negative and not all zero", list(w))
        w = w / w.sum()
    sizes = [len(a) for a in alphabets]
    label = name or f"product of {n} randomized responses ({' x '.join(str(k) for k in sizes)} values)"
    inputs = tuple(tuple(t) for t in itertools.product(*alphabets))

    def split(eps: float) -> list[float]:
        return [float(wi) * eps if wi > 0 else 0.0 for wi in w]

    def build(eps: float) -> Mechanism:
        return product(*(randomized_response(a, e) for a, e in zip(alphabets, split(eps))), name=label)

    def keep(eps: float) -> float:
        return float(np.prod([_keep(e, k) for e, k in zip(split(eps), sizes)]))

    return MechanismFamily(label, inputs, build, keep)
