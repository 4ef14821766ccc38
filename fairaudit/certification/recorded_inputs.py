"""What a certificate records so that a third party can re-derive its numbers: its ``inputs`` and their SHA-256.

A certificate's numbers follow from its mechanisms, its utility, its population and, with a model, the kernel behind
the filter. :func:`certificate_inputs` writes them as JSON (every float exactly, as Python's ``repr`` writes it, so
a reader gets the very binary numbers the tool used), and :func:`fairaudit.base.json_values.canonical_digest` hashes them canonically. The
format is ``docs/certificates.md`` ("The certificate's format"); ``fairaudit verify`` reads it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from fairaudit.base.json_values import Report, label
from fairaudit.laws.closed_forms import RandomizedResponse
from fairaudit.laws.mechanisms import Mechanism
from fairaudit.laws.tables import Kernel, Population
from fairaudit.laws.utilities import Utility
from fairaudit.worstcase.known_utility import worst_model

if TYPE_CHECKING:
    from fairaudit.certification.spec import Spec
    from fairaudit.worstcase.calibration_result import Calibration

__all__ = [
    "CERTIFICATE_FORMAT",
    "FORMAT_VERSION",
    "certificate_inputs",
    "json_array",
    "mechanism_inputs",
    "member_proofs",
]

CERTIFICATE_FORMAT = "fairaudit-certificate"
"""The value of a certificate's ``format`` key."""

FORMAT_VERSION = 3
"""The certificate format's version (``format_version``): raised whenever a key's meaning changes (2: the black
box carries its proof per program, ``screens`` and exact multipliers ``"n/d"``; 3: a calibration over the class
Lipschitz in the group carries its members' proofs, which ``verify`` checks without solving)."""


def json_array(a: npt.ArrayLike) -> Any:
    """An array as nested JSON lists, floats exact (``repr``), NaN as None and ±inf as ``"inf"``/``"-inf"``.

    Examples
    --------
    >>> json_array([[0.1, float("inf")], [float("nan"), 2.0]])
    [[0.1, 'inf'], [None, 2.0]]
    """
    x = np.asarray(a, dtype=float)
    if np.all(np.isfinite(x)):
        return x.tolist()
    out = x.astype(object)
    out[np.isnan(x)] = None
    out[np.isposinf(x)] = "inf"
    out[np.isneginf(x)] = "-inf"
    return out.tolist()


def mechanism_inputs(m: Mechanism) -> Report:
    """A mechanism as its certificate records it: labels and ``kind`` with its parameters.

    ``randomized_response`` is the exact k-ary randomized response at ``epsilon`` (p = e^ε/(e^ε + k − 1), the
    closed forms' mechanism); ``identity`` releases the input; ``matrix`` is any other, by its rows exactly.

    Examples
    --------
    >>> from fairaudit.laws.closed_forms import randomized_response
    >>> mechanism_inputs(randomized_response(["Tom", "Mary"], epsilon=0.5))
    {'inputs': ['Tom', 'Mary'], 'outputs': ['Tom', 'Mary'], 'kind': 'randomized_response', 'epsilon': 0.5}
    """
    out: Report = {"inputs": [label(v) for v in m.inputs], "outputs": [label(v) for v in m.outputs]}
    if m.is_identity:
        out["kind"] = "identity"
    elif isinstance(m, RandomizedResponse):
        out.update(kind="randomized_response", epsilon=float(m.rr.epsilon))
    else:
        out.update(kind="matrix", matrix=json_array(m.matrix))
    return out


