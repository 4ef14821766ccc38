"""The main theorem's hypotheses: each checked on the data given (violated, checked or vouched for), through the bounds
that carry them.
"""

from __future__ import annotations

import fairaudit as fa


def test_assumptions_checked_on_data():
    m = fa.randomized_response(["a", "b"], keep=0.7)
    g = fa.indicator("y", ["y", "n"])
    dep = fa.Population([[0.4, 0.1], [0.1, 0.4]], ["x0", "x1"], ["a", "b"])
    b = fa.paper_bound(m, utility_class=fa.UtilityClass(tau=0.2), utility=g, population=dep)
    # X and A dependent voids only L-bar <= L (proofs/main_theorem.md): the bound on L still holds.
    assert b.holds
    status = {a.name: a.status for a in b.assumptions}
    assert status["X independent of A"] == "violated"
    assert [a.scope for a in b.assumptions if a.name == "X independent of A"] == ["global"]
    assert status["M_A is differentially private"] == "checked"
    assert status["g <= gamma"] == "checked"
    assert status["E[g | x, a] >= tau for every model"] == "vouched"
    ind = fa.Population.uniform(["x0", "x1"], ["a", "b"])
    assert fa.tight_bound(m, utility_class=fa.UtilityClass(tau=0.2), utility=g, population=ind).holds
    # A law whose E[g | x, a] = 0.1 < τ = 0.2 violates the τ hypothesis.
    law = fa.Law([[[0.1, 0.9], [0.5, 0.5]], [[0.5, 0.5], [0.5, 0.5]]], ["x0", "x1"], ["a", "b"], ["y", "n"])
    b = fa.tight_bound(m, utility_class=fa.UtilityClass(tau=0.2), utility=g, population=ind, law=law)
    assert not b.holds
    # γ smaller than max g is violated.
    g2 = fa.from_table([0.0, 2.0], ["y", "n"])
    b = fa.paper_bound(m, utility_class=fa.UtilityClass(tau=0.2, gamma=1.5), utility=g2)
    assert {a.name: a.status for a in b.assumptions}["g <= gamma"] == "violated"
