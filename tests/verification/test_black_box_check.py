"""The verifier's black-box worst cases (exact programs) against the tool's own LP route, and by hand."""

from __future__ import annotations

import json
import math
from fractions import Fraction as F

import pytest
from _cli import OFFICE_SPEC
from _exact_route import exact_enclosures, kernel_global
from _verified import certified_and_verified

import fairaudit.verification.black_box_check as bb
from fairaudit.certification.certificate import certify
from fairaudit.certification.spec import parse_spec
from fairaudit.verification.black_box_check import black_box_enclosures
from fairaudit.verification.evidence import Evidence
from fairaudit.verification.rederive import verify

OFFICE = OFFICE_SPEC + "tau = 0.25\n"  # binary randomized response keeping 0.7, g = 1{yes}

RR3 = """
[sensitive]
name = "group"
values = ["a", "b", "c"]
[context]
name = "job"
values = ["x", "y"]
[decision]
name = "rank"
values = ["1", "2", "3"]
[privacy.sensitive]
mechanism = "randomized_response"
epsilon = 1.3
[utility]
kind = "table"
values = [1.0, 0.5, 0.0]
tau = 0.3
"""


@pytest.mark.parametrize(
    "spec", [RR3, RR3.replace("tau = 0.3", "tau = 0.05"), OFFICE], ids=["binding", "loose", "office"]
)
def test_the_black_box_agrees_with_the_tools_lp_route(spec):
    # the bounds the certificate's proofs give (three cells behind randomized response) against the tool's own LP
    # route: two routes to the worst case
    from fairaudit.worstcase.known_utility import worst_model

    parsed = parse_spec(spec)
    cert = json.loads(json.dumps(certify(parsed).to_dict()))
    assert verify(cert).holds, [c.line() for c in verify(cert).failures]
    worst = black_box_enclosures(cert["inputs"], cert["bound_details"]["black_box"])
    lp = worst_model(parsed.sensitive_mechanism, parsed.utility, population=parsed.population, tau=parsed.tau,
                     context_mechanism=parsed.context_mechanism, method="lp")  # fmt: skip
    assert math.log(worst.local.hi) == pytest.approx(lp.local_fairness.value, rel=1e-8, abs=1e-9)
    assert math.log(worst.global_.hi) == pytest.approx(lp.global_fairness.value, rel=1e-8, abs=1e-9)


def test_binary_randomized_response_by_hand():
    # keep 0.7, g = 1{yes}, tau = 0.25 (not binding at the threshold point: M[a']·h = 0.3 >= 0.25): the ratio 7/3,
    # its log the mechanism's epsilon
    cert = json.loads(json.dumps(certify(parse_spec(OFFICE)).to_dict()))
    worst = black_box_enclosures(cert["inputs"])
    t = math.exp(cert["inputs"]["sensitive_mechanism"]["epsilon"])
    assert float(worst.local.lo) == pytest.approx(t, rel=1e-15) and worst.local.hi - worst.local.lo < 1e-40


def _many_contexts(n_contexts, k=3, tau=0.4):
    """Randomized response on k groups, n contexts whose g(no) cycles through 0, 1/4, 1/2, X and A independent."""
    groups, contexts = [f"g{i}" for i in range(k)], [f"c{i}" for i in range(n_contexts)]
    values = [[[1.0, (0.0, 0.25, 0.5)[x % 3]]] * k for x in range(n_contexts)]
    return {
        "sensitive_mechanism": {"inputs": groups, "outputs": groups, "kind": "randomized_response", "epsilon": 1.0},
        "context_mechanism": {"inputs": contexts, "outputs": contexts, "kind": "identity"},
        "utility": {"values": values, "tau": tau},
        "population": {"contexts": contexts, "groups": groups, "probabilities": [[0.125] * k] * n_contexts},
    }


def test_l_bar_merges_contexts_alike_without_changing_its_value(monkeypatch):
    # six contexts, three utility tables (g(no) in 0, 1/4, 1/2; group g0 gets more for "no"): L̄'s exact program
    # merges the contexts of one table (their P(x | a) are proportional), three blocks instead of six; the unmerged
    # program (every context its own block) is the second route
    import _exact_route

    inputs = _many_contexts(6)
    for plane in inputs["utility"]["values"]:
        plane[0] = [1.0, 0.75]
    merged = exact_enclosures(inputs).global_
    monkeypatch.setattr(_exact_route, "_merged", lambda s: {x: s.weights[i] for i, x in enumerate(s.live)})
    unmerged = exact_enclosures(inputs).global_
    assert merged == unmerged and merged.lo > 1


