"""The strategies of mechanisms keep their promises (exact ε, exact δ at ε, randomized response, products)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import find, given, settings
from hypothesis import strategies as st
from hypothesis.errors import InvalidArgument

from fairaudit import Mechanism
from fairaudit.testing import mechanisms, product_mechanisms, randomized_responses

TOL = 1e-9
EPS = st.floats(0.0, 6.0)
DELTA = st.floats(0.0, 1.0)


def rows_sum_to_one(array: np.ndarray) -> bool:
    rows = array.reshape(-1, array.shape[-1])
    return bool(np.all(np.abs(rows.sum(axis=1) - 1.0) <= 1e-12) and np.all(rows >= 0))


# --------------------------------------------------------------------------- mechanisms


@given(mechanisms(allow_zeros=True, n_outputs=range(1, 4)))
def test_random_mechanisms_are_row_stochastic(m):
    assert isinstance(m, Mechanism) and rows_sum_to_one(m.matrix)


@pytest.mark.slow
@given(st.data(), EPS, st.booleans())
def test_mechanisms_attain_the_requested_epsilon(data, eps, zeros):
    m = data.draw(mechanisms(epsilon=eps, n_inputs=range(2, 5), allow_zeros=zeros))
    assert rows_sum_to_one(m.matrix)
    assert abs(m.epsilon - eps) <= TOL
    # pure ε-DP: no hockey-stick mass left at ε
    assert m.delta(eps) <= TOL


@pytest.mark.slow
@given(mechanisms(epsilon=st.floats(0.0, 3.0), n_inputs=3, n_outputs=range(2, 6)))
def test_rectangular_mechanisms_with_epsilon(m):
    assert m.matrix.shape[0] == 3 and m.outputs[0] == "o0"


@given(mechanisms(epsilon=math.inf, allow_zeros=True))
def test_mechanisms_with_infinite_epsilon(m):
    assert m.epsilon == math.inf and rows_sum_to_one(m.matrix)


@pytest.mark.slow
@given(st.data(), st.floats(0.0, 4.0), DELTA, st.booleans())
def test_mechanisms_attain_the_requested_delta(data, eps, delta, zeros):
    m = data.draw(mechanisms(epsilon=eps, delta=delta, n_inputs=range(2, 5), allow_zeros=zeros))
    assert rows_sum_to_one(m.matrix)
    assert abs(m.delta(eps) - delta) <= TOL
    # every pair has the same divergence δ at ε
    pair = m.pairwise_delta(eps)
    off = ~np.eye(len(m.inputs), dtype=bool)
    assert np.all(np.abs(pair[off] - delta) <= TOL)
    # the profile is non-increasing: above ε it is at most δ
    assert m.delta(eps + 0.5) <= delta + TOL


def test_delta_needs_epsilon():
    with pytest.raises(InvalidArgument):
        find(mechanisms(delta=0.1), lambda m: True)
    with pytest.raises(InvalidArgument):
        find(mechanisms(epsilon=1.0, n_inputs=1), lambda m: True)
    with pytest.raises(InvalidArgument):
        find(mechanisms(epsilon=800.0), lambda m: True)
    with pytest.raises(InvalidArgument):
        find(mechanisms(epsilon=math.inf, delta=0.1), lambda m: True)


@pytest.mark.slow
def test_mechanisms_edge_cases_are_drawn():
    assert find(mechanisms(allow_zeros=True), lambda m: m.epsilon == math.inf).epsilon == math.inf
    assert np.any(
        find(mechanisms(epsilon=1.0, allow_zeros=True, n_inputs=2, n_outputs=3), lambda m: np.any(m.matrix == 0)).matrix
        == 0
    )
    m = find(mechanisms(epsilon=0.5, delta=0.2), lambda m: m.epsilon < math.inf)
    assert abs(m.delta(0.5) - 0.2) <= TOL and m.epsilon > 0.5


@given(randomized_responses())
def test_randomized_responses(m):
    k = len(m.inputs)
    eps = m.epsilon
    assert m.inputs == m.outputs
    assert abs(m.keep_probability - math.exp(eps) / (math.exp(eps) + k - 1)) <= 1e-12


@given(st.data(), st.floats(0.0, 5.0))
def test_randomized_responses_have_the_requested_epsilon(data, eps):
    m = data.draw(randomized_responses(epsilon=eps))
    assert m.epsilon == eps and abs(Mechanism(m.matrix, m.inputs).epsilon - eps) <= TOL


@settings(max_examples=100)
@given(st.data(), st.floats(0.0, 4.0))
def test_product_mechanisms_have_the_requested_epsilon(data, eps):
    m = data.draw(product_mechanisms(epsilon=eps))
    assert all(isinstance(label, tuple) for label in m.inputs) and m.inputs == m.outputs
    assert rows_sum_to_one(m.matrix)
    assert abs(m.epsilon - eps) <= TOL


@given(product_mechanisms(kind="randomized_response", n_attributes=3, n_values=2))
def test_product_of_randomized_responses(m):
    assert len(m.inputs) == 8 and len(m.inputs[0]) == 3
