"""Fairness–privacy curves: every certificate and the observed fairness along a family of mechanisms.

For a grid of privacy budgets ε (nats) and a one-parameter family ε ↦ M_ε
(k-ary randomized response, or a product of randomized responses with a fixed
split of ε; :class:`~fairaudit.laws.families.MechanismFamily`), :func:`privacy_curve`
computes at each ε

* the bounds on local g-fairness L that hold for *any* decision model behind
  M_ε: ``paper`` and ``tight`` (main theorem and its proof, paper SI C; need
  τ), ``black_box`` (the exact maximum over every model,
  :func:`fairaudit.worstcase.black_box.black_box_bound`) and ``corollary`` (ε itself,
  for g independent of the group);
* with a known decision kernel K: the observed L and L̄ of the law
  Q = compose(K, M_ε, M_X), and the smallest E[g | x, a] of that law (to see
  where it breaks the τ that the paper and tight bounds assume).

The result, :class:`PrivacyCurve`, is what ``fairaudit certify --plot``
draws (:func:`fairaudit.reports.plots.plot_curve`) and ``--plot-data`` writes as CSV.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from fairaudit.base.arrays import BoolArray, FloatArray
from fairaudit.base.errors import InputError, UnderflowError
from fairaudit.base.files import write_atomic
from fairaudit.base.labels import format_label
from fairaudit.base.progress import STEP_DELAY, progress_bar
from fairaudit.laws.composition import compose
from fairaudit.laws.families import MechanismFamily
from fairaudit.laws.mechanisms import Mechanism
from fairaudit.laws.tables import Kernel, Population
from fairaudit.laws.utilities import Utility, UtilityClass, check_metric
from fairaudit.metrics.bounds import corollary_bound, paper_bound, tight_bound
from fairaudit.metrics.fairness import global_fairness, local_fairness
from fairaudit.metrics.reductions import expected_utility
from fairaudit.worstcase.black_box import black_box_bound
from fairaudit.worstcase.known_utility import worst_model

if TYPE_CHECKING:
    import pandas as pd

    from fairaudit.certification.spec import Spec

__all__ = ["COLUMNS", "PrivacyCurve", "default_epsilons", "privacy_curve"]

#: Columns of :meth:`PrivacyCurve.to_frame` (and of the CSV), in order.
COLUMNS = (
    "epsilon_nats",
    "keep_probability",
    "paper_nats",
    "tight_nats",
    "black_box_nats",
    "corollary_nats",
    "observed_local_nats",
    "observed_global_nats",
    "min_expected_utility",
    "tau_holds",
    "is_spec_epsilon",
)


@dataclass(frozen=True, eq=False, kw_only=True)
class PrivacyCurve:
    """Certified and observed local g-fairness along a family of mechanisms.

    Every array has shape (n,), one entry per grid point, in increasing ε.
    Values are in nats; NaN where a quantity does not apply (``paper`` and
    ``tight`` without τ; ``observed_*`` and ``min_expected_utility`` without a
    kernel; ``black_box`` and ``corollary`` for a utility that depends on the
    group when no program covers it); +inf where nothing can be certified.

    Attributes
    ----------
    epsilon : numpy.ndarray
        The grid of ε ≥ 0, nats (includes :attr:`spec_epsilon` when finite).
    keep_probability : numpy.ndarray
        Probability that the true group is released unchanged by M_ε.
    paper, tight : numpy.ndarray
        :func:`fairaudit.metrics.bounds.paper_bound` and :func:`~fairaudit.metrics.bounds.tight_bound`
        of M_ε (minimised over its privacy profile), nats.
    black_box : numpy.ndarray
        :func:`fairaudit.worstcase.black_box.black_box_bound` of M_ε, nats.
    corollary : numpy.ndarray
        ε(M_ε), the corollary's bound (= ε up to rounding), nats.
    observed_local, observed_global : numpy.ndarray
        L and L̄ of compose(kernel, M_ε, M_X), nats; NaN where that law has a cell of positive probability below the
        float range (randomized response above about 708 nats: :func:`~fairaudit.laws.composition.compose` refuses it).
    min_expected_utility : numpy.ndarray
        min over (x, a) of E[g | x, a] of that law (NaN where the law is refused).
    family : str
        The family's name.
    groups : tuple
        Its inputs (the sensitive groups).
    gamma, lower : float
        The utility class [lower, γ].
    tau : float or None
        τ of the paper and tight bounds (None when absent).
    lipschitz : float
        L_A.
    spec_epsilon : float or None
        ε of the mechanism the curve is about (a spec's M_A), marked on plots.
    spec_on_family : bool or None
        Whether that mechanism is the family's member at ``spec_epsilon``
        (so the curve there repeats the spec's certificate); None without one.
    title : str or None
        Shown on plots.
    """

    epsilon: FloatArray
    keep_probability: FloatArray
    paper: FloatArray
    tight: FloatArray
    black_box: FloatArray
    corollary: FloatArray
    observed_local: FloatArray
    observed_global: FloatArray
    min_expected_utility: FloatArray
    family: str
    groups: tuple
    gamma: float
    lower: float
    tau: float | None
    lipschitz: float
    spec_epsilon: float | None = None
    spec_on_family: bool | None = None
    title: str | None = None

    def __len__(self) -> int:
        return int(self.epsilon.size)

    def __repr__(self) -> str:
        lo, hi = (float(self.epsilon[0]), float(self.epsilon[-1])) if len(self) else (math.nan, math.nan)
        return f"PrivacyCurve({self.family!r}, {len(self)} values of epsilon in [{lo:.6g}, {hi:.6g}] nats)"

    @property
    def has_kernel(self) -> bool:
        """True when the observed columns were computed (a kernel was given)."""
        return bool(np.any(~np.isnan(self.observed_local)))

    @property
    def tau_holds(self) -> BoolArray:
        """Boolean (n,): False where the observed law has some E[g | x, a] < τ.

        There the paper and tight bounds do not apply to the observed model
        (their hypothesis E[g | x, a] ≥ τ fails), and its L may exceed them.
        True where nothing contradicts τ (no τ, or no kernel).
        """
        if self.tau is None:
            return np.ones(len(self), dtype=bool)
        m = self.min_expected_utility
        return np.isnan(m) | (m >= self.tau - 1e-12)

    @property
    def is_spec_epsilon(self) -> BoolArray:
        """Boolean (n,): True at the grid point equal to :attr:`spec_epsilon`."""
        if self.spec_epsilon is None or not math.isfinite(self.spec_epsilon):
            return np.zeros(len(self), dtype=bool)
        return self.epsilon == self.spec_epsilon

    def to_frame(self) -> pd.DataFrame:
        """The curve as a pandas DataFrame, one row per ε, columns :data:`COLUMNS`.

        Columns ending in ``_nats`` are in nats; ``keep_probability`` and
        ``min_expected_utility`` are probabilities (expected utilities);
        ``tau_holds`` and ``is_spec_epsilon`` are booleans.

        Examples
        --------
        >>> from fairaudit.laws.families import randomized_response_family
        >>> from fairaudit.laws.utilities import UtilityClass
        >>> family, tau = randomized_response_family(["a", "b"]), UtilityClass(tau=0.2)
        >>> c = privacy_curve(family=family, epsilons=[0.0, 1.0], utility_class=tau)
        >>> c.to_frame()[["epsilon_nats", "keep_probability", "black_box_nats"]].round(6).values.tolist()
        [[0.0, 0.5, 0.0], [1.0, 0.731059, 1.0]]
        """
        import pandas as pd

        return pd.DataFrame({column: getattr(self, column.removesuffix("_nats")) for column in COLUMNS})

    def to_csv(self, path: str | Path) -> None:
        """Write :meth:`to_frame` as CSV to ``path`` atomically (temporary file, then rename).

        Numbers are written with full precision (they read back exactly);
        +inf as ``inf``, NaN as an empty field.

        Raises
        ------
        InputError
            If the folder does not exist or cannot be written.
        """
        write_atomic(path, self.to_frame().to_csv(index=False, lineterminator="\n"))


def default_epsilons(spec_epsilon: float | None = None, n: int = 61) -> FloatArray:
    """The default grid: ``n`` points from 0 to 1.5 × ``spec_epsilon`` (0 to 5 nats without one), plus it.

    Parameters
    ----------
    spec_epsilon : float, optional
        The ε of interest, nats; ignored when infinite, NaN or 0.
    n : int
        Number of evenly spaced points (≥ 2).

    Returns
    -------
    numpy.ndarray, shape (n,) or (n + 1,)
        Sorted, distinct, starting at 0.

    Raises
    ------
    InputError
        When ``n`` < 2.

    Examples
    --------
    >>> default_epsilons(None, 6).tolist()
    [0.0, 1.0, 2.0, 3.0, 4.0, 5.0]
    >>> default_epsilons(0.7, 4).tolist()
    [0.0, 0.35, 0.7, 1.05]
    >>> default_epsilons(0.8, 3).tolist()
    [0.0, 0.6, 0.8, 1.2]
    """
    if int(n) < 2:
        raise InputError("n", "a grid needs at least 2 points", n)
    top = 5.0
    if spec_epsilon is not None and math.isfinite(spec_epsilon) and spec_epsilon > 0:
        top = 1.5 * float(spec_epsilon)
        top = top if math.isfinite(top) else float(spec_epsilon)  # 1.5 x beyond the largest float: the point itself
    grid = np.linspace(0.0, top, int(n))
    return _with_point(grid, spec_epsilon)


def _with_point(grid: FloatArray, point: float | None) -> FloatArray:
    """``grid`` with ``point`` in it: a grid point within 1e-9 (relative) of it is replaced by it."""
    if point is None or not math.isfinite(point):
        return grid
    near = np.isclose(grid, point, rtol=1e-9, atol=1e-12)
    if np.any(near):
        grid = grid.copy()
        grid[np.flatnonzero(near)[0]] = float(point)
        return np.unique(grid)
    return np.sort(np.append(grid, float(point)))


def _check_grid(epsilons: Iterable[float]) -> FloatArray:
    try:
        values: list[object] = list(epsilons) if not np.isscalar(epsilons) else [epsilons]
        grid = np.asarray(values, dtype=float).ravel()
    except (TypeError, ValueError):
        raise InputError("epsilons", "must be numbers (nats)", epsilons) from None
    if grid.size == 0:
        raise InputError("epsilons", "needs at least one value", list(grid))
    bad = ~np.isfinite(grid) | (grid < 0)
    if np.any(bad):
        raise InputError("epsilons", "must be finite and non-negative (nats)", float(grid[bad][0]))
    return np.unique(grid)


def privacy_curve(
    spec: Spec | None = None,
    *,
    family: MechanismFamily | None = None,
    epsilons: Iterable[float] | None = None,
    kernel: Kernel | None = None,
    utility: Utility | None = None,
    population: Population | None = None,
    context_mechanism: Mechanism | None = None,
    utility_class: UtilityClass | None = None,
    spec_epsilon: float | None = None,
    title: str | None = None,
) -> PrivacyCurve:
    """Bounds and observed g-fairness along a family of mechanisms, on a grid of ε.

    For each ε of the grid, with M_ε = ``family(ε)``:
    ``paper_bound(M_ε)``, ``tight_bound(M_ε)`` (when τ is given), the
    black-box worst case over every model (``worst_model(M_ε, utility)``
    for a given utility, as ``certify`` reports it; ``black_box_bound(M_ε)``
    for the class [lower, γ] without one), ``corollary_bound(M_ε)`` and, with a kernel,
    ``local_fairness`` / ``global_fairness`` of ``compose(kernel, M_ε, M_X)``.

    Parameters
    ----------
    spec : Spec, optional
        Takes every other input from the spec: ``family`` =
        :attr:`Spec.sensitive_family`, its model (``kernel``), utility,
        population, M_X, γ, lower, τ, L_A, metric, and marks its M_A's ε.
        A keyword (or a field of ``utility_class``) given explicitly
        overrides the spec's value.
    family : MechanismFamily
        ε ↦ M_ε on the sensitive groups (required without a spec).
    epsilons : iterable of float, optional
        The grid, nats, each finite and ≥ 0 (sorted, duplicates dropped).
        Default :func:`default_epsilons` (61 points from 0 to 1.5 × the
        spec's ε, or 0 to 5). ``spec_epsilon``, when finite, is always added.
    kernel : Kernel, optional
        The decision model P(U | X̃, Ã), shape (n_released_contexts,
        n_groups, n_decisions); its groups must be the family's inputs.
    utility : Utility, optional
        g; needed with a kernel. Supplies γ, lower and L_A when they are not given.
    population : Population, optional
        P(X, A) for L̄ (default uniform and independent).
    context_mechanism : Mechanism, optional
        M_X (default identity).
    utility_class : UtilityClass, optional
        The class of utilities, each field by default (``diameter`` is not
        used: diam(A) is the metric's):

        - ``gamma``, ``lower``: the class [lower, γ]; from ``utility``, else
          [0, 1].
        - ``tau``: τ > 0; without it ``paper`` and ``tight`` are NaN.
        - ``lipschitz``: L_A; from ``utility`` and ``metric``, else 0.
        - ``metric``: d(a, a'), shape (n_groups, n_groups); the discrete
          metric.
    spec_epsilon : float, optional
        The ε to mark (default: the spec's M_A's ε).
    title : str, optional
        Default: the spec's title.

    Returns
    -------
    PrivacyCurve

    Raises
    ------
    InputError
        Without a family (or a spec with at least 2 groups), on a bad grid,
        a kernel without a utility, labels that do not match, or invalid
        constants (τ > γ, negative values).

    Notes
    -----
    Every bound is non-decreasing in ε along a family whose smaller members
    are post-processings of larger ones (randomized response, products with a
    fixed split). Sources: paper SI C (main theorem and corollary),
    ``proofs/main_theorem.md``, ``proofs/corollary.md``, ``proofs/black_box.md``.

    Examples
    --------
    Binary randomized response and the model that chooses a candidate iff it
    is shown as group ``"b"``: L = ε at every ε (the corollary is attained;
    P(chosen | b) / P(chosen | a) = p / (1 − p) = e^ε).

    >>> from fairaudit.laws.tables import Kernel
    >>> from fairaudit.laws.families import randomized_response_family
    >>> from fairaudit.laws.utilities import UtilityClass, indicator
    >>> k = Kernel([[[0.0, 1.0], [1.0, 0.0]]], ["all"], ["a", "b"], ["chosen", "not chosen"])
    >>> c = privacy_curve(family=randomized_response_family(["a", "b"]), epsilons=[0.0, 0.5, 1.0], kernel=k,
    ...                   utility=indicator("chosen", ["chosen", "not chosen"]), utility_class=UtilityClass(tau=0.2))
    >>> c.observed_local.round(12).tolist(), c.black_box.round(12).tolist()
    ([0.0, 0.5, 1.0], [0.0, 0.5, 1.0])
    >>> bool(np.all(c.tight <= c.paper + 1e-12))
    True
    """
    c = UtilityClass() if utility_class is None else utility_class
    if not isinstance(c, UtilityClass):
        raise InputError("utility_class", "must be a UtilityClass", type(c).__name__)
    given: dict[str, Any] = {
        "family": family,
        "kernel": kernel,
        "utility": utility,
        "population": population,
        "context_mechanism": context_mechanism,
        "gamma": c.gamma,
        "lower": c.lower,
        "tau": c.tau,
        "lipschitz": c.lipschitz,
        "metric": c.metric,
        "spec_epsilon": spec_epsilon,
        "title": title,
    }
    if spec is not None:
        given = _spec_defaults(spec, given)
    return _curve(spec, epsilons, **given)


def _spec_defaults(spec: Spec, given: dict[str, Any]) -> dict[str, Any]:
    """The keywords of :func:`privacy_curve` with the spec's values where none was given."""
    from fairaudit.certification.spec import Spec

    if not isinstance(spec, Spec):
        raise InputError("spec", "must be a Spec (use load_spec)", type(spec).__name__)
    if given["family"] is None and spec.sensitive_family is None:
        raise InputError(
            f"{spec.source}: sensitive", "a fairness-privacy curve needs at least 2 groups", len(spec.groups)
        )
    other: dict[str, Callable[[], Any]] = {  # the rest are the spec's attributes of their names
        "family": lambda: spec.sensitive_family,
        "kernel": spec.kernel,
        "spec_epsilon": lambda: spec.sensitive_mechanism.epsilon,
        "title": lambda: spec.model.title or spec.source,
    }
    return {
        key: (other[key]() if key in other else getattr(spec, key)) if value is None else value
        for key, value in given.items()
    }


def _check_family_and_kernel(family: object, kernel: object, utility: Utility | None) -> None:
    """A family is given; a kernel is a :class:`Kernel` of the family's outputs and comes with a utility."""
    if not isinstance(family, MechanismFamily):
        raise InputError(
            "family", "give a MechanismFamily (or a spec)", None if family is None else type(family).__name__
        )
    if kernel is not None and utility is None:
        raise InputError("utility", "is needed to measure the observed fairness of the kernel")
    if kernel is not None and not isinstance(kernel, Kernel):
        raise InputError("kernel", "must be a Kernel", type(kernel).__name__)
    if kernel is not None and tuple(family(0.0).outputs) != tuple(kernel.groups):
        released = [format_label(o) for o in family(0.0).outputs[:3]]
        raise InputError(
            "kernel",
            f"mechanism '{family.name}' releases {released}..., not the kernel's groups: no curve "
            "along it (a spec whose mechanism releases other values than its groups has none)",
            [format_label(g) for g in kernel.groups[:3]],
        )


def _curve(
    spec: Spec | None,
    epsilons: Iterable[float] | None,
    *,
    family: MechanismFamily | None,
    kernel: Kernel | None,
    utility: Utility | None,
    population: Population | None,
    context_mechanism: Mechanism | None,
    gamma: float | None,
    lower: float | None,
    tau: float | None,
    lipschitz: float | None,
    metric: npt.ArrayLike | None,
    spec_epsilon: float | None,
    title: str | None,
) -> PrivacyCurve:
    """:func:`privacy_curve` once the spec's values are in: check, fill the defaults, compute."""
    _check_family_and_kernel(family, kernel, utility)
    assert isinstance(family, MechanismFamily)  # (checked above)
    if gamma is None:
        gamma = utility.gamma if utility is not None else 1.0
    if lower is None:
        lower = utility.lower if utility is not None else 0.0
    n_groups = len(family.inputs)
    d = check_metric(metric, n_groups)
    if lipschitz is None:
        lipschitz = utility.lipschitz(metric) if utility is not None else 0.0
    gamma, lower, lipschitz = float(gamma), float(lower), float(lipschitz)
    mark = None if spec_epsilon is None else float(spec_epsilon)
    grid = default_epsilons(mark) if epsilons is None else _with_point(_check_grid(epsilons), mark)
    diameter = float(d.max()) if n_groups > 1 else 0.0
    out = {key: np.full(grid.size, np.nan) for key in _VALUES}

    def fill(i: int, eps: float) -> None:
        """The values at ε = ``eps``, written at index ``i`` of ``out``."""
        mech = family(eps)
        out["keep_probability"][i] = family.keep_probability(eps)
        if tau is not None:
            theorem = UtilityClass(tau=tau, gamma=gamma, lipschitz=lipschitz)
            out["paper"][i] = paper_bound(mech, utility_class=replace(theorem, diameter=diameter)).value
            out["tight"][i] = tight_bound(mech, utility_class=replace(theorem, metric=metric)).value
        if utility is not None:
            worst = worst_model(mech, utility, context_mechanism=context_mechanism, population=population, tau=tau)
            out["black_box"][i] = worst.local_fairness.value
        else:  # the class certificate, with L_A and the metric only where L_A > 0
            on = lipschitz > 0
            uc = UtilityClass(
                lower=lower, gamma=gamma, tau=tau, lipschitz=lipschitz if on else None, metric=metric if on else None
            )
            out["black_box"][i] = black_box_bound(mech, utility_class=uc, population=population).value
        if not (utility is not None and utility.depends_on_group):
            out["corollary"][i] = corollary_bound(mech).value
        if kernel is not None and utility is not None:  # (a kernel comes with a utility: checked before)
            try:
                law = compose(kernel, mech, context_mechanism)
            except UnderflowError:
                return  # the law is beyond floating point: its metrics stay NaN (not drawn)
            except InputError as exc:
                raise exc.under("kernel") from None
            out["observed_local"][i] = local_fairness(law, utility, population).value
            out["observed_global"][i] = global_fairness(law, utility, population).value
            e = expected_utility(law, utility)
            out["min_expected_utility"][i] = float(np.nanmin(e)) if np.any(~np.isnan(e)) else math.nan

    with progress_bar(grid.size, "curve", unit="epsilon", delay=STEP_DELAY) as bar:  # (shown inside progress_shown)
        for i, eps in enumerate(grid):
            fill(i, float(eps))
            bar.update()
    on_family = None
    if spec is not None and mark is not None:
        on_family = bool(math.isfinite(mark) and _same_mechanism(spec.sensitive_mechanism, family(mark)))
    for arr in (grid, *out.values()):
        arr.setflags(write=False)
    return PrivacyCurve(
        epsilon=grid,
        **out,
        family=family.name,
        groups=tuple(family.inputs),
        gamma=gamma,
        lower=lower,
        tau=None if tau is None else float(tau),
        lipschitz=lipschitz,
        spec_epsilon=mark,
        spec_on_family=on_family,
        title=title,
    )


#: The values computed at each ε: the fields of :class:`PrivacyCurve` behind the columns between ε and the verdicts
#: (the keys of the arrays that :func:`_curve` fills).
_VALUES = tuple(column.removesuffix("_nats") for column in COLUMNS[1:9])


def _same_mechanism(a: Mechanism, b: Mechanism) -> bool:
    return (
        tuple(a.inputs) == tuple(b.inputs)
        and tuple(a.outputs) == tuple(b.outputs)
        and a.matrix.shape == b.matrix.shape
        and bool(np.allclose(a.matrix, b.matrix, rtol=0, atol=1e-12))
    )
