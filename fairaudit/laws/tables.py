"""Labelled, validated probability tables: populations, kernels and laws.

Every table is a numpy array indexed in the order **[x, a, u]** (context,
sensitive group, decision), with the labels of each axis kept beside it.

* :class:`Population` — P(X = x, A = a), shape (n_contexts, n_groups).
* :class:`Kernel` — the decision model P(U = u | X̃ = x̃, Ã = ã) on the
  *released* (privatized) context and group, shape (n_contexts, n_groups,
  n_decisions).
* :class:`Law` — P(U = u | X = x, A = a) on the *true* context and group,
  same shape; :func:`~fairaudit.laws.composition.compose` builds it from a kernel and the
  mechanisms (:mod:`fairaudit.laws.composition`): ``Q[x, a, u] = Σ_{x̃, ã} M_X[x, x̃] M_A[a, ã] K[x̃, ã, u]``.

A table estimated from counts keeps them (``counts``, same shape); a cell
(x, a) with no record is *empty*: its row holds NaN and metrics exclude and
report it.
"""

from __future__ import annotations

import functools
from collections.abc import Hashable, Sequence
from dataclasses import dataclass, field
from typing import Any, Self

import numpy as np
import numpy.typing as npt

from fairaudit.base.arrays import ROW_TOLERANCE, BoolArray, FloatArray, as_float_array, check_probabilities, check_shape
from fairaudit.base.errors import InputError
from fairaudit.base.json_values import Report, label, number
from fairaudit.base.labels import Labels, format_label

__all__ = [
    # tables
    "IndependenceCheck",
    "Kernel",
    "Law",
    "Population",
    # the population a law's metrics use
    "default_population",
    "population_for",
]

SOURCES = ("given", "records", "assumed")
"""Where a :class:`Population` comes from (its ``source``)."""


@dataclass(frozen=True)
class IndependenceCheck:
    """Whether X and A are independent in a population.

    Attributes
    ----------
    independent : bool
        True when ``max_deviation <= tolerance``.
    max_deviation : float
        max over (x, a) of |P(x, a) − P(x) P(a)|.
    context, group : hashable
        The cell where the deviation is largest.
    tolerance : float
        The tolerance used.
    """

    independent: bool
    max_deviation: float
    context: Hashable
    group: Hashable
    tolerance: float


class _ContextsAndGroups:
    """The context and group axes' labels of a population or a decision table (``_labels[0]``, ``_labels[1]``)."""

    _labels: tuple[Labels, ...]

    @property
    def contexts(self) -> tuple:
        """The context labels, a tuple (made on first use when they were given as a range or an array)."""
        return self._labels[0].tuple

    @property
    def groups(self) -> tuple:
        """The group labels, a tuple."""
        return self._labels[1].tuple

    @property
    def context_labels(self) -> Labels:
        """The context labels as given, compact (a range or an array stays one): ``context_labels[i]``, ``len``."""
        return self._labels[0]

    @property
    def group_labels(self) -> Labels:
        """The group labels as a :class:`~fairaudit.base.labels.Labels`."""
        return self._labels[1]


