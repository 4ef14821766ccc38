"""The pairs' screens: the one-floor relaxation's threshold θ that certify records for every program over the model's
table, against the relaxation solved exactly; and certificates verified from them."""

from __future__ import annotations

import json
from fractions import Fraction as F

import numpy as np
import pytest
from _verified import product_by_group
from hypothesis import given
from hypothesis import strategies as st
from test_black_box_check_duality import _simplex

from fairaudit.base.table_relaxation import relaxation_bounds
from fairaudit.certification.certificate import certify
from fairaudit.certification.spec import parse_spec
from fairaudit.verification.rederive import verify

PRODUCT = """
[sensitive]
name = "profile"
[decision]
name = "outcome"
values = ["chosen", "not chosen"]
[privacy.sensitive]
mechanism = "product"
{components}
[utility]
kind = "indicator"
decision = "chosen"
{tau}
"""

_VALUES = st.sampled_from([F(0), F(1), F(1, 3), F(2, 7), F(1, 2**1000), F(5, 3**40), F(1, 10**12), F(1) + F(1, 2**52)])


def _product(components: int, tau: str = "tau = 0.1") -> dict:
    """The certificate of binary randomized responses keeping 0.7 on ``components`` attributes (2^components groups),
    g = 1{chosen}, tau = 0.1 (or ``tau`` as TOML, "" for none), as JSON."""
    component = '[[privacy.sensitive.components]]\nname = "c{i}"\nmechanism = "randomized_response"\n'
    text = "".join(component.format(i=i) + "values = [0, 1]\nkeep = 0.7\n" for i in range(components))
    return json.loads(json.dumps(certify(parse_spec(PRODUCT.format(components=text, tau=tau))).to_dict()))


def test_sixty_four_groups_are_verified_from_their_proofs():
    # six attributes, 64 groups: the 2 x 64 x 63 programs of L and L-bar are each bounded by the proof certify
    # records, and verify holds; a value moved by 1e-7 (beyond the certificate's tolerance, 1e-9) fails
    cert = _product(6)
    checked = verify(cert)
    assert checked.holds, [c.line() for c in checked.failures]
    assert "bounds.black_box" in {c.name for c in checked.checks}
    cert["bound_details"]["black_box"]["value"] += 1e-7 * max(1.0, cert["bound_details"]["black_box"]["value"])
    assert "bound_details.black_box.value" in {c.name for c in verify(cert).failures}


@pytest.mark.slow
def test_two_hundred_fifty_six_groups_are_verified_whole():
    # eight attributes, 256 groups (about 25 s): the black box, L-bar and the tight bound (every pair's minimum over
    # epsilon) are all re-derived, and hold
    checked = verify(_product(8))
    assert checked.holds, [c.line() for c in checked.failures]
    names = {c.name for c in checked.checks}
    assert {"bounds.black_box", "bound_details.black_box.global.value", "bounds.tight"} <= names


@pytest.mark.slow
def test_a_matrix_of_128_variables_without_a_floor_is_re_derived():
    # seven attributes, 128 groups and released values, no tau: the programs are beyond the 64 variables solved
    # exactly and certify records no dual (no linear program runs), so verify listed the black box as not
    # re-derived; the threshold rule's maximiser attains its bound, and the screens set the other pairs aside
    cert = _product(7, tau="")
    checked = verify(cert)
    assert checked.holds, [c.line() for c in checked.failures]
    assert {"bounds.black_box", "bound_details.black_box.global.value"} <= {c.name for c in checked.checks}
    how = ("bound_details.black_box.worst_model", "bound_details.black_box (certified, certified_from_dual)")
    assert not any("black_box" in name for name, _ in checked.not_checked if name not in how)


def test_over_the_table_a_threshold_below_zero_by_hand():
    # one row, decisions (q, p) = (6/5, 3/14), (3, 3/2), (1/4, 2), (1/2, 9/17), t = 1/3: the largest ratio, 8, has
    # q = 1/4 < 1/3; moving 1/33 of the row to (3, 3/2) reaches q = 1/3 with p = 2 - 1/66, ratio 131/22 (moving to
    # (1/2, 9/17) gives 77/17, to (6/5, 3/14) 1471/266). The hull edge's slope is -2/11: f(-2/11) = -2/11 + 3(2 + 1/22)
    forms = {0: [[F(3, 14), F(3, 2), F(2), F(9, 17)]], 1: [[F(6, 5), F(3), F(1, 4), F(1, 2)]]}
    assert relaxation_bounds(forms, {0: F(1, 3), 1: F(1, 3)})[(0, 1)][0] == F(131, 22)
    assert relaxation_bounds(forms, {0: None, 1: None})[(0, 1)] == (8, None)  # (without the floor: the row on (1/4, 2))


def test_over_the_table_without_a_floor_the_root_between_floats_by_hand():
    # three rows, no floor: R(theta) = 1 + (1 - theta/4) + (3/4 - theta/2) for theta >= 1 (row one's third decision has
    # q = 0 < p), whose root is 11/3, between two floats: the table (third, second, second decision) has ratio
    # (1 + 1 + 3/4)/(0 + 1/4 + 1/2) = 11/3. At the float below it R > 0 in floats, so f is +inf there, and the root is
    # computed exactly all the same (a draft left it out and kept the float above: 11/3 + 1.8e-14)
    top = [[F(1), F(1), F(1)], [F(3, 4), F(1), F(3, 4)], [F(1), F(3, 4), F(1, 2)]]
    bottom = [[F(1, 4), F(1, 4), F(0)], [F(1), F(1, 4), F(1, 4)], [F(3, 4), F(1, 2), F(1, 2)]]
    assert relaxation_bounds({0: top, 1: bottom}, {0: None, 1: None})[(0, 1)] == (F(11, 3), None)


