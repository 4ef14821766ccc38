"""The recorded inputs are distributions: every row of a kernel and of a mechanism's matrix, and the population.

certify refuses a table that is not one (``fairaudit.base.arrays.check_probabilities``: every entry finite and
≥ 0, every row summing to 1 within :data:`ROW_TOLERANCE`; the population's entries summing to 1 within it,
``docs/design.md`` "Array layout"). A certificate edited afterwards (its ``inputs_sha256`` recomputed) may hold one
that is not; every number re-derived from it would then be re-derived from a law that is none. The same rule is
applied exactly: the schema (``certificate.schema.json``, ``probability_rows``) admits only numbers in [0, 1], and the
sums are checked here on the recorded floats read as rationals: no floating-point sum decides.
"""

from __future__ import annotations

from collections.abc import Mapping
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
    row that is not (a sum farther than 1e-9 from 1; the schema has checked that each entry is in [0, 1]).

    Parameters
    ----------
    inputs : mapping
        A certificate's ``inputs`` (checked against the schema).

    Returns
    -------
    list of Check
        ``inputs.population.probabilities``, ``inputs.kernel.probabilities`` (its rows over the decisions) and each mechanism's ``matrix``
        (``inputs.sensitive_mechanism``, ``inputs.context_mechanism``, ``inputs.calibration.<member>``).

    Examples
    --------
    >>> pop = {"probabilities": [[0.25, 0.25], [0.25, 0.25]]}
    >>> kernel = {"probabilities": [[[0.6, 0.6], [0.5, 0.5]]]}
    >>> [c.line() for c in distribution_checks({"population": pop, "kernel": kernel})]
    ['inputs.population.probabilities = 1: holds', 'inputs.kernel.probabilities[0][0] = 1.2: fails by 0.2 (a row sums to 1.2, not 1 within 1e-9)']
    """
    out = []
    if inputs.get("population") is not None:
        cells = [v for row in inputs["population"]["probabilities"] for v in row]
        out.append(_check("inputs.population.probabilities", [("", cells)], "its entries sum"))
    if inputs.get("kernel") is not None:
        planes = inputs["kernel"]["probabilities"]
        rows = [(f"[{x}][{a}]", row) for x, block in enumerate(planes) for a, row in enumerate(block)]
        out.append(_check("inputs.kernel.probabilities", rows, "a row sums"))
    members = inputs.get("calibration") or {}
    mechanisms = [(f"inputs.{key}", inputs.get(key)) for key in ("sensitive_mechanism", "context_mechanism")]
    for where, m in mechanisms + [(f"inputs.calibration.{key}", members.get(key)) for key in MEMBERS]:
        if m is not None and m["kind"] == "matrix":
            out.append(_check(f"{where}.matrix", [(f"[{i}]", row) for i, row in enumerate(m["matrix"])], "a row sums"))
    return out


def _check(field: str, rows: list[tuple[str, list[Any]]], what: str) -> Check:
    """The first row of ``rows`` that is not a distribution, as a failing check; else one check that holds (the schema
    lets only numbers in [0, 1] through)."""
    for index, row in rows:
        total = sum(map(Fraction, row), Fraction(0))
        miss = abs(total - 1) - ROW_TOLERANCE
        if miss > 0:
            shown = float(total)
            return Check(name=f"{field}{index}", reported=shown, derived_low=1.0, derived_high=1.0, side="estimate",
                         holds=False, fails_by=float(miss),
                         detail=f"{what} to {shown:.12g}, not 1 within 1e-9")  # fmt: skip
    return Check(name=field, reported=1, derived_low=1.0, derived_high=1.0, side="estimate", holds=True, fails_by=0.0,
                 detail=f"{what} to 1 within 1e-9, every entry >= 0")  # fmt: skip