@dataclass(frozen=True, eq=False)
class Population(_ContextsAndGroups):
    """The joint distribution P(X = x, A = a) of context and sensitive group.

    Parameters
    ----------
    probabilities : array_like, shape (n_contexts, n_groups)
        Non-negative, finite, summing to 1 within 1e-9.
    contexts, groups : sequence of hashable
        Labels of the axes; a ``range`` or a 1-D numpy array of integers or text stays one
        (``context_labels``; ``contexts`` is the tuple, made when first asked for).
    source : {"given", "records", "assumed"}
        Where it comes from: ``"given"`` by the caller or the spec's
        ``[population]``; ``"records"``, the records' own P(X, A) = n(x, a) / n
        (:meth:`from_counts`); ``"assumed"``, a default nobody stated (uniform
        and independent, or P(X) from ``context.distribution`` with P(A)
        uniform and X ⊥ A). Reports say which; an assumed population's X ⊥ A
        is reported as assumed, never as checked.

    Raises
    ------
    InputError
        On a shape that does not match the labels, a negative or non-finite
        entry, a total that is not 1, or an unknown ``source``.

    Examples
    --------
    >>> pop = Population.uniform(["x0", "x1"], ["a0", "a1"])
    >>> pop.probabilities.tolist(), pop.source
    ([[0.25, 0.25], [0.25, 0.25]], 'given')
    >>> pop.independence().independent
    True
    >>> rec = Population.from_counts([[30, 10], [10, 10]], ["x0", "x1"], ["a0", "a1"])
    >>> rec.source, rec.describe()
    ('records', "the records' own P(X, A) (60 records)")
    """

    probabilities: FloatArray
    source: str = "given"
    records: float | None = None
    """The number of records behind a ``"records"`` population, else None."""
    _labels: tuple[Labels, Labels] = field(init=False, repr=False, compare=False)

    def __init__(
        self,
        probabilities: npt.ArrayLike,
        contexts: Sequence[Hashable] | Labels,
        groups: Sequence[Hashable] | Labels,
        *,
        source: str = "given",
        records: float | None = None,
        _owned: bool = False,
    ) -> None:
        if source not in SOURCES:
            raise InputError("source", f"must be one of {', '.join(SOURCES)}", source)
        labels = (Labels.of(contexts, "population contexts"), Labels.of(groups, "population groups"))
        array = as_float_array(probabilities, "population", ndim=2, copy=not _owned)  # our own copy
        check_shape(array, tuple(map(len, labels)), "population", ("contexts", "groups"))
        check_probabilities(
            array[:, :, None],
            "population",
            (*labels, (None,)),
            ("context", "group", "-"),
            rows_sum_to_one=False,
        )
        total = float(array.sum())
        if abs(total - 1.0) > ROW_TOLERANCE:
            raise InputError("population", f"entries sum to {total:.12g}, not 1")
        array.setflags(write=False)
        vars(self).update(probabilities=array, _labels=labels, source=source, records=records)  # (frozen)

    def __repr__(self) -> str:
        return (
            f"Population(probabilities={self.probabilities!r}, contexts={self.contexts!r}, groups={self.groups!r}, "
            f"source={self.source!r}, records={self.records!r})"
        )

    @classmethod
    def uniform(
        cls, contexts: Sequence[Hashable] | Labels, groups: Sequence[Hashable] | Labels, *, source: str = "given"
    ) -> Population:
        """Uniform and independent: P(x, a) = 1 / (n_contexts · n_groups).

        The default population of a probability table is ``uniform(..., source="assumed")``.
        """
        xs, gs = Labels.of(contexts, "population contexts"), Labels.of(groups, "population groups")
        p = np.full((len(xs), len(gs)), 1.0 / (len(xs) * len(gs)))
        return cls(p, xs, gs, source=source, _owned=True)

    @classmethod
    def independent(
        cls,
        p_context: npt.ArrayLike,
        p_group: npt.ArrayLike,
        contexts: Sequence[Hashable],
        groups: Sequence[Hashable],
        *,
        source: str = "given",
    ) -> Population:
        """The product P(x) P(a) of two marginals (each summing to 1)."""
        px = as_float_array(p_context, "context distribution", ndim=1)
        pa = as_float_array(p_group, "group distribution", ndim=1)
        xs, gs = Labels.of(contexts, "population contexts"), Labels.of(groups, "population groups")
        check_shape(px, (len(xs),), "context distribution", ("contexts",))
        check_shape(pa, (len(gs),), "group distribution", ("groups",))
        check_probabilities(px[None, :], "context distribution", ((None,), xs), ("table", "context"))
        check_probabilities(pa[None, :], "group distribution", ((None,), gs), ("table", "group"))
        return cls(np.outer(px, pa), xs, gs, source=source, _owned=True)

    @classmethod
    def from_counts(
        cls, counts: npt.ArrayLike, contexts: Sequence[Hashable] | Labels, groups: Sequence[Hashable] | Labels
    ) -> Population:
        """The records' own population P(x, a) = n(x, a) / n from a (n_contexts, n_groups) table of counts.

        Its ``source`` is ``"records"`` and ``records`` is n.
        """
        array = as_float_array(counts, "population counts", ndim=2)
        if np.any(array < 0) or not np.all(np.isfinite(array)):
            raise InputError("population counts", "must be finite and non-negative")
        total = array.sum()
        if total <= 0:
            raise InputError("population counts", "must contain at least one record", float(total))
        return cls(array / total, contexts, groups, source="records", records=float(total), _owned=True)

    def describe(self) -> str:
        """Where the population comes from, in words (the reports' ``population.source`` line)."""
        if self.source == "records":
            n = self.records
            count = "" if n is None else f" ({n:.0f} records)" if float(n).is_integer() else f" (total weight {n:.6g})"
            return f"the records' own P(X, A){count}"
        if self.source == "assumed":
            ind = self.independence()
            uniform = bool(np.allclose(self.probabilities, 1.0 / self.probabilities.size, rtol=0, atol=1e-15))
            shape = "uniform, independent" if uniform and ind.independent else "independent"
            return f"assumed ({shape}): no population was given"
        return "the given P(X, A)"

    @functools.cached_property
    def p_context(self) -> FloatArray:
        """Marginal P(X = x), shape (n_contexts,), read-only (computed once)."""
        return _read_only(np.einsum("xa->x", self.probabilities))

    @functools.cached_property
    def p_group(self) -> FloatArray:
        """Marginal P(A = a), shape (n_groups,), read-only (computed once)."""
        return _read_only(self.probabilities.sum(axis=0))

    def context_given_group(self) -> FloatArray:
        """P(X = x | A = a), shape (n_contexts, n_groups); columns of groups with P(a) = 0 are NaN (0 / 0)."""
        with np.errstate(invalid="ignore"):
            return self.probabilities / self.p_group

    def independence(self, tolerance: float = 1e-9) -> IndependenceCheck:
        """Check X ⊥ A: max |P(x, a) − P(x) P(a)| ≤ ``tolerance``."""
        dev = np.abs(self.probabilities - np.outer(self.p_context, self.p_group))
        i, j = np.unravel_index(int(dev.argmax()), dev.shape)
        worst = float(dev[i, j])
        return IndependenceCheck(worst <= tolerance, worst, self._labels[0][i], self._labels[1][j], tolerance)

    def to_dict(self) -> Report:
        """The report dictionary: where P(X, A) comes from and whether X ⊥ A holds in it.

        ``source`` is ``"given"``, ``"records"`` or ``"assumed"``; ``independent`` is
        ``"assumed"`` for an assumed population (never checked), else a bool with
        ``max_deviation`` = max |P(x, a) − P(x) P(a)| at ``context``, ``group``.

        Examples
        --------
        >>> Population.from_counts([[30, 10], [10, 10]], ["x0", "x1"], ["a0", "a1"]).to_dict()["max_deviation"]
        0.05555555555555558
        """
        ind = self.independence()
        out: Report = {"source": self.source, "description": self.describe(), "records": number(self.records)}
        out["independent"] = "assumed" if self.source == "assumed" else bool(ind.independent)
        out.update(max_deviation=number(ind.max_deviation), context=label(ind.context), group=label(ind.group))
        return out


