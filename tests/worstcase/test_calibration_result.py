"""The result of a calibration: :class:`Calibration` repeats its inputs (:class:`Common`) and builds its report."""

from __future__ import annotations

import dataclasses
import math

import fairaudit as fa
from fairaudit.worstcase.calibration import calibrate
from fairaudit.worstcase.calibration_result import Calibration, Common

INPUTS = ("target", "kind", "groups", "gamma", "lower", "tau", "delta", "lipschitz", "diameter")


def test_the_inputs_are_the_common_fields_and_the_report_repeats_them():
    assert tuple(f.name for f in dataclasses.fields(Common)) == INPUTS
    c = calibrate(
        0.5, family=fa.randomized_response_family(range(3)), utility_class=fa.UtilityClass(tau=0.5, lower=0.1)
    )
    assert isinstance(c, Common) and isinstance(c, Calibration)
    d = c.to_dict()
    assert list(d)[:4] == ["epsilon", "keep_probability", "method", "bound"]  # the contract keys first
    assert {k: d[k] for k in INPUTS} == {
        "target": 0.5,
        "kind": "local",
        "groups": 3,
        "gamma": 1.0,
        "lower": 0.1,
        "tau": 0.5,
        "delta": 0.0,
        "lipschitz": 0.0,
        "diameter": 1.0,
    }
    assert d["mechanism"] == c.mechanism.name and d["target_impact_ratio"] is None and "unparsed" not in d


def test_a_result_is_equal_only_to_itself():
    a, b = calibrate(0.5), calibrate(0.5)
    assert a == a and a != b and len({a, b}) == 2


def test_infeasible_report_names_the_family_and_no_tau_is_null():
    c = calibrate(0.3, method="paper", utility_class=fa.UtilityClass(tau=0.5, lipschitz=0.2))
    d = c.to_dict()
    assert (d["feasible"], d["epsilon"], d["mechanism"], d["family"]) == (False, None, c.family, c.family)
    assert "infeasible" in repr(c)
    assert calibrate(0.5).to_dict()["tau"] is None and math.isnan(calibrate(0.5).tau)


def test_the_impact_ratio_target_is_the_nats_target_with_the_ratio_repeated():
    ratio = calibrate(target_impact_ratio=0.8, family=fa.randomized_response_family(range(3)))
    nats = calibrate(math.log(1.25), family=fa.randomized_response_family(range(3)))
    assert ratio.to_dict() == {**nats.to_dict(), "target_impact_ratio": 0.8}
    assert "(impact ratio 0.8)" in repr(ratio)
