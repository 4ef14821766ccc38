"""Fairness-privacy curves: real values by hand calculation, order of the bounds, CSV round trip, errors."""

from __future__ import annotations

import inspect
import math
from fractions import Fraction
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from _terminal import lines_drawn, on_terminal
from hypothesis import given, settings
from hypothesis import strategies as st

from fairaudit import InputError, UtilityClass
from fairaudit.certification.certificate import certify
from fairaudit.certification.curves import COLUMNS, PrivacyCurve, default_epsilons, privacy_curve
from fairaudit.certification.spec import load_spec, parse_spec
from fairaudit.laws.families import product_family, randomized_response_family
from fairaudit.laws.tables import Kernel
from fairaudit.laws.utilities import indicator
from fairaudit.worstcase.black_box import black_box_bound

ROOT = Path(__file__).resolve().parents[2]
HR_SPEC = ROOT / "examples" / "hr_office" / "hr_office.toml"
DECISIONS = ["chosen", "not chosen"]
CHOSEN = indicator("chosen", DECISIONS)
GRID = np.linspace(0.0, 4.0, 17)


def released_group_kernel(groups, favoured, contexts=("all",)) -> Kernel:
    """K[x̃, ã, chosen] = 1{ã = favoured}: the model chooses a candidate iff it is shown as ``favoured``."""
    k = np.zeros((len(contexts), len(groups), 2))
    for j, g in enumerate(groups):
        k[:, j, 0 if g == favoured else 1] = 1.0
    return Kernel(k, list(contexts), list(groups), DECISIONS)


# -- real values ----------------------------------------------------------------------------------------


