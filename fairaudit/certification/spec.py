"""The TOML certification spec: parse, validate, and build the objects it names.

Sections (docs/design.md "Command-line contract"; full reference in docs/spec.md):

``[sensitive]`` name, values · ``[context]`` name, values, distribution
(optional; one context ``"all"`` when absent) · ``[decision]`` name, values,
unparsed (optional: the decision of replies read as no option) ·
``[population]`` probabilities (n_contexts × n_groups) or group_distribution
(optional; default uniform and independent) · ``[privacy.sensitive]`` and
``[privacy.context]`` mechanism = "identity" | "randomized_response" (epsilon
or keep) | "matrix" (rows, outputs) | "product" (components) ·
``[model]`` table or records (path relative to the spec), count_column,
probability_column, where, csv (how a text file is read) · ``[utility]`` kind = "indicator" (decision) |
"table" (values), gamma, lower, tau, lipschitz, metric · ``[target]`` local,
global.

Validation uses pydantic (the tables' models are in
:mod:`~fairaudit.certification.spec_schema`); every error becomes one
:class:`InputError` line naming the dotted field (``privacy.sensitive.epsilon``)
and the value. The ``[privacy.*]`` tables' mechanisms are built by
:mod:`~fairaudit.certification.spec_mechanisms`, the ``[model]`` table is read
by :mod:`~fairaudit.certification.spec_model_table`.
"""

from __future__ import annotations

from collections.abc import Hashable
from dataclasses import replace
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from fairaudit.base.arrays import FloatArray
from fairaudit.base.checks import real
from fairaudit.base.errors import InputError
from fairaudit.base.labels import as_labels, format_label
from fairaudit.base.toml_documents import (
    parse_toml,
    validation_error,
)
from fairaudit.certification.spec_mechanisms import build_mechanism, mechanism_family, view_family
from fairaudit.certification.spec_model_table import match_label, read_model
from fairaudit.data.counts import CountTable
from fairaudit.laws.families import MechanismFamily
from fairaudit.laws.mechanisms import Mechanism
from fairaudit.laws.tables import Kernel, Population
from fairaudit.laws.utilities import Utility, UtilityClass, check_metric, from_table, indicator

if TYPE_CHECKING:
    from fairaudit.certification.spec_schema import AttributeSpec, MechanismSpec, SpecModel

__all__ = [
    # a validated spec
    "Spec",
    # reading one
    "load_spec",
    "parse_spec",
]


