"""Utilities g(u, x, a) ≥ 0: indicators, tables, functions; range and Lipschitz constant.

A utility is stored either as a vector over decisions, shape (n_decisions,),
when g depends on u only (the per-candidate framing of docs/design.md), or as a
full table of shape (n_contexts, n_groups, n_decisions) indexed [x, a, u]
(note: the paper writes g(u, x, a); the array's axis order is [x, a, u]).

The quantities the main theorem needs (paper SI C):

* γ = max g (``gamma``) and the lower bound ``lower`` = min g;
* L_A = sup over u, x, a ≠ a' of |g(u, x, a) − g(u, x, a')| / d(a, a'), the
  Lipschitz constant in the group (``lipschitz``), and diam(A) = max d(a, a')
  (``diameter``). Without a metric the discrete metric d(a, a') = 1 for
  a ≠ a' is used, so diam(A) = 1.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable, Sequence
from dataclasses import dataclass
from typing import SupportsIndex

import numpy as np
import numpy.typing as npt

from fairaudit.base.arrays import FloatArray, as_float_array, check_shape
from fairaudit.base.checks import nonnegative
from fairaudit.base.errors import InputError
from fairaudit.base.labels import as_labels, format_label

__all__ = [
    # utilities
    "Utility",
    "from_function",
    "from_table",
    "indicator",
    # the class of utilities a bound holds for
    "UtilityClass",
    # metrics on the groups
    "check_metric",
    "discrete_metric",
]


def discrete_metric(n_groups: int) -> FloatArray:
    """The discrete metric on n groups: d(a, a') = 1 for a ≠ a', shape (n, n)."""
    return 1.0 - np.eye(n_groups)


def check_metric(metric: npt.ArrayLike | None, n_groups: int) -> FloatArray:
    """Validate a metric d(a, a') on n groups; None gives the discrete metric.

    Raises
    ------
    InputError
        Unless the array has shape (n, n), is finite, symmetric, zero on the
        diagonal and positive off it, and meets the triangle inequality
        d(a, c) ≤ d(a, b) + d(b, c) (within :data:`TRIANGLE_SLACK` relative,
        the rounding of distances computed in floats). A table that misses it
        is no metric: a utility Lipschitz for it is Lipschitz for its shortest
        paths, a smaller diameter, so the bounds that read the diameter would
        overstate the worst case they claim to be.

    Examples
    --------
    >>> check_metric([[0, 1, 3], [1, 0, 1], [3, 1, 0]], 3)
    Traceback (most recent call last):
    ...
    fairaudit.base.errors.InputError: metric: must meet the triangle inequality: d(0, 2) = 3 > d(0, 1) + d(1, 2) = 2 (got [[0.0, 1.0, 3.0], [1.0, 0.0, 1.0], [3.0, 1.0, 0.0]])
    """
    if metric is None:
        return discrete_metric(n_groups)
    d = as_float_array(metric, "metric", ndim=2)
    check_shape(d, (n_groups, n_groups), "metric", ("groups", "groups"))
    off = ~np.eye(n_groups, dtype=bool)
    if not np.all(np.isfinite(d)) or np.any(d[off] <= 0) or np.any(np.diag(d) != 0) or np.any(d != d.T):
        raise InputError("metric", "must be symmetric, zero on the diagonal and positive off it", d.tolist())
    _check_triangle(d)
    return d


TRIANGLE_SLACK = 1e-13
"""How far (relative) d(a, c) may exceed d(a, b) + d(b, c): the rounding of distances computed in floats (|p_a − p_c|
is within 2^-53 relative of its exact value, so a line's distances miss the inequality by an ulp or two). A metric's
diameter overstated by this much moves a bound by less than verify's tolerance (1e-12 relative)."""


def _check_triangle(d: FloatArray) -> None:
    """d(a, c) ≤ (d(a, b) + d(b, c))·(1 + :data:`TRIANGLE_SLACK`) for every a, b, c, one b at a time (n² memory)."""
    for b in range(d.shape[0]):
        sums = d[:, b, None] + d[None, b, :]
        bad = np.argwhere(d > sums * (1 + TRIANGLE_SLACK))
        if bad.size:
            a, c = (int(i) for i in bad[0])
            raise InputError(
                "metric",
                f"must meet the triangle inequality: d({a}, {c}) = {d[a, c]:g} > d({a}, {b}) + d({b}, {c}) = "
                f"{sums[a, c]:g}",
                d.tolist(),
            )


_NUMBERS = ("lower", "gamma", "tau", "lipschitz", "diameter")
"""The numbers of a :class:`UtilityClass` (its fields but the metric)."""


@dataclass(frozen=True, kw_only=True, eq=False)
class UtilityClass:
    """The class of utilities a bound holds for: lower ≤ g ≤ γ, E[g | x, a] ≥ τ, L_A-Lipschitz in the group.

    One object for the constants of the main theorem (paper SI C) and of the
    exact worst case over a class of utilities (``proofs/black_box.md``), given
    to :func:`~fairaudit.paper_bound`, :func:`~fairaudit.tight_bound`,
    :func:`~fairaudit.black_box_bound`, :func:`~fairaudit.worst_utility`,
    :func:`~fairaudit.calibrate`, :func:`~fairaudit.calibrate_randomized_response`
    and :func:`~fairaudit.privacy_curve` as ``utility_class``. A field left
    None is taken from the utility the function is given, or is that
    function's default (its docstring says which).

    Parameters
    ----------
    lower : float, optional
        The lower end of g's range, 0 ≤ lower ≤ γ.
    gamma : float, optional
        γ ≥ max g, the upper end of g's range.
    tau : float, optional
        τ > 0, a lower bound on E[g | x, a] of every model behind the filter,
        for every context x and group a; None: no such bound is claimed.
    lipschitz : float, optional
        L_A ≥ 0: |g(u, x, a) − g(u, x, a')| ≤ L_A·d(a, a'); 0 means g does not
        depend on the group.
    metric : array_like, shape (n_groups, n_groups), optional
        d(a, a'), a metric: symmetric, zero on the diagonal, positive off it and
        meeting the triangle inequality (checked
        against the group count where it is used); None: the discrete metric.
    diameter : float, optional
        diam(A) = max d(a, a') for the bounds that need only it (the paper
        form, the calibration by a closed form); None: that of ``metric``,
        1 under the discrete metric.

    Raises
    ------
    InputError
        A number that is negative or not finite (the field named), a metric
        that is not a square array of finite numbers, or a diameter below the
        metric's largest distance. The relations between
        the fields (τ ≤ γ, lower ≤ γ) and the metric's group count are checked
        by the function that uses them.

    Examples
    --------
    >>> c = UtilityClass(gamma=1.0, tau=0.2)
    >>> c.gamma, c.tau, c.lipschitz, c == UtilityClass(tau=0.2, gamma=1)
    (1.0, 0.2, None, True)
    >>> UtilityClass(lipschitz=-1)
    Traceback (most recent call last):
    ...
    fairaudit.base.errors.InputError: lipschitz: must be a finite non-negative number (got -1)
    """

    lower: float | None = None
    gamma: float | None = None
    tau: float | None = None
    lipschitz: float | None = None
    metric: npt.ArrayLike | None = None  # (stored as a read-only float array)
    diameter: float | None = None

    def __post_init__(self) -> None:
        for name in _NUMBERS:
            value = getattr(self, name)
            if value is not None:
                object.__setattr__(self, name, nonnegative(value, name))
        if self.metric is not None:
            d = as_float_array(self.metric, "metric", ndim=2).copy()
            if d.shape[0] != d.shape[1]:
                raise InputError("metric", "must be a square array (groups x groups)", d.shape)
            if self.diameter is not None and d.size and self.diameter < d.max():
                raise InputError("diameter", f"is below the metric's largest distance {d.max():g}", self.diameter)
            d.setflags(write=False)
            object.__setattr__(self, "metric", d)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, UtilityClass):
            return NotImplemented
        same = all(getattr(self, name) == getattr(other, name) for name in _NUMBERS)
        if self.metric is None or other.metric is None:
            return same and self.metric is other.metric
        return same and np.array_equal(self.metric, other.metric)

    __hash__ = None  # type: ignore[assignment]  # (equal by value, holds an array)


@dataclass(frozen=True, eq=False)
class Utility:
    """A non-negative utility g over decisions (and optionally context and group).

    Parameters
    ----------
    values : array_like, shape (n_decisions,) or (n_contexts, n_groups, n_decisions)
        g(u) or g[x, a, u]; finite and ≥ 0.
    decisions : sequence of hashable
        Decision labels (last axis).
    contexts, groups : sequence of hashable, optional
        Required with a full table; the labels of its first two axes.
    name : str
        Description used in reports.

    Raises
    ------
    InputError
        On a negative or non-finite value or a shape that does not match the
        labels.

    Examples
    --------
    >>> g = indicator("HR_2", ["HR_1", "HR_2"])
    >>> g.values.tolist(), g.gamma, g.lower, g.lipschitz()
    ([0.0, 1.0], 1.0, 0.0, 0.0)
    """

    values: FloatArray
    decisions: tuple
    contexts: tuple | None = None
    groups: tuple | None = None
    name: str = "utility"

    def __init__(
        self,
        values: npt.ArrayLike,
        decisions: Sequence[Hashable],
        contexts: Sequence[Hashable] | None = None,
        groups: Sequence[Hashable] | None = None,
        name: str = "utility",
    ) -> None:
        decisions = as_labels(decisions, "utility decisions")
        array = as_float_array(values, "utility")
        if array.ndim == 1:
            check_shape(array, (len(decisions),), "utility", ("decisions",))
            if contexts is not None or groups is not None:
                raise InputError("utility", "a vector over decisions takes no contexts or groups")
        elif array.ndim == 3:
            if contexts is None or groups is None:
                raise InputError("utility", "a full table [x, a, u] needs contexts and groups labels")
            contexts = as_labels(contexts, "utility contexts")
            groups = as_labels(groups, "utility groups")
            check_shape(
                array, (len(contexts), len(groups), len(decisions)), "utility", ("contexts", "groups", "decisions")
            )
        else:
            raise InputError("utility", "must be a vector over decisions or a table [x, a, u]", array.shape)
        if not np.all(np.isfinite(array)):
            raise InputError("utility", "values must be finite", float(array[~np.isfinite(array)][0]))
        if np.any(array < 0):
            idx = np.unravel_index(int(np.argmin(array)), array.shape)
            raise InputError(
                "utility",
                f"must be non-negative; g at {self._where(idx, decisions, contexts, groups)} is",
                float(array[idx]),
            )
        array = array.copy()
        array.setflags(write=False)
        full = array.ndim == 3
        vars(self).update(values=array, decisions=decisions)  # (frozen: as object.__setattr__ would)
        vars(self).update(contexts=contexts if full else None, groups=groups if full else None, name=name)

    @staticmethod
    def _where(
        idx: Sequence[SupportsIndex],
        decisions: tuple,
        contexts: tuple | None,
        groups: tuple | None,
    ) -> str:
        if len(idx) == 1:
            return f"u={format_label(decisions[idx[0]])!r}"
        assert contexts is not None and groups is not None  # a full table [x, a, u] has its labels
        return (
            f"(x={format_label(contexts[idx[0]])!r}, a={format_label(groups[idx[1]])!r}, "
            f"u={format_label(decisions[idx[2]])!r})"
        )

    def __repr__(self) -> str:
        kind = "g(u)" if self.values.ndim == 1 else "g(u, x, a)"
        return f"Utility({self.name!r}, {kind}, range [{self.lower:g}, {self.gamma:g}])"

    @property
    def gamma(self) -> float:
        """γ = max g, the upper bound of the main theorem."""
        return float(self.values.max())

    @property
    def lower(self) -> float:
        """min g, the lower end of g's range."""
        return float(self.values.min())

    @property
    def depends_on_group(self) -> bool:
        """True when g(u, x, a) differs between two groups for some (u, x)."""
        return self._varies(1)

    @property
    def depends_on_context(self) -> bool:
        """True when g(u, x, a) differs between two contexts for some (u, a)."""
        return self._varies(0)

    def _varies(self, axis: int) -> bool:
        """Whether g differs along ``axis`` of a full table [x, a, u] (0: the contexts, 1: the groups)."""
        g = self.values
        return g.ndim == 3 and bool(np.any(g != g.take([0], axis=axis)))

    def _metric(self, metric: npt.ArrayLike | None) -> FloatArray:
        if self.groups is not None:
            return check_metric(metric, len(self.groups))
        return check_metric(metric, 1 if metric is None else len(np.asarray(metric)))

    def lipschitz(self, metric: npt.ArrayLike | None = None) -> float:
        """L_A = max over u, x, a ≠ a' of |g(u, x, a) − g(u, x, a')| / d(a, a').

        Parameters
        ----------
        metric : array_like, shape (n_groups, n_groups), optional
            d(a, a'); default the discrete metric.

        Returns
        -------
        float
            0 when g does not depend on the group (paper SI C, Definition of L_A).
        """
        if not self.depends_on_group:
            return 0.0
        d = self._metric(metric)
        g = self.values
        diff = np.abs(g[:, :, None, :] - g[:, None, :, :]).max(axis=(0, 3))
        off = ~np.eye(d.shape[0], dtype=bool)
        return float((diff[off] / d[off]).max())

    def diameter(self, metric: npt.ArrayLike | None = None) -> float:
        """diam(A) = max d(a, a'); 1 under the discrete metric (0 with one group)."""
        d = self._metric(metric)
        return float(d.max()) if d.size > 1 else (1.0 if metric is None else 0.0)

    def table(
        self, contexts: Sequence[Hashable], groups: Sequence[Hashable], decisions: Sequence[Hashable]
    ) -> FloatArray:
        """g as a full array [x, a, u] for the given labels.

        Raises
        ------
        InputError
            If the labels differ from the utility's own.
        """
        own: list[tuple[str, Sequence[Hashable], tuple | None]] = [("decisions", decisions, self.decisions)]
        if self.values.ndim == 3:  # a full table [x, a, u] has its labels
            own += [("contexts", contexts, self.contexts), ("groups", groups, self.groups)]
        for what, given, labels in own:
            if tuple(given) != labels:
                mine = list(map(format_label, labels or ()))
                raise InputError(
                    f"utility {what}", f"must match the table's {what} {list(map(format_label, given))}", mine
                )
        if self.values.ndim == 1:
            return np.broadcast_to(self.values, (len(contexts), len(groups), len(decisions)))
        return self.values


def indicator(value: Hashable, decisions: Sequence[Hashable], name: str | None = None) -> Utility:
    """g(u) = 1{u = value}: the probability of one decision (for example "selected").

    Raises
    ------
    InputError
        If ``value`` is not one of ``decisions``.

    Examples
    --------
    >>> indicator(1, [1, 2, 3]).values.tolist()
    [1.0, 0.0, 0.0]
    """
    decisions = as_labels(decisions, "decisions")
    if value not in decisions:
        raise InputError(
            "utility.decision", f"must be one of the decisions {list(map(format_label, decisions))}", value
        )
    values = np.array([1.0 if d == value else 0.0 for d in decisions])
    return Utility(values, decisions, name=name or f"1{{decision = {format_label(value)}}}")


def from_table(
    values: npt.ArrayLike,
    decisions: Sequence[Hashable],
    contexts: Sequence[Hashable] | None = None,
    groups: Sequence[Hashable] | None = None,
    name: str = "table",
) -> Utility:
    """A utility from a vector over decisions or a full [x, a, u] table."""
    return Utility(values, decisions, contexts, groups, name=name)


def from_function(
    function: Callable[[Hashable, Hashable, Hashable], float],
    decisions: Sequence[Hashable],
    contexts: Sequence[Hashable],
    groups: Sequence[Hashable],
    name: str | None = None,
) -> Utility:
    """Tabulate a Python function ``function(u, x, a)`` (the paper's argument order).

    The function is called once per (u, x, a) label triple; the result is a
    full table [x, a, u].

    Examples
    --------
    >>> g = from_function(lambda u, x, a: float(u == a), ["HR_1", "HR_2"], ["doc"], ["HR_1", "HR_2"])
    >>> g.values[0].tolist(), g.lipschitz(), g.depends_on_group
    ([[1.0, 0.0], [0.0, 1.0]], 1.0, True)
    """
    decisions = as_labels(decisions, "decisions")
    contexts = as_labels(contexts, "contexts")
    groups = as_labels(groups, "groups")
    try:
        values = [[[float(function(u, x, a)) for u in decisions] for a in groups] for x in contexts]
    except (TypeError, ValueError) as exc:
        raise InputError("utility function", f"must return a number for every (u, x, a) ({exc})") from None
    return Utility(values, decisions, contexts, groups, name=name or str(getattr(function, "__name__", "function")))