def test_binary_randomized_response_and_the_released_group_model_give_L_equal_to_epsilon():
    """Hand calculation: P(chosen | b) = p, P(chosen | a) = 1 - p with p = e^ε/(1+e^ε), so L = log(p/(1-p)) = ε."""
    fam = randomized_response_family(["a", "b"])
    c = privacy_curve(
        family=fam,
        epsilons=GRID,
        kernel=released_group_kernel(["a", "b"], "b"),
        utility=CHOSEN,
        utility_class=UtilityClass(tau=0.01),
    )
    p = np.exp(GRID) / (1 + np.exp(GRID))
    by_hand = np.log(p / (1 - p))
    np.testing.assert_allclose(c.epsilon, GRID)
    np.testing.assert_allclose(c.keep_probability, p, rtol=1e-12)
    np.testing.assert_allclose(c.observed_local, by_hand, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(c.observed_global, by_hand, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(c.min_expected_utility, 1 - p, rtol=1e-12)
    np.testing.assert_allclose(c.corollary, GRID, rtol=1e-12, atol=1e-15)
    # the corollary is attained: the exact worst case over all models is ε itself
    np.testing.assert_allclose(c.black_box, GRID, rtol=1e-7, atol=1e-9)
    assert np.all(c.black_box >= c.observed_local - 1e-9)
    assert np.all(c.tight <= c.paper + 1e-12)
    assert c.tau_holds.all()


def test_exact_fractions_at_keep_probability_seven_tenths():
    """p = 7/10: P(chosen | b) / P(chosen | a) = (7/10) / (3/10) = 7/3 exactly."""
    eps = math.log(Fraction(7, 3))
    c = privacy_curve(
        family=randomized_response_family(["a", "b"]),
        epsilons=[eps],
        kernel=released_group_kernel(["a", "b"], "b"),
        utility=CHOSEN,
    )
    assert math.exp(c.observed_local[0]) == pytest.approx(7 / 3, rel=1e-12)
    assert c.keep_probability[0] == pytest.approx(0.7, rel=1e-12)
    assert np.isnan(c.paper[0]) and np.isnan(c.tight[0])  # no τ: the main theorem does not apply


def test_three_groups_ratio_is_e_to_the_epsilon():
    """3-ary: P(chosen | a0) = e^ε/(e^ε+2), P(chosen | a1) = 1/(e^ε+2); ratio e^ε."""
    groups = ["a0", "a1", "a2"]
    c = privacy_curve(
        family=randomized_response_family(groups),
        epsilons=GRID,
        kernel=released_group_kernel(groups, "a0"),
        utility=CHOSEN,
        utility_class=UtilityClass(tau=0.05),
    )
    np.testing.assert_allclose(c.observed_local, GRID, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(c.min_expected_utility, 1 / (np.exp(GRID) + 2), rtol=1e-12)
    ok = c.tau_holds
    assert np.all(c.black_box[ok] >= c.observed_local[ok] - 1e-9)
    assert np.all(c.tight <= c.paper + 1e-12)


@pytest.mark.slow
def test_hr_example_observed_L_is_three_log_odds_and_tau_fails_where_hand_calculation_says():
    """Product of three binary randomized responses, each keeping with p: L = 3 ln(p/(1-p)), min E = (1-p)^3."""
    spec = load_spec(HR_SPEC)
    c = privacy_curve(spec, epsilons=np.linspace(0.0, 6.0, 25))
    p = 1 / (1 + np.exp(-c.epsilon / 3))
    np.testing.assert_allclose(c.observed_local, 3 * np.log(p / (1 - p)), rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(c.observed_global, 3 * np.log(p / (1 - p)), rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(c.keep_probability, p**3, rtol=1e-12)
    np.testing.assert_allclose(c.min_expected_utility, (1 - p) ** 3, rtol=1e-9)
    # τ = 0.02 holds iff (1 - p)^3 >= 0.02, i.e. ε <= 3 ln(p*/(1-p*)) with p* = 1 - 0.02^(1/3)
    p_star = 1 - 0.02 ** (1 / 3)
    eps_star = 3 * math.log(p_star / (1 - p_star))
    np.testing.assert_array_equal(c.tau_holds, c.epsilon <= eps_star)
    ok = c.tau_holds
    assert np.all(c.black_box[ok] >= c.observed_local[ok] - 1e-9)
    assert np.all(c.tight[ok] >= c.observed_local[ok] - 1e-9)  # the bounds hold where their τ does
    assert np.all(c.tight <= c.paper + 1e-12)
    # the spec's ε 3 ln(7/3) is on the grid, and the curve there repeats the certificate
    assert c.spec_epsilon == pytest.approx(3 * math.log(7 / 3), rel=1e-12)
    assert c.spec_on_family is True
    i = int(np.flatnonzero(c.is_spec_epsilon)[0])
    cert = certify(spec).to_dict()  # the JSON contract keys
    assert c.paper[i] == pytest.approx(cert["bounds"]["paper"], rel=1e-9)
    assert c.tight[i] == pytest.approx(cert["bounds"]["tight"], rel=1e-9)
    assert c.black_box[i] == pytest.approx(cert["bounds"]["black_box"], rel=1e-7)
    assert c.observed_local[i] == pytest.approx(cert["observed"]["local"]["value"], rel=1e-9)
    assert c.observed_global[i] == pytest.approx(cert["observed"]["global"]["value"], rel=1e-9)


def test_product_family_keep_probability_is_the_whole_tuple_kept():
    fam = product_family(["Tom", "Mary"], [25, 55], ["Asian", "American"])
    c = privacy_curve(family=fam, epsilons=[3 * math.log(7 / 3)], utility_class=UtilityClass(tau=0.02))
    assert c.keep_probability[0] == pytest.approx(0.343, rel=1e-12)
    assert c.corollary[0] == pytest.approx(3 * math.log(7 / 3), rel=1e-12)


# -- properties -----------------------------------------------------------------------------------------


@st.composite
def kernels(draw):
    k = draw(st.integers(2, 4))
    n_ctx = draw(st.integers(1, 2))
    raw = draw(st.lists(st.floats(0.0, 1.0), min_size=n_ctx * k, max_size=n_ctx * k))
    chosen = np.array(raw).reshape(n_ctx, k)
    table = np.stack([chosen, 1 - chosen], axis=-1)
    groups = [f"g{i}" for i in range(k)]
    return Kernel(table, [f"x{i}" for i in range(n_ctx)], groups, DECISIONS), groups


@settings(max_examples=25)
@given(kernels(), st.sampled_from([None, 0.05, 0.2]))
def test_order_of_bounds_along_the_curve(kg, tau):
    """tight ≤ paper; observed L ≤ black-box where τ holds; L̄ ≤ L; every bound non-decreasing in ε."""
    kernel, groups = kg
    grid = np.linspace(0.0, 3.0, 7)
    c = privacy_curve(
        family=randomized_response_family(groups),
        epsilons=grid,
        kernel=kernel,
        utility=CHOSEN,
        utility_class=UtilityClass(tau=tau),
    )
    ok = c.tau_holds & np.isfinite(c.observed_local)
    assert np.all(c.black_box[ok] >= c.observed_local[ok] - 1e-7)
    assert np.all(c.observed_global[ok] <= c.observed_local[ok] + 1e-9)
    for b in (c.black_box, c.corollary) + ((c.paper, c.tight) if tau is not None else ()):
        assert np.all(np.diff(b) >= -1e-7)
    if tau is not None:
        assert np.all(c.tight <= c.paper + 1e-12)
        if "tau" in inspect.signature(black_box_bound).parameters:  # the black-box program that uses τ
            assert np.all(c.black_box <= c.tight + 1e-7)
    else:
        assert np.isnan(c.paper).all() and np.isnan(c.tight).all()


# -- grid, frame, CSV ---------------------------------------------------------------------------------------


def test_default_grid_contains_the_spec_epsilon():
    g = default_epsilons(2.0)
    assert g[0] == 0.0 and g[-1] == pytest.approx(3.0) and 2.0 in g and np.all(np.diff(g) > 0)
    g = default_epsilons(math.inf)
    assert g[-1] == 5.0 and len(g) == 61
    odd = default_epsilons(0.123456789)  # point 40 of 61 is the spec's ε (up to rounding, then exactly)
    assert odd[40] == 0.123456789 and len(odd) == 61


def test_user_grid_is_sorted_deduplicated_and_gets_the_spec_epsilon():
    spec = load_spec(HR_SPEC)
    c = privacy_curve(spec, epsilons=[3.0, 1.0, 1.0, 0.0])
    eps = spec.sensitive_mechanism.epsilon
    assert eps == pytest.approx(3 * math.log(7 / 3), rel=1e-12)
    assert c.epsilon.tolist() == [0.0, 1.0, eps, 3.0]
    assert c.is_spec_epsilon.tolist() == [False, False, True, False]


def test_csv_round_trip(tmp_path):
    c = privacy_curve(load_spec(HR_SPEC), epsilons=np.linspace(0, 5, 11))
    path = tmp_path / "curve.csv"
    c.to_csv(path)
    back = pd.read_csv(path)
    assert tuple(back.columns) == COLUMNS
    pd.testing.assert_frame_equal(back, c.to_frame(), check_exact=True)


def test_csv_writes_inf_and_nan():
    arr = np.array([0.0, 1.0, math.inf])
    nan = np.full(3, math.nan)
    c = PrivacyCurve(
        epsilon=np.array([0.0, 1.0, 2.0]),
        keep_probability=np.array([0.5, 0.6, 0.7]),
        paper=nan,
        tight=nan,
        black_box=arr,
        corollary=arr,
        observed_local=nan,
        observed_global=nan,
        min_expected_utility=nan,
        family="f",
        groups=("a", "b"),
        gamma=1.0,
        lower=0.0,
        tau=None,
        lipschitz=0.0,
    )
    text = c.to_frame().to_csv(index=False)
    assert ",inf," in text
    frame = c.to_frame()
    assert frame["black_box_nats"].tolist()[-1] == math.inf and frame["paper_nats"].isna().all()


def test_without_tau_paper_and_tight_are_nan_but_black_box_is_not():
    c = privacy_curve(family=randomized_response_family(["a", "b"]), epsilons=[0.0, 1.0])
    assert np.isnan(c.paper).all() and np.isnan(c.tight).all() and not c.has_kernel
    np.testing.assert_allclose(c.black_box, [0.0, 1.0], atol=1e-9)


def test_matrix_mechanism_is_marked_off_the_family():
    spec = parse_spec(
        '[sensitive]\nname = "a"\nvalues = ["x", "y"]\n[decision]\nname = "u"\nvalues = ["yes", "no"]\n'
        '[privacy.sensitive]\nmechanism = "matrix"\nrows = [[0.9, 0.1], [0.2, 0.8]]\n'
        '[utility]\ndecision = "yes"\ntau = 0.1\n'
    )
    c = privacy_curve(spec, epsilons=[0.0, 1.0])
    assert c.spec_epsilon == pytest.approx(math.log(8))  # 0.8 / 0.1 and c.spec_on_family is False


# -- errors -------------------------------------------------------------------------------------------------


def test_errors_are_one_line_input_errors():
    fam = randomized_response_family(["a", "b"])
    with pytest.raises(InputError, match="family: give a MechanismFamily"):
        privacy_curve()
    with pytest.raises(InputError, match=r"epsilons: must be finite and non-negative \(nats\) \(got -1.0\)"):
        privacy_curve(family=fam, epsilons=[0.0, -1.0])
    with pytest.raises(InputError, match="epsilons: needs at least one value"):
        privacy_curve(family=fam, epsilons=[])
    with pytest.raises(InputError, match="utility: is needed"):
        privacy_curve(family=fam, kernel=released_group_kernel(["a", "b"], "b"))
    with pytest.raises(InputError, match="kernel: mechanism"):
        privacy_curve(
            family=randomized_response_family(["c", "d"]), kernel=released_group_kernel(["a", "b"], "b"), utility=CHOSEN
        )
    with pytest.raises(InputError, match="tau"):
        privacy_curve(family=fam, utility_class=UtilityClass(tau=2.0))
    one = parse_spec(
        '[sensitive]\nname = "a"\nvalues = ["x"]\n[decision]\nname = "u"\nvalues = [1, 0]\n[utility]\ndecision = 1\n'
    )
    with pytest.raises(InputError, match="needs at least 2 groups"):
        privacy_curve(one)


def test_the_curve_draws_a_bar_by_epsilon_inside_progress_shown(monkeypatch):
    import fairaudit.certification.curves as curves
    from fairaudit.base.progress import progress_shown

    terminal = on_terminal(monkeypatch)
    monkeypatch.setattr(curves, "STEP_DELAY", 0.0)
    spec = load_spec(HR_SPEC)
    quiet = privacy_curve(spec, epsilons=[0.0, 1.0])
    assert terminal.getvalue() == ""
    with progress_shown():
        shown = privacy_curve(spec, epsilons=[0.0, 1.0])
    n = len(shown)  # (the grid's 2 values and the spec's epsilon)
    assert n == len(quiet) == 3
    assert lines_drawn(terminal.getvalue())[0] == f"curve:   0%|          | 0/{n} [00:00<?, ?epsilon/s]"
    pd.testing.assert_frame_equal(shown.to_frame(), quiet.to_frame())
