"""`fairaudit.verification.calibration_check`: the calibrated epsilon re-derived from the recorded member (the shipped
certificates hold; a changed epsilon, bound, target or member fails; the worst case against the hand value 17/13)."""

from __future__ import annotations

import copy
import json
import math
from pathlib import Path

import pytest
from _cli import OFFICE_SPEC

from fairaudit.base.json_values import canonical_digest
from fairaudit.certification.certificate import certify
from fairaudit.certification.spec import parse_spec
from fairaudit.verification.calibration_check import LARGEST
from fairaudit.verification.rederive import verify

ROOT = Path(__file__).resolve().parents[2]

# binary randomized response, utilities in [0.5, 1]: the worst ratio at keep 0.7 is (7/3 + 1/2)/(7/6 + 1) = 17/13
# (proofs/black_box.md §3), so calibrating to ln(17/13) returns epsilon = ln(7/3)
HAND = OFFICE_SPEC.replace('kind = "indicator"\ndecision = "yes"\n', 'kind = "table"\nvalues = [1.0, 0.5]\n')
HAND += f"[target]\nlocal = {math.log(17 / 13)!r}\n"


def _cert(spec: str) -> dict:
    source = str(ROOT / spec) if "\n" not in spec else parse_spec(spec)
    return json.loads(json.dumps(certify(source).to_dict()))


@pytest.fixture(scope="module")
def hand() -> dict:
    return _cert(HAND)


def _named(result, prefix: str) -> dict:
    return {c.name: c for c in result.checks if c.name.startswith(prefix)}


def test_the_hand_calibration_is_re_derived(hand):
    assert hand["calibration"]["method"] == "black_box"
    assert hand["calibration"]["epsilon"] == pytest.approx(math.log(7 / 3), rel=1e-9)
    checks = _named(verify(hand), "calibration")
    assert set(checks) == {
        "calibration.epsilon",
        "calibration.bound",
        "calibration.target",
        LARGEST,
        "calibration.feasible",
    }
    assert all(c.holds for c in checks.values())
    bound = checks["calibration.bound"]
    assert bound.derived_low <= math.log(17 / 13) <= bound.derived_high + 1e-15  # the exact worst case, enclosed
    assert bound.derived_high - bound.derived_low < 1e-15


@pytest.mark.slow
@pytest.mark.parametrize("spec", ["examples/hr_office/hr_office.toml", "examples/llm_hiring/gpt35.toml"])
def test_shipped_calibrations_hold_black_box_and_white_box(spec):
    result = verify(_cert(spec))
    checks = _named(result, "calibration")
    assert result.holds
    assert {"calibration.bound", "calibration.white_box.bound", "calibration.white_box.target"} <= set(checks)
    assert {LARGEST, "calibration.white_box.epsilon is the largest"} <= set(checks)
    assert "calibration" not in dict(result.not_checked)


@pytest.mark.slow
def test_a_white_box_epsilon_of_inf_is_the_largest():
    # gpt4's model meets the target without privacy: the white-box calibration is epsilon = +inf, and no member lies
    # above it (its bound at +inf is re-derived beside it)
    cert = _cert("examples/llm_hiring/gpt4.toml")
    assert cert["calibration"]["white_box"]["epsilon"] == "inf"
    assert cert["inputs"]["calibration"]["white_box_above"] is None
    result = verify(cert)
    largest = _named(result, "calibration.white_box.epsilon is the largest")
    assert [(c.holds, c.detail) for c in largest.values()] == [(True, "epsilon is +inf: no larger epsilon exists")]
    assert _named(result, "calibration.white_box.target")["calibration.white_box.target"].holds
    assert "calibration.white_box.epsilon is the largest" not in dict(result.not_checked)
    cert["calibration"]["white_box"]["epsilon"] = 3.0  # a finite epsilon claimed, with no member above it recorded
    assert "calibration.white_box.epsilon is the largest" in dict(verify(cert).not_checked)


@pytest.mark.parametrize(
    "path, change, failing",
    [
        # not the member's epsilon: moved 1e-7 relative, beyond the certificate's tolerance (1e-9)
        (("calibration", "epsilon"), lambda v: v - 1e-7 * max(1.0, v), "calibration.epsilon"),
        (("calibration", "bound"), lambda v: v - 1e-9, "calibration.bound"),
        (("calibration", "target"), lambda v: v - 1e-6, "calibration.target"),  # a target the worst case misses
    ],
)
def test_a_changed_calibration_fails(hand, path, change, failing):
    tampered = copy.deepcopy(hand)
    section, key = path
    tampered[section][key] = change(tampered[section][key])
    assert failing in [c.name for c in verify(tampered).failures]