@dataclass(frozen=True, eq=False)
class _DecisionTable(_ContextsAndGroups):
    probabilities: FloatArray
    counts: FloatArray | None = None
    name: str = "table"
    complete: bool = True
    """True when every cell (x, a) is observed (no empty cell)."""
    _observed: BoolArray = field(init=False, repr=False, compare=False)
    _labels: tuple[Labels, Labels, Labels] = field(init=False, repr=False, compare=False)

    _axes = ("context", "group", "decision")

    def __init__(
        self,
        probabilities: npt.ArrayLike,
        contexts: Sequence[Hashable] | Labels,
        groups: Sequence[Hashable] | Labels,
        decisions: Sequence[Hashable] | Labels,
        *,
        counts: npt.ArrayLike | None = None,
        name: str | None = None,
        _owned: bool = False,
    ) -> None:
        name = name or self._default_name
        labels = (
            Labels.of(contexts, f"{name} contexts"),
            Labels.of(groups, f"{name} groups"),
            Labels.of(decisions, f"{name} decisions"),
        )
        shape = (len(labels[0]), len(labels[1]), len(labels[2]))
        array, source = _table_array(probabilities, name, _owned)
        check_shape(array, shape, name, ("contexts", "groups", "decisions"))
        empty = None
        if counts is not None:
            counts, counts_source = _table_array(counts, f"{name} counts", _owned)
            if counts_source is not None:
                np.copyto(counts, counts_source)
            check_shape(counts, shape, f"{name} counts", ("contexts", "groups", "decisions"))
            if not (counts.size == 0 or counts.min() >= 0) or not np.isfinite(counts.sum()):
                raise InputError(f"{name} counts", "must be finite and non-negative")
            empty = np.einsum("...u->...", counts) == 0
            counts.setflags(write=False)
        check_probabilities(array, name, labels, self._axes, skip_rows=empty, source=source)
        if empty is not None and empty.any():
            if not np.isnan(array[empty]).all():  # (a kernel's own rows hold NaN already)
                if not array.flags.writeable:
                    array = array.copy()
                array[empty] = np.nan
            observed = ~empty
        else:
            observed = np.ones(shape[:2], dtype=bool)  # rows are checked finite: no NaN without counts
        observed.setflags(write=False)
        if array.flags.writeable:
            array.setflags(write=False)
        vars(self).update(_observed=observed, complete=bool(observed.all()))  # (frozen: as object.__setattr__ would)
        vars(self).update(probabilities=array, _labels=labels, counts=counts, name=name)

    @property
    def decisions(self) -> tuple:
        """The decision labels, a tuple."""
        return self._labels[2].tuple

    @property
    def decision_labels(self) -> Labels:
        """The decision labels as a :class:`~fairaudit.base.labels.Labels`."""
        return self._labels[2]

    _default_name = "table"

    @classmethod
    def from_counts(
        cls,
        counts: npt.ArrayLike,
        contexts: Sequence[Hashable] | Labels,
        groups: Sequence[Hashable] | Labels,
        decisions: Sequence[Hashable] | Labels,
        *,
        name: str | None = None,
    ) -> Self:
        """Estimate the table from counts of shape (n_contexts, n_groups, n_decisions).

        Each row is divided by its total; rows with no record are empty
        (NaN) and reported by :attr:`empty_cells`.
        """
        array = as_float_array(counts, f"{name or cls._default_name} counts", ndim=3)  # our own copy
        totals = np.einsum("...u->...", array)[..., None]
        with np.errstate(divide="ignore", invalid="ignore"):
            probs = array / totals  # NaN in rows with no record (0 / 0)
        return cls(probs, contexts, groups, decisions, counts=array, name=name, _owned=True)

    def __repr__(self) -> str:
        n = self.probabilities.shape
        return f"{type(self).__name__}({self.name!r}, {n[0]} contexts x {n[1]} groups x {n[2]} decisions)"

    @property
    def shape(self) -> tuple[int, int, int]:
        """(n_contexts, n_groups, n_decisions)."""
        return self.probabilities.shape

    @property
    def observed(self) -> BoolArray:
        """Boolean (n_contexts, n_groups), read-only: True where the cell's row is known (it has records)."""
        return self._observed

    @property
    def cell_counts(self) -> FloatArray | None:
        """Records per cell (x, a), shape (n_contexts, n_groups), or None."""
        return None if self.counts is None else self.counts.sum(axis=-1)

    @property
    def empty_cells(self) -> tuple[tuple[Any, Any], ...]:
        """Labels (context, group) of the empty cells, in table order."""
        if self.complete:
            return ()
        idx = np.argwhere(~self.observed)
        xs, gs = self._labels[0], self._labels[1]
        return tuple((xs[i], gs[j]) for i, j in idx)

    def to_dict(self) -> dict[str, dict[str, dict[str, float]]]:
        """{context: {group: {decision: probability}}}, labels as text, probabilities rounded to 12 digits.

        Examples
        --------
        >>> Kernel([[[0.2, 0.8]]], ["doc1"], ["HR_1"], ["go", "stay"]).to_dict()
        {'doc1': {'HR_1': {'go': 0.2, 'stay': 0.8}}}
        """
        p = np.round(self.probabilities, 12) + 0.0
        return {
            str(label(x)): {
                str(label(a)): {str(label(u)): float(p[i, j, m]) for m, u in enumerate(self.decisions)}
                for j, a in enumerate(self.groups)
            }
            for i, x in enumerate(self.contexts)
        }