def certificate_inputs(spec: Spec, calibrated: Mapping[str, Mechanism | None] | None = None) -> Report:
    """The ``inputs`` section of a certificate: everything its numbers are computed from.

    Parameters
    ----------
    spec : Spec
        The spec certified: its M_A and M_X; its utility g (``values`` of shape (n_decisions,) or (n_contexts,
        n_groups, n_decisions)) and the class the bounds hold for, its fields resolved ([lower, γ], τ or None, L_A,
        the metric d(a, a') of shape (n_groups, n_groups) or None for the discrete metric, and diam(A)); its
        population P(X, A), shape (n_contexts, n_groups); and its model behind the filter, if any, shape
        (n_released_contexts, n_released_groups, n_decisions).
    calibrated : mapping, optional
        The family's member at each calibrated ε, ``{"black_box": M or None, "white_box": M or None}``, and just
        above it (``"black_box_above"``, ``"white_box_above"``: the member at ε + 1e-9·max(1, ε), which misses the
        target); None when the certificate has no calibration.

    Returns
    -------
    dict
        ``sensitive_mechanism``, ``context_mechanism`` (:func:`mechanism_inputs`), ``utility`` (``decisions``,
        ``values`` and the class: ``lower``, ``gamma``, ``tau``, ``lipschitz``, ``metric``, ``diameter``), ``population`` (``contexts``, ``groups``, ``probabilities``), ``kernel`` (None, or
        its labels and ``probabilities``) and, with a calibration, ``calibration`` (each member by
        :func:`mechanism_inputs`, or None).
    """
    c, population, kernel = spec.utility_class, spec.population, spec.kernel()
    out: Report = {
        "sensitive_mechanism": mechanism_inputs(spec.sensitive_mechanism),
        "context_mechanism": mechanism_inputs(spec.context_mechanism),
        "utility": {
            "decisions": [label(v) for v in spec.utility.decisions],
            "values": json_array(spec.utility.values),
            **{name: _real(getattr(c, name)) for name in ("lower", "gamma", "tau", "lipschitz")},
            "metric": None if c.metric is None else json_array(c.metric),
            "diameter": _real(c.diameter),
        },
        "population": _table(population, "contexts", "groups"),
        "kernel": None if kernel is None else _table(kernel, "contexts", "groups", "decisions"),
    }
    if calibrated is not None:
        out["calibration"] = {k: None if m is None else mechanism_inputs(m) for k, m in calibrated.items()}
    return out


def _table(table: Population | Kernel, *axes: str) -> Report:
    """A population or a kernel as its certificate records it: the labels of each axis, then ``probabilities``."""
    return {
        **{axis: [label(v) for v in getattr(table, axis)] for axis in axes},
        "probabilities": json_array(table.probabilities),
    }


def _real(x: float | None) -> float | str | None:
    """A class field as JSON: None stays None, ±inf as a string."""
    return None if x is None else json_array(float(x))


def member_proofs(
    spec: Spec, cal: Calibration | None, members: Mapping[str, Mechanism | None] | None
) -> dict[str, Report]:
    """The proofs of the black-box calibration's members (at ε and just above it), by member, for ``fairaudit
    verify``: each the black box of the programs it checks there, as ``bound_details.black_box`` records one.

    On L (and on L̄ through L, X and A independent) the class's worst case: one context ``"x"``, the member's
    groups, uniform, the utility (γ, lower) on two decisions and the class's τ (``proofs/black_box.md`` §1, §6: a
    utility free of the group enters only through h in [lower, γ]); on L̄ with X and A dependent, the worst case
    for the spec's utility, population and context mechanism behind the member. For the class Lipschitz in the
    group, each member's :func:`~fairaudit.worstcase.lipschitz_proofs.lipschitz_proof` instead (where it records
    one: ``verify`` lists a member without it as not re-derived).
    """
    if cal is None or members is None:
        return {}
    tau = None if math.isnan(cal.tau) else cal.tau
    dependent = not cal.lipschitz and cal.kind == "global" and not spec.population.independence().independent
    out: dict[str, Report] = {}
    for key in ("black_box", "black_box_above"):
        m = members.get(key)
        if m is None or (len(m.inputs) < 2 and not cal.lipschitz):
            continue
        if cal.lipschitz:
            from fairaudit.worstcase.lipschitz_proofs import lipschitz_proof  # (the Lipschitz class's only)

            metric = None if spec.metric is None else np.asarray(spec.metric, dtype=float).tolist()
            proof = lipschitz_proof(mechanism_inputs(m), cal.lower, cal.gamma, tau, cal.lipschitz, metric)
        elif dependent:
            proof = worst_model(m, spec.utility, context_mechanism=spec.context_mechanism,
                                population=spec.population, tau=spec.tau).to_dict()  # fmt: skip
        else:
            k = len(m.inputs)
            population = Population([[1 / k] * k], ["x"], m.inputs)
            proof = worst_model(m, Utility([cal.gamma, cal.lower], ["gamma", "lower"]), population=population,
                                tau=tau).to_dict()  # fmt: skip
        if proof is not None:
            out[key] = proof
    return out
