"""One-parameter families ε ↦ M_ε of mechanisms: k-ary randomized response and products of them.

Calibration and fairness–privacy curves move along a family; each member has pure privacy budget ε(M_ε) = ε (nats).

Proof of the facts used here: ``proofs/privacy.md``.
"""

from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Callable, Hashable, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from fairaudit.base.arrays import as_float_array
from fairaudit.base.checks import epsilon as check_epsilon
from fairaudit.base.errors import InputError
from fairaudit.base.labels import as_labels
from fairaudit.laws.closed_forms import RandomizedResponse, keep_of_checked, randomized_response
from fairaudit.laws.mechanisms import Mechanism, product

__all__ = [
    "MechanismFamily",
    "epsilon_scale",
    "product_family",
    "product_rows_family",
    "randomized_response_family",
]


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
    inputs : tuple or range
        The alphabet (the sensitive groups), the inputs of every member (a
        ``range`` of integers stays one: O(1) memory).
    build : callable
        ε ↦ :class:`~fairaudit.laws.mechanisms.Mechanism`, for ε ≥ 0 (+inf gives the identity).
    keep : callable
        ε ↦ the probability that the true value is released unchanged (the
        price of the guarantee), in [1/k, 1].
    mixing : bool
        Whether a member at a smaller ε is the larger one behind a
        row-stochastic R on the true value, M_ε' = R·M_ε (true of both
        shipped families, whose members commute; default False). Then, for a
        utility free of the group, a fixed model's L, and its L̄ over a
        population with X and A independent and every group present, are
        non-decreasing in ε (``proofs/calibration.md``, Proposition 5b), and
        the white-box calibration says so instead of resting on its scan.

    Notes
    -----
    Use :func:`randomized_response_family` or :func:`product_family`.

    Examples
    --------
    >>> import math
    >>> fam = randomized_response_family(["a", "b", "c"])
    >>> m = fam(math.log(4))
    >>> round(m.epsilon, 12) == round(math.log(4), 12), round(fam.keep_probability(math.log(4)), 6)
    (True, 0.666667)
    """

    name: str
    inputs: tuple | range
    build: Callable[[float], Mechanism]
    keep: Callable[[float], float]
    mixing: bool = False

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
        The labels. A ``range`` of integers is kept as it is (distinct by
        construction, O(1) memory): a billion groups cost no labels.
    name : str, optional

    Returns
    -------
    MechanismFamily
        ε ↦ :func:`~fairaudit.laws.closed_forms.randomized_response` (values, ε); keep probability
        e^ε / (e^ε + k − 1).

    Raises
    ------
    InputError
        With fewer than 2 values.

    Examples
    --------
    >>> import math
    >>> fam = randomized_response_family(["Tom", "Mary"])
    >>> round(fam.keep_probability(math.log(7 / 3)), 12)
    0.7
    """
    # a range of integers is distinct by construction, and kept as it is: O(1) memory, whatever k
    labels = (
        values if isinstance(values, range) and len(values) > 0 else as_labels(values, "randomized_response values")
    )
    k = len(labels)
    if k < 2:
        raise InputError("values", "a randomized response family needs at least 2 values", list(labels))
    label = name or f"{k}-ary randomized response"
    # each member in O(1): the labels are checked once, here, not again for every ε
    return MechanismFamily(
        label, labels, lambda eps: RandomizedResponse(labels, eps, label), lambda eps: keep_of_checked(eps, k), True
    )


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
        Inputs are tuples in ``itertools.product`` order (as :func:`~fairaudit.laws.mechanisms.product`).

    Raises
    ------
    InputError
        With no attribute, an attribute with fewer than 2 values, or weights
        of the wrong length, negative, or all zero.

    Examples
    --------
    Name, age and race, each kept with p = 0.7: ε = 3 ln(7/3), not 0.7/0.3.

    >>> import math
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
    w = _shares(weights, n)
    sizes = [len(a) for a in alphabets]
    label = name or f"product of {n} randomized responses ({' x '.join(str(k) for k in sizes)} values)"
    inputs = tuple(tuple(t) for t in itertools.product(*alphabets))

    def split(eps: float) -> list[float]:
        return [float(wi) * eps if wi > 0 else 0.0 for wi in w]

    def build(eps: float) -> Mechanism:
        return product(*(randomized_response(a, e) for a, e in zip(alphabets, split(eps))), name=label)

    def keep(eps: float) -> float:
        return float(np.prod([keep_of_checked(e, k) for e, k in zip(split(eps), sizes)]))

    return MechanismFamily(label, inputs, build, keep, True)


def _shares(weights: Sequence[float] | None, n: int) -> npt.NDArray[np.float64]:
    """The n shares of ε that ``weights`` give (equal by default), summing to 1; errors name ``weights``."""
    if weights is None:
        return np.full(n, 1.0 / n)
    w = as_float_array(weights, "weights", ndim=1)
    if w.size != n:
        raise InputError("weights", f"needs one weight per attribute ({n})", list(w))
    if np.any(w < 0) or not np.all(np.isfinite(w)) or w.sum() <= 0:
        raise InputError("weights", "must be finite, non-negative and not all zero", list(w))
    return w / w.sum()


