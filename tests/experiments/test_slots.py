"""k candidates per prompt: the per-candidate law against brute-force enumeration in exact rational arithmetic.

The independent route: for every true prompt T (with its probability) and every shown cell s, P(s | T) is the
product of the attributes' randomized-response probabilities, and the candidate in slot i gets outcome o_i(u)
read by hand from the decision u (chosen if u names its slot; its place in the order u). Summing gives
P(o | x, slot i, a) as a Fraction; fairaudit composes the per-candidate kernel with M_cand instead.
"""

from __future__ import annotations

import itertools
import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fairaudit.base.errors import InputError
from fairaudit.experiments.slots import (
    candidate_epsilon,
    candidate_kernel,
    candidate_mechanism,
    candidate_population,
    check_size,
    epsilon_factor,
    epsilon_from_keep,
    outcome_index,
    true_prompts,
)
from fairaudit.experiments.taskfile import parse_task
from fairaudit.experiments.vlm.filter import TaskFilter, candidate_family, profile_budget
from fairaudit.laws.composition import compose
from fairaudit.laws.mechanisms import Mechanism, identity, product
from fairaudit.laws.tables import Kernel


def _task(k: int, decision: str = "choose", population: str = '"all"', positions: str = "balanced", values=None):
    values = values or [["a", "b"]]
    attrs = "\n".join(
        f'[[attribute]]\nname = "q{j}"\nvalues = {list(v)!r}\n'.replace("'", '"') for j, v in enumerate(values)
    )
    if k == 1:
        options, utility = '{ "yes" = "approve", "no" = "deny" }', "{ approve = 1.0, deny = 0.0 }"
    else:
        options = "{ " + ", ".join(f'"{i}" = {i}' for i in range(1, k + 1)) + " }"
        utility = '"rank"' if decision == "rank" else '{ chosen = 1.0, "not chosen" = 0.0 }'
    text = f"""
[task]
candidates = {k}
decision = "{decision}"
positions = "{positions}"
population = {population}
[prompt]
user = "{{{{ context }}}}: {{% for c in candidates %}}{{{{ c }}}}; {{% endfor %}}"
[context]
name = "job"
values = ["j1", "j2"]
{attrs}
[decision]
options = {options}
[utility]
values = {utility}
"""
    return parse_task(text, name=f"k{k}")


def _rr(n: int, keep: Fraction) -> list[list[Fraction]]:
    other = (1 - keep) / (n - 1)
    return [[keep if i == j else other for j in range(n)] for i in range(n)]


def _profile_matrix(task, keeps) -> list[list[Fraction]]:
    """M_P as Fractions: the product of the attributes' randomized responses (profiles in product order)."""
    mats = [_rr(len(a.values), kp) for a, kp in zip(task.attributes, keeps)]
    idx = list(itertools.product(*(range(len(a.values)) for a in task.attributes)))
    return [[math.prod((m[x[j]][y[j]] for j, m in enumerate(mats)), start=Fraction(1)) for y in idx] for x in idx]


def _outcome(task, slot: int, u: int) -> int:
    """o_i(u) by hand."""
    if u == len(task.decisions) - 1:
        return len(task.outcomes) - 1
    if task.slots == 1:
        return u
    if task.kind == "choice":
        return 0 if u == slot else 1
    if task.slots == 2:
        return 0 if u == slot else 1
    return list(task.orders[u]).index(slot)


def _brute_law(task, positions, kernel, keeps):
    """P(o | (x, slot), a) by enumeration, as Fractions: dict (x, slot, a) -> list over outcomes."""
    n_p, k = len(task.profiles), task.slots
    mp = _profile_matrix(task, keeps)
    prompts, weights = true_prompts(task, positions)
    w = [Fraction(x).limit_denominator(10**6) for x in weights]
    mass: dict = {}
    for x in range(len(task.contexts)):
        for t, wt in zip(prompts, w):
            for s in itertools.product(range(n_p), repeat=k):
                p_s = wt * math.prod((mp[t[j]][s[j]] for j in range(k)), start=Fraction(1))
                cell = np.ravel_multi_index(s, (n_p,) * k)
                for i in range(k):
                    key = (x, i, int(t[i]))
                    row = mass.setdefault(key, [Fraction(0)] * len(task.outcomes))
                    for u, pu in enumerate(kernel[x][cell]):
                        row[_outcome(task, i, u)] += p_s * pu
    return {key: [v / sum(row) for v in row] for key, row in mass.items()}