@given(st.data())
def test_each_row_s_maximiser_decided_in_floats_is_the_exact_one(data):
    # floats decide a row only where their error bounds separate its largest p - theta q from the others; near-ties,
    # exact ties (theta at a breakpoint: the largest q wins) and subnormal values are compared exactly. Against the
    # maximisers computed in integers throughout
    from fairaudit.base.exact_duality import on_one_denominator
    from fairaudit.base.table_relaxation import _best, _exact_maximisers, _float_maximisers

    rows, n_u = data.draw(st.integers(1, 4)), data.draw(st.integers(1, 4))
    forms = [[data.draw(st.lists(_VALUES, min_size=n_u, max_size=n_u)) for _ in range(rows)] for _ in range(3)]
    top, bottoms = forms[0], forms[1:]
    thetas = [data.draw(_VALUES), data.draw(_VALUES) * 7]
    for q in bottoms:  # (the breakpoints of the first row: ties)
        thetas += [(top[0][u] - top[0][v]) / (q[0][u] - q[0][v]) for u in range(n_u) for v in range(u)
                   if q[0][u] != q[0][v]]  # fmt: skip
    ints, d = on_one_denominator([[v for row in form for v in row] for form in forms])
    exact = np.array(ints, dtype=object).reshape(3, rows, n_u)
    floats = np.array([[[float(v) for v in row] for row in form] for form in forms])
    for theta in thetas:
        num, den = (np.array([v] * 2, dtype=object) for v in theta.as_integer_ratio())
        values = exact[0][None] * den[:, None, None] - num[:, None, None] * exact[1:]
        found, undecided = _float_maximisers(floats[0], floats[1:], num, den, None)  # (floats decide, then integers)
        programs, left = np.nonzero(undecided)
        found[programs, left] = _exact_maximisers(
            exact[0][left], exact[1:][programs, left], num[programs], den[programs]
        )
        assert (found == _best(values, exact[1:])[1]).all(), theta


@st.composite
def _tables(draw):
    """E_a per group over 1 to 4 rows and 1 to 4 decisions (zeros, tiny cells, near-ties); a floor or none."""
    k, rows, n_u = draw(st.integers(2, 4)), draw(st.integers(1, 4)), draw(st.integers(1, 4))
    forms = {a: [draw(st.lists(_VALUES, min_size=n_u, max_size=n_u)) for _ in range(rows)] for a in range(k)}
    return forms, draw(st.sampled_from([F(1, 10), F(1, 4), F(1, 2), F(1, 10**9), None]))


def _relaxation(top, bottom, t):
    """The pair's one-floor relaxation by the rational simplex (a second route): max (P·K)/(Q·K) over tables K with
    Q·K >= t; None where no table reaches it or no finite maximum."""
    found = _simplex(top, bottom, [bottom], t)
    return found.value if found.status == "optimal" else None


@given(_tables())
def test_every_table_screen_bounds_its_relaxation_is_tight_and_its_threshold_proves_it(program):
    # each pair's relaxation over the tables with E_b·K >= t its only floor, by the rational simplex: the screen, the
    # least f found exactly, is its value; and the threshold returned proves the screen by hand, U = theta +
    # max(R(theta), 0)/t with R(theta) = sum over rows of max_u (E_a - theta E_b)
    forms, t = program
    screens = relaxation_bounds(forms, dict.fromkeys(forms, t))
    assert set(screens) == {(a, b) for a in forms for b in forms if a != b}
    for (a, b), (screen, theta) in screens.items():
        if t is None:
            assert theta is None
            continue
        r = sum(max(p - theta * q for p, q in zip(pr, qr, strict=True)) for pr, qr in zip(forms[a], forms[b]))
        assert screen == theta + max(r, 0) / t
        value = _relaxation(forms[a], forms[b], t)
        if value is not None:
            assert screen == value, (a, b)


@pytest.mark.slow
def test_sixteen_groups_with_a_utility_by_group_are_certified_with_their_proofs():
    # four binary randomized responses keeping 0.7 (16 groups), g by group, tau 0.1: the certificate records a
    # screen's threshold for every program and the multipliers of those an LP bounded; verify checks the black box
    # from them alone and it holds
    cert = json.loads(json.dumps(certify(parse_spec(product_by_group(4, seed=5))).to_dict()))
    details = cert["bound_details"]["black_box"]
    assert len(details["screens"]) == len(details["global"]["screens"]) == 16 * 15  # (one context)
    checked = verify(cert)
    assert checked.holds, [c.line() for c in checked.failures]
    assert {"bounds.black_box", "bounds.global"} <= {c.name for c in checked.checks}


@pytest.mark.slow
def test_sixty_four_groups_with_a_utility_by_group_are_certified_and_verified():
    # six binary randomized responses keeping 0.7 (64 groups), g by group, tau 0.1: certify orders its programs over
    # the model's table by their one-floor relaxations and solves a few (it solved most of 2 x 64 x 63 before), and
    # verify re-derives the black box from a few of them (about 3 s each)
    cert = json.loads(json.dumps(certify(parse_spec(product_by_group(6, seed=6))).to_dict()))
    details = cert["bound_details"]["black_box"]
    assert details["certified"] and details["programs_solved"] <= 4 and details["global"]["programs_solved"] <= 4
    checked = verify(cert)
    assert checked.holds, [c.line() for c in checked.failures]
    assert {"bounds.black_box", "bound_details.black_box.global.value"} <= {c.name for c in checked.checks}