class Kernel(_DecisionTable):
    """A decision model P(U = u | X̃ = x̃, Ã = ã): the black box behind the filter.

    Parameters
    ----------
    probabilities : array_like, shape (n_contexts, n_groups, n_decisions)
        Indexed [x̃, ã, u]; each row over u sums to 1 within 1e-9 (every entry is checked, in one
        pass). A float64 C-contiguous array is copied once, while it is checked, so that later writes
        to it do not reach the table; a read-only one (nothing can write to its memory) is used as it
        is, with no copy.
    contexts, groups, decisions : sequence of hashable
        Labels of the released context, released group and decision. A ``range`` or a 1-D numpy
        array of integers or text stays one (``context_labels`` …; ``contexts`` … are their tuples,
        made when first asked for): a million contexts cost no Python object each.
    counts : array_like, optional
        The counts the table was estimated from (same shape).
    name : str, optional
        Name used in error messages and reports (default ``"kernel"``).

    Raises
    ------
    InputError
        Names the table, the row's labels and its sum when a row does not sum
        to 1; the entry when it is negative or not finite; the shape when it
        does not match the labels.

    Examples
    --------
    >>> k = Kernel([[[0.2, 0.8]], [[0.5, 0.5]]], ["doc1", "doc2"], ["HR_1"], ["go", "stay"])
    >>> k.shape
    (2, 1, 2)
    >>> Kernel([[[0.2, 0.7]]], ["doc1"], ["HR_1"], ["go", "stay"])
    Traceback (most recent call last):
    ...
    fairaudit.base.errors.InputError: kernel: row (context='doc1', group='HR_1') sums to 0.9, not 1
    """

    _default_name = "kernel"


