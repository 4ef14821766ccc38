"""The numbers a certificate repeats from its inputs or reads off them: the utility class, each mechanism's size, δ and
keep probability, and the population's departure from independence.

Each is re-derived from ``inputs`` exactly (``proofs/verification.md`` §4c): a repeated number must equal its input,
a number read off must equal (or, behind randomized response, enclose) its exact value.
"""

from __future__ import annotations

from collections.abc import Mapping
from fractions import Fraction
from typing import Any

from fairaudit.verification.checks import Check, equal, judge
from fairaudit.verification.enclosures import INF, Enclosure, RecordedMechanism, independence

__all__ = ["recorded_checks"]

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
    >>> [c.line() for c in recorded_checks({"privacy": {"sensitive": {"keep_probability": 0.5}}}, m, m)]
    ['privacy.sensitive.keep_probability = 0.5: holds']
    """
    out: list[Check] = []
    utility, recorded = cert.get("utility"), cert.get("inputs", {}).get("utility")
    if utility is not None and recorded is not None:
        out += [equal(f"utility.{k}", utility.get(k), recorded.get(k), "inputs.utility") for k in CLASS_FIELDS]
    for name, m in (("sensitive", sensitive), ("context", context)):
        section = cert.get("privacy", {}).get(name)
        if section is None:
            continue
        where = f"privacy.{name}"
        if "inputs" in section:
            out.append(equal(f"{where}.inputs", section["inputs"], len(m.inputs), "its input labels"))
            out.append(equal(f"{where}.outputs", section["outputs"], len(m.outputs), "its output labels"))
        if "delta" in section:
            finite = m.epsilon_enclosure().hi != INF
            out.append(equal(f"{where}.delta", section["delta"], 0.0 if finite else None, "delta at its own epsilon"))
        out.append(_keep_check(f"{where}.keep_probability", section.get("keep_probability"), m))
    if "population" in cert and "max_deviation" in cert["population"]:
        out += _deviation_checks(cert)
    return out


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
