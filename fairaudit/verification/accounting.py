"""Every number and verdict of a certificate accounted for: re-derived by a check, or listed with the reason it is not.

:func:`unaccounted` walks the numbers of a certificate outside ``inputs`` (which are the data, not claims) and its
verdicts (every boolean, and the categorical verdicts of :data:`VERDICTS`), and names those that no check re-derived
and no reason already covers, grouped by kind, so that ``fairaudit verify`` never passes over one in silence
(``proofs/verification.md`` §4c).
"""

from __future__ import annotations

import re
from collections.abc import Iterator, Mapping, Sequence
from typing import Any

from fairaudit.verification.checks import Check

__all__ = ["KINDS", "unaccounted"]

KINDS: tuple[tuple[str, str, str], ...] = (
    (
        r"^(observed|unfiltered)\.((local|global)\.interval|intervals)\b",
        r"\1.intervals",
        "statistical intervals are estimates, not certified numbers",
    ),
    (
        r"^bound_details\.black_box(\.global)?\.worst_model\.",
        "bound_details.black_box.worst_model",
        "the worst model's probabilities, printed to 12 digits for reading: its value is the witness",
    ),
    (
        r"^bound_details\.black_box(\.global)?\.(duals|screens|witness_point)\b",
        "bound_details.black_box (duals, screens, witness_point)",
        "the evidence the black box is checked with (multipliers or a screen's threshold bound a program, a point "
        "attains the witness)",
    ),
    (
        r"^calibration\.proofs\.",
        "calibration.proofs",
        "the members' programs and their proofs: each member's worst case is re-derived from them (calibration.bound, "
        "calibration.epsilon is the largest); the values they repeat are certify's, not claims",
    ),
    (r"(^|\.)programs_solved$", "programs_solved", "a count of the programs solved, not a certified number"),
    (
        r"^bound_details\.black_box(\.global)?\.(certified|certified_from_dual)$",
        "bound_details.black_box (certified, certified_from_dual)",
        "how certify's solve reached the value (the solver's word, or a dual): verify re-derives the value itself",
    ),
    (
        r"^targets\.(local|global)\.target$",
        r"targets.\1.target",
        "the target asked about: the question, not a derived number",
    ),
    (r"^population\.records$", "population.records", "the number of records counted, not in inputs"),
    (
        r"^(calibration(\.white_box)?)\.(gamma|lower|tau|lipschitz|diameter|groups|keep_probability|delta|targets)\b",
        r"\1 (its class, targets and member)",
        "what the calibration repeats: the class and targets it was asked for, its member's size, keep and delta",
    ),
    (
        r"^bound_details\.paper\.epsilon$",
        "bound_details.paper.epsilon",
        "the epsilon the paper's bound is evaluated at (any is valid): its delta and value are re-derived at it",
    ),
    (
        r"^bound_details\.tight\.(epsilon|delta)$",
        r"bound_details.tight.\1",
        "the tight form's minimiser, a reading aid: its value is re-derived as a minimum over every epsilon",
    ),
)
"""(pattern on the number's path, the name it is listed under, the reason), first match wins; a number matched by
none is listed under its own path as "not re-derived"."""

_SKIP = ("format_version", "tolerance", "inputs", "inputs_sha256")
"""Top-level keys that are not claims: the format's version, the tolerance the numbers are judged to and the data
themselves."""

VERDICTS = re.compile(r"^(bounds\.best_form|population\.independent|assumptions\[\d+\]\.status)$")
"""The verdicts a certificate states as labels (every boolean is a verdict too)."""


def _numbers(value: Any, path: str) -> Iterator[str]:
    """The paths of the numbers (and "inf"/"-inf"/"nan" strings) and verdicts (booleans, :data:`VERDICTS`) under
    ``value``."""
    if isinstance(value, Mapping):
        for key, inner in value.items():
            yield from _numbers(inner, f"{path}.{key}" if path else str(key))
    elif isinstance(value, list):
        for i, inner in enumerate(value):
            yield from _numbers(inner, f"{path}[{i}]")
    elif isinstance(value, (int, float)) or value in ("inf", "-inf", "nan") or VERDICTS.match(path):
        yield path


def unaccounted(
    certificate: Mapping[str, Any], checks: Sequence[Check], skipped: Sequence[tuple[str, str]]
) -> list[tuple[str, str]]:
    """The numbers and verdicts of ``certificate`` that neither a check nor a reason in ``skipped`` covers, grouped,
    with reasons.

    Parameters
    ----------
    certificate : mapping
        A certificate (checked against its schema).
    checks : sequence of Check
        The checks made (a check's ``name`` is the JSON path of the number it re-derives).
    skipped : sequence of (str, str)
        The numbers already listed as not re-derived (a name covers the section under it).

    Returns
    -------
    list of (str, str)
        One (name, reason) per group of :data:`KINDS` that holds an unaccounted number, in the order first met.

    Examples
    --------
    >>> cert = {"format_version": 2, "bounds": {"tight": 0.5}, "bound_details": {"black_box": {"programs_solved": 3}}}
    >>> unaccounted(cert, [], [])
    [('bounds.tight', 'not re-derived'), ('programs_solved', 'a count of the programs solved, not a certified number')]
    >>> unaccounted({"certified": True, "bounds": {"best_form": "tight", "tight": 0.5}}, [], [("bounds.tight", "")])
    [('certified', 'not re-derived'), ('bounds.best_form', 'not re-derived')]
    """
    covered = {c.name for c in checks} | {name for name, _ in skipped}  # (a reason's name covers the section under it)
    sections = tuple(name + tail for name, _ in skipped for tail in ".[")
    out: dict[str, str] = {}
    groups: dict[tuple[int, str], str] = {}  # (a kind, the text it matched): its group (expand is slow)
    for path in _numbers({key: v for key, v in certificate.items() if key not in _SKIP}, ""):
        if path in covered or path.startswith(sections):
            continue
        for i, (pattern, group, reason) in enumerate(KINDS):
            match = re.search(pattern, path)
            if match:
                if (i, match[0]) not in groups:
                    groups[i, match[0]] = match.expand(group)
                out.setdefault(groups[i, match[0]], reason)
                break
        else:
            out.setdefault(path, "not re-derived")
    return list(out.items())