@pytest.mark.slow
def test_l_bar_over_a_thousand_contexts_alike_is_re_derived():
    # X and A independent, three boxes: three blocks whatever the number of contexts (it was 3,000 variables)
    worst = exact_enclosures(_many_contexts(1000))
    assert worst.global_ is not None and worst.global_.hi - worst.global_.lo < 1e-40


def _unlike_contexts(n_contexts, utility):
    """Randomized response at epsilon = 1 on three groups, n contexts whose P(x | a) differ (nothing merges)."""
    cells = [[1 + x, 1 + (5 * x) % 31, 1 + (x * x) % 37] for x in range(n_contexts)]  # no two rows proportional
    total = sum(map(sum, cells))
    rows = ", ".join("[" + ", ".join(repr(c / total) for c in row) + "]" for row in cells)
    return (
        '[sensitive]\nname = "group"\nvalues = ["a", "b", "c"]\n'
        f'[context]\nname = "job"\nvalues = {json.dumps([f"c{x}" for x in range(n_contexts)])}\n'
        '[decision]\nname = "d"\nvalues = ["yes", "no"]\n'
        f"[population]\nprobabilities = [{rows}]\n"
        '[privacy.sensitive]\nmechanism = "randomized_response"\nepsilon = 1.0\n'
        f"[utility]\n{utility}\ntau = 0.2\n"
    )


@pytest.mark.slow
@pytest.mark.parametrize(
    "utility",
    ['kind = "indicator"\ndecision = "yes"', 'kind = "table"\nvalues = [[[1.0, 0.0], [0.75, 0.0], [1.0, 0.25]]]'],
    ids=["box", "table"],
)
def test_l_bar_over_contexts_unlike_is_re_derived_block_by_block(utility, tmp_path):
    # 30 contexts with P(x | a) unlike: one program over all of them has 90 variables (box) or 121 (table), beyond
    # 64; each context is a block of a product, solved block by block. The certificate's L-bar holds and one moved
    # by 1e-7 relative (beyond the certificate's tolerance, 1e-9) fails
    spec = _unlike_contexts(30, utility)
    if "table" in utility:
        spec = spec.replace(
            "[[[1.0, 0.0], [0.75, 0.0], [1.0, 0.25]]]",
            "[" + ", ".join(["[[1.0, 0.0], [0.75, 0.0], [1.0, 0.25]]"] * 30) + "]",
        )
    cert, result, checked = certified_and_verified(spec, tmp_path)
    assert "bound_details.black_box.global.value" in checked
    assert not [why for _, why in result.not_checked if "beyond" in why]
    glob = cert["bound_details"]["black_box"]["global"]
    glob["value"] += 1e-7 * max(1.0, glob["value"])
    assert "bound_details.black_box.global.value" in {c.name for c in verify(cert).failures}


def test_l_bar_beyond_the_limit_is_bounded_by_its_duals_and_without_them_fails(monkeypatch):
    # a block wider than the limit (here 2 < randomized response's three groups, unlike: L-bar's blocks are k wide;
    # L's are three cells): L-bar is bounded by the floors' multipliers certify records; without them its value
    # fails

    spec = _unlike_contexts(4, 'kind = "indicator"\ndecision = "yes"')
    cert = json.loads(json.dumps(certify(parse_spec(spec)).to_dict()))
    result = verify(cert)
    assert result.holds, [c.line() for c in result.failures]
    assert {"bounds.black_box", "bound_details.black_box.global.value"} <= {c.name for c in result.checks}
    del cert["bound_details"]["black_box"]["global"]["duals"]  # (nothing is solved beyond the size: it fails)
    assert "bound_details.black_box.global.value" in {c.name for c in verify(cert).failures}


