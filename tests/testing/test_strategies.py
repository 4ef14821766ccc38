"""The strategies of populations, kernels, laws and utilities keep their promises (dependence, edge cases, exact range)."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from hypothesis import find, given
from hypothesis import strategies as st
from hypothesis.errors import InvalidArgument

from fairaudit import Kernel, Law, Population, Utility, compose
from fairaudit.testing import (
    kernels,
    laws,
    mechanisms,
    populations,
    utilities,
)


def rows_sum_to_one(array: np.ndarray) -> bool:
    rows = array.reshape(-1, array.shape[-1])
    rows = rows[~np.isnan(rows[:, 0])]
    return bool(np.all(np.abs(rows.sum(axis=1) - 1.0) <= 1e-12) and np.all(rows >= 0))


# --------------------------------------------------------------------------- import hygiene


def test_import_fairaudit_does_not_import_hypothesis():
    code = "import fairaudit, sys; assert 'hypothesis' not in sys.modules"
    subprocess.run([sys.executable, "-c", code], check=True)


# --------------------------------------------------------------------------- populations


@given(populations(independent=True, allow_zero_contexts=True))
def test_independent_populations_are_independent(pop):
    assert isinstance(pop, Population)
    assert pop.independence().independent
    assert np.all(pop.p_group > 0) and abs(pop.probabilities.sum() - 1) <= 1e-12


@pytest.mark.slow
@given(populations(independent=False, allow_zero_contexts=True, contexts=range(2, 5)))
def test_dependent_populations_are_dependent(pop):
    check = pop.independence()
    assert not check.independent and check.max_deviation >= 1e-6
    assert np.all(pop.p_group > 0) and (pop.p_context > 0).sum() >= 2


def test_populations_edge_cases_are_drawn():
    assert find(populations(allow_zero_contexts=True), lambda p: np.any(p.p_context == 0)).p_context.min() == 0
    assert len(find(populations(), lambda p: len(p.contexts) == 1).contexts) == 1
    dep = find(populations(), lambda p: not p.independence().independent)
    assert dep.independence().max_deviation >= 1e-6


@pytest.mark.parametrize("kwargs", [dict(independent=False, contexts=1), dict(independent=False, groups=range(1, 2))])
def test_populations_refuse_impossible_dependence(kwargs):
    with pytest.raises(InvalidArgument):
        find(populations(**kwargs), lambda p: True)


# --------------------------------------------------------------------------- kernels and laws


@given(kernels(allow_zeros=True))
def test_kernels_are_row_stochastic(k):
    assert isinstance(k, Kernel) and rows_sum_to_one(k.probabilities)


@given(kernels(deterministic=True))
def test_deterministic_kernels_are_one_hot(k):
    assert np.all((k.probabilities == 0) | (k.probabilities == 1))


@given(st.data(), mechanisms(epsilon=1.0))
def test_kernels_compose_with_mechanism_outputs(data, m):
    k = data.draw(kernels(groups=m.outputs))
    law = compose(k, sensitive=m)
    assert law.groups == m.inputs and rows_sum_to_one(law.probabilities)


@given(laws(zero_cells=True))
def test_laws_are_row_stochastic(law):
    assert isinstance(law, Law) and rows_sum_to_one(law.probabilities)


@given(laws())
def test_laws_without_zero_cells_are_positive(law):
    assert np.all(law.probabilities > 0)


@given(laws(counts=True))
def test_laws_from_counts(law):
    assert law.observed.any() and rows_sum_to_one(law.probabilities)
    assert len(law.empty_cells) == int((law.cell_counts == 0).sum())


@pytest.mark.slow
def test_laws_edge_cases_are_drawn():
    assert find(laws(), lambda q: len(q.groups) == 1).shape[1] == 1
    assert find(laws(), lambda q: len(q.contexts) == 1).shape[0] == 1
    assert find(laws(), lambda q: len(q.decisions) == 1).shape[2] == 1
    one = find(laws(), lambda q: True)
    assert one.shape == (1, 1, 1)
    zero = find(laws(zero_cells=True), lambda q: np.any(q.probabilities == 0))
    assert np.any(zero.probabilities == 0)
    empty = find(laws(counts=True), lambda q: len(q.empty_cells) > 0)
    assert empty.empty_cells and empty.observed.any()
    big = find(laws(), lambda q: q.shape == (2, 3, 3))
    assert big.shape == (2, 3, 3)


# --------------------------------------------------------------------------- utilities

RANGES = st.tuples(st.floats(0.0, 5.0), st.floats(0.0, 5.0)).map(sorted)


@given(st.data(), RANGES)
def test_utilities_have_the_exact_range(data, bounds):
    lower, gamma = bounds
    g = data.draw(utilities(gamma=gamma, lower=lower))
    assert isinstance(g, Utility) and g.values.ndim == 1
    assert g.gamma == gamma and g.lower == lower and g.lipschitz() == 0.0


@given(st.data(), RANGES)
def test_table_utilities_independent_of_group(data, bounds):
    lower, gamma = bounds
    g = data.draw(utilities(gamma=gamma, lower=lower, contexts=range(1, 3), groups=range(1, 4)))
    assert g.values.ndim == 3 and g.gamma == gamma and g.lower == lower
    assert not g.depends_on_group and g.lipschitz() == 0.0


@given(st.data(), RANGES.filter(lambda b: b[1] > b[0]))
def test_group_dependent_utilities(data, bounds):
    lower, gamma = bounds
    g = data.draw(utilities(gamma=gamma, lower=lower, depends_on_group=True, contexts=range(1, 3), groups=range(2, 4)))
    assert g.depends_on_group and g.gamma == gamma and g.lower == lower
    assert 0 < g.lipschitz() <= gamma - lower + 1e-12


@pytest.mark.slow
@given(st.data(), RANGES.filter(lambda b: b[1] > b[0]), st.floats(0.01, 1.0))
def test_utilities_with_a_lipschitz_constant(data, bounds, share):
    lower, gamma = bounds
    lip = share * (gamma - lower)
    g = data.draw(
        utilities(
            decisions=range(2, 4), gamma=gamma, lower=lower, lipschitz=lip, contexts=range(1, 3), groups=range(2, 4)
        )
    )
    assert g.gamma == gamma and g.lower == lower
    assert abs(g.lipschitz() - lip) <= 1e-12 * max(1.0, gamma)


def test_utilities_refuse_impossible_requests():
    for kwargs in (
        dict(gamma=1.0, lower=2.0),
        dict(decisions=1, gamma=1.0, lower=0.0),
        dict(gamma=1.0, lower=0.0, lipschitz=2.0),
        dict(decisions=1, contexts=1, groups=2, gamma=1.0, lower=0.0, lipschitz=0.5),
    ):
        with pytest.raises(InvalidArgument):
            find(utilities(**kwargs), lambda g: True)