def test_a_changed_member_fails(hand):
    tampered = copy.deepcopy(hand)
    tampered["inputs"]["calibration"]["black_box"]["epsilon"] += 1e-6  # a member less private than calibrated
    names = [c.name for c in verify(tampered).failures]
    assert "inputs_sha256" in names and "calibration.epsilon" in names


def test_an_epsilon_below_the_largest_fails():
    # calibrated to a lower target, epsilon is below ln(7/3); claimed for ln(17/13), the member just above it meets
    # ln(17/13) too, so it is not the largest (the inputs, and their digest, are those of a real certificate)
    low = _cert(HAND.replace(f"local = {math.log(17 / 13)!r}", "local = 0.25"))
    assert low["calibration"]["epsilon"] < math.log(7 / 3) - 0.01
    assert verify(low).holds
    low["calibration"]["target"] = math.log(17 / 13)
    result = verify(low)
    assert [c.name for c in result.failures] == [LARGEST]
    assert result.failures[0].detail == "a larger epsilon meets the target too"


def test_a_member_above_that_is_not_above_fails(hand):
    tampered = copy.deepcopy(hand)
    tampered["inputs"]["calibration"]["black_box_above"] = tampered["inputs"]["calibration"]["black_box"]
    tampered["inputs_sha256"] = canonical_digest(tampered["inputs"])
    checks = _named(verify(tampered), LARGEST)
    assert not checks[LARGEST].holds and checks[LARGEST].detail == "the member above is not just above epsilon"


GLOBAL = HAND.replace("[target]\nlocal", "[target]\nglobal")


@pytest.mark.parametrize(
    "population, basis",
    [
        ("[[0.25, 0.25], [0.25, 0.25]]", "worst case on L (L-bar <= L: X and A independent)"),
        # P(x) P(a) in floats: independent only within rounding (F = 1 + 2e-15)
        ("[[0.1, 0.15], [0.30000000000000004, 0.44999999999999996]]", "worst case on L plus ln F"),
        ("[[0.3, 0.2], [0.2, 0.3]]", "worst case on L-bar"),  # dependent: the exact worst case on L-bar itself
    ],
)
def test_a_calibration_on_l_bar_is_re_derived(population, basis):
    cert = _cert(GLOBAL + f"[population]\nprobabilities = {population}\n")
    assert cert["calibration"]["kind"] == "global" and cert["calibration"]["method"] == "black_box"
    result = verify(cert)
    checks = _named(result, "calibration")
    assert result.holds and {"calibration.bound", "calibration.target"} <= set(checks)
    assert basis in checks["calibration.bound"].detail
    if basis.startswith("worst case on L ("):  # the hand value: epsilon = ln(7/3) meets ln(17/13)
        assert cert["calibration"]["epsilon"] == pytest.approx(math.log(7 / 3), rel=1e-9)
    for key, change in (("bound", -1e-9), ("target", -1e-6)):
        tampered = copy.deepcopy(cert)
        tampered["calibration"][key] += change
        assert f"calibration.{key}" in [c.name for c in verify(tampered).failures]


def test_the_member_above_misses_the_target_only_by_its_lower_end():
    # the member above's exact value enclosed in [1/2, 2] against the target 1: it may meet the target (its value
    # may be 1/2), so epsilon is not shown the largest; enclosed in [1, 2], it misses it whatever its value
    from fractions import Fraction as F

    from fairaudit.verification.calibration_check import _largest
    from fairaudit.verification.enclosures import Enclosure

    above = Enclosure(F(1, 1) + F(1, 10**10), F(1, 1) + F(1, 10**10))  # epsilon 1 + 1e-10
    wide, missed = Enclosure(F(1, 2), F(2)), Enclosure(F(1), F(2))
    assert not _largest(LARGEST, 1.0, 1.0, above, wide).holds
    assert _largest(LARGEST, 1.0, 1.0, above, missed).holds


def test_the_members_proofs_bound_them_without_a_solve(monkeypatch):
    # the hand calibration with the floor tau = 0.75, which binds (min g = 0.5): with the exact solve switched off
    # (as beyond its size) each member's bound is re-derived from the thresholds recorded for its programs; without
    # them the bound without floors is above the value, and the check fails

    cert = _cert(HAND.replace("[target]", "tau = 0.75\n[target]"))
    assert set(cert["calibration"]["proofs"]) == {"black_box", "black_box_above"}
    assert cert["calibration"]["proofs"]["black_box"]["screens"]
    bound = _named(verify(cert), "calibration")["calibration.bound"]
    assert bound.holds
    del cert["calibration"]["proofs"]
    assert "calibration.bound" in {c.name for c in verify(cert).failures}
