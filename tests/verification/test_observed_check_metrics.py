"""`fairaudit.verification.observed_check.observed_checks`: the ratios, gaps, sups over g and maximisers of the observed
and unfiltered sections against hand calculations; on the shipped examples and on random specs every such number
moved by 1e-7 (beyond the certificate's tolerance, 1e-9) fails, and a swapped pair, a changed event or a label not
among the inputs' fails."""

from __future__ import annotations

import copy
import json
import math
from fractions import Fraction as F
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, assume, given, settings
from test_rederive_random import MAX_EXAMPLES, certificate_of, specs

import fairaudit
from fairaudit.base.errors import InputError
from fairaudit.verification.checks import Check
from fairaudit.verification.enclosures import RecordedMechanism
from fairaudit.verification.observed_check import observed_checks as metric_checks

ROOT = Path(__file__).resolve().parents[2]
SHIPPED = ["examples/hr_office/hr_office.toml", "examples/llm_hiring/gpt35.toml", "examples/llm_hiring/gpt4.toml"]

HEAD = """
[sensitive]
name = "group"
values = ["a", "b"]
[context]
name = "job"
values = ["x", "y"]
[decision]
name = "chosen"
values = ["yes", "no"]
[model]
table = "table.csv"
[utility]
decision = "yes"
"""
# M_A = [[3/4, 1/4], [1/4, 3/4]]: exactly as a matrix, and as randomized response keeping 3/4 (epsilon = ln 3, a
# float: its law within 1e-16 of the matrix's)
MATRIX = HEAD + '[privacy.sensitive]\nmechanism = "matrix"\nrows = [[0.75, 0.25], [0.25, 0.75]]\n'
RR = HEAD + '[privacy.sensitive]\nmechanism = "randomized_response"\nkeep = 0.75\n'
# P(yes | x, a) = 1/2, P(yes | x, b) = 1/4, P(yes | y, a) = 3/4, P(yes | y, b) = 1/2
TABLE = "job,group,chosen,probability\n" + "".join(
    f"{x},{a},yes,{p}\n{x},{a},no,{1 - p}\n"
    for x, a, p in [("x", "a", 0.5), ("x", "b", 0.25), ("y", "a", 0.75), ("y", "b", 0.5)]
)

# By hand. Behind M_A: P(yes | x, .) = (3/4·1/2 + 1/4·1/4, 1/4·1/2 + 3/4·1/4) = (7/16, 5/16), P(yes | y, .) = (11/16,
# 9/16); uniform P(x, a): P(yes | a) = 9/16, P(yes | b) = 7/16. The model alone: P(yes | a) = 5/8, P(yes | b) = 3/8.
HAND = {
    "observed.local.ratio": F(7, 5),  # 7/16 over 5/16 in x
    "observed.global.ratio": F(9, 7),
    "observed.demographic_parity": F(1, 8),  # |9/16 − 7/16|
    "observed.equalized_odds": F(1, 8),  # 2/16 in x and in y
    "observed.details.sup_local.ratio": F(7, 5),  # yes in x (and no in y)
    "observed.details.sup_global.ratio": F(9, 7),  # yes: 9/16 over 7/16 (and no: 9/16 over 7/16)
    "unfiltered.local.ratio": F(2),  # 1/2 over 1/4 in x
    "unfiltered.global.ratio": F(5, 3),
    "unfiltered.demographic_parity": F(1, 4),
    "unfiltered.equalized_odds": F(1, 4),
    "unfiltered.details.sup_local.ratio": F(2),  # yes in x, no in y (1/2 over 1/4)
    "unfiltered.details.sup_global.ratio": F(5, 3),  # yes: 5/8 over 3/8, no: 5/8 over 3/8
}
LOGS = {  # the values in nats: ln of the ratios above
    "observed.sup_local": F(7, 5),
    "observed.sup_global": F(9, 7),
    "unfiltered.local.value": F(2),
    "unfiltered.global.value": F(5, 3),
    "unfiltered.sup_local": F(2),
    "unfiltered.sup_global": F(5, 3),
}


