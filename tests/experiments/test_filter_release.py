"""The paper design's release runs the one deployable filter (issue 41, part 4).

``TaskFilter.release`` draws through a :class:`fairaudit.PrivacyFilter` per attribute and one on the context (exact
rational rows, integer sampling) from a source seeded by the query's seed. The filters are built from the same ε as
the mechanisms the analysis reads, and their own ε is never above the analysis's. Expected rows are the mechanisms'
(themselves checked against hand formulas in test_harness.py and test_filter_keep.py).
"""

from __future__ import annotations

import math
import random
from fractions import Fraction

import numpy as np
import pytest
from scipy import stats

from fairaudit import PrivacyFilter
from fairaudit.experiments.harness import plan_queries, query_seed
from fairaudit.experiments.taskfile import HR_DELIVERY, PACKAGE_DELIVERY, parse_task
from fairaudit.experiments.vlm.filter import TaskFilter

HR, PKG = HR_DELIVERY, PACKAGE_DELIVERY

MIXED = """
title = "Mixed sizes"
[task]
candidates = 1
decision = "choose"
[prompt]
user = '''Applicant {{ c1.gender }}, {{ c1.region }}. Loan: {{ context }}. Approve? yes or no.'''
[context]
name = "loan"
values = ["small", "large"]
[[attribute]]
name = "gender"
values = ["female", "male"]
[[attribute]]
name = "region"
values = ["north", "south", "east", "west", "centre"]
[decision]
options = { yes = "approved", no = "denied" }
[utility]
values = { approved = 1.0, denied = 0.0 }
"""

EPSILONS = [0.0, 1e-60, 1e-9, 0.01, 6 * math.log(7 / 3), 50.0, 700.0, 2000.0, math.inf]


def _rows(f: PrivacyFilter) -> np.ndarray:
    """The filter's exact rows as floats (each entry its exact rational rounded once), shape (k, k)."""
    return np.array([[float(Fraction(n, f.denominator)) for n in row] for row in f.numerator_rows()])


def _check_same_filter(f: TaskFilter) -> None:
    """Each running filter's ε ≤ its mechanism's ε (+1e-12) and their rows agree to 1e-15; labels alike."""
    pairs = [*zip(f.attribute_mechanisms, f.attribute_filters), (f.context_mechanism, f.context_filter)]
    for mech, running in pairs:
        assert running.inputs == mech.inputs and running.outputs == mech.outputs, mech.name
        assert running.epsilon <= mech.epsilon + 1e-12, (mech.name, running.epsilon, mech.epsilon)
        np.testing.assert_allclose(_rows(running), mech.matrix, rtol=0, atol=1e-15, err_msg=mech.name)


@pytest.mark.parametrize("epsilon", EPSILONS)
@pytest.mark.parametrize("task", [HR, parse_task(MIXED)], ids=["hr", "mixed"])
def test_the_running_filter_is_the_analysed_one_and_never_less_private(task, epsilon):
    f = TaskFilter.from_epsilon(task, epsilon, context_epsilon=None if math.isinf(epsilon) else epsilon)
    _check_same_filter(f)
    # ε = 0 (and an ε too small for exp_down) is uniform on every attribute, exactly
    if epsilon < 1e-50:
        assert all(g.keep == g.move for g in f.attribute_filters)


def test_the_paper_filters_at_6_ln_7_3_keep_each_attribute_with_0_7_and_the_context_is_shown_as_is():
    f = TaskFilter.for_candidates(HR, 6 * math.log(7 / 3))
    _check_same_filter(f)
    for g in f.attribute_filters:
        assert abs(Fraction(g.keep, g.denominator) - Fraction(7, 10)) < 1e-15
    assert f.context_filter.move == 0 and f.context_filter.epsilon == math.inf