def _random_kernel(task, rng):
    n_cells = len(task.profiles) ** task.slots
    raw = rng.integers(0, 4, size=(len(task.contexts), n_cells, len(task.decisions))) + np.eye(len(task.decisions))[0]
    return [[[Fraction(int(v), int(row.sum())) for v in row] for row in ctx] for ctx in raw]


def _check_law(task, positions, keeps, seed):
    rng = np.random.default_rng(seed)
    exact = _random_kernel(task, rng)
    probs = np.array([[[float(v) for v in row] for row in ctx] for ctx in exact])
    kern = Kernel(probs, task.contexts, list(range(probs.shape[1])), task.decisions)
    mp = Mechanism(
        np.array(_profile_matrix(task, keeps), dtype=float),
        [task.profile_label(p) for p in task.profiles],
        [task.profile_label(p) for p in task.profiles],
    )
    kc = candidate_kernel(task, kern)
    mech = candidate_mechanism(task, mp, positions)
    law = compose(kc, mech, identity(kc.contexts))
    expected = _brute_law(task, positions, exact, keeps)
    groups = [tuple(c) for c in task.candidates]
    profiles = task.profiles
    seen = 0
    for (x, i, a), row in expected.items():
        got = law.probabilities[x * task.slots + i, groups.index(profiles[a])]
        np.testing.assert_allclose(got, [float(v) for v in row], rtol=0, atol=1e-12)
        seen += 1
    assert seen > 0


@pytest.mark.parametrize(
    ("k", "decision", "population", "positions"),
    [
        (1, "choose", '"all"', "balanced"),
        (2, "choose", '"all"', "fixed"),
        (3, "choose", '"all"', "balanced"),
        (3, "rank", '"all"', "latin"),
        (3, "rank", '[[["a"], ["b"], ["c"]]]', "balanced"),
        (3, "rank", '[[["a"], ["b"], ["c"]]]', "latin"),
        (3, "choose", '[[["a"], ["b"], ["c"]], [["a"], ["b"], ["d"]]]', "balanced"),
        (2, "rank", '"distinct"', "balanced"),
    ],
)
def test_per_candidate_law_matches_brute_force(k, decision, population, positions):
    values = [["a", "b", "c", "d"]] if "c" in population or "distinct" in population else [["a", "b"]]
    task = _task(k, decision, population, positions, values)
    _check_law(task, positions, [Fraction(3, 5)], seed=k)


def test_two_attributes_with_different_keeps_match_brute_force():
    task = _task(2, "rank", '"distinct"', "latin", [["a", "b", "c"], ["x", "y"]])
    _check_law(task, "latin", [Fraction(1, 2), Fraction(4, 5)], seed=7)


@pytest.mark.slow
@settings(deadline=None)
@given(
    k=st.sampled_from([1, 2, 3]),
    decision=st.sampled_from(["choose", "rank"]),
    positions=st.sampled_from(["balanced", "latin", "fixed"]),
    population=st.sampled_from(['"all"', '"distinct"', "listed"]),
    keep=st.fractions(min_value=Fraction(1, 10), max_value=Fraction(19, 20), max_denominator=20),
    seed=st.integers(0, 2**16),
)
def test_per_candidate_law_matches_brute_force_for_any_small_design(k, decision, positions, population, keep, seed):
    if k == 1:
        decision = "choose"
    values = [["a", "b", "c"]]
    if population == "listed":
        rng = np.random.default_rng(seed)
        combos = {tuple(sorted(rng.choice(3, size=k, replace=False))) for _ in range(2)}
        population = "[" + ", ".join("[" + ", ".join(f'["{"abc"[i]}"]' for i in c) + "]" for c in combos) + "]"
    task = _task(k, decision, population, positions, values)
    try:
        _check_law(task, positions, [keep], seed)
    except InputError as exc:  # a fixed order whose view depends on the slot: refused, never a wrong law
        assert "depends on its slot" in str(exc) and positions == "fixed"


def test_true_prompts_of_each_positions():
    task = _task(3, "rank", '[[["a"], ["b"], ["c"]]]', "latin", [["a", "b", "c"]])
    latin, w = true_prompts(task, "latin")
    assert latin.tolist() == [[0, 1, 2], [1, 2, 0], [2, 0, 1]] and w.tolist() == [1 / 3] * 3
    balanced, w = true_prompts(task, "balanced")
    assert sorted(map(tuple, balanced.tolist())) == sorted(
        itertools.permutations(range(3))
    ) and w.sum() == pytest.approx(1)
    assert true_prompts(task, "fixed")[0].tolist() == [[0, 1, 2]]
    with pytest.raises(InputError, match="positions: must be one of"):
        true_prompts(task, "random")


