"""The mechanisms a spec's ``[privacy.*]`` tables name, and the family that calibration and curves move along.

A table is ``mechanism = "identity" | "randomized_response" (epsilon or keep) | "matrix" (rows, outputs) |
"product" (components)`` (docs/spec.md); its errors name its fields (``privacy.sensitive.components[1].keep``).
"""

from __future__ import annotations

import math
from collections.abc import Hashable, Sequence
from typing import TYPE_CHECKING

import numpy as np

from fairaudit.base.errors import InputError
from fairaudit.laws.closed_forms import epsilon_from_keep_probability, randomized_response
from fairaudit.laws.families import MechanismFamily, product_family, product_rows_family, randomized_response_family
from fairaudit.laws.mechanisms import Mechanism, from_matrix, identity, product

if TYPE_CHECKING:
    import numpy.typing as npt

    from fairaudit.certification.spec_schema import FamilySpec, MechanismSpec, WeightedInput

__all__ = [
    # building them
    "build_mechanism",
    "mechanism_family",
    "view_family",
]


_MECHANISM_FIELDS = {"epsilon", "keep"}
"""Fields of a mechanism table that errors of the privacy functions name as they are (``keep``: ...)."""


def build_mechanism(spec: MechanismSpec, values: Sequence[Hashable] | None, name: str, field: str) -> Mechanism:
    """The mechanism of a ``[privacy.*]`` table on ``values``.

    Randomized response on one value (k = 1) keeps it with probability 1:
    ``keep`` must then be 1, and every ``epsilon`` gives that mechanism
    (p = e^ε / (e^ε + k − 1) = 1), whose ε(M) is 0.

    Parameters
    ----------
    spec : MechanismSpec
        The validated table.
    values : sequence of hashable or None
        The labels it takes (a product takes its components' own).
    name : str
        The mechanism's name.
    field : str
        Where the table is, for errors (``"SPEC: privacy.sensitive"``).

    Raises
    ------
    InputError
        Under ``field``: a field of the table joined to it by a dot
        (``field.components[1].keep``), any other error under it.
    """
    try:
        return _built(spec, values, name)
    except InputError as exc:
        if exc.field in _MECHANISM_FIELDS or exc.field.startswith("components["):  # a field of the spec's table
            raise InputError(f"{field}.{exc.field}", exc.problem, exc.value) from None
        raise exc.under(field) from None


def _built(spec: MechanismSpec, values: Sequence[Hashable] | None, name: str) -> Mechanism:
    """The mechanism of a table; errors name its fields as they are (``keep``, ``components[1].keep``)."""
    if spec.mechanism == "product":
        comps = []
        for i, c in enumerate(spec.components or []):
            if c.values is None:
                raise InputError(f"components[{i}].values", "each component needs its values")
            comps.append(build_mechanism(c, c.values, c.name or f"{c.mechanism}[{i}]", f"components[{i}]"))
        return product(*comps, name=name)
    if values is None:
        raise InputError("values", "are required")
    if spec.mechanism == "identity":
        return identity(values, name=name)
    if spec.mechanism == "randomized_response":
        if len(values) == 1 and spec.keep is not None and spec.keep != 1:
            problem = "with one value (k = 1) there is nothing to randomize: keep must be 1 (or use identity)"
            raise InputError("keep", problem, spec.keep)
        return randomized_response(values, spec.epsilon, keep=spec.keep, name=name)
    assert spec.rows is not None  # (MechanismSpec: a matrix has rows)
    return from_matrix(spec.rows, values, spec.outputs, name=name)


def mechanism_family(spec: MechanismSpec, groups: tuple) -> MechanismFamily | None:
    """The one-parameter family along which the mechanism of the table ``spec`` on ``groups`` moves.

    Randomized response on the groups when the table is randomized
    response, identity or a matrix; for a product, a product of randomized
    responses on the components' values with ε split in proportion to the
    components' ε (equally when they are all 0 or infinite). None with fewer
    than 2 groups.
    """
    if len(groups) < 2:
        return None
    if spec.mechanism == "product" and spec.components:
        values, weights = _split(spec.components)  # (every component has values: checked when built)
        if all(len(v) >= 2 for v in values):
            return product_family(*values, weights=weights)
    return randomized_response_family(groups)


