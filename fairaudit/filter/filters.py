"""The privacy filter you deploy: exact rows, its own ε rounded up, exact sampling from a secure source.

A :class:`PrivacyFilter` is a finite mechanism M (``M[a, o] = P(release o | true a)``, every pair of inputs
adjacent, as in :mod:`fairaudit.laws.mechanisms`) whose rows are integer numerators over one integer
denominator, so that what runs is exactly what its ε describes:

* k-ary randomized response (:meth:`PrivacyFilter.randomized_response`), from a keep probability (exact) or
  from ε: e^ε is irrational, so the filter keeps with t / (t + k − 1) for t = ``exp_down(ε)``, a float
  ≤ e^ε; its exact ε, ln t, is then ≤ the ε asked for, and within about 4e-16 of it;
* any finite mechanism from its matrix (:meth:`PrivacyFilter.from_matrix`) or from a
  :class:`~fairaudit.laws.mechanisms.Mechanism` (:meth:`PrivacyFilter.from_mechanism`);
* products, one filter per attribute applied to tuples (:meth:`PrivacyFilter.product`).

Its ε (:attr:`PrivacyFilter.epsilon`) is the exact max log ratio of its rational entries rounded up
(:func:`fairaudit.base.outward.log_up`), and δ(ε) is rounded up too. :meth:`PrivacyFilter.apply` samples with
integers only (:mod:`fairaudit.filter.exact_sampling`), from :func:`secrets.token_bytes` unless given another
source. :meth:`PrivacyFilter.to_dict` writes its parameters as JSON (``"format": "fairaudit-filter"``) and
:meth:`PrivacyFilter.from_dict` reads them back exactly. Guide: ``docs/filter.md``.
"""

from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Hashable, Mapping, Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import numpy as np
import numpy.typing as npt

from fairaudit.base.checks import epsilon as check_epsilon
from fairaudit.base.errors import InputError
from fairaudit.base.json_values import Report, number
from fairaudit.base.labels import as_labels, is_hashable
from fairaudit.base.outward import exp_down, fraction_up, log_up
from fairaudit.filter.exact_sampling import RandomBytes, below, pick, uniform_below, words
from fairaudit.filter.filter_format import FORMAT, FORMAT_VERSION, KINDS, json_labels, parameters_filter
from fairaudit.filter.rationals import Rows, as_rows, exact_number
from fairaudit.laws.closed_forms import RandomizedResponse
from fairaudit.laws.mechanisms import Mechanism

__all__ = ["PrivacyFilter"]

_ROUNDED = "keep rounded down: t = exp_down(requested_epsilon) <= e^requested_epsilon, exact epsilon ln t"