@pytest.mark.slow
def test_a_product_of_five_binary_filters_is_re_derived(tmp_path):
    # 32 groups (the paper's filter on five attributes), tau binding: every pair's floor relaxation meets the other
    # floors, so no program is solved; the black box holds, and moved by 1e-9 it fails
    components = "".join(
        f'[[privacy.sensitive.components]]\nname = "{c}"\nmechanism = "randomized_response"\n'
        f'values = ["{c}0", "{c}1"]\nkeep = 0.7\n'
        for c in ("name", "age", "race", "gender", "region")
    )
    spec = (
        '[sensitive]\nname = "profile"\n[context]\nname = "doc"\nvalues = ["a", "b"]\n'
        '[decision]\nname = "outcome"\nvalues = ["chosen", "not chosen"]\n'
        '[privacy.sensitive]\nmechanism = "product"\n'
        + components
        + '[utility]\nkind = "indicator"\ndecision = "chosen"\ntau = 0.02\n'
    )
    cert, result, checked = certified_and_verified(spec, tmp_path)
    assert {"bounds.black_box", "bounds.global", "bound_details.black_box.value"} <= set(checked)
    assert not [why for _, why in result.not_checked if "beyond" in why]
    cert["bounds"]["black_box"] -= 1e-9 * cert["bounds"]["black_box"]
    assert "bounds.black_box" in {c.name for c in verify(cert).failures}


def test_a_relaxed_maximiser_that_misses_a_floor_is_solved_by_hand():
    # rows g0 = (0, 1), g1 = (1, 0), g2 = (2/3, 1/3), h in [0, 1]^2, tau = 0.3: the floors h2 >= 0.3, h1 >= 0.3 and
    # (2 h1 + h2)/3 >= 0.3. L: g1 over g0, h1/h2 <= 1/0.3 = 10/3 at h = (1, 0.3). L-bar over the groups present (g0,
    # g2): g0 over g2 is 3 h2/(2 h1 + h2), whose relaxation (g2's floor only) takes h1 = 0 for 3, but g1's floor
    # h1 >= 0.3 gives 3/1.6 = 15/8; g2 over g0 is (2 h1 + h2)/(3 h2) <= 2.3/0.9 = 23/9 at h = (1, 0.3)
    inputs = {
        "sensitive_mechanism": {
            "inputs": ["g0", "g1", "g2"],
            "outputs": ["o0", "o1"],
            "kind": "matrix",
            "matrix": [[0.0, 1.0], [1.0, 0.0], [2 / 3, 1 / 3]],
        },
        "context_mechanism": {"inputs": ["c0"], "outputs": ["c0"], "kind": "identity"},
        "utility": {"values": [[[1.0, 0.0]] * 3], "tau": 0.3},
        "population": {"contexts": ["c0"], "groups": ["g0", "g1", "g2"], "probabilities": [[0.5, 0.0, 0.5]]},
    }
    m21, m22, tau = F(2 / 3), F(1 / 3), F(0.3)  # the recorded floats, exactly
    worst = exact_enclosures(inputs)  # (the rational simplex: verify solves nothing)
    assert worst.local.lo == worst.local.hi == 1 / tau  # 10/3 in reals
    assert worst.global_.lo == worst.global_.hi == (m21 + m22 * tau) / tau  # 23/9 in reals
    [(_, setting)] = bb._settings(inputs, Evidence())
    assert kernel_global(setting, (0, 2)) == 1 / (m21 * tau + m22)  # 15/8 in reals, not the relaxation's 3


@pytest.mark.slow
def test_an_uncertified_value_s_pair_need_only_reach_its_witness():
    # an inexact solve (Clarabel's optimal_inaccurate beyond the exact size, found by a random hunt) leaves L-bar's
    # value uncertified, 6.5e-6 above the exact worst case: its named pair's exact worst case need only reach the
    # witness. A pair that does not reach the witness still fails
    cert = json.loads(
        json.dumps(certify(parse_spec(_unlike_contexts(4, 'kind = "indicator"\ndecision = "yes"'))).to_dict())
    )
    glob = cert["bound_details"]["black_box"]["global"]
    value = glob["value"] + 1e-6
    glob.update(certified=False, value=value, ratio=math.nextafter(math.exp(value), math.inf))
    glob["gap"] = math.nextafter(value - glob["witness"], math.inf)
    cert["bounds"]["global"] = "inf"  # (certify's: X and A dependent, and no certified L-bar)
    bounds = cert["bounds"]  # certify leaves a black box out of the best bound when a worst case is not certified
    bounds["best_form"] = min(("tight", "corollary", "paper"), key=lambda form: bounds[form])
    bounds["best"] = bounds[bounds["best_form"]]
    result = verify(cert)
    assert result.holds, [c.line() for c in result.failures]
    assert "bound_details.black_box.global (its groups)" in {c.name for c in result.checks}
    assert "bound_details.black_box.global.value" in dict(result.not_checked)
    glob["witness"] = value
    glob["gap"] = 0.0
    assert "bound_details.black_box.global (its groups)" in {c.name for c in verify(cert).failures}
