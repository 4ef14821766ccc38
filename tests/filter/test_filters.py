"""PrivacyFilter: exact ε by hand, the rounding of randomized response, δ(ε), values outside the labels, the JSON."""

from __future__ import annotations

import json
import math
import random
from fractions import Fraction

import mpmath
import pytest

from fairaudit.base.errors import InputError
from fairaudit.base.outward import log_up
from fairaudit.filter.filters import PrivacyFilter
from fairaudit.laws.closed_forms import randomized_response
from fairaudit.laws.mechanisms import from_matrix, identity, product

mpmath.mp.dps = 60


def rr(values, **kw):
    return PrivacyFilter.randomized_response(values, **kw)


# -- exact epsilon -----------------------------------------------------------------------------------------------


def test_keep_three_quarters_on_two_values_is_ln_3():
    f = rr(["a", "b"], keep="3/4")
    assert (f.keep, f.move, f.denominator, f.ratio) == (3, 1, 4, 3)
    assert f.epsilon == log_up(3) and math.log(3) <= f.epsilon <= math.nextafter(math.log(3), 4)
    assert rr(["a", "b"], keep=0.75).to_dict() == f.to_dict()  # 0.75 is 3/4 in binary too


def test_keep_on_k_values_moves_evenly():
    f = rr([0, 1, 2, 3], keep="2/5")  # the others get (3/5)/3 = 1/5 each: ratio 2
    assert f.numerator_rows()[0] == (2, 1, 1, 1) and f.denominator == 5 and f.ratio == 2


def test_matrix_product_and_infinite_epsilon_by_hand():
    m = PrivacyFilter.from_matrix([["9/10", "1/10"], ["7/10", "3/10"]], [0, 1])
    assert m.ratio == 3 and m.epsilon == log_up(3)  # the paper's X-privacy mechanism: max(9/7, 3/1)
    p = PrivacyFilter.product(rr(["f", "m"], keep="3/4"), rr([1, 2, 3], keep="1/2"))
    assert p.ratio == 3 * 2 and p.epsilon == log_up(6) and p.denominator == 4 * 4
    zero = PrivacyFilter.from_matrix([["1/2", "1/2"], [1, 0]], ["a", "b"])
    assert zero.ratio == math.inf and zero.epsilon == math.inf
    assert rr(["a", "b"], keep=1).epsilon == math.inf and rr(["a", "b"], epsilon=math.inf).epsilon == math.inf
    assert rr(["only"], epsilon=3.0).epsilon == 0.0 and rr(["a", "b"], keep="1/2").epsilon == 0.0


@pytest.mark.parametrize("epsilon", [1e-12, 1e-6, 0.1, 0.5, 1.0, math.log(3), 5.0, 30.0, 100.0, 600.0, 700.0])
@pytest.mark.parametrize("k", [2, 3, 1000])
def test_randomized_response_from_epsilon_is_at_most_as_asked_and_close(epsilon, k):
    f = rr(list(range(k)), epsilon=epsilon)
    exact = mpmath.log(mpmath.mpf(f.keep) / mpmath.mpf(f.move))  # 60 digits
    assert exact <= epsilon  # at least as private as asked
    assert epsilon - exact <= 1e-15 * max(1.0, epsilon)
    assert f.epsilon >= exact and f.epsilon - exact <= 2.0**-52 * max(1.0, epsilon)  # rounded up, by an ulp
    assert f.keep + (k - 1) * f.move == f.denominator and f.requested_epsilon == epsilon
    assert f.rounding.startswith("keep rounded down")


@pytest.mark.parametrize("epsilon", [5e-324, 1e-300, 1e-60, 1e-50])
def test_a_tiny_epsilon_gives_uniform_rows_not_an_error(epsilon):
    """exp_down(ε) is 1 − 2^-53 for ε ≤ about 1e-50; the filter keeps with t = 1 ≤ e^ε instead (exact ε 0)."""
    f = rr(["a", "b", "c"], epsilon=epsilon)
    assert (f.keep, f.move, f.denominator) == (1, 1, 3) and f.epsilon == 0.0 and f.requested_epsilon == epsilon