class Spec:
    """A validated certification spec and the objects it defines.

    Attributes
    ----------
    source : str
        Where it came from (path or ``"<string>"``).
    base : pathlib.Path
        Folder that model paths are relative to.
    model : SpecModel
        The validated fields.
    sensitive_mechanism, context_mechanism : Mechanism
        M_A and M_X.
    groups, contexts, decisions : tuple
        Labels.
    population : Population
        P(X, A) with its ``source``: the spec's, the records' own, or assumed
        (see the property).
    given_population : Population or None
        The spec's ``[population]``, if any.
    utility : Utility
    unparsed : hashable or None
        The decision that ``[decision] unparsed`` names (replies read as no
        option, whose utility is known only within [min g, max g]), or None.

    Notes
    -----
    Use :func:`load_spec` or :func:`parse_spec` to make one.
    """

    def __init__(self, model: SpecModel, source: str, base: Path) -> None:
        from fairaudit.certification.spec_schema import AttributeSpec  # (already loaded: the model is one)

        self.model = model
        self.source = source
        self.base = base
        self.sensitive_mechanism = self._mechanism(model.privacy.sensitive, model.sensitive, "privacy.sensitive")
        self.groups = self.sensitive_mechanism.inputs
        if model.sensitive.values is not None:
            given = as_labels(model.sensitive.values, "sensitive.values")
            if given != self.groups:
                raise self._err(
                    "sensitive.values",
                    "must equal the product of the components' values, in order",
                    [format_label(g) for g in given],
                )
        family = model.privacy.family
        self._family = (
            None if family is None else view_family(family, self.sensitive_mechanism, f"{source}: privacy.family")
        )
        if model.context is None:
            self.contexts: tuple = ("all",)
            self.context_name = "context"
        else:
            assert model.context.values is not None  # (required by SpecModel)
            self.contexts = as_labels(model.context.values, "context.values")
            self.context_name = model.context.name
        self.context_mechanism = self._mechanism(
            model.privacy.context, AttributeSpec(name=self.context_name, values=list(self.contexts)), "privacy.context"
        )
        assert model.decision.values is not None  # (required by SpecModel)
        self.decisions = as_labels(model.decision.values, "decision.values")
        self._context_distribution: FloatArray  # P(X) given, else uniform: the default population's
        self.given_population = self._population()
        self._kernel: Kernel | None | bool = False  # False: not read yet
        self.weighted_table: CountTable | None = None  # [model] records with weight_column: their weighted counts
        self.utility = self._utility()
        u = model.utility
        if u.lower is not None and u.lower > self.utility.lower + 1e-12:
            raise self._err(
                "utility.lower", f"exceeds the utility's smallest value min g = {self.utility.lower:g}", u.lower
            )
        if u.gamma is not None and u.gamma < self.utility.gamma - 1e-12:
            raise self._err(
                "utility.gamma", f"is below the utility's largest value max g = {self.utility.gamma:g}", u.gamma
            )
        if u.tau is not None and u.tau > self.gamma:  # (with gamma given, SpecModel checked it)
            raise self._err("utility.tau", f"cannot exceed gamma = {self.gamma:g} (E[g | x, a] <= max g)", u.tau)
        self.unparsed = self._unparsed()
        self.metric: FloatArray | None = None
        if model.utility.metric is not None:
            try:
                self.metric = check_metric(model.utility.metric, len(self.groups))
            except InputError as exc:
                raise exc.under(f"{self.source}: utility.metric", keep_own=False) from None

    # -- helpers ---------------------------------------------------------------------------------
    def _err(self, field: str, problem: str, value: object = InputError._missing) -> InputError:
        return InputError(f"{self.source}: {field}", problem, value)

    def _mechanism(self, spec: MechanismSpec, attribute: AttributeSpec, field: str) -> Mechanism:
        name = spec.name or f"{spec.mechanism} on {attribute.name}"
        return build_mechanism(spec, attribute.values, name, f"{self.source}: {field}")

    def _distribution(self, values: list[float] | None, labels: tuple, field: str, what: str) -> FloatArray | None:
        """A validated distribution over ``labels`` from the spec's ``field`` (None when absent)."""
        if values is None:
            return None
        if len(values) != len(labels):
            raise self._err(field, f"must have one entry per {what} ({len(labels)})", values)
        for i, (v, label) in enumerate(zip(values, labels, strict=True)):
            real(
                v,
                f"{self.source}: {field}[{i}]",
                low=0.0,
                what=f"a finite number >= 0 ({what} {format_label(label)!r})",
            )
        p = np.asarray(values, dtype=float)
        total = float(p.sum())
        if abs(total - 1.0) > 1e-9:
            raise self._err(field, f"entries sum to {total:.12g}, not 1", values)
        return p

    def _population(self) -> Population | None:
        """The population the spec gives: ``[population]`` (source "given"), or None.

        ``context.distribution`` alone gives P(X) only: it is kept for the
        default (:attr:`population`), with P(A) uniform and X ⊥ A assumed.
        """
        pop = self.model.population
        ctx = self.model.context
        px = self._distribution(ctx.distribution if ctx else None, self.contexts, "context.distribution", "context")
        self._context_distribution = np.full(len(self.contexts), 1.0 / len(self.contexts)) if px is None else px
        if pop is None:
            return None
        if pop.probabilities is not None:
            rows = pop.probabilities
            if len(rows) != len(self.contexts) or any(len(r) != len(self.groups) for r in rows):
                raise self._err(
                    "population.probabilities",
                    f"must be {len(self.contexts)} rows (contexts) of {len(self.groups)} entries (groups)",
                    rows,
                )
            try:
                return Population(rows, self.contexts, self.groups)
            except InputError as exc:
                raise exc.under(f"{self.source}: population.probabilities", keep_own=False) from None
        pa = self._distribution(pop.group_distribution, self.groups, "population.group_distribution", "group")
        return (
            None if pa is None else Population.independent(self._context_distribution, pa, self.contexts, self.groups)
        )

    def _utility(self) -> Utility:
        u = self.model.utility
        try:
            if u.kind == "indicator":
                value = match_label(u.decision, self.decisions)
                if value is None:
                    raise self._err(
                        "utility.decision",
                        f"must be one of decision.values {[format_label(d) for d in self.decisions]}",
                        u.decision,
                    )
                return indicator(value, self.decisions, name=u.name)
            arr = np.asarray(u.values, dtype=float)
            # a list over decisions, or a [context][group][decision] table
            contexts, groups = (None, None) if arr.ndim == 1 else (self.contexts, self.groups)
            return from_table(arr, self.decisions, contexts, groups, name=u.name or "table")
        except InputError as exc:
            if exc.field.startswith(self.source):
                raise
            raise exc.under(f"{self.source}: utility.values", keep_own=False) from None
        except (TypeError, ValueError) as exc:
            raise self._err("utility.values", f"must be numbers ({exc})") from None

    def _unparsed(self) -> Hashable | None:
        """The decision ``[decision] unparsed`` names, or None; its utility must be g of the decision only."""
        given = self.model.decision.unparsed
        if given is None:
            return None
        value = match_label(given, self.decisions) if isinstance(given, str) else None
        if value is None:
            valid = [format_label(d) for d in self.decisions]
            raise self._err("decision.unparsed", f"must be a string naming one of decision.values {valid}", given)
        if np.ndim(self.utility.values) != 1:
            raise self._err(
                "decision.unparsed",
                "needs a utility of the decision only (kind = 'indicator', or utility.values a list over decisions, "
                "not a [context][group][decision] table)",
                given,
            )
        return value

    # -- public ----------------------------------------------------------------------------------
    @property
    def gamma(self) -> float:
        """γ: the spec's gamma, else max g."""
        return self.model.utility.gamma if self.model.utility.gamma is not None else self.utility.gamma

    @property
    def lower(self) -> float:
        """The lower end of g's class: the spec's lower, else min g."""
        return self.model.utility.lower if self.model.utility.lower is not None else self.utility.lower

    @property
    def tau(self) -> float | None:
        """τ as given (None when absent: the paper and tight bounds need it)."""
        return self.model.utility.tau

    @property
    def lipschitz(self) -> float:
        """L_A: the spec's, else from the utility table and metric."""
        u = self.model.utility
        return u.lipschitz if u.lipschitz is not None else self.utility.lipschitz(self.metric)

    @property
    def utility_class(self) -> UtilityClass:
        """The class of utilities the bounds hold for: [lower, γ], τ, L_A, the metric and diam(A), as resolved above."""
        return UtilityClass(
            lower=self.lower,
            gamma=self.gamma,
            tau=self.tau,
            lipschitz=self.lipschitz,
            metric=self.metric,
            diameter=self.utility.diameter(self.metric),
        )

    @property
    def sensitive_family(self) -> MechanismFamily | None:
        """The one-parameter family that calibration and curves move along.

        Randomized response on the groups when ``[privacy.sensitive]`` is
        randomized response, identity or a matrix; for a product, a product of
        randomized responses on the components' values with ε split in
        proportion to the components' ε (equally when they are all 0 or
        infinite). None with fewer than 2 groups. ``[privacy.family]``, when
        given, names it instead: a product of randomized responses seen on the
        rows the groups are (:func:`~fairaudit.certification.spec_mechanisms.view_family`),
        as the spec of a per-candidate experiment has it.
        """
        if self._family is not None:
            return self._family
        return mechanism_family(self.model.privacy.sensitive, self.groups)

    @property
    def sees_inputs(self) -> bool:
        """True when both mechanisms release the labels they take (the model's table is indexed by true values)."""
        return all(tuple(m.outputs) == tuple(m.inputs) for m in (self.sensitive_mechanism, self.context_mechanism))

    @cached_property
    def population(self) -> Population:
        """P(X, A), shape (n_contexts, n_groups), and where it comes from (its ``source``).

        In order: the spec's ``[population]`` (``"given"``); else, when
        ``[model]`` gives counts or records indexed by the true labels (the
        mechanisms release the values they take), the records' own
        P(x, a) = n(x, a) / n (``"records"``); else P(X) from
        ``context.distribution`` (uniform without it), P(A) uniform and X ⊥ A
        (``"assumed"``, never reported as checked).

        Raises
        ------
        InputError
            As :meth:`kernel`, when the model file must be read and is invalid.
        """
        if self.given_population is not None:
            return self.given_population
        kernel = self.kernel()
        counts = None if kernel is None or not self.sees_inputs else kernel.cell_counts
        if counts is not None and counts.sum() > 0:
            return Population.from_counts(counts, self.contexts, self.groups)
        pa = np.full(len(self.groups), 1.0 / len(self.groups))
        return Population.independent(self._context_distribution, pa, self.contexts, self.groups, source="assumed")

    def kernel(self) -> Kernel | None:
        """The decision model P(U | X̃, Ã) from [model], or None (read once, then kept).

        The table is indexed by the *released* values: the outputs of
        ``[privacy.context]`` and ``[privacy.sensitive]`` (the same labels as
        their inputs, except for a ``matrix`` mechanism with ``outputs``).

        Raises
        ------
        InputError
            If the file is missing, a column is unknown, a label is not in the
            spec, or a (context, group) cell has no row.
        """
        if self._kernel is False:
            self._kernel, self.weighted_table = read_model(self)
        assert self._kernel is not True  # (only False, None or a Kernel)
        return self._kernel

    def calibration_options(self, groups: int | None = None, method: str | None = None) -> dict[str, Any]:
        """The keyword arguments of :func:`fairaudit.worstcase.calibration.calibrate` that this spec defines.

        ``family`` (:attr:`sensitive_family`), ``utility_class`` (γ, lower,
        τ, L_A and the metric), ``population``, ``context_mechanism``,
        ``kernel`` (None without ``[model]``) and ``utility``: pass them on,
        with any of them overridden, as ``calibrate(target, **options)``.
        With ``[decision] unparsed`` and a model, for the white-box method,
        also ``unparsed_decision`` (its index): the answer is then the upper end
        over every utility of that decision in [min g, max g]
        (``proofs/unparsed.md`` §5).

        Parameters
        ----------
        groups : int, optional
            A number of groups the caller expects; checked against the spec's.
        method : {"paper", "tight", "black_box", "white_box"}, optional
            The method the caller will use (None: calibrate's default, white-box
            with a model). The model is for white-box only: with ``paper``,
            ``tight`` or ``black_box``, ``kernel`` is None and there is no
            ``unparsed_decision`` (their bounds hold for every model).

        Raises
        ------
        InputError
            Field ``groups`` when it is given and is not the spec's number of
            groups; field ``spec`` when the spec has fewer than 2 groups
            (nothing to calibrate); field ``privacy.family`` when the model
            is indexed by other values than the groups (the outputs of a
            matrix) and the spec names no family on them; as :meth:`kernel`
            for an invalid model.

        Examples
        --------
        >>> spec = parse_spec('''
        ... [sensitive]
        ... name = "office"
        ... values = ["HR_1", "HR_2", "HR_3"]
        ... [decision]
        ... name = "chosen"
        ... values = ["yes", "no"]
        ... [privacy.sensitive]
        ... mechanism = "randomized_response"
        ... epsilon = 1.0
        ... [utility]
        ... kind = "indicator"
        ... decision = "yes"
        ... ''')
        >>> options = spec.calibration_options()
        >>> options["family"].name, options["kernel"]
        ('3-ary randomized response', None)
        """
        n = len(self.groups)
        if groups is not None and groups != n:
            raise InputError("groups", f"the spec {self.source} has {n} groups", groups)
        family = self.sensitive_family
        if family is None:
            raise InputError("spec", "needs at least 2 sensitive groups to calibrate", self.source)
        kernel = None if method in ("paper", "tight", "black_box") else self.kernel()
        if kernel is not None and tuple(family(0.0).outputs) != tuple(kernel.groups):
            problem = (
                f"is needed to calibrate on the model: [privacy.sensitive] releases {len(kernel.groups)} values, "
                f"not the {n} groups, and without it calibration moves along randomized response on the groups "
                "(docs/spec.md)"
            )
            raise self._err("privacy.family", problem)
        options = {
            "family": family,
            "utility_class": replace(self.utility_class, diameter=None),
            "population": self.population,
            "context_mechanism": self.context_mechanism,
            "kernel": kernel,
            "utility": self.utility,
        }
        if self.unparsed is not None and kernel is not None:
            options["unparsed_decision"] = self.decisions.index(self.unparsed)
        return options