def _certificate(spec: str, table: str | None, folder: Path) -> dict[str, Any]:
    (folder / "spec.toml").write_text(spec, encoding="utf-8")
    if table is not None:
        (folder / "table.csv").write_text(table, encoding="utf-8")
    return json.loads(json.dumps(fairaudit.certify(folder / "spec.toml").to_dict()))


@pytest.fixture(scope="module")
def hand(tmp_path_factory) -> dict[str, dict[str, Any]]:
    out = {}
    for name, spec in (("matrix", MATRIX), ("randomized response", RR)):
        out[name] = _certificate(spec, TABLE, tmp_path_factory.mktemp(name.replace(" ", "_")))
    return out


def _checks(cert: dict[str, Any]) -> list[Check]:
    inputs = cert["inputs"]
    sensitive = RecordedMechanism.from_record(inputs["sensitive_mechanism"], "inputs.sensitive_mechanism")
    context = RecordedMechanism.from_record(inputs["context_mechanism"], "inputs.context_mechanism")
    return metric_checks(cert, sensitive, context, [])


def _failing(cert: dict[str, Any]) -> list[str]:
    return [c.name for c in _checks(cert) if not c.holds]


@pytest.mark.parametrize("kind", ["matrix", "randomized response"])
@pytest.mark.parametrize("name", list(HAND) + list(LOGS))
def test_each_metric_is_re_derived_by_hand(hand, kind, name):
    checks = {c.name: c for c in _checks(hand[kind])}
    check = checks[name]
    want = float(HAND[name]) if name in HAND else math.log(LOGS[name])
    slack = 1e-15 if kind == "matrix" and name in HAND else 1e-14  # (exact) or a float ln, or epsilon = ln 3 a float
    assert check.holds, check.line()
    assert check.derived_low - slack <= want <= check.derived_high + slack
    assert check.derived_high - check.derived_low <= 1e-15


def test_randomized_response_is_enclosed_not_exact(hand):
    widths = [c.derived_high - c.derived_low for c in _checks(hand["randomized response"]) if c.name in HAND]
    assert all(w <= 1e-15 for w in widths) and len(widths) == len(HAND)


def test_every_maximiser_is_checked(hand):
    names = {c.name for c in _checks(hand["matrix"])}
    for section in ("observed", "unfiltered"):
        assert {f"{section}.global (its groups)",
                f"{section}.details.demographic_parity (its pair and event)",
                f"{section}.details.equalized_odds (its context, pair and event)",
                f"{section}.details.sup_local (its context, pair and decision)",
                f"{section}.details.sup_global (its pair and decision)"} <= names  # fmt: skip
    assert "unfiltered.local (its context and groups)" in names


def test_a_changed_label_fails_where_the_metric_differs(hand):
    cert = copy.deepcopy(hand["matrix"])
    detail = cert["unfiltered"]["details"]["sup_local"]  # yes in x: 2; in y the ratio at yes is 3/2
    assert (detail["context"], detail["decision"]) == ("x", "yes")
    detail["context"] = "y"
    assert _failing(cert) == ["unfiltered.details.sup_local (its context, pair and decision)"]
    detail["context"], detail["decision"] = "x", "no"  # no in x: 3/4 over 1/2
    assert _failing(cert) == ["unfiltered.details.sup_local (its context, pair and decision)"]
    cert = copy.deepcopy(hand["matrix"])
    cert["observed"]["details"]["equalized_odds"]["event"] = ["yes", "no"]  # P(S) = 1 for both: 0
    assert _failing(cert) == ["observed.details.equalized_odds (its context, pair and event)"]


def _at(cert: dict[str, Any], name: str) -> tuple[dict[str, Any], str] | None:
    """The dictionary and key of the number a check names, if it is a finite number."""
    where: Any = cert
    *path, last = name.split(".")
    for key in path:
        if not isinstance(where, dict) or key not in where:
            return None
        where = where[key]
    value = where.get(last) if isinstance(where, dict) else None
    if not isinstance(value, (int, float)) or isinstance(value, bool):
        return None
    return where, last