def product_rows_family(
    *values: Sequence[Hashable],
    rows: Sequence[Sequence[Hashable]],
    inputs: Sequence[Hashable],
    outputs: Sequence[Hashable] | None = None,
    weights: Sequence[float] | None = None,
    name: str | None = None,
    mixture: npt.ArrayLike | None = None,
) -> MechanismFamily:
    """A product of randomized responses seen on some of its inputs only, or on mixtures of them, with ε rescaled so
    each member's ε is ε.

    What a candidate's prompt shows about it when it always faces the same rivals is such a view: randomized response
    on every attribute of every profile shown, on the rows of the tuples the candidates are shown with (docs/design.md,
    "k candidates behind a filter"); when it faces several, it is the mixture of those rows (``mixture``) the design
    draws. Component i gets w_i t / c (Σ w_i = 1), where c is the largest sum of the shares of the components on which
    two kept rows differ. Without ``mixture``, t = ε: the kept rows' ε is then ε (each differing component multiplies
    the likelihood ratio by at most e^{w_i ε / c}, attained together at one output). With a mixture, t solves
    ε(M_t) = ε (:func:`epsilon_scale`). A smaller member is the larger post-processed on the outputs, so ε(M_t) is
    non-decreasing in t and certificates along the family are too; ``mixing`` is False (mixing the kept rows does not
    give a smaller member). Only the kept rows are built: memory is len(rows) × Π k_i, not its square.

    Parameters
    ----------
    *values : sequences of hashable
        Each component's alphabet (≥ 2 values each).
    rows : sequence of sequences, length ≥ 2
        The product's inputs kept (one value per component each), distinct.
    inputs : sequence of hashable
        Their labels (the sensitive groups), one per row; with ``mixture``, one per row of ``mixture``.
    outputs : sequence of hashable, optional
        Labels of the Π k_i outputs in ``itertools.product`` order (default the tuples).
    weights : sequence of float, optional
        Non-negative shares of ε, as :func:`product_family`'s; equal by default.
    name : str, optional
    mixture : array_like, shape (len(inputs), len(rows)), optional
        W[a, r]: the probability that input a is row r (each row of W non-negative, summing to 1 to 1e-9; it is
        normalised). The member is W · (the kept rows). None: input a is row a.

    Returns
    -------
    MechanismFamily
        ε ↦ the kept rows (or their mixtures), shape (len(inputs), Π k_i), ε(M_ε) = ε; its keep probability is the
        chance that a row's own tuple is released, Π_i e^{ε_i} / (e^{ε_i} + k_i − 1).

    Raises
    ------
    InputError
        As :func:`product_family`; field ``rows``: fewer than 2, not distinct, a value not in its component's
        alphabet, or rows that differ only where the weights are 0 (no budget to spend); field ``inputs`` or
        ``outputs``: the wrong number of labels; field ``mixture``: of another shape, a row that is not a
        distribution, or inputs whose mixtures stay within a finite ε at every t (the family cannot reach every ε).

    Examples
    --------
    Tom (25) and Mary (55), each shown with the other: own name and age, then the rival's.

    >>> fam = product_rows_family(["Tom", "Mary"], [25, 55], ["Tom", "Mary"], [25, 55],
    ...                           rows=[("Tom", 25, "Mary", 55), ("Mary", 55, "Tom", 25)], inputs=["Tom", "Mary"])
    >>> round(fam(2.0).epsilon, 12), fam(2.0).matrix.shape, fam.keep_probability(float("inf"))
    (2.0, (2, 16), 1.0)

    Three names, each shown with the other two in either order (a mixture of two rows each, as ``balanced``):

    >>> names = ["Emily", "Lakisha", "Jorge"]
    >>> rows = [(a, b, c) for a in names for b in names for c in names if len({a, b, c}) == 3]
    >>> fam = product_rows_family(names, names, names, rows=rows, inputs=names, mixture=np.kron(np.eye(3), [0.5, 0.5]))
    >>> round(fam(1.0).epsilon, 12), fam(1.0).matrix.shape
    (1.0, (3, 27))
    """
    full = product_family(*values, weights=weights)  # (its checks: the alphabets and the weights)
    alphabets = [as_labels(v, f"values[{i}]") for i, v in enumerate(values)]
    kept = as_labels([tuple(r) for r in rows], "rows")
    if len(kept) < 2:
        raise InputError("rows", "keep at least 2 inputs of the product", list(kept))
    try:
        index = np.array([[a.index(v) for a, v in zip(alphabets, r, strict=True)] for r in kept], dtype=np.intp)
    except ValueError:
        bad = next(r for r in kept if len(r) != len(alphabets) or any(v not in a for a, v in zip(alphabets, r)))
        raise InputError(
            "rows", f"each must be an input of the product: one value of each of its {len(alphabets)} alphabets", bad
        ) from None
    labels = as_labels(inputs, "inputs")
    w_mix = None if mixture is None else _mixture(mixture, len(labels), len(kept))
    if w_mix is None and len(labels) != len(kept):
        raise InputError("inputs", f"needs one label per kept row ({len(kept)})", list(labels))
    sizes = [len(a) for a in alphabets]
    out = full.inputs if outputs is None else as_labels(outputs, "outputs")
    if len(out) != math.prod(sizes):
        raise InputError("outputs", f"needs one label per output of the product ({math.prod(sizes)})", len(out))
    shares = _shares(weights, len(alphabets))
    differ = index[:, None, :] != index[None, :, :]
    scale = float(np.max(differ @ shares))
    if not scale > 0:
        raise InputError("rows", "are released alike at every epsilon: there is no budget to calibrate", list(kept))
    label = name or f"{full.name} on {len(kept)} of its inputs"
    n = len(kept)

    def split(t: float) -> list[float]:
        return [float(w) * t / scale if w > 0 else 0.0 for w in shares]

    def at(t: float) -> Mechanism:
        matrix = np.ones((n, 1))
        for e, k, col in zip(split(t), sizes, index.T):
            keep = keep_of_checked(e, k)
            part = np.full((n, k), keep * math.exp(-e))  # 1 / (e^ε + k − 1), without 1 − p's cancellation
            part[np.arange(n), col] = keep
            matrix = (matrix[:, :, None] * part[:, None, :]).reshape(n, -1)
        return Mechanism(matrix if w_mix is None else w_mix @ matrix, labels, out, name=label)

    if w_mix is not None and math.isfinite(reach := at(math.inf).epsilon):
        problem = f"the inputs' mixtures stay within epsilon {reach:.6g} at every scale: no member reaches more"
        raise InputError("mixture", problem, w_mix.tolist())
    t_of = epsilon_scale(lambda t: at(t).epsilon, 1.0 if w_mix is None else None)  # the kept rows: ε(M_t) = t

    def keep(eps: float) -> float:
        return float(np.prod([keep_of_checked(e, k) for e, k in zip(split(t_of(eps)), sizes)]))

    return MechanismFamily(label, labels, lambda eps: at(t_of(eps)), keep)


