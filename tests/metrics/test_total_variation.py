"""Group maxima in linear time: the largest TV over pairs of groups by events, L by max and min, ties named.

Every maximum over pairs of groups is a maximum over groups of a range: L = max over contexts of log(max_a E /
min_a E), and the largest TV over pairs is the largest range over groups of P(S), S over the events (subsets of
the decisions, :func:`fairaudit.metrics.total_variation.event_sums`). Checked here against routes written from scratch: every pair
of groups with :func:`itertools.combinations`, exact fractions, and numpy's max minus min at 10^5 groups.
"""

from __future__ import annotations

import itertools
import math
from fractions import Fraction

import numpy as np
import pytest
from _cli import run
from hypothesis import given
from hypothesis import strategies as st

import fairaudit as fa
from fairaudit.laws.tables import Law
from fairaudit.metrics.fairness import all_metrics
from fairaudit.metrics.total_variation import event_sums, max_tv_pair


def _pairwise(rows: np.ndarray) -> tuple[float, list[tuple[int, int]]]:
    """The largest TV over every pair (a < b) of present rows, as Σ_u (P_a − P_b)⁺, and every pair within 4 ulp."""
    present = [a for a in range(len(rows)) if not np.isnan(rows[a, 0])]
    tv = {(a, b): float(np.clip(rows[a] - rows[b], 0.0, None).sum()) for a, b in itertools.combinations(present, 2)}
    best = max(tv.values())
    return best, [p for p, v in tv.items() if v >= best - 4 * np.spacing(max(best, 1e-300))]


@st.composite
def rows(draw):
    """Group rows of counts normalised: few values (ties), zeros, sometimes absent groups (NaN rows)."""
    A, K = draw(st.integers(2, 9)), draw(st.integers(1, 6))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    counts = rng.choice([0, 1, 1, 2, 5], size=(A, K)).astype(float)
    counts[counts.sum(1) == 0, 0] = 1.0
    q = counts / counts.sum(1, keepdims=True)
    absent = rng.random(A) < 0.2
    absent[:2] = False
    q[absent] = np.nan
    return q


@given(rows())
def test_the_largest_tv_by_events_is_the_largest_over_every_pair(q):
    value, a, b = max_tv_pair(q)
    best, pairs = _pairwise(q)
    assert value == pytest.approx(best, abs=4e-16)
    assert a < b and (a, b) in pairs
    assert value == float(np.clip(q[a] - q[b], 0.0, None).sum())  # the named pair's own TV


def test_ties_are_named_by_the_first_event_then_the_first_groups():
    # events (bit masks of decisions u0, u1): {u0} ranges 0.5 (groups 1 vs 3); {u1} 0.5 (groups 2 vs 1); {u0, u1}
    # 0.5 (groups 2 vs 3). The first event by mask is {u0}: the first largest P(u0) is group 1 (tied with 4), the
    # first smallest group 3 (tied with 5)
    q = np.array(
        [
            [0.25, 0.25, 0.5],
            [0.5, 0.0, 0.5],
            [0.25, 0.5, 0.25],
            [0.0, 0.25, 0.75],
            [0.5, 0.0, 0.5],
            [0.0, 0.25, 0.75],
        ]
    )
    assert max_tv_pair(q) == (0.5, 1, 3)
    law = Law(q[None], ["x"], list("abcdef"), ["u0", "u1", "u2"])
    eo = fa.equalized_odds(law)
    assert (eo.value, eo.group, eo.other_group, eo.event) == (0.5, "b", "d", ("u0",))


def test_identical_groups_name_the_first_two_and_one_decision_gives_zero():
    assert max_tv_pair(np.full((4, 3), 1 / 3)) == (0.0, 0, 1)
    assert max_tv_pair(np.array([[np.nan], [1.0], [np.nan], [1.0]])) == (0.0, 1, 3)
    value, a, b = max_tv_pair(np.array([[np.nan, np.nan], [0.5, 0.5]]))  # one group present: no pair
    assert math.isnan(value) and (a, b) == (None, None)