class Law(_DecisionTable):
    """The law P(U = u | X = x, A = a) of decisions given the true context and group.

    Same layout and checks as :class:`Kernel`, indexed [x, a, u]. Build it
    directly (a model that sees the true attributes), from counts, or with
    :func:`~fairaudit.laws.composition.compose`.

    Examples
    --------
    >>> law = Law.from_counts([[[3, 1], [0, 0]]], ["x"], ["a", "b"], ["yes", "no"])
    >>> law.probabilities[0, 0].tolist(), law.empty_cells
    ([0.75, 0.25], (('x', 'b'),))
    """

    _default_name = "law"

    @classmethod
    def from_kernel(cls, kernel: Kernel) -> Law:
        """The law of a model that sees the true attributes (identity filters)."""
        return cls(kernel.probabilities, *kernel._labels, counts=kernel.counts, name="law")


def _table_array(values: object, field: str, owned: bool) -> tuple[FloatArray, FloatArray | None]:
    """The table as our float64 array, and the caller's array still to be copied into it (or None).

    Ours already (``owned``), or a conversion (a list, another dtype, a non-contiguous array: the
    conversion is our copy): used as it is. The caller's float64 C-contiguous array is not copied when
    nothing can write to it (:func:`_frozen`); a writable one is copied once, block by block while it is
    checked (:func:`~fairaudit.base.arrays.check_probabilities`' ``source``), so a later write by the caller
    cannot change the table.
    """
    if type(values) is np.ndarray and values.dtype == np.float64 and values.flags.c_contiguous and values.ndim == 3:
        if owned or _frozen(values):
            return values, None
        return np.empty(values.shape), values
    return as_float_array(values, field, ndim=3, copy=not owned), None


