"""The recorded inputs are distributions: every row of a kernel and of a mechanism's matrix, and the population.

certify refuses a table that is not one (``fairaudit.base.arrays.check_probabilities``: every entry finite and
≥ 0, every row summing to 1 within :data:`ROW_TOLERANCE`; the population's entries summing to 1 within it,
``docs/design.md`` "Array layout"). A certificate edited afterwards (its ``inputs_sha256`` recomputed) may hold one
that is not; every number re-derived from it would then be re-derived from a law that is none. The same rule is
applied here exactly, on the recorded floats read as rationals: no floating-point sum decides.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from fractions import Fraction
from typing import Any

from fairaudit.verification.checks import Check

__all__ = ["ROW_TOLERANCE", "distribution_checks"]

ROW_TOLERANCE = Fraction(1e-9)
"""How far a row's exact sum may be from 1 (certify's input validation, ``base.arrays.ROW_TOLERANCE``)."""

MEMBERS = ("black_box", "white_box", "black_box_above", "white_box_above")
"""The calibrated members ``inputs.calibration`` may record."""


def distribution_checks(inputs: Mapping[str, Any]) -> list[Check]:
    """One check per recorded distribution of ``inputs``: it holds when every row is one, else it names the first
    row that is not (an entry below 0, or a sum farther than 1e-9 from 1).

    Parameters
    ----------
    inputs : mapping
        A certificate's ``inputs`` (checked against the schema).

    Returns
    -------
    list of Check
        ``inputs.population.probabilities``, ``inputs.kernel.probabilities`` (its rows over the decisions; a row
        with an empty cell is skipped, as certify's estimated tables do) and each mechanism's ``matrix``
        (``inputs.sensitive_mechanism``, ``inputs.context_mechanism``, ``inputs.calibration.<member>``).

    Examples
    --------
    >>> pop = {"probabilities": [[0.25, 0.25], [0.25, 0.25]]}
    >>> kernel = {"probabilities": [[[0.6, 0.6], [0.5, 0.5]]]}
    >>> [c.line() for c in distribution_checks({"population": pop, "kernel": kernel})]
    ['inputs.population.probabilities = 1: holds', 'inputs.kernel.probabilities[0][0] = 1.2: fails by 0.2 (a row sums to 1.2, not 1 within 1e-9)']
    >>> [c.line() for c in distribution_checks({"kernel": {"probabilities": [[[1.5, -0.5]]]}})]
    ['inputs.kernel.probabilities[0][0][1] = -0.5: fails by 0.5 (an entry is negative)']
    """
    out = []
    population = inputs.get("population")
    if isinstance(population, Mapping):
        cells = [v for row in population["probabilities"] for v in row]
        out.append(_check("inputs.population.probabilities", [("", cells)], "its entries sum"))
    kernel = inputs.get("kernel")
    if isinstance(kernel, Mapping):
        rows = [(f"[{x}][{a}]", row) for x, block in enumerate(kernel["probabilities"]) for a, row in enumerate(block)]
        out.append(_check("inputs.kernel.probabilities", [(i, r) for i, r in rows if None not in r], "a row sums"))
    for where, m in _mechanisms(inputs):
        if m.get("kind") == "matrix":
            rows = [(f"[{i}]", row) for i, row in enumerate(m["matrix"])]
            out.append(_check(f"{where}.matrix", rows, "a row sums"))
    return out


def _mechanisms(inputs: Mapping[str, Any]) -> Iterator[tuple[str, Mapping[str, Any]]]:
    """Every mechanism ``inputs`` records, with its path."""
    for key in ("sensitive_mechanism", "context_mechanism"):
        if isinstance(inputs.get(key), Mapping):
            yield f"inputs.{key}", inputs[key]
    calibration = inputs.get("calibration")
    if isinstance(calibration, Mapping):
        for key in MEMBERS:
            if isinstance(calibration.get(key), Mapping):
                yield f"inputs.calibration.{key}", calibration[key]


def _check(field: str, rows: list[tuple[str, list[Any]]], what: str) -> Check:
    """The first row of ``rows`` that is not a distribution, as a failing check; else one check that holds."""
    for index, row in rows:
        values = [Fraction(v) for v in row]  # the schema lets only finite numbers through
        for j, v in enumerate(values):
            if v < 0:
                return Check(name=f"{field}{index}[{j}]", reported=row[j], derived_low=0.0, derived_high=math.inf,
                             side="at least", holds=False, fails_by=float(-v), detail="an entry is negative")  # fmt: skip
        total = sum(values, Fraction(0))
        miss = abs(total - 1) - ROW_TOLERANCE
        if miss > 0:
            shown = float(total)
            return Check(name=f"{field}{index}", reported=shown, derived_low=1.0, derived_high=1.0, side="estimate",
                         holds=False, fails_by=float(miss),
                         detail=f"{what} to {shown:.12g}, not 1 within 1e-9")  # fmt: skip
    return Check(name=field, reported=1, derived_low=1.0, derived_high=1.0, side="estimate", holds=True, fails_by=0.0,
                 detail=f"{what} to 1 within 1e-9, every entry >= 0")  # fmt: skip
