"""The numbers a certificate repeats from its inputs or reads off them: the utility class, each mechanism's size, δ and
keep probability, and the population's departure from independence (:func:`recorded_checks`); and the inputs
themselves are distributions (:func:`distribution_checks`).

Each is re-derived from ``inputs`` exactly (``proofs/verification.md`` §4c): a repeated number must equal its input,
a number read off must equal (or, behind randomized response, enclose) its exact value.

Every recorded distribution must be one: certify refuses a table that is not one (``fairaudit.base.arrays.check_probabilities``: every entry finite and
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

from fairaudit.verification.checks import Check, equal, judge
from fairaudit.verification.enclosures import INF, Enclosure, RecordedMechanism, independence

__all__ = ["ROW_TOLERANCE", "distribution_checks", "recorded_checks"]

CLASS_FIELDS = ("gamma", "lower", "tau", "lipschitz", "diameter")
"""The utility class's parameters that the ``utility`` section repeats from ``inputs.utility``."""


def recorded_checks(cert: Mapping[str, Any], sensitive: RecordedMechanism, context: RecordedMechanism) -> list[Check]:
    """The utility class, the mechanisms' sizes, δ and keep probabilities, and ``population.max_deviation``.

    Parameters
    ----------
    cert : mapping
        A certificate (checked against its schema).
    sensitive, context : RecordedMechanism
        M_A and M_X as ``inputs`` records them.

    Returns
    -------
    list of Check
        ``utility.<gamma, lower, tau, lipschitz, diameter>`` equal to ``inputs.utility``; ``privacy.<sensitive,
        context>.<inputs, outputs>`` the numbers of labels; ``.delta`` 0 at a finite ε (a finite mechanism with a
        finite ε is pure ε-DP) and null at ε = +inf; ``.keep_probability`` min_a M[a, a] (e^ε/(e^ε + k − 1) for
        randomized response, enclosed; null when the outputs are other labels); ``population.max_deviation`` =
        max |P(x, a) − P(x) P(a)|, exactly, and its context and group.

    Examples
    --------
    >>> m = RecordedMechanism.from_record({"inputs": ["a", "b"], "outputs": ["a", "b"], "kind": "matrix",
    ...                                    "matrix": [[0.75, 0.25], [0.5, 0.5]]}, "m")
    >>> _keep_check("privacy.sensitive.keep_probability", 0.5, m).line()
    'privacy.sensitive.keep_probability = 0.5: holds'
    """
    utility, recorded = cert["utility"], cert["inputs"]["utility"]  # (the schema requires every key read here)
    out = [equal(f"utility.{k}", utility[k], recorded[k], "inputs.utility") for k in CLASS_FIELDS]
    for name, m in (("sensitive", sensitive), ("context", context)):
        section, where = cert["privacy"][name], f"privacy.{name}"
        out.append(equal(f"{where}.inputs", section["inputs"], len(m.inputs), "its input labels"))
        out.append(equal(f"{where}.outputs", section["outputs"], len(m.outputs), "its output labels"))
        finite = m.epsilon_enclosure().hi != INF
        out.append(equal(f"{where}.delta", section["delta"], 0.0 if finite else None, "delta at its own epsilon"))
        out.append(_keep_check(f"{where}.keep_probability", section["keep_probability"], m))
    return out + _deviation_checks(cert)


def _keep_check(name: str, reported: Any, m: RecordedMechanism) -> Check:
    """min over a of M[a, a]: the smallest probability that the input is released unchanged."""
    if set(m.inputs) != set(m.outputs):
        return equal(name, reported, None, "the outputs are other labels")
    if m.kind == "identity":
        return judge(name, reported, Enclosure.point(Fraction(1)), "estimate", "the identity")
    rows = m.matrix_rows()
    if rows is None:  # randomized response: p = e^ε/(e^ε + k − 1), enclosed
        return judge(name, reported, m.rr_rows()[0], "estimate", "e^epsilon/(e^epsilon + k - 1)")
    keep = min(row[list(m.outputs).index(a)] for row, a in zip(rows, m.inputs))
    return judge(name, reported, Enclosure.point(keep), "estimate", "min_a M[a, a]")


def _deviation_checks(cert: Mapping[str, Any]) -> list[Check]:
    """max |P(x, a) − P(x) P(a)| over the recorded population, exactly, and where it is attained."""
    pop = cert["inputs"]["population"]
    dev, _ = independence(pop["probabilities"])
    largest = max(max(row) for row in dev)
    reported = cert["population"]
    out = [judge("population.max_deviation", reported["max_deviation"], Enclosure.point(largest), "estimate")]
    contexts, groups, name = pop["contexts"], pop["groups"], "population.max_deviation (its context and group)"
    if reported.get("context") in contexts and reported.get("group") in groups:
        at = Enclosure.point(dev[contexts.index(reported["context"])][groups.index(reported["group"])])
        where = f"at {reported['context']!r}, {reported['group']!r}"
        return [*out, judge(name, reported["max_deviation"], at, "estimate", where)]
    why = "the context or group is not a label of inputs.population"
    return [*out, equal(name, reported.get("group"), None, why)]


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
        rows = [
            (f"[{x}][{a}]", row) for x, block in enumerate(planes) for a, row in enumerate(block) if None not in row
        ]
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
