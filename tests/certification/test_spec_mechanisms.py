"""The mechanisms of a spec's ``[privacy.*]`` tables, the errors that name their fields, and their family."""

from __future__ import annotations

import json
import math

import numpy as np
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


def _view_spec(rows_at: float, inputs: str) -> str:
    """Tom (25) and Mary (25), each shown with the other: name and age of both through binary randomized response
    at ε/2 per name (the ages are alike: they carry nothing), as a matrix on the 16 views, and its family."""
    p = math.exp(rows_at / 2) / (1 + math.exp(rows_at / 2))
    rr = {v: [p, 1 - p] if i == 0 else [1 - p, p] for i, v in enumerate(["Tom", "Mary"])}
    age = [p, 1 - p]  # 25 of [25, 55]
    rows = [np.kron(np.kron(np.kron(rr[a], age), rr[b]), age).tolist() for a, b in (("Tom", "Mary"), ("Mary", "Tom"))]
    views = [
        f"{n} & {y} | {m} & {z}" for n in ("Tom", "Mary") for y in (25, 55) for m in ("Tom", "Mary") for z in (25, 55)
    ]
    comp = '{mechanism = "randomized_response", values = %s, epsilon = 1.0}'
    one = ", ".join([comp % '["Tom", "Mary"]', comp % "[25, 55]"])
    return HEAD.replace("[sensitive]\n", '[sensitive]\nvalues = ["Tom & 25", "Mary & 25"]\n') + (
        f'[privacy.sensitive]\nmechanism = "matrix"\noutputs = {json.dumps(views)}\nrows = {json.dumps(rows)}\n'
        f"[privacy.family]\ncomponents = [{one}, {one}]\ninputs = {inputs}\n"
    )


def test_a_named_family_is_the_product_on_the_groups_rows():
    # Each name component gets a quarter of the product's budget, and the kept rows differ in the two names only:
    # the member at epsilon is the product at 2 epsilon on those rows, epsilon / 2 per name, as written above.
    rows = '[["Tom", 25, "Mary", 25], ["Mary", 25, "Tom", 25]]'
    spec = parse_spec(_view_spec(1.3, rows))
    family = spec.sensitive_family
    assert family is not None and family.name == "matrix on profile" and family.inputs == spec.groups
    for eps in (0.0, 0.4, 1.3, 5.0):
        expected = parse_spec(_view_spec(eps, rows)).sensitive_mechanism
        assert family(eps).epsilon == pytest.approx(eps, abs=1e-12)
        np.testing.assert_allclose(family(eps).matrix, expected.matrix, rtol=1e-12, atol=1e-15)
        assert family(eps).outputs == expected.outputs
    assert family.keep_probability(1.3) == pytest.approx((math.exp(0.65) / (1 + math.exp(0.65))) ** 4, rel=1e-12)
    assert not family.mixing


def test_a_named_family_must_pass_through_the_mechanism():
    rows = '[["Tom", 25, "Mary", 25], ["Mary", 25, "Tom", 25]]'
    with pytest.raises(
        InputError, match=r"privacy.family: does not pass through the mechanism of \[privacy.sensitive\]"
    ):
        parse_spec(_view_spec(1.3, rows.replace('"Mary", 25], [', '"Mary", 55], [')))
    with pytest.raises(
        InputError,
        match=r"privacy.family: rows: each must be an input of the product: one value of each of its 4 alphabets \(got \('Tom', 30",
    ):
        parse_spec(_view_spec(1.3, rows.replace('[["Tom", 25', '[["Tom", 30')))
    with pytest.raises(InputError, match=r"privacy.family.inputs\[1\]: needs one value per component \(4\)"):
        parse_spec(_view_spec(1.3, rows.replace(', "Tom", 25]]', "]]")))
