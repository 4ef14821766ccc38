"""The TOML spec: what it builds, checked by hand and against the direct API."""

from __future__ import annotations

import math

import pytest
from _spec_head import HEAD_TAU

import fairaudit as fa
from fairaudit import InputError, parse_spec
from fairaudit.worstcase.calibration import calibrate


def test_product_values_must_match_components():
    with pytest.raises(InputError, match="sensitive.values"):
        parse_spec(
            HEAD_TAU.replace('name = "profile"', 'name = "profile"\nvalues = [["Tom", 25]]')
            + """
[privacy.sensitive]
mechanism = "product"
components = [{mechanism = "identity", values = ["Tom", "Mary"]}, {mechanism = "identity", values = [25, 55]}]
"""
        )


def test_population_and_context_distribution():
    spec = parse_spec(
        HEAD_TAU.replace('name = "profile"', 'name = "profile"\nvalues = ["a", "b"]')
        + """
[context]
name = "doc"
values = ["sick", "holiday"]
distribution = [0.25, 0.75]
[population]
group_distribution = [0.4, 0.6]
"""
    )
    assert spec.population.probabilities.ravel().tolist() == pytest.approx([0.1, 0.15, 0.3, 0.45], rel=1e-15)
    assert spec.population.independence().independent
    dep = parse_spec(
        HEAD_TAU.replace('name = "profile"', 'name = "profile"\nvalues = ["a", "b"]')
        + """
[context]
name = "doc"
values = ["sick", "holiday"]
[population]
probabilities = [[0.4, 0.1], [0.1, 0.4]]
"""
    )
    ind = dep.population.independence()
    assert not ind.independent and ind.max_deviation == pytest.approx(0.15, rel=1e-12)  # 0.4 - 0.5*0.5
    cert = fa.certify(dep)
    # No filter (identity): a model can give E[g | x, a] = 1 to one group and tau = 0.1 to the other, and no more
    # (E <= gamma = 1, E >= tau), so the exact black-box maximum of L and of L-bar is log(1 / 0.1), X and A
    # dependent or not; the tight form, delta(0) = 1, gives log(1 + 1/0.1).
    assert cert.global_bound == pytest.approx(math.log(10), rel=1e-9)
    assert cert.best == pytest.approx(math.log(10), rel=1e-9) and cert.best_form == "black_box"
    assert cert.tight.value == pytest.approx(math.log(11), rel=1e-12)
    assert any(a.name == "X independent of A" and a.status == "violated" for a, _ in cert.assumptions)


def test_table_utility_with_group_dependence():
    # g(u, x, a) = 1{u = a's own office}: depends on the group, L_A = 1 under the discrete metric.
    spec = parse_spec("""
[sensitive]
name = "office"
values = ["HR_1", "HR_2"]
[decision]
name = "office"
values = ["HR_1", "HR_2"]
[privacy.sensitive]
mechanism = "randomized_response"
epsilon = 1.0
[utility]
kind = "table"
values = [[[1.0, 0.0], [0.0, 1.0]]]
tau = 0.5
""")
    assert spec.utility.depends_on_group and spec.lipschitz == 1.0
    cert = fa.certify(spec)
    # Black box by hand: kernel K[released, "HR_1"] = (1, t), keep p = e/(1+e). E[g | HR_1] = p + (1-p) t,
    # E[g | HR_2] = p (1 - t) >= tau = 1/2 binds at t = 1 - 1/(2p); raising K[HR_1-released, HR_1] to 1 only helps
    # (derivative (p^2 - (1-p)^2)/p > 0). Ratio 2 (p + (1-p)(1 - 1/(2p))).
    p = math.e / (1 + math.e)
    want = math.log(2 * (p + (1 - p) * (1 - 1 / (2 * p))))
    assert cert.black_box.local_fairness.value == pytest.approx(want, rel=1e-7)
    assert (cert.black_box.local_fairness.group, cert.black_box.local_fairness.other_group) == ("HR_1", "HR_2")
    assert cert.best == pytest.approx(want, rel=1e-7) and cert.best_form == "black_box"
    # paper: min over eps of eps + log(1 + (1 + delta(eps))/0.5); at eps = 1, delta = 0: 1 + log 3
    assert cert.paper.value <= 1 + math.log(3) + 1e-12
    corollary = [a for a, forms in cert.assumptions if a.name == "g independent of the group"][0]
    assert corollary.status == "violated" and cert.best_form != "corollary"


def test_utility_class_must_contain_g():
    # g = 1{office = HR_2} takes the value 0, so a class [0.5, 1] would certify a model it does not cover.
    with pytest.raises(InputError, match="utility.lower: exceeds the utility's smallest value"):
        parse_spec(HEAD_TAU.replace('name = "profile"', 'name = "profile"\nvalues = ["a", "b"]') + "lower = 0.5\n")
    with pytest.raises(InputError, match="utility.gamma: is below"):
        parse_spec(
            HEAD_TAU.replace('name = "profile"', 'name = "profile"\nvalues = ["a", "b"]').replace(
                "tau = 0.1", "tau = 0.1\ngamma = 0.5"
            )
        )


def test_ignored_fields_are_rejected():
    with pytest.raises(InputError, match="sensitive.distribution: is not a known field"):
        parse_spec(
            HEAD_TAU.replace('name = "profile"', 'name = "profile"\nvalues = ["a", "b"]\ndistribution = [0.5, 0.5]')
        )


def test_metric_with_a_utility_of_the_decision_only():
    spec = parse_spec(
        HEAD_TAU.replace('name = "profile"', 'name = "profile"\nvalues = ["a", "b", "c"]')
        + "metric = [[0, 1, 2], [1, 0, 1], [2, 1, 0]]\n"
    )
    assert spec.utility.diameter(spec.metric) == 2.0 and spec.lipschitz == 0.0


def _one_spec(values, privacy='[privacy.sensitive]\nmechanism = "randomized_response"\nkeep = 0.75'):
    return fa.parse_spec(
        f"""
[sensitive]
name = "office"
values = {values}
[decision]
name = "chosen"
values = ["yes", "no"]
{privacy}
[utility]
kind = "indicator"
decision = "yes"
"""
    )


def test_calibration_options_are_calibrate_keywords():
    spec = _one_spec('["HR_1", "HR_2"]')
    options = spec.calibration_options(groups=2)
    assert options["kernel"] is None and options["utility"] is spec.utility
    # keep 3/4 on two groups is epsilon = log 3; calibrating to that target gives it back
    cal = calibrate(math.log(3), **options)
    assert cal.epsilon == pytest.approx(math.log(3), abs=1e-9)
    assert cal.keep_probability == pytest.approx(0.75, abs=1e-9)
    with pytest.raises(fa.InputError, match=r"^groups: the spec <string> has 2 groups \(got 3\)$"):
        spec.calibration_options(groups=3)
    with pytest.raises(fa.InputError, match=r"^spec: needs at least 2 sensitive groups to calibrate"):
        _one_spec('["HR_1"]', privacy="").calibration_options()


# ---------------------------------------------------------------- a model table counted by DuckDB and numpy