def test_population_is_uniform_over_slots_with_all_orders():
    task = _task(3, "choose", '[[["a"], ["b"], ["c"]]]', "balanced", [["a", "b", "c"]])
    pop = candidate_population(task, "balanced").probabilities
    assert pop.shape == (6, 3) and np.allclose(pop, 1 / 18)
    fixed = candidate_population(task, "fixed").probabilities[:3]
    assert np.allclose(fixed, np.eye(3) / 6)  # the slot reveals the group


def test_outcome_index_of_a_ranking_of_three():
    task = _task(3, "rank", '"all"', "balanced")
    o = outcome_index(task)
    assert task.decisions[0] == "1 > 2 > 3" and task.decisions[3] == "2 > 3 > 1"
    assert o[:, 3].tolist() == [2, 0, 1]  # slot 1 last, slot 2 first, slot 3 second
    assert o[:, -1].tolist() == [3, 3, 3]


def test_epsilon_of_the_candidate_by_case():
    """all: ε_P; a point mass: the views' differing profiles; all orders of one set: within [ε_P, 2 ε_P] (a coupling
    that swaps a and a' between the candidate and the rival holding a' changes two shown profiles)."""
    e = math.log(3)  # keep 3/4 on two values
    every = _task(3, "choose", '"all"', "balanced")
    assert candidate_epsilon(every, (e,)) == pytest.approx(e) and epsilon_factor(every) == 1
    assert candidate_mechanism(every, TaskFilter.from_epsilon(every, e).profile_mechanism).epsilon == pytest.approx(
        e, abs=1e-12
    )
    triple = _task(3, "choose", '[[["a"], ["b"], ["c"]]]', "latin", [["a", "b", "c"]])
    # cyclic shifts: a always sees (a, b, c) from its slot on, b always (b, c, a): all three shown profiles differ
    assert epsilon_factor(triple, "latin") == 3
    mech = candidate_mechanism(triple, TaskFilter.from_epsilon(triple, 1.0).profile_mechanism, "latin")
    assert mech.epsilon == pytest.approx(3.0, abs=1e-12)
    assert epsilon_factor(triple, "balanced") is None  # rivals in either order: a mixture
    mixed = candidate_mechanism(triple, TaskFilter.from_epsilon(triple, 1.0).profile_mechanism, "balanced")
    assert 1.0 <= mixed.epsilon <= 2.0 + 1e-12
    fam = candidate_family(triple, "balanced")
    for eps in (0.3, 1.0, 4.0):
        assert fam(eps).epsilon == pytest.approx(eps, abs=1e-9)
    assert profile_budget(triple, "balanced")(0.0) == 0.0
    assert epsilon_from_keep(triple, 0.5, "balanced") == pytest.approx(mixed_at_keep(triple, 0.5), abs=1e-12)


def mixed_at_keep(task, keep):
    mp = Mechanism(
        np.array(_profile_matrix(task, [Fraction(keep)]), dtype=float),
        [task.profile_label(p) for p in task.profiles],
        [task.profile_label(p) for p in task.profiles],
    )
    return candidate_mechanism(task, mp, "balanced").epsilon


def test_a_design_too_large_to_enumerate_is_refused_in_one_line():
    task = _task(8, "rank", '"distinct"', "latin", [[f"g{i}" for i in range(8)]])
    assert task.slots == 8 and len(task.combinations) == 1
    with pytest.raises(InputError, match=r"task.candidates: .* shown cells = 33,554,432 .*design \"paper\""):
        check_size(task)


def test_fixed_order_whose_view_depends_on_the_slot_is_refused():
    task = _task(2, "choose", '[[["a"], ["b"]], [["b"], ["c"]]]', "fixed", [["a", "b", "c"]])
    with pytest.raises(InputError, match="task.positions: .*'b'.* depends on its slot"):
        candidate_mechanism(task, TaskFilter.from_epsilon(task, 1.0).profile_mechanism, "fixed")


def test_profile_product_matches_the_filter():
    task = _task(2, "choose", '"all"', "balanced", [["a", "b", "c"], ["x", "y"]])
    f = TaskFilter.from_epsilon(task, 2.0)
    expected = product(*f.attribute_mechanisms).matrix
    assert np.allclose(f.profile_mechanism.matrix, expected)