def parse_spec(text: str, source: str = "<string>", base: str | Path = ".") -> Spec:
    """Parse and validate a spec from TOML text.

    Raises
    ------
    InputError
        One line naming the source, the dotted field and the value.

    Examples
    --------
    >>> s = parse_spec('''
    ... [sensitive]
    ... name = "office"
    ... values = ["HR_1", "HR_2"]
    ... [decision]
    ... name = "chosen"
    ... values = ["yes", "no"]
    ... [privacy.sensitive]
    ... mechanism = "randomized_response"
    ... keep = 0.7
    ... [utility]
    ... kind = "indicator"
    ... decision = "yes"
    ... tau = 0.2
    ... ''')
    >>> round(s.sensitive_mechanism.epsilon, 6), s.gamma, s.tau
    (0.847298, 1.0, 0.2)
    >>> parse_spec('[sensitive]\\nname = "a"\\nvalues = [1, 2]\\n[decision]\\nname = "u"\\nvalues = [0, 1]\\n'
    ...            '[privacy.sensitive]\\nmechanism = "laplace"\\n[utility]\\ndecision = 1\\n')
    Traceback (most recent call last):
    ...
    fairaudit.base.errors.InputError: <string>: privacy.sensitive.mechanism: Input should be 'identity', 'randomized_response', 'matrix' or 'product' (got 'laplace')
    """
    raw = parse_toml(text, source)
    if _is_task_file(raw):
        raise InputError(
            source,
            "is a task file (it has [task] and [prompt]), not a spec: run `fairaudit experiment "
            f"{source} --out DIR` with a model, which writes the specs (DIR/spec-eps-*.toml) that certify reads",
        )
    try:
        from pydantic import ValidationError  # (pydantic: imported when a spec is read)

        from fairaudit.certification.spec_schema import SpecModel

        model = SpecModel.model_validate(raw)
        return Spec(model, source, Path(base))
    except ValidationError as exc:
        raise validation_error(exc, source, whole="spec") from None
    except RecursionError:
        raise InputError(source, "is too deeply nested to validate") from None


def _is_task_file(raw: dict[str, Any]) -> bool:
    """Whether TOML read as a spec is a task file of ``fairaudit experiment`` (by its keys alone: a [task] or a
    [prompt] table, with [[attribute]] or [task], and no [sensitive])."""
    if "sensitive" in raw:
        return False
    task, prompt = isinstance(raw.get("task"), dict), isinstance(raw.get("prompt"), dict)
    return (task and (prompt or "attribute" in raw)) or (prompt and isinstance(raw.get("attribute"), list))


def load_spec(path: str | Path) -> Spec:
    """Read and validate a spec file; model paths are relative to its folder.

    Raises
    ------
    InputError
        If the file is missing or unreadable, or the spec is invalid.
    """
    p = Path(path)
    if not p.is_file():
        raise InputError("SPEC", "no such file", str(path))
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError("SPEC", f"cannot be read ({exc})", str(path)) from None
    return parse_spec(text, source=str(path), base=p.parent)
