"""The results of the worst cases: :class:`WorstCase`'s constructors and report dictionary, :class:`WorstModel`'s."""

from __future__ import annotations

import math

import pytest

import fairaudit as fa
from fairaudit.worstcase.pair_search import SearchResult
from fairaudit.worstcase.worst_cases import WorstCase


def test_threshold_case_is_unbounded_exactly_when_its_value_is_infinite():
    finite = WorstCase.threshold("local", 2.5, math.log(2.5), context="x", group="a", other_group="b")
    assert (finite.status, finite.method, finite.solver_status, finite.programs_solved) == (
        "optimal",
        "threshold",
        "threshold",
        0,
    )
    overflow = WorstCase.threshold("global", math.inf, 800.0, context=None, group="a", other_group="b")
    assert overflow.status == "optimal"  # (the ratio overflows, the value in nats does not)
    unbounded = WorstCase.threshold(
        "global",
        math.inf,
        math.inf,
        context=None,
        group="a",
        other_group="b",
        reason="why",
        solver_status="closed form",
    )
    assert (unbounded.status, unbounded.reason, unbounded.solver_status) == ("unbounded", "why", "closed form")


def test_unmet_search_is_infeasible_with_the_reason():
    found = SearchResult(index=-1, result=None, solved=3, reason="")
    w = WorstCase.unmet("local", found, "no decision model meets tau")
    assert math.isnan(w.value) and math.isnan(w.ratio)
    assert (w.status, w.method, w.solver_status, w.reason, w.programs_solved) == (
        "infeasible",
        "lp",
        "",
        "no decision model meets tau",
        3,
    )
    assert w.to_dict()["reason"] == "no decision model meets tau"


def test_searched_case_is_the_maximiser_of_the_worst_utility():
    law = fa.Law([[[0.5, 0.3, 0.2], [0.2, 0.3, 0.5]]], ["x"], ["a", "b"], ["hire", "wait", "reject"])
    w = fa.worst_utility(law, utility_class=fa.UtilityClass(tau=0.3), method="lp").local_fairness
    assert (w.method, w.status, w.context, w.group, w.other_group) == ("lp", "optimal", "x", "a", "b")
    assert w.programs_solved >= 1 and w.value >= math.log(w.ratio)  # ln rounded up
    assert w.value == pytest.approx(math.log(w.ratio), rel=1e-15)


def test_worst_model_report_takes_the_reason_given():
    m = fa.randomized_response(["Tom", "Mary"], keep=0.7)
    w = fa.worst_model(m, fa.indicator("chosen", ["chosen", "not chosen"]))
    d = w.to_dict("the reason")
    assert d["reason"] == "the reason" and "context" in d and "context" not in d["global"]
    assert d["global"] == w.global_fairness.to_dict() and d["worst_model"] == w.local_fairness.kernel.to_dict()
