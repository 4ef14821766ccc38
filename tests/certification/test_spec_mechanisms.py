"""The mechanisms of a spec's ``[privacy.*]`` tables, the errors that name their fields, and their family."""

from __future__ import annotations

import math

import pytest
from _spec_head import HEAD

from fairaudit import InputError, parse_spec
from fairaudit.certification.spec_mechanisms import build_mechanism, mechanism_family
from fairaudit.certification.spec_schema import MechanismSpec


def test_product_mechanism_from_spec():
    # The paper's filter: name, age and race randomized independently, each kept with p = 0.7.
    spec = parse_spec(
        HEAD
        + """
[privacy.sensitive]
mechanism = "product"
components = [
  {mechanism = "randomized_response", keep = 0.7, values = ["Tom", "Mary"]},
  {mechanism = "randomized_response", keep = 0.7, values = [25, 55]},
  {mechanism = "randomized_response", keep = 0.7, values = ["Asian", "American"]},
]
"""
    )
    m = spec.sensitive_mechanism
    assert len(spec.groups) == 8 and spec.groups[0] == ("Tom", 25, "Asian")
    assert m.epsilon == pytest.approx(3 * math.log(7 / 3), rel=1e-12)  # 2.5419, not 3 * 0.7/0.3
    # P((Tom,25,Asian) -> (Mary,25,Asian)) = 0.3 * 0.7 * 0.7
    assert m.matrix[0, m.outputs.index(("Mary", 25, "Asian"))] == pytest.approx(0.147, rel=1e-12)
    # the family splits epsilon in proportion to the components' (here equally)
    family = spec.sensitive_family
    assert family is not None and family(3.0).epsilon == pytest.approx(3.0, rel=1e-12)


def test_errors_name_the_fields_of_the_table():
    inner = MechanismSpec(mechanism="randomized_response", keep=0.5, values=["a"])
    table = MechanismSpec(mechanism="product", components=[MechanismSpec(mechanism="identity", values=[1, 2]), inner])
    with pytest.raises(InputError) as err:
        build_mechanism(table, None, "filter", "spec.toml: privacy.sensitive")
    assert err.value.field == "spec.toml: privacy.sensitive.components[1].keep"
    assert str(err.value).endswith("keep must be 1 (or use identity) (got 0.5)")
    with pytest.raises(InputError, match=r"^spec.toml: privacy.sensitive: values: are required$"):
        build_mechanism(MechanismSpec(mechanism="identity"), None, "filter", "spec.toml: privacy.sensitive")


def test_a_family_needs_two_groups():
    table = MechanismSpec(mechanism="randomized_response", epsilon=1.0)
    assert mechanism_family(table, ("a",)) is None
    family = mechanism_family(table, ("a", "b", "c"))
    assert family is not None and family.name == "3-ary randomized response"