def test_keep_outside_its_range_and_bad_arguments_are_refused():
    with pytest.raises(InputError, match=r"^keep: must be a keep probability in \[1/k, 1\] = \[1/3, 1\]"):
        rr(["a", "b", "c"], keep="1/4")
    with pytest.raises(InputError, match="give exactly one of `epsilon` and `keep`"):
        rr(["a", "b"], epsilon=1.0, keep="1/2")
    with pytest.raises(InputError, match="^epsilon: "):
        rr(["a", "b"], epsilon=-1.0)


# -- delta -------------------------------------------------------------------------------------------------------


def delta_60(f: PrivacyFilter, eps: float):
    """δ(ε) in 60 digits from the exact rows."""
    rows, t = f.numerator_rows(), mpmath.exp(mpmath.mpf(eps))
    return max(
        sum(max(mpmath.mpf(0), (x - t * y) / mpmath.mpf(f.denominator)) for x, y in zip(p, q))
        for i, p in enumerate(rows)
        for j, q in enumerate(rows)
        if i != j
    )


@pytest.mark.parametrize("eps", [0.0, 0.3, 1.0, 1.0986, 2.0])
def test_delta_is_rounded_up_and_randomized_response_agrees_with_its_rows(eps):
    filters = [
        rr(["a", "b", "c"], keep="3/5"),
        PrivacyFilter.from_matrix([["9/10", "1/10"], ["7/10", "3/10"]], [0, 1]),
        PrivacyFilter.product(rr(["f", "m"], keep="3/4"), rr([1, 2], keep="2/3")),
    ]
    for f in filters:
        exact = delta_60(f, eps)
        assert f.delta(eps) >= exact and f.delta(eps) - exact <= 1e-15
    same = PrivacyFilter.from_matrix(
        [[Fraction(n, filters[0].denominator) for n in row] for row in filters[0].numerator_rows()], ["a", "b", "c"]
    )
    assert same.delta(eps) == filters[0].delta(eps)


def test_delta_at_infinity_is_the_mass_another_input_cannot_reach():
    assert rr(["a", "b"], keep=1).delta(math.inf) == 1.0 and rr(["a", "b"], keep="3/4").delta(math.inf) == 0.0
    assert PrivacyFilter.from_matrix([["1/2", "1/2"], [1, 0]], ["a", "b"]).delta(math.inf) == 0.5


# -- apply -------------------------------------------------------------------------------------------------------


def test_a_value_outside_the_labels_is_named():
    f = rr(["Tom", "Mary"], keep="3/4")
    with pytest.raises(InputError, match=r"^values: holds a value that is not among .* \(got 'Bob'\)"):
        f.apply(["Tom", "Bob", "Mary"])
    with pytest.raises(InputError, match=r"^values: .*\(got \[1\]\)"):
        f.apply(["Tom", [1]])  # not even hashable
    p = PrivacyFilter.product(f, rr([25, 55], keep="3/4"))
    with pytest.raises(InputError, match=r"^values \(component 1\): .*\(got 30\)"):
        p.apply([("Tom", 25), ("Mary", 30)])
    with pytest.raises(InputError, match=r"^values: must be tuples of 2 values"):
        p.apply([("Tom", 25), "Mary"])


def test_a_seeded_source_is_deterministic_and_the_default_is_secure():
    f = PrivacyFilter.product(rr(["f", "m"], epsilon=0.3), rr([1, 2, 3], keep="1/2"))
    values = [("f", 1), ("m", 3), ("m", 2)] * 200
    first = f.apply(values, random_bytes=random.Random(5).randbytes)
    assert first == f.apply(values, random_bytes=random.Random(5).randbytes)
    assert first != f.apply(values, random_bytes=random.Random(6).randbytes)
    assert len(f.apply(values)) == len(values) and f.apply([]) == []


