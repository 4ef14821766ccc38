"""Exact integer sampling: uniform integers below any bound (one word, several, a power of two) and the pick."""

from __future__ import annotations

import random

import numpy as np
import pytest
from scipy import stats

from fairaudit.filter.exact_sampling import below, pick, random_words, uniform_below, word_count, words


def as_int(row: np.ndarray) -> int:
    return int("".join(f"{int(w):016x}" for w in row), 16)


@pytest.mark.parametrize("bound", [1, 2, 3, 7, 2**63 + 1, 2**64, 2**64 + 1, 3 * 2**130 + 5])
def test_draws_are_below_the_bound_and_cover_its_range(bound):
    draws = uniform_below(bound, 20_000, random.Random(bound % 1000).randbytes)
    assert draws.shape == (20_000, word_count(bound))
    values = [as_int(r) for r in draws]
    assert max(values) < bound
    if bound > 1:  # the top and bottom halves of [0, bound) each get about half (a binomial test)
        low = sum(v < bound // 2 for v in values)
        assert stats.binomtest(low, len(values), (bound // 2) / bound).pvalue > 1e-4


def test_small_bounds_are_uniform():
    draws = uniform_below(5, 100_000, random.Random(3).randbytes)[:, 0]
    assert stats.chisquare(np.bincount(draws.astype(int), minlength=5)).pvalue > 1e-4


def test_words_and_below_compare_as_numbers():
    a = np.array([words(2**64 + 1, 2), words(2**64 - 1, 2), words(5, 2)])
    assert below(a, words(2**64, 2)).tolist() == [False, True, True]
    assert [as_int(r) for r in a] == [2**64 + 1, 2**64 - 1, 5]


def test_pick_follows_the_cumulative_numerators_and_skips_zeros():
    d = np.arange(10, dtype=np.uint64)[:, None]
    assert pick(d, (3, 0, 5, 2)).tolist() == [0, 0, 0, 2, 2, 2, 2, 2, 3, 3]


def test_a_short_source_is_refused():
    with pytest.raises(ValueError, match="returned 3 bytes"):
        random_words(1, 1, lambda n: b"abc")


def test_a_seeded_source_gives_the_same_draws_and_another_seed_others():
    one = uniform_below(10**30, 50, random.Random(1).randbytes)
    assert np.array_equal(one, uniform_below(10**30, 50, random.Random(1).randbytes))
    assert not np.array_equal(one, uniform_below(10**30, 50, random.Random(2).randbytes))
