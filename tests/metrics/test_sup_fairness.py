"""The sups over g of L and L̄ (Lemma 1): exact ``Fraction`` arithmetic with explicit loops over every pair of
groups (the rational example), Lemma 1 as a property, and AIF360's smoothed empirical differential fairness.
"""

from __future__ import annotations

import itertools
import math
import warnings
from fractions import Fraction as F

import numpy as np
import pandas as pd
import pytest
from _rational_law import Q, argmax_set, fr_group_law, laws, rational_law, rational_population
from hypothesis import given

import fairaudit as fa


def test_sup_local_by_fractions():
    best, keys = argmax_set(
        [
            (Q[x][a][u] / Q[x][b][u], (x, u, a, b))
            for x in range(2)
            for u in range(3)
            for a, b in itertools.permutations(range(3), 2)
        ]
    )
    # Hand: x1, decision u0: P(u0 | b) / P(u0 | a) = (1/4) / (1/10) = 5/2.
    assert best == F(5, 2) and keys == {(1, 0, 1, 0)}
    r = fa.sup_local_fairness(rational_law())
    assert r.value == pytest.approx(math.log(2.5), rel=1e-12)
    assert (r.context, r.decision, r.group, r.other_group) == ("x1", "u0", "b", "a")


def test_sup_global_by_fractions():
    pu = fr_group_law()
    best, keys = argmax_set(
        [(pu[a][u] / pu[b][u], (u, a, b)) for u in range(3) for a, b in itertools.permutations(range(3), 2)]
    )
    # Hand: P(u2 | a) = 29/60, P(u2 | c) = 1/3·1/5 + 2/3·1/4 = 7/30; ratio 29/14.
    assert best == F(29, 14) and keys == {(2, 0, 2)}
    r = fa.sup_global_fairness(rational_law(), rational_population())
    assert r.value == pytest.approx(math.log(29 / 14), rel=1e-12)
    assert (r.decision, r.group, r.other_group) == ("u2", "a", "c")


# --------------------------------------------------------------------------- property: Lemma 1


@given(laws())
def test_lemma1_sup_dominates_and_is_attained(data):
    law, pop, g = data
    sup_l = fa.sup_local_fairness(law, pop)
    sup_g = fa.sup_global_fairness(law, pop)
    loc = fa.local_fairness(law, g, pop).value
    if not math.isnan(loc):
        assert loc <= sup_l.value + 1e-12
    assert fa.global_fairness(law, g, pop).value <= sup_g.value + 1e-12
    # Attained by the indicator of the maximising decision: E[1{u}|x,a] = Q[x,a,u].
    ind = fa.indicator(sup_l.decision, law.decisions)
    assert fa.local_fairness(law, ind, pop).value == pytest.approx(sup_l.value, rel=1e-12)
    ind = fa.indicator(sup_g.decision, law.decisions)
    assert fa.global_fairness(law, ind, pop).value == pytest.approx(sup_g.value, rel=1e-12)


# --------------------------------------------------------------------------- peer: AIF360


def aif360_smoothed_edf(df: pd.DataFrame, protected: list[str], concentration: float) -> float:
    pytest.importorskip("aif360")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        from aif360.datasets import BinaryLabelDataset
        from aif360.metrics import BinaryLabelDatasetMetric

        ds = BinaryLabelDataset(
            favorable_label=1, unfavorable_label=0, df=df, label_names=["label"], protected_attribute_names=protected
        )
        return BinaryLabelDatasetMetric(ds).smoothed_empirical_differential_fairness(concentration=concentration)


def our_smoothed_edf(df: pd.DataFrame, protected: list[str], concentration: float) -> float:
    # AIF360 (binary_label_dataset_metric._smoothed_base_rates): P(y=1 | s) = (n_pos + α/2) / (n_s + α) with
    # α = concentration (a symmetric Dirichlet prior split over the 2 labels), over the groups present in the data.
    # So: counts + α/2 in every (group, decision) cell, one context, and the sup of L̄ over g(u) (Lemma 1).
    keys = [tuple(r) for r in df[protected].to_numpy().tolist()]
    groups = sorted(set(keys))
    counts = np.zeros((1, len(groups), 2))
    for k, y in zip(keys, df["label"].tolist()):
        counts[0, groups.index(k), 0 if y == 1 else 1] += 1
    law = fa.Law.from_counts(counts + concentration / 2, ["all"], groups, [1, 0])
    return fa.sup_global_fairness(law).value


def test_aif360_smoothed_edf_synthetic():
    rng = np.random.default_rng(5)
    n = 400
    race = rng.choice([0, 1, 2, 3], size=n, p=[0.4, 0.3, 0.2, 0.1])
    sex = rng.choice([0, 1], size=n)
    label = (rng.uniform(size=n) < np.array([0.6, 0.45, 0.3, 0.2])[race] + 0.1 * sex).astype(int)
    df = pd.DataFrame({"race": race.astype(float), "sex": sex.astype(float), "label": label.astype(float)})
    for protected in (["race"], ["race", "sex"]):
        for conc in (1.0, 2.0, 0.5):
            peer = aif360_smoothed_edf(df, protected, conc)
            assert our_smoothed_edf(df, protected, conc) == pytest.approx(peer, rel=1e-12)


def test_aif360_smoothed_edf_hand_example():
    # Groups 0: 3 positives of 4; 1: 0 of 2. α = 1: rates (3.5/5, 0.5/3) = (0.7, 1/6);
    # positives ratio 0.7 / (1/6) = 4.2, negatives (5/6) / 0.3 = 25/9 = 2.78 -> log 4.2.
    df = pd.DataFrame({"race": [0.0] * 4 + [1.0] * 2, "label": [1.0, 1.0, 1.0, 0.0, 0.0, 0.0]})
    assert our_smoothed_edf(df, ["race"], 1.0) == pytest.approx(math.log(4.2), rel=1e-12)
    assert aif360_smoothed_edf(df, ["race"], 1.0) == pytest.approx(math.log(4.2), rel=1e-12)


def test_aif360_smoothed_edf_compas(shared_data):
    path = shared_data / "compas" / "compas-scores-two-years.csv"
    if not path.exists():
        pytest.skip(f"COMPAS file not found at {path}")
    raw = pd.read_csv(path)
    races = sorted(raw["race"].unique())
    df = pd.DataFrame(
        {"race": raw["race"].map(races.index).astype(float), "label": (raw["decile_score"] >= 5).astype(float)}
    )
    peer = aif360_smoothed_edf(df, ["race"], 1.0)
    assert our_smoothed_edf(df, ["race"], 1.0) == pytest.approx(peer, rel=1e-12)