def _mixture(mixture: npt.ArrayLike, n_inputs: int, n_rows: int) -> npt.NDArray[np.float64]:
    """W of :func:`product_rows_family`, checked (shape, rows distributions to 1e-9) and normalised."""
    w = as_float_array(mixture, "mixture", ndim=2)
    if w.shape != (n_inputs, n_rows):
        raise InputError("mixture", f"needs shape (inputs, rows) = ({n_inputs}, {n_rows})", w.shape)
    total = w.sum(axis=1)
    if np.any(w < 0) or not np.all(np.isfinite(w)) or not np.all(np.abs(total - 1) <= 1e-9):
        raise InputError("mixture", "each row must be non-negative and sum to 1 (to 1e-9)", w.tolist())
    return w / total[:, None]


def epsilon_scale(epsilon_at: Callable[[float], float], factor: float | None = None) -> Callable[[float], float]:
    """The map ε ↦ the scale t ≥ 0 at which a one-parameter mechanism M_t has ε(M_t) = ε.

    With ``factor`` c (ε(M_t) = c t for every t): t = ε / c in closed form
    (+inf for c = 0). Without, t solves ``epsilon_at(t)`` = ε by Brent's
    method (:func:`scipy.optimize.brentq`, to 1e-13) on a bracket grown by
    doubling from ε and halving towards 0; 0 and +inf map to themselves, and
    an ε beyond ``epsilon_at`` (1e6) to +inf. The answers are cached (the
    last 4096).

    Parameters
    ----------
    epsilon_at : callable
        t ↦ ε(M_t) (nats), non-decreasing in t ≥ 0 with ε(M_0) = 0: true
        when M_t at a smaller t is a post-processing of the one at a larger
        (randomized responses at a common scale, and mixtures of their
        products, ``proofs/privacy.md``).
    factor : float, optional
        The constant ratio ε(M_t) / t when there is one.

    Returns
    -------
    callable
        ε (nats, ≥ 0, +inf allowed) ↦ t.

    Examples
    --------
    >>> epsilon_scale(lambda t: 2 * t, 2.0)(3.0)
    1.5
    >>> round(epsilon_scale(lambda t: math.log1p(t))(math.log(3.0)), 12)     # ln(1 + t) = ln 3
    2.0
    """
    if factor is not None:
        c = float(factor)
        return lambda eps: eps / c if c > 0 else math.inf

    @functools.lru_cache(maxsize=4096)
    def solve(eps: float) -> float:
        if eps == 0 or math.isinf(eps):
            return eps
        from scipy.optimize import brentq

        def gap(t: float) -> float:
            return epsilon_at(t) - eps

        hi = eps
        while gap(hi) < 0:
            hi *= 2
            if hi > 1e6:
                return math.inf
        lo = hi / 2
        while gap(lo) > 0 and lo > 1e-12:
            lo /= 2
        return float(brentq(gap, lo, hi, xtol=1e-13, rtol=1e-13))

    return solve
