"""Each result builds its own report dictionary (``to_dict``): the JSON of its command."""

from __future__ import annotations

import json
import math
from fractions import Fraction

import numpy as np
import pandas as pd
import pytest
from _cli import OFFICE_SPEC

import fairaudit as fa
from fairaudit.cli.plan import _plans_dict
from fairaudit.statistics.intervals import Interval


def _strict_json(d):
    """The dictionary survives strict JSON (no NaN or inf numbers) unchanged."""
    return json.loads(json.dumps(d, allow_nan=False))


def test_fairness_and_gaps_by_hand():
    # E[g | x, a] = 1/2 and 1/4 in the one context: L = log 2; TV = 1/4 on the event {0}.
    law = fa.Law([[[0.5, 0.5], [0.25, 0.75]]], contexts=["x"], groups=["a", "b"], decisions=[0, 1])
    g = fa.Utility([1.0, 0.0], [0, 1])
    local = fa.local_fairness(law, g)
    assert local.to_dict() == {
        "value": math.log(2),
        "ratio": 2.0,
        "context": "x",
        "group": "a",
        "other_group": "b",
        "interval": None,
    }
    assert local.to_dict((0.25, float("inf")))["interval"] == [0.25, "inf"]
    assert local.to_dict(Interval(0.1, 0.9, 0.5, 0.95, "multinomial"))["interval"] == [0.1, 0.9]
    assert "context" not in fa.global_fairness(law, g).to_dict()
    dp = fa.demographic_parity(law).to_dict()
    assert dp == {"value": 0.25, "context": None, "group": "a", "other_group": "b", "event": [0]}
    sup = fa.sup_local_fairness(law).to_dict()
    # the largest likelihood ratio: P(0 | a) / P(0 | b) = 2 beats 0.75 / 0.5 = 1.5
    assert (sup["ratio"], sup["decision"]) == (2.0, 0)


def test_mechanism_and_population_by_hand():
    m = fa.randomized_response(["Tom", "Mary", "Ann"], keep=0.5)
    # keep 1/2 over 3 values: the others get 1/4 each, e^epsilon = 2
    d = m.to_dict()
    assert d["epsilon"] == pytest.approx(math.log(2), abs=1e-15)
    assert (d["delta"], d["keep_probability"], d["inputs"], d["outputs"]) == (0.0, 0.5, 3, 3)
    pop = fa.Population.from_counts([[30, 10], [10, 10]], ["x0", "x1"], ["a0", "a1"])
    # P(x0, a0) = 1/2 against P(x0) P(a0) = 2/3 * 2/3 = 4/9: deviation 1/18 (the largest, at every cell)
    p = pop.to_dict()
    assert p["max_deviation"] == pytest.approx(float(Fraction(1, 18)), abs=1e-15)
    assert (p["source"], p["records"], p["independent"]) == ("records", 60, False)
    assert fa.Population.uniform(["x"], ["a", "b"], source="assumed").to_dict()["independent"] == "assumed"


def test_kernel_dict_labels_as_text():
    k = fa.Kernel([[[0.2, 0.8], [1 / 3, 2 / 3]]], [("doc", 1)], ["HR_1", 2], ["go", "stay"])
    assert k.to_dict() == {
        "doc & 1": {"HR_1": {"go": 0.2, "stay": 0.8}, "2": {"go": 0.333333333333, "stay": 0.666666666667}}
    }


@pytest.fixture(scope="module")
def certificate(tmp_path_factory):
    folder = tmp_path_factory.mktemp("spec")
    rows = [
        ("maternity", "HR_1", "yes", 0.6),
        ("maternity", "HR_1", "no", 0.4),
        ("maternity", "HR_2", "yes", 0.3),
        ("maternity", "HR_2", "no", 0.7),
        ("holiday", "HR_1", "yes", 0.5),
        ("holiday", "HR_1", "no", 0.5),
        ("holiday", "HR_2", "yes", 0.5),
        ("holiday", "HR_2", "no", 0.5),
    ]
    pd.DataFrame(rows, columns=["document", "office", "chosen", "probability"]).to_csv(folder / "k.csv", index=False)
    (folder / "spec.toml").write_text(OFFICE_SPEC + '[model]\ntable = "k.csv"\n[target]\nlocal = 0.3\n')
    return fa.certify(folder / "spec.toml")


def test_certificate_to_dict(certificate):
    d = certificate.to_dict()
    assert _strict_json(d) == d
    # the worst case over every model is the kernel the certificate reports
    bb = d["bound_details"]["black_box"]
    assert bb["value"] == d["bounds"]["black_box"] == certificate.black_box.local_fairness.value
    assert bb["worst_model"] == certificate.black_box.local_fairness.kernel.to_dict()
    assert d["observed"]["local"]["value"] == certificate.observed.local_fairness.value
    assert d["targets"]["local"] == certificate.targets["local"].to_dict()
    assert d["calibration"]["epsilon"] == certificate.calibration.epsilon
    assert d["privacy"]["sensitive"] == certificate.spec.sensitive_mechanism.to_dict()


def test_audit_and_intervals_dicts():
    records = pd.DataFrame({"g": ["a"] * 4 + ["b"] * 4, "y": [1, 1, 1, 0, 1, 0, 0, 0]})
    a = fa.audit(records, sensitive="g", outcome="y", positive=1, intervals=fa.IntervalOptions(confidence=0.9))
    d = a.to_dict()
    assert _strict_json(d) == d
    # selection rates 3/4 and 1/4: L = log 3
    assert d["local"]["value"] == pytest.approx(math.log(3), abs=1e-15)
    assert [c["expected_utility"] for c in d["cells"]] == [0.75, 0.25]
    assert d["intervals"] == a.intervals.to_dict()
    local = d["intervals"]["local"]
    assert local["lower"] <= math.log(3) <= local["upper"] and local["estimate"] == d["local"]["value"]


def test_calibration_and_plan_dicts():
    c = fa.calibrate_randomized_response(0.5, groups=2)
    assert c.to_dict()["keep_probability"] == pytest.approx(math.exp(0.5) / (math.exp(0.5) + 1), abs=1e-15)
    plans = [
        fa.plan(target=1.0, disparity=0.2, method=m, datasets=4, max_n=200, seed=1)
        for m in ("clopper-pearson", "multinomial")
    ]
    joined = _plans_dict(plans)
    assert [p["method"] for p in joined["plans"]] == ["clopper-pearson", "multinomial"]
    assert joined["feasible"] == all(p.feasible for p in plans)
    assert {k: v for k, v in joined.items() if k not in ("plans", "feasible")} == {
        k: v for k, v in plans[0].to_dict().items() if k not in ("plans", "feasible")
    }
    assert np.isfinite(joined["true_value"])