@pytest.mark.parametrize("K", [2, 5, 12])
def test_event_sums_visit_every_subset_once_with_its_exact_sum(K):
    """Integers as floats: every sum exact, so each subset's P(S) equals its sum in fractions."""
    ct = np.arange(1, K + 1, dtype=float)[:, None] * np.array([[1.0, 3.0]])
    seen = {}
    for m, s in event_sums(ct):
        assert m not in seen
        seen[m] = s.copy()
    assert sorted(seen) == list(range(1, 1 << (K - 1)))
    for m, s in seen.items():
        want = sum(Fraction(u + 1) for u in range(K) if m >> u & 1)
        assert s.tolist() == [float(want), float(3 * want)]


def test_a_hundred_thousand_groups_equal_numpy_max_minus_min():
    """10^5 groups, two decisions: L = log(max/min) of P(u1 | a), TV = max − min of P(u0 | a), with the first argmax
    and argmin as the pair (TV's pair in label order); each metric's pair is numpy's."""
    rng = np.random.default_rng(39)
    A = 100_000
    counts = rng.integers(1, 30, size=(1, A, 2)).astype(float)
    law = Law.from_counts(counts, ["all"], [f"g{i}" for i in range(A)], ["no", "yes"])
    p = counts[0] / counts[0].sum(1, keepdims=True)
    result = all_metrics(law, fa.indicator("yes", law.decisions))
    hi, lo = int(np.argmax(p[:, 1])), int(np.argmin(p[:, 1]))
    assert result["local"].value == math.log(p[hi, 1] / p[lo, 1])
    assert (result["local"].group, result["local"].other_group) == (f"g{hi}", f"g{lo}")
    a, b = sorted((int(np.argmax(p[:, 0])), int(np.argmin(p[:, 0]))))
    for kind in ("demographic_parity", "equalized_odds"):
        tv = result[kind]
        assert (tv.group, tv.other_group) == (f"g{a}", f"g{b}")
        assert tv.value == pytest.approx(p[:, 0].max() - p[:, 0].min(), abs=1e-15)


def test_ties_in_l_name_the_first_largest_and_the_first_smallest_group():
    counts = np.array([[[1, 1], [1, 3], [3, 1], [2, 6], [6, 2]]], dtype=float)  # P(yes): 1/2, 1/4, 3/4, 1/4, 3/4
    law = Law.from_counts(counts, ["x"], list("abcde"), ["yes", "no"])
    local = fa.local_fairness(law, fa.indicator("yes", law.decisions))
    assert (local.group, local.other_group, local.value) == ("c", "b", math.log(3))


def test_a_bayes_band_too_large_to_allocate_exits_2_naming_draws(tmp_path, capsys, monkeypatch):
    """numpy's MemoryError for the posterior draws becomes one line: the size, and what to change (before: a
    traceback with numpy's 26.8 GiB allocation at 10^5 groups)."""
    import fairaudit.statistics.bayes as bayes

    def no_memory(rng, alpha, draws):
        raise MemoryError("Unable to allocate 26.8 GiB")

    monkeypatch.setattr(bayes, "_dirichlet", no_memory)
    path = tmp_path / "r.csv"
    path.write_text("g,y\na,1\na,0\nb,1\nb,1\nc,0\nc,1\n")
    code, out, err = run(
        capsys, "audit", path, "--sensitive", "g", "--outcome", "y", "--method", "bayes", "--confidence", "0.9"
    )
    assert code == 2 and out == ""
    # one context: 3 cells x 2 decisions (no pooled groups), 4000 draws, 3 arrays of 8 bytes = 0.55 MiB
    assert err == (
        "fairaudit: error: --draws: 4000 posterior draws of 6 probabilities need about 0.5 MiB, more than this"
        " machine can allocate; use fewer --draws, leave out small cells with --min-count, or --method multinomial"
        " (got 4000)\n"
    )