def test_the_identity_releases_each_value_unchanged_and_draws_nothing():
    def no_bytes(n):
        raise AssertionError("the identity draws no random bytes")

    assert rr(["a", "b"], keep=1).apply(["b", "a"], random_bytes=no_bytes) == ["b", "a"]


# -- from a Mechanism ----------------------------------------------------------------------------------------------


def test_from_mechanism():
    f = PrivacyFilter.from_mechanism(randomized_response(["a", "b", "c"], epsilon=0.7))
    assert f.kind == "randomized_response" and f.epsilon == rr(["a", "b", "c"], epsilon=0.7).epsilon
    assert PrivacyFilter.from_mechanism(identity(["a", "b"])).epsilon == math.inf
    m = PrivacyFilter.from_mechanism(from_matrix([[0.9, 0.1], [0.7, 0.3]], [0, 1]))
    assert m.rows == ((9, 1), (7, 3)) and m.denominator == 10  # the decimals a spec writes
    half = PrivacyFilter.from_mechanism(from_matrix([[0.5, 0.25, 0.25], [0.25, 0.5, 0.25]], [0, 1], ["x", "y", "z"]))
    assert half.rows == ((2, 1, 1), (1, 2, 1))
    pair = product(randomized_response([0, 1], keep=0.75), randomized_response(["a", "b"], keep=0.5))
    assert PrivacyFilter.from_mechanism(pair).ratio == 3


# -- JSON --------------------------------------------------------------------------------------------------------


ROUND_TRIP = {
    "rr_epsilon": rr(["a", "b", "c"], epsilon=600.0),
    "rr_keep": rr([1, 2], keep="7/10"),
    "matrix": PrivacyFilter.from_matrix([["1/3", "2/3"], [1, 0]], [("f", 1), ("m", 2)], [True, False]),
    "product": PrivacyFilter.product(
        rr(["f", "m"], epsilon=0.5), PrivacyFilter.from_matrix([["1/2", "1/2"]], ["x"], ["y", "z"])
    ),
}


@pytest.mark.parametrize("name", ROUND_TRIP)
def test_to_dict_and_from_dict_round_trip_exactly(name):
    f = ROUND_TRIP[name]
    d = json.loads(json.dumps(f.to_dict()))
    g = PrivacyFilter.from_dict(d)
    assert g.to_dict() == f.to_dict() and g.numerator_rows() == f.numerator_rows() and g.inputs == f.inputs
    assert (g.denominator, g.ratio, g.epsilon, g.rounding, g.requested_epsilon) == (
        f.denominator,
        f.ratio,
        f.epsilon,
        f.rounding,
        f.requested_epsilon,
    )
    assert d["format"] == "fairaudit-filter" and d["format_version"] == 1 and d["mechanism"] == f.kind


def test_from_dict_refuses_a_changed_dictionary():
    d = rr(["a", "b"], keep="3/4").to_dict()
    with pytest.raises(InputError, match="^epsilon: is not the filter's own epsilon"):
        PrivacyFilter.from_dict({**d, "epsilon": d["epsilon"] - 1e-9})
    with pytest.raises(InputError, match="^keep: must be keep >= move >= 0 with keep"):
        PrivacyFilter.from_dict({**d, "keep": "4"})
    with pytest.raises(InputError, match="^format_version: must be 1"):
        PrivacyFilter.from_dict({**d, "format_version": 2})
    with pytest.raises(InputError, match="^format: must be 'fairaudit-filter'"):
        PrivacyFilter.from_dict({**d, "format": "other"})
    m = ROUND_TRIP["product"].to_dict()
    m["components"][1]["rows"] = [["1", "2"]]
    with pytest.raises(InputError, match=r"^components\[1\]\.rows\[0\]: must sum to the denominator 2"):
        PrivacyFilter.from_dict(m)
    with pytest.raises(InputError, match="^denominator: is missing"):
        PrivacyFilter.from_dict({k: v for k, v in d.items() if k != "denominator"})