@pytest.mark.slow
def test_release_frequencies_match_the_randomized_response_rows():
    """20,000 releases of one attribute, and 20,000 of the context each from its own seeded source as the harness
    draws them: chi-square against the row, p-value above 1e-4 (fixed seeds, the same result every run).

    The MIXED task's region (5 values, its ε from a budget of 2 nats), 20,000 profiles released in one call, and the
    package task's context (3 values) at ε = ln 2, rows 1/2, 1/4, 1/4.
    """
    n = 20_000
    mixed = parse_task(MIXED)
    f = TaskFilter.from_epsilon(mixed, 2.0)
    region = mixed.attributes[1].values
    ctx, shown = f.release("small", [("female", "east")] * n, np.random.default_rng(7).bytes)
    assert ctx == "small" and len(shown) == n
    shown_region = np.bincount([region.index(p[1]) for p in shown], minlength=len(region))
    g = TaskFilter.from_epsilon(PKG, 1.0, context_epsilon=math.log(2))
    shown_context = np.zeros(len(PKG.contexts), dtype=int)
    for i in range(n):
        ctx, _ = g.release("groceries", (), np.random.default_rng([i, 1]).bytes)
        shown_context[PKG.contexts.index(ctx)] += 1
    assert g.context_mechanism.matrix[1].tolist() == pytest.approx([0.25, 0.5, 0.25], abs=1e-15)
    for observed, mech, true in (
        (shown_region, f.attribute_mechanisms[1], "east"),
        (shown_context, g.context_mechanism, "groceries"),
    ):
        row = mech.matrix[mech.inputs.index(true)]
        assert 0.05 < row.min() < row.max() < 0.95  # neither uniform nor the identity: the test can tell
        assert stats.chisquare(observed, n * row).pvalue > 1e-4, (mech.name, observed, n * row)


def test_release_draws_only_through_the_core_filters_from_the_source_given():
    """The same bytes give the same release as applying the core filters by hand, context first, then each
    attribute over every profile; the identity draws nothing."""
    f = TaskFilter.from_epsilon(HR, 1.5, context_epsilon=0.5)
    profiles = [HR.candidates[1], HR.candidates[0], HR.candidates[1]]
    for seed in range(20):
        got = f.release("sick leave", profiles, random.Random(seed).randbytes)
        source = random.Random(seed).randbytes
        ctx = f.context_filter.apply(["sick leave"], random_bytes=source)[0]
        columns = [a.apply([p[i] for p in profiles], random_bytes=source) for i, a in enumerate(f.attribute_filters)]
        assert got == (ctx, tuple(zip(*columns)))

    def no_bytes(k: int) -> bytes:
        raise AssertionError("the identity draws nothing")

    free = TaskFilter.from_epsilon(HR, math.inf)
    assert free.release("sick leave", profiles, no_bytes) == ("sick leave", tuple(profiles))


def test_the_same_query_seed_gives_the_same_release_for_resumption():
    """The paper design's queries, planned twice (as a resumed run plans them), show the same cells; each query's
    release is the filter's at the source seeded by its own seed, whatever the other queries."""
    eps = 6 * math.log(7 / 3)
    first = plan_queries(HR, "paper", 3, 11, epsilons=[eps], context_epsilon=1.0)
    again = plan_queries(HR, "paper", 3, 11, epsilons=[eps], context_epsilon=1.0)
    assert [(q.id, q.context, q.profiles) for q in first] == [(q.id, q.context, q.profiles) for q in again]
    f = TaskFilter.for_candidates(HR, eps, context_epsilon=1.0)
    for q in first:
        assert q.seed == query_seed(11, q.id)
        ctx, order = q.truth
        assert f.release(ctx, order, np.random.default_rng([q.seed, 1]).bytes) == (q.context, q.profiles)
    other = plan_queries(HR, "paper", 3, 12, epsilons=[eps], context_epsilon=1.0)
    assert [(q.context, q.profiles) for q in other] != [(q.context, q.profiles) for q in first]


def test_the_report_states_the_release_rule():
    from fairaudit.experiments.report import privacy_dict
    from fairaudit.experiments.vlm.filter import RELEASE_RULE

    eps = 6 * math.log(7 / 3)
    privacy = privacy_dict(HR, TaskFilter.for_candidates(HR, eps), eps)
    assert privacy["release"] == RELEASE_RULE and "seeded by the query's seed" in RELEASE_RULE