@dataclass(frozen=True, eq=False)
class PrivacyFilter:
    """A finite privacy mechanism with exact rational rows, ready to release real values.

    Build it with :meth:`randomized_response`, :meth:`from_matrix`, :meth:`from_mechanism`, :meth:`product` or
    :meth:`from_dict`; the fields are checked whichever way it is made.

    Attributes
    ----------
    kind : str
        ``"randomized_response"``, ``"matrix"`` or ``"product"`` (:data:`KINDS`).
    inputs, outputs : tuple
        The labels of the rows and columns (a product's: tuples, in ``itertools.product`` order).
    denominator : int
        D: every probability is an integer numerator over D (a product's: the product of its components').
    rows : tuple of tuple of int, shape (n_inputs, n_outputs)
        A matrix's numerators, each row summing to D; () for the other kinds.
    keep, move : int
        Randomized response: each row keeps its value with ``keep / D`` and moves to each of the k − 1 others
        with ``move / D`` (``keep + (k − 1) move = D``); 0 for the other kinds. Its k × k rows are never built
        to sample, so memory is linear in k.
    components : tuple of PrivacyFilter
        A product's filters, one per attribute; () for the other kinds.
    rounding : str
        ``"exact"`` (the probabilities given), or how the keep probability was rounded from
        ``requested_epsilon``.
    requested_epsilon : float or None
        The ε asked for, when randomized response was made from ε (nats).
    name : str
        A short description, in reports.

    Examples
    --------
    >>> f = PrivacyFilter.randomized_response(["Tom", "Mary"], keep="3/4")
    >>> f.keep, f.move, f.denominator, f.epsilon == log_up(3)
    (3, 1, 4, True)
    >>> import random
    >>> f.apply(["Tom", "Mary", "Tom"], random_bytes=random.Random(7).randbytes)
    ['Tom', 'Tom', 'Tom']
    """

    kind: str
    inputs: tuple
    outputs: tuple
    denominator: int
    rows: Rows = ()
    keep: int = 0
    move: int = 0
    components: tuple[PrivacyFilter, ...] = ()
    rounding: str = "exact"
    requested_epsilon: float | None = None
    name: str = "filter"

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise InputError("kind", f"must be one of {', '.join(KINDS)}", self.kind)
        if self.kind != "product":
            object.__setattr__(self, "inputs", as_labels(self.inputs, "inputs"))
            object.__setattr__(self, "outputs", as_labels(self.outputs, "outputs"))
        if not isinstance(self.denominator, int) or self.denominator < 1:
            raise InputError("denominator", "must be a whole number >= 1", self.denominator)
        check = {"randomized_response": self._check_randomized_response, "matrix": self._check_matrix}
        check.get(self.kind, self._check_product)()

    def _check_randomized_response(self) -> None:
        """keep ≥ move ≥ 0, keep + (k − 1) move = D, the same labels in and out."""
        k = len(self.inputs)
        if self.outputs != self.inputs:
            raise InputError("outputs", "of randomized response must be its inputs", self.outputs)
        if not (0 <= self.move <= self.keep) or self.keep + (k - 1) * self.move != self.denominator:
            problem = "must be keep >= move >= 0 with keep + (k - 1) move = denominator"
            raise InputError(
                "keep", problem, {"keep": self.keep, "move": self.move, "k": k, "denominator": self.denominator}
            )

    def _check_matrix(self) -> None:
        """One row of integers ≥ 0 per input, one entry per output, each row summing to D."""
        if len(self.rows) != len(self.inputs):
            raise InputError("rows", f"must have one row per input ({len(self.inputs)})", len(self.rows))
        for i, row in enumerate(self.rows):
            if len(row) != len(self.outputs) or any(not isinstance(n, int) or n < 0 for n in row):
                raise InputError(f"rows[{i}]", f"must be {len(self.outputs)} whole numbers >= 0", row)
            if sum(row) != self.denominator:
                raise InputError(f"rows[{i}]", f"must sum to the denominator {self.denominator}", row)

    def _check_product(self) -> None:
        """Components that are filters; labels and denominator theirs."""
        if not self.components or not all(isinstance(c, PrivacyFilter) for c in self.components):
            raise InputError("components", "must be one or more PrivacyFilter objects", self.components)
        inputs = tuple(itertools.product(*(c.inputs for c in self.components)))
        outputs = tuple(itertools.product(*(c.outputs for c in self.components)))
        if tuple(self.inputs) != inputs or tuple(self.outputs) != outputs:
            raise InputError("inputs", "of a product must be the tuples of its components' labels", self.inputs[:3])
        if self.denominator != math.prod(c.denominator for c in self.components):
            raise InputError("denominator", "of a product must be its components' product", self.denominator)

    # ------------------------------------------------------------------ constructors

    @classmethod
    def randomized_response(
        cls,
        values: Sequence[Hashable],
        epsilon: float | None = None,
        *,
        keep: Fraction | int | float | str | None = None,
        name: str | None = None,
    ) -> PrivacyFilter:
        """k-ary randomized response on ``values``, with exact rational probabilities.

        Give exactly one of ``epsilon`` and ``keep``. From ``keep`` = p (exact, as
        :func:`~fairaudit.filter.rationals.exact_number` reads it: ``"7/10"`` is 7/10, the float 0.7 its binary
        value), rows keep with p and move to each other value with (1 − p)/(k − 1). From ``epsilon``: e^ε is
        irrational, so the filter uses t = ``exp_down(epsilon)`` (a float ≤ e^ε, as an exact rational; 1 when
        that float is below 1, as it is for 0 < ε ≤ about 1e-50) and keeps with t / (t + k − 1), moving with
        1 / (t + k − 1): its exact ε is ln t ≤ ``epsilon`` (at least as private as asked) and ``epsilon`` − ln t ≤
        about 4.5e-16 · max(1, ``epsilon``). ``epsilon`` = +inf, or ``keep`` = 1, is the identity (never private:
        ε = +inf for k ≥ 2).

        Parameters
        ----------
        values : sequence of hashable, length k ≥ 1
            The alphabet, inputs and outputs alike.
        epsilon : float, optional
            ε ≥ 0 in nats.
        keep : Fraction, int, float or str, optional
            p in [1/k, 1].
        name : str, optional
            Default ``"k-ary randomized response"``.

        Raises
        ------
        InputError
            Neither or both of ``epsilon`` and ``keep``; ε negative or NaN; p outside [1/k, 1] or not a number.

        Examples
        --------
        >>> f = PrivacyFilter.randomized_response(["a", "b", "c"], epsilon=1.0)
        >>> float(f.ratio) <= math.e, f.epsilon <= 1.0 + 2**-52, f.rounding.startswith("keep rounded down")
        (True, True, True)
        """
        labels = as_labels(values, "values")
        k = len(labels)
        name = name or f"{k}-ary randomized response"
        if (epsilon is None) == (keep is None):
            raise InputError(
                "randomized_response", "give exactly one of `epsilon` and `keep`", {"epsilon": epsilon, "keep": keep}
            )
        eps: float | None = None  # (the ε asked for, when made from ε)
        keep_n, move_n = 1, 0  # keep / move = t, the ratio of the rows; 1 / 0: the identity (one value, p = 1, ε = inf)
        if keep is not None:
            p = exact_number(keep, "keep")
            if not (Fraction(1, k) <= p <= 1):
                raise InputError("keep", f"must be a keep probability in [1/k, 1] = [1/{k}, 1]", keep)
            if k > 1 and p < 1:  # p = t / (t + k − 1)
                keep_n, move_n = (p * (k - 1) / (1 - p)).as_integer_ratio()
        else:
            eps = check_epsilon(epsilon)
            if k > 1 and not math.isinf(eps):  # e^ε ≥ 1: exp_down of a tiny ε may be just below 1
                keep_n, move_n = max(Fraction(exp_down(eps)), Fraction(1)).as_integer_ratio()
        rounding = _ROUNDED if eps is not None and k > 1 else "exact"
        return cls("randomized_response", labels, labels, keep_n + (k - 1) * move_n, keep=keep_n, move=move_n,
                   rounding=rounding, requested_epsilon=eps, name=name)  # fmt: skip

    @classmethod
    def from_matrix(
        cls,
        rows: Sequence[Sequence[object]],
        inputs: Sequence[Hashable],
        outputs: Sequence[Hashable] | None = None,
        *,
        name: str = "matrix",
    ) -> PrivacyFilter:
        """Any finite mechanism from its matrix of rows P(output | input), exactly.

        Parameters
        ----------
        rows : sequence of sequences, shape (n_inputs, n_outputs)
            Entries as :class:`~fractions.Fraction`, integers, strings such as ``"1/3"`` or ``"0.1"``, or floats,
            read as their exact binary rationals: each row must then sum to exactly 1.
        inputs, outputs : sequence of hashable
            Labels; ``outputs`` defaults to ``inputs``.
        name : str

        Raises
        ------
        InputError
            Naming ``rows[i]`` (or ``rows[i][j]``): a ragged matrix, a negative entry, a row whose exact sum is
            not 1; ``inputs`` or ``outputs`` not distinct or not matching the shape.

        Examples
        --------
        The paper's X-privacy mechanism (SI C, Example) is (ln 3)-DP:

        >>> f = PrivacyFilter.from_matrix([["0.9", "0.1"], ["0.7", "0.3"]], [0, 1])
        >>> f.rows, f.denominator, f.ratio
        (((9, 1), (7, 3)), 10, Fraction(3, 1))
        >>> PrivacyFilter.from_matrix([[0.9, 0.1], [0.7, 0.3]], [0, 1])
        Traceback (most recent call last):
        ...
        fairaudit.base.errors.InputError: rows[0]: must sum to exactly 1, not 36028797018963969/36028797018963968 (floats count as their exact binary values: give fractions or strings such as '1/3' or '0.1') (got [0.9, 0.1])
        """
        labels_in = as_labels(inputs, "inputs")
        labels_out = labels_in if outputs is None else as_labels(outputs, "outputs")
        numerators, d = as_rows(rows, "rows")
        if len(numerators) != len(labels_in) or len(numerators[0]) != len(labels_out):
            shape = f"({len(labels_in)}, {len(labels_out)})"
            raise InputError(
                "rows", f"must have shape (inputs, outputs) = {shape}", f"{len(numerators)} x {len(numerators[0])}"
            )
        return cls("matrix", labels_in, labels_out, d, rows=numerators, name=name)

    @classmethod
    def from_mechanism(cls, mechanism: Mechanism) -> PrivacyFilter:
        """The filter of a :class:`~fairaudit.laws.mechanisms.Mechanism`: its labels and its matrix.

        k-ary randomized response (as :func:`fairaudit.randomized_response` and the spec's
        ``randomized_response`` tables build it) becomes :meth:`randomized_response` at its ε; the identity,
        randomized response keeping with 1. Any other matrix is read entry by entry as its exact binary
        rational when every row then sums to exactly 1, else as the shortest decimal that prints each entry
        (``0.1`` is 1/10: what a spec or a caller wrote), whose rows must then sum to exactly 1.

        Raises
        ------
        InputError
            When the rows sum to 1 neither way: build the filter with :meth:`from_matrix` and exact fractions.

        Examples
        --------
        >>> from fairaudit.laws.mechanisms import from_matrix
        >>> PrivacyFilter.from_mechanism(from_matrix([[0.9, 0.1], [0.7, 0.3]], [0, 1])).rows
        ((9, 1), (7, 3))
        """
        if isinstance(mechanism, RandomizedResponse):
            return cls.randomized_response(mechanism.inputs, mechanism.rr.epsilon, name=mechanism.name)
        if mechanism.is_identity:
            return cls.randomized_response(mechanism.inputs, keep=1, name=mechanism.name)
        matrix = mechanism.matrix.tolist()
        try:
            return cls.from_matrix(matrix, mechanism.inputs, mechanism.outputs, name=mechanism.name)
        except InputError:
            decimals = [[Fraction(repr(float(v))) for v in row] for row in matrix]
        try:
            return cls.from_matrix(decimals, mechanism.inputs, mechanism.outputs, name=mechanism.name)
        except InputError as exc:
            problem = (
                "has rows that sum to 1 neither as binary floats nor as the decimals that print them "
                f"({exc.field}); build the filter with PrivacyFilter.from_matrix and exact fractions"
            )
            raise InputError(f"mechanism '{mechanism.name}'", problem, exc.value) from None

    @classmethod
    def product(cls, *filters: PrivacyFilter, name: str | None = None) -> PrivacyFilter:
        """The product of filters: each attribute of a tuple released by its own filter, independently.

        Inputs and outputs are the tuples of the components' labels in ``itertools.product`` order. With every
        pair of tuples adjacent, the product's exact e^ε is the product of its components' (ε adds up:
        ``proofs/privacy.md``).

        Raises
        ------
        InputError
            With no filter, or a component that is not a :class:`PrivacyFilter`.

        Examples
        --------
        >>> rr = [PrivacyFilter.randomized_response(v, keep="7/10") for v in (["Tom", "Mary"], [25, 55])]
        >>> f = PrivacyFilter.product(*rr)
        >>> f.inputs[:2], f.ratio
        ((('Tom', 25), ('Tom', 55)), Fraction(49, 9))
        """
        if not filters or not all(isinstance(f, PrivacyFilter) for f in filters):
            raise InputError("product", "needs one or more PrivacyFilter objects", filters)
        inputs = tuple(itertools.product(*(f.inputs for f in filters)))
        outputs = tuple(itertools.product(*(f.outputs for f in filters)))
        d = math.prod(f.denominator for f in filters)
        label = name or " x ".join(f.name for f in filters)
        return cls("product", inputs, outputs, d, components=tuple(filters), name=label)

    # ------------------------------------------------------------------ privacy

    @functools.cached_property
    def ratio(self) -> Fraction | float:
        """e^ε exactly: max over outputs o and inputs a, a' of M[a, o] / M[a', o] (a rational ≥ 1).

        +inf (a float) when some output has a positive probability under one input and 0 under another.
        """
        return _ratio(self)

    @property
    def epsilon(self) -> float:
        """The filter's own ε in nats: ln :attr:`ratio`, rounded up (:func:`~fairaudit.base.outward.log_up`).

        0 for one input or equal rows; +inf when the ratio is infinite.
        """
        ratio = self.ratio
        return math.inf if isinstance(ratio, float) else log_up(ratio)

    def delta(self, epsilon: float) -> float:
        """δ(ε) = max over a ≠ a' of Σ_o [M[a, o] − e^ε M[a', o]]₊, rounded up.

        Computed with exact rationals with e^ε replaced by ``exp_down(epsilon)`` ≤ e^ε (which can only make each
        term larger), then rounded up (:func:`~fairaudit.base.outward.fraction_up`). Randomized response is a
        closed form; a matrix or a product costs (n_inputs² × n_outputs) exact operations.

        Parameters
        ----------
        epsilon : float
            ε ≥ 0 in nats; +inf gives the mass some input puts where another puts none.

        Raises
        ------
        InputError
            If ``epsilon`` is negative or NaN.

        Examples
        --------
        >>> f = PrivacyFilter.randomized_response(["a", "b"], keep="3/4")
        >>> f.delta(0.0), f.delta(f.epsilon), f.delta(math.inf)
        (0.5, 0.0, 0.0)
        """
        eps = check_epsilon(epsilon)
        if len(self.inputs) < 2:
            return 0.0
        t = None if math.isinf(eps) else Fraction(exp_down(eps))
        if self.kind == "randomized_response":
            if t is None:
                return 1.0 if self.move == 0 else 0.0
            return fraction_up(max(Fraction(0), (self.keep - t * self.move) / self.denominator))
        pairs = itertools.permutations(self.numerator_rows(), 2)  # (two inputs at least: never empty)
        if t is None:
            best = Fraction(max(sum(x for x, y in zip(p, q) if y == 0) for p, q in pairs))
        else:
            best = max(sum((x - t * y for x, y in zip(p, q) if x > t * y), Fraction(0)) for p, q in pairs)
        return fraction_up(best / self.denominator)

    def numerator_rows(self) -> Rows:
        """Every row's integer numerators over :attr:`denominator`, shape (n_inputs, n_outputs).

        Builds randomized response's k × k rows and a product's Kronecker rows: for reports and checks, not for
        sampling.

        Examples
        --------
        >>> PrivacyFilter.randomized_response([0, 1, 2], keep="1/2").numerator_rows()
        ((2, 1, 1), (1, 2, 1), (1, 1, 2))
        """
        if self.kind == "matrix":
            return self.rows
        if self.kind == "randomized_response":
            k = len(self.inputs)
            return tuple(tuple(self.keep if o == a else self.move for o in range(k)) for a in range(k))
        parts = [c.numerator_rows() for c in self.components]
        return tuple(tuple(math.prod(x) for x in itertools.product(*row)) for row in itertools.product(*parts))

    # ------------------------------------------------------------------ sampling

    def apply(self, values: Sequence[Hashable], *, random_bytes: RandomBytes | None = None) -> list[Hashable]:
        """Release each value through the filter: labels in, labels out.

        Value i becomes output o with probability ``M[value_i, o]`` exactly, independently of the others: a
        uniform integer in [0, D) drawn by rejection from uniform random bytes picks o by the row's cumulative
        integer numerators (randomized response: keep when it is below ``keep``, else a uniform other value).
        No floating point enters a draw (Mironov 2012). A product releases each attribute of the tuples with
        its own component. Vectorised over the values.

        Parameters
        ----------
        values : sequence of hashable, length n
            Labels among :attr:`inputs` (a product's: tuples, one entry per component).
        random_bytes : callable, optional
            ``random_bytes(k) -> bytes`` of uniform random bytes; default :func:`secrets.token_bytes`, the
            operating system's cryptographically secure source. Tests pass a seeded one, such as
            ``random.Random(seed).randbytes``; never deploy with one.

        Returns
        -------
        list, length n
            The released labels, in the order of ``values``.

        Raises
        ------
        InputError
            Naming ``values`` and quoting the first value that is not among the labels.

        Examples
        --------
        >>> import random
        >>> f = PrivacyFilter.randomized_response(["a", "b"], keep=1)
        >>> f.apply(["a", "b", "b"], random_bytes=random.Random(0).randbytes)
        ['a', 'b', 'b']
        >>> f.apply(["a", "z"])
        Traceback (most recent call last):
        ...
        fairaudit.base.errors.InputError: values: holds a value that is not among the filter's inputs ('a', 'b') (got 'z')
        """
        if self.kind != "product":
            released = self.release_indices(self.input_indices(values, "values"), random_bytes)
            return list(self._output_array[released])
        n_parts = len(self.components)
        items = list(values)
        bad = [v for v in items if not isinstance(v, (tuple, list)) or len(v) != n_parts]
        if bad:
            raise InputError("values", f"must be tuples of {n_parts} values, one per component", bad[0])
        columns = list(zip(*items)) if items else [() for _ in self.components]
        released_columns = []
        for j, (component, column) in enumerate(zip(self.components, columns)):
            indices = component.input_indices(column, f"values (component {j})")
            released_columns.append(component._output_array[component.release_indices(indices, random_bytes)])
        return list(zip(*released_columns)) if items else []

    def input_indices(self, values: Sequence[Hashable], field: str = "values") -> npt.NDArray[np.intp]:
        """The row of each value among :attr:`inputs` (a dictionary look-up each, at C speed), shape (n,).

        Raises
        ------
        InputError
            Naming ``field`` and quoting the first value not among the inputs.
        """
        index = self._input_index
        try:
            return np.fromiter(map(index.__getitem__, values), dtype=np.intp, count=len(values))
        except (KeyError, TypeError):
            bad = next(v for v in values if not is_hashable(v) or v not in index)
            shown = self.inputs if len(self.inputs) <= 10 else f"{len(self.inputs)} labels"
            raise InputError(field, f"holds a value that is not among the filter's inputs {shown}", bad) from None

    def release_indices(self, rows: npt.NDArray[np.intp], random_bytes: RandomBytes | None) -> npt.NDArray[np.intp]:
        """The output index released for each input index of ``rows`` (shape (n,)), sampled exactly.

        Randomized response or a matrix (a product releases its components' one by one, in :meth:`apply`).
        ``random_bytes`` None draws from :func:`secrets.token_bytes`.
        """
        n = rows.size
        if self.kind == "randomized_response":
            k = len(self.inputs)
            if k < 2 or self.move == 0:
                return rows.copy()
            draws = uniform_below(self.denominator, n, random_bytes)
            moved = ~below(draws, words(self.keep, draws.shape[1]))
            out = rows.copy()
            others = uniform_below(k - 1, int(moved.sum()), random_bytes)[:, 0].astype(np.intp)
            others += others >= rows[moved]  # the (k − 1) values other than the input, in order
            out[moved] = others
            return out
        draws = uniform_below(self.denominator, n, random_bytes)
        out = np.zeros(n, dtype=np.intp)
        for i in np.unique(rows).tolist():
            chosen = rows == i
            out[chosen] = pick(draws[chosen], self.rows[i])
        return out

    @functools.cached_property
    def _input_index(self) -> dict[Hashable, int]:
        """Each input label's row."""
        return {label: i for i, label in enumerate(self.inputs)}

    @functools.cached_property
    def _output_array(self) -> npt.NDArray[np.object_]:
        """The output labels as a numpy array of objects (tuples stay tuples)."""
        return np.fromiter(self.outputs, dtype=object, count=len(self.outputs))

    # ------------------------------------------------------------------ JSON

    def to_dict(self) -> Report:
        """The filter's parameters as a JSON dictionary, exact: what :meth:`from_dict` reads back.

        Keys: ``format`` (``"fairaudit-filter"``), ``format_version`` (1), ``mechanism`` (the kind), ``name``,
        ``epsilon`` (rounded up; ``"inf"`` when infinite), ``rounding`` (``"exact"`` or how the keep probability
        was rounded) and ``requested_epsilon``; then randomized response's ``values``, ``keep``, ``move`` and
        ``denominator``, a matrix's ``inputs``, ``outputs``, ``rows`` and ``denominator``, or a product's
        ``components`` (each a filter's dictionary without ``format`` and ``format_version``). Integers are
        written as decimal strings (exact in every JSON reader); labels as they are, tuples as lists.

        Examples
        --------
        >>> PrivacyFilter.randomized_response(["Tom", "Mary"], keep="3/4").to_dict()
        {'format': 'fairaudit-filter', 'format_version': 1, 'mechanism': 'randomized_response', 'name': '2-ary randomized response', 'epsilon': 1.0986122886681098, 'rounding': 'exact', 'requested_epsilon': None, 'values': ['Tom', 'Mary'], 'keep': '3', 'move': '1', 'denominator': '4'}
        """
        return {"format": FORMAT, "format_version": FORMAT_VERSION, **self._parameters()}

    def _parameters(self) -> Report:
        """:meth:`to_dict` without its format and version (a product's components)."""
        head: Report = {
            "mechanism": self.kind,
            "name": self.name,
            "epsilon": number(self.epsilon),
            "rounding": self.rounding,
            "requested_epsilon": number(self.requested_epsilon),
        }
        if self.kind == "randomized_response":
            return {**head, "values": json_labels(self.inputs), "keep": str(self.keep), "move": str(self.move),
                    "denominator": str(self.denominator)}  # fmt: skip
        if self.kind == "matrix":
            rows = [[str(n) for n in row] for row in self.rows]
            return {**head, "inputs": json_labels(self.inputs), "outputs": json_labels(self.outputs),
                    "rows": rows, "denominator": str(self.denominator)}  # fmt: skip
        return {**head, "components": [c._parameters() for c in self.components]}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> PrivacyFilter:
        """The filter a :meth:`to_dict` dictionary describes, exactly (its ``epsilon`` checked against it).

        Raises
        ------
        InputError
            A ``format`` or ``format_version`` this version does not read, a missing or malformed field (named),
            rows that do not sum to the denominator, or an ``epsilon`` that is not the filter's own.

        Examples
        --------
        >>> f = PrivacyFilter.randomized_response(["a", "b", "c"], epsilon=0.5)
        >>> g = PrivacyFilter.from_dict(f.to_dict())
        >>> (g.keep, g.move, g.denominator, g.epsilon) == (f.keep, f.move, f.denominator, f.epsilon)
        True
        """
        if not isinstance(data, Mapping):
            raise InputError("filter", "must be a JSON object", type(data).__name__)
        if data.get("format") != FORMAT:
            raise InputError("format", f"must be {FORMAT!r}", data.get("format"))
        if data.get("format_version") != FORMAT_VERSION:
            raise InputError("format_version", f"must be {FORMAT_VERSION}", data.get("format_version"))
        return parameters_filter(cls, data, "")


def _ratio(f: PrivacyFilter) -> Fraction | float:
    """e^ε of a filter, exactly (+inf as a float)."""
    if len(f.inputs) < 2:
        return Fraction(1)
    if f.kind == "randomized_response":
        return math.inf if f.move == 0 else Fraction(f.keep, f.move)
    if f.kind == "product":
        parts = [c.ratio for c in f.components]
        return math.inf if any(isinstance(r, float) for r in parts) else math.prod(parts, start=Fraction(1))
    extremes = [(max(column), min(column)) for column in zip(*f.rows) if any(column)]  # (all-zero columns: no ratio)
    if any(low == 0 for _, low in extremes):
        return math.inf
    return max((Fraction(top, low) for top, low in extremes), default=Fraction(1))