def _read_only(array: FloatArray) -> FloatArray:
    """``array``, made read-only."""
    array.setflags(write=False)
    return array


def _frozen(array: object) -> bool:
    """True when numpy cannot write ``array``'s memory: it and every array it views are read-only, down to
    an array that owns its memory or immutable ``bytes``."""
    while isinstance(array, np.ndarray):
        if array.flags.writeable:
            return False
        if array.base is None:
            return True
        array = array.base
    return isinstance(array, bytes)


def default_population(law: _DecisionTable) -> Population:
    """The population P(X, A) a law stands for when the caller gives none.

    A law (or kernel) estimated from counts stands for its records: their own
    P(x, a) = n(x, a) / n (``source="records"``). A table of probabilities
    says nothing about who is decided on: uniform and independent, reported
    as assumed (``source="assumed"``).

    Parameters
    ----------
    law : Law or Kernel
        Shape (n_contexts, n_groups, n_decisions).

    Returns
    -------
    Population
        Shape (n_contexts, n_groups), labelled as the law.

    Examples
    --------
    >>> law = Law.from_counts([[[3, 1], [1, 1]], [[1, 1], [5, 3]]], ["x0", "x1"], ["a", "b"], ["yes", "no"])
    >>> pop = default_population(law)
    >>> pop.source, pop.probabilities.tolist()
    ('records', [[0.25, 0.125], [0.125, 0.5]])
    >>> default_population(Law([[[0.5, 0.5]]], ["x"], ["a"], ["yes", "no"])).source
    'assumed'
    """
    counts = law.cell_counts
    if counts is not None and counts.sum() > 0:
        return Population.from_counts(counts, law.context_labels, law.group_labels)
    return Population.uniform(law.context_labels, law.group_labels, source="assumed")


def population_for(law: _DecisionTable, population: object = None) -> Population:
    """The population a metric of ``law`` uses: ``population`` checked against the law, else the law's default.

    Parameters
    ----------
    law : Law or Kernel
        Shape (n_contexts, n_groups, n_decisions).
    population : Population, optional
        P(X, A); its contexts and groups must be the law's. None gives
        :func:`default_population` (the records' own for a law from counts,
        else uniform and independent, reported as assumed).

    Returns
    -------
    Population
        Shape (n_contexts, n_groups), labelled as the law.

    Raises
    ------
    InputError
        ``population`` is not a Population, or its labels differ from the law's.

    Examples
    --------
    >>> law = Law([[[0.5, 0.5]], [[0.2, 0.8]]], ["x0", "x1"], ["a"], ["yes", "no"])
    >>> population_for(law).source
    'assumed'
    >>> population_for(law, Population.uniform(["x1", "x0"], ["a"]))
    Traceback (most recent call last):
    ...
    fairaudit.base.errors.InputError: population contexts: must match the law's contexts ['x0', 'x1'] (got ['x1', 'x0'])
    """
    if population is None:
        return default_population(law)
    if not isinstance(population, Population):
        raise InputError("population", "must be a Population", type(population).__name__)
    for axis, ours, theirs in zip(("contexts", "groups"), law._labels, population._labels):
        if not theirs.same(ours):
            raise InputError(
                f"population {axis}",
                f"must match the law's {axis} {list(map(format_label, ours.tuple))}",
                list(map(format_label, theirs.tuple)),
            )
    return population