def _details(cert: dict[str, Any]) -> list[tuple[str, str, dict[str, Any]]]:
    """(section, metric, detail) of every detail with a pair, for the pair, event and label edits."""
    out = []
    for section in ("observed", "unfiltered"):
        if section not in cert:
            continue
        for key, detail in cert[section]["details"].items():
            if detail["group"] is not None:
                out.append((section, key, detail))
        if cert[section]["global"]["group"] is not None:
            out.append((section, "global", cert[section]["global"]))
    return out


def _check_edits(cert: dict[str, Any]) -> None:
    """Every metric check holds; each of its numbers moved by 1e-7·max(1, |v|) either way (beyond the certificate's
    tolerance, 1e-9) fails; a swapped pair, the complement of an event and a label not among the inputs' fail."""
    checks = _checks(cert)
    assert all(c.holds for c in checks), [c.line() for c in checks if not c.holds]
    for check in checks:
        for sign in (1, -1):
            moved = copy.deepcopy(cert)
            found = _at(moved, check.name)
            if found is None:  # "inf", null or a maximiser
                continue
            where, key = found
            where[key] += sign * 1e-7 * max(1.0, abs(where[key]))
            assert check.name in _failing(moved), (check.name, sign)
    decisions = cert["inputs"]["kernel"]["decisions"]
    for section, key, detail in _details(copy.deepcopy(cert)):
        path = f"{section}.{key}" if key == "global" else f"{section}.details.{key}"
        # a swapped pair (or an event's complement) gives -v: within the tolerance 1e-9 of v when v is as small
        distinct = detail["value"] == "inf" or detail["value"] > 1e-8
        edits = [{"group": detail["other_group"], "other_group": detail["group"]}] if distinct else []
        edits.append({"group": "no such group"})
        if detail.get("context") is not None:
            edits.append({"context": "no such context"})
        if "event" in detail:
            edits.append({"event": [u for u in decisions if u not in detail["event"]]})
            edits.append({"event": ["no such decision"]})
        if "decision" in detail:
            edits.append({"decision": "no such decision"})
        for edit in edits:
            if "event" in edit and not distinct:
                continue
            edited = copy.deepcopy(cert)
            where = edited[section] if key == "global" else edited[section]["details"]
            where[key].update(edit)
            assert any(f.startswith(path + " (its") for f in _failing(edited)), (path, edit)


@pytest.mark.slow
@pytest.mark.parametrize("path", SHIPPED)
def test_shipped_numbers_moved_and_maximisers_edited_fail(path):
    cert = json.loads(json.dumps(fairaudit.certify(ROOT / path).to_dict()))
    assert "unfiltered" in cert and cert["inputs"]["kernel"] is not None
    _check_edits(cert)


@pytest.mark.parametrize("kind", ["matrix", "randomized response"])
def test_hand_numbers_moved_and_maximisers_edited_fail(hand, kind):
    _check_edits(hand[kind])


@pytest.mark.slow
@settings(max_examples=MAX_EXAMPLES, suppress_health_check=[HealthCheck.function_scoped_fixture], deadline=None)
@given(drawn=specs())
def test_random_numbers_moved_and_maximisers_edited_fail(drawn, tmp_path):
    spec, csv = drawn
    assume(csv is not None)
    try:
        cert = certificate_of(spec, csv, tmp_path)
    except InputError:
        assume(False)
        raise
    _check_edits(cert)


def test_what_is_not_re_derived_is_listed(hand):
    cert = copy.deepcopy(hand["matrix"])
    cert["inputs"]["kernel"]["probabilities"][0][0][0] = None  # an empty cell
    skipped: list[tuple[str, str]] = []
    inputs = cert["inputs"]
    m = RecordedMechanism.from_record(inputs["sensitive_mechanism"], "m")
    x = RecordedMechanism.from_record(inputs["context_mechanism"], "m")
    assert metric_checks(cert, m, x, skipped) == []
    assert skipped == [("observed", "the kernel has empty cells"), ("unfiltered", "the kernel has empty cells")]
