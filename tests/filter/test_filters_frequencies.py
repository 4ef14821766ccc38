"""The filter's release frequencies over 10^6 draws match its exact matrix (chi-square per input row, fixed seeds)."""

from __future__ import annotations

import random
from fractions import Fraction

import numpy as np
import pytest
from scipy import stats

from fairaudit.filter.filters import PrivacyFilter

DRAWS = 1_000_000
LEVEL = 1e-4  # a row fails when its chi-square p-value is below this (fixed seeds: the result is the same every run)


def counts(f: PrivacyFilter, value, seed: int) -> np.ndarray:
    """How often each output is released for ``DRAWS`` copies of ``value``."""
    released = f.apply([value] * DRAWS, random_bytes=random.Random(seed).randbytes)
    index = {label: i for i, label in enumerate(f.outputs)}
    return np.bincount([index[v] for v in released], minlength=len(f.outputs))


def chi_square_p(observed: np.ndarray, row: tuple[int, ...], denominator: int) -> float:
    """The chi-square p-value of ``observed`` against the exact row (outputs of probability 0 must not occur)."""
    expected = np.array([Fraction(n, denominator) * DRAWS for n in row], dtype=float)
    positive = expected > 0
    assert observed[~positive].sum() == 0  # an output of probability 0 is never released
    return float(stats.chisquare(observed[positive], expected[positive]).pvalue)


FILTERS = {
    "randomized_response": PrivacyFilter.randomized_response(["a", "b", "c"], epsilon=1.0),
    "product": PrivacyFilter.product(
        PrivacyFilter.randomized_response(["f", "m"], keep="3/4"),
        PrivacyFilter.randomized_response([25, 40, 55], epsilon=0.5),
    ),
    "matrix": PrivacyFilter.from_matrix(
        [["1/2", "1/3", "1/6", 0], ["1/10", "1/10", "1/5", "3/5"], [0, "1/7", "4/7", "2/7"]],
        ["x", "y", "z"],
        ["p", "q", "r", "s"],
    ),
}


@pytest.mark.slow
@pytest.mark.parametrize("kind", FILTERS)
def test_every_row_releases_with_its_exact_probabilities(kind):
    f = FILTERS[kind]
    rows = f.numerator_rows()
    for i, value in enumerate(f.inputs):
        observed = counts(f, value, seed=1000 + i)
        assert observed.sum() == DRAWS
        assert chi_square_p(observed, rows[i], f.denominator) > LEVEL, (kind, value)


def test_the_chi_square_check_catches_a_wrong_matrix():
    """The check above can fail: randomized response at ε = 1 does not match the rows of ε = 1.01."""
    f = FILTERS["randomized_response"]
    wrong = PrivacyFilter.randomized_response(["a", "b", "c"], epsilon=1.01)
    observed = counts(f, "a", seed=1000)
    assert chi_square_p(observed, wrong.numerator_rows()[0], wrong.denominator) < LEVEL