def view_family(spec: FamilySpec, mechanism: Mechanism, field: str) -> MechanismFamily:
    """The family of a ``[privacy.family]`` table: its product of randomized responses on the rows ``inputs``, or
    on the mixtures of rows ``mixtures``.

    The product splits ε in proportion to its components' ε (equally when
    they are all 0 or infinite), as :func:`mechanism_family` does for a
    product; its rows ``inputs`` (or each group's weighted rows ``mixtures``)
    are the sensitive groups, its outputs those of ``[privacy.sensitive]`` in
    the product's order, and ε is rescaled so that each member's ε is ε
    (:func:`fairaudit.laws.families.product_rows_family`: in closed form on
    rows, by root finding on mixtures).

    Parameters
    ----------
    spec : FamilySpec
        The validated table.
    mechanism : Mechanism
        The spec's ``[privacy.sensitive]`` mechanism: the family's inputs and outputs are its, and the family
        must pass through it (its member at ε(M) equals M to 1e-9).
    field : str
        Where the table is, for errors (``"SPEC: privacy.family"``).

    Returns
    -------
    MechanismFamily

    Raises
    ------
    InputError
        Under ``field``: a component with fewer than 2 values, an input that is not one of the product's, outputs
        of another number, mixtures of another number than the groups or that no member separates beyond a finite
        ε, or a family that does not pass through ``mechanism``.
    """
    values, weights = _split(spec.components)  # (every component has values: FamilySpec checks it)
    if spec.mixtures is not None and len(spec.mixtures) != len(mechanism.inputs):
        problem = f"needs one mixture per group ({len(mechanism.inputs)}, the inputs of [privacy.sensitive])"
        raise InputError(f"{field}.mixtures", problem, len(spec.mixtures))
    rows, mixture = (spec.inputs, None) if spec.inputs is not None else _mixture(spec.mixtures or [])
    try:
        family = product_rows_family(
            *values,
            rows=[tuple(r) for r in rows],
            inputs=mechanism.inputs,
            outputs=mechanism.outputs,
            weights=weights,
            name=spec.name or mechanism.name,
            mixture=mixture,
        )
    except InputError as exc:
        raise exc.under(field) from None
    gap = float(np.max(np.abs(family(mechanism.epsilon).matrix - mechanism.matrix)))
    if not gap <= 1e-9:
        problem = f"does not pass through the mechanism of [privacy.sensitive] at its epsilon {mechanism.epsilon:.6g}"
        raise InputError(field, problem + " (largest difference of a cell)", gap)
    return family


def _mixture(mixtures: list[list[WeightedInput]]) -> tuple[list[list], npt.NDArray[np.float64] | None]:
    """The distinct rows of ``mixtures`` in order of appearance and W[group, row] (None when W is the identity: each
    group is its own row, in closed form)."""
    rows: list[list] = []  # (labels may be lists: compared, not hashed)
    for mix in mixtures:
        rows += [m.input for m in mix if m.input not in rows]
    w = np.zeros((len(mixtures), len(rows)))
    for g, mix in enumerate(mixtures):
        for m in mix:
            w[g, rows.index(m.input)] += m.weight
    return rows, None if w.shape == (len(rows),) * 2 and np.array_equal(w, np.eye(len(rows))) else w


def _split(components: list[MechanismSpec]) -> tuple[list[list], list[float] | None]:
    """A product's components' values, and the weights its family splits ε by: the components' ε, or None (equally)
    when they are all 0 or one is infinite."""
    eps = [_component_epsilon(c) for c in components]
    return [c.values or [] for c in components], eps if all(map(math.isfinite, eps)) and sum(eps) > 0 else None


def _component_epsilon(spec: MechanismSpec) -> float:
    """ε of a product's component as its table gives it (inf for identity and matrix)."""
    if spec.mechanism == "randomized_response":
        if spec.values is not None and len(spec.values) < 2:
            return 0.0  # one value: nothing is randomized, epsilon(M) = 0 whatever the spec says
        if spec.epsilon is not None:
            return float(spec.epsilon)
        if spec.values:
            assert spec.keep is not None  # (MechanismSpec: epsilon or keep)
            return epsilon_from_keep_probability(spec.keep, len(spec.values))
    return math.inf
