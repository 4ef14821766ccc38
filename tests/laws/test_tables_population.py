"""The population P(X, A) behind L̄ and L_dp: where it comes from, and what depends on it (issue 19).

From counts or records it is the records' own P(x, a) = n(x, a) / n unless the spec or the caller gives
another; from a probability table with none it is uniform and independent, reported as assumed, never as
checked. ``certify`` and ``audit`` give the same numbers on the same records, and the global black-box
certificate and its calibration hold for a population where X and A are dependent.

Expected values come from hand calculations in exact fractions and from a Charnes–Cooper LP written here
with scipy's ``linprog`` (independent of fairaudit's cvxpy and threshold routes).
"""

from __future__ import annotations

import json
import math
from fractions import Fraction
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy.optimize import linprog

import fairaudit as fa
from fairaudit import UtilityClass
from fairaudit.certification.certificate import certify
from fairaudit.certification.spec import load_spec
from fairaudit.cli import main
from fairaudit.data.counts import count_records
from fairaudit.worstcase.calibration import calibrate

# Counts n(x, a, u) with X and A dependent: group "a" lives mostly in context "young", group "b" in "old".
COUNTS = {
    ("young", "a", 1): 30,
    ("young", "a", 0): 10,
    ("young", "b", 1): 3,
    ("young", "b", 0): 7,
    ("old", "a", 1): 2,
    ("old", "a", 0): 8,
    ("old", "b", 1): 12,
    ("old", "b", 0): 28,
}
N = sum(COUNTS.values())  # 100


def _records(folder: Path) -> Path:
    rows = [{"age": x, "group": a, "hired": u} for (x, a, u), n in COUNTS.items() for _ in range(n)]
    path = folder / "records.csv"
    pd.DataFrame(rows).to_csv(path, index=False)
    return path


SPEC = """
[sensitive]
name = "group"
values = ["a", "b"]
[context]
name = "age"
values = ["young", "old"]
[decision]
name = "hired"
values = [1, 0]
[privacy.sensitive]
mechanism = "randomized_response"
epsilon = {epsilon}
[model]
records = "records.csv"
[utility]
decision = 1
{extra}
"""


def _spec(folder: Path, epsilon: float = 1.0, extra: str = "") -> Path:
    _records(folder)
    path = folder / "spec.toml"
    path.write_text(SPEC.format(epsilon=repr(float(epsilon)), extra=extra))
    return path


def _hand_global() -> Fraction:
    """L̄ of the records under their own population, by hand: E[g | a] = hired share of group a."""
    share = {
        a: Fraction(
            sum(n for (x, b, u), n in COUNTS.items() if b == a and u == 1),
            sum(n for k, n in COUNTS.items() if k[1] == a),
        )
        for a in ("a", "b")
    }
    return max(share.values()) / min(share.values())  # a: 32/50, b: 15/50 -> 32/15


def test_global_fairness_of_a_law_from_counts_uses_the_records_population(tmp_path: Path) -> None:
    frame = pd.read_csv(_records(tmp_path))
    table = count_records(frame, sensitive=["group"], outcome="hired", context=["age"])
    g = fa.indicator(1, table.decisions)
    r = fa.global_fairness(table.law(), g)
    assert r.population.source == "records"
    assert r.ratio == pytest.approx(float(_hand_global()), rel=1e-13)  # 32/15, not the uniform population's
    uniform = fa.global_fairness(table.law(), g, fa.Population.uniform(table.contexts, table.groups))
    # Hand, uniform P(x | a) = 1/2: E[g|a] = (3/4 + 1/5)/2 = 19/40, E[g|b] = (3/10 + 3/10)/2 = 3/10 -> 19/12
    assert uniform.ratio == pytest.approx(19 / 12, rel=1e-13)
    # A probability table says nothing about who is decided on: the default is uniform, and says so
    table_law = fa.Law(table.law().probabilities, table.contexts, table.groups, table.decisions)
    assumed = fa.global_fairness(table_law, g)
    assert assumed.population.source == "assumed" and assumed.ratio == pytest.approx(19 / 12, rel=1e-13)


def test_certify_and_audit_agree_on_the_same_records(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    spec = _spec(tmp_path)
    assert main(["certify", str(spec), "--format", "json"]) in (0, 1)
    cert = json.loads(capsys.readouterr().out)
    assert main(
        ["audit", str(tmp_path / "records.csv"), "--sensitive", "group", "--context", "age", "--outcome", "hired",
         "--positive", "1", "--confidence", "0.95", "--format", "json"]
    ) == 0  # fmt: skip
    aud = json.loads(capsys.readouterr().out)
    own = cert["unfiltered"]  # the model on its own: the records themselves
    assert own["global"]["ratio"] == pytest.approx(float(_hand_global()), rel=1e-12)
    for key in ("demographic_parity", "equalized_odds", "sup_local", "sup_global"):
        assert own[key] == pytest.approx(aud[key], rel=1e-12), key
    for key in ("local", "global"):
        assert own[key]["value"] == pytest.approx(aud[key]["value"], rel=1e-12), key
        assert own[key]["interval"] == pytest.approx(aud[key]["interval"], rel=1e-12), key
    assert own["intervals"] == aud["intervals"]  # the same route: every interval, level and note
    # Hand: demographic parity gap = |32/50 - 15/50| = 0.34 under the records' own population
    assert aud["demographic_parity"] == pytest.approx(0.34, rel=1e-12)
    for report in (cert, aud):
        pop = report["population"]
        assert pop["source"] == "records" and pop["records"] == N
        # P(young, a) = 0.4 against P(young) P(a) = 0.5 * 0.5: dependent by 0.15
        assert pop["independent"] is False and pop["max_deviation"] == pytest.approx(0.15, abs=1e-12)
    xa = [a for a in cert["assumptions"] if a["name"] == "X independent of A"]
    assert xa[0]["status"] == "violated" and "0.15" in xa[0]["detail"] and "records" in xa[0]["detail"]


def test_a_probability_table_population_is_assumed_never_checked(tmp_path: Path) -> None:
    (tmp_path / "table.csv").write_text(
        "age,group,hired,probability\n"
        + "".join(f"{x},{a},{u},{p}\n" for x in ("young", "old") for a, p1 in (("a", 0.75), ("b", 0.3))
                  for u, p in ((1, p1), (0, 1 - p1)))
    )  # fmt: skip
    (tmp_path / "spec.toml").write_text(
        SPEC.format(epsilon="1.0", extra="").replace("records = ", "table = ").replace("records.csv", "table.csv")
    )
    cert = certify(tmp_path / "spec.toml")
    assert cert.spec.population.source == "assumed"
    xa = [a for a, _ in cert.assumptions if a.name == "X independent of A"]
    assert [a.status for a in xa] == ["assumed"] and "uniform, independent" in xa[0].detail
    from fairaudit.reports.formats import render

    text = render(cert.to_dict(), "certify", "text")
    assert "population P(X, A): assumed (uniform, independent)" in text
    assert "[checked] X independent of A" not in text


def test_a_given_population_wins_over_the_records(tmp_path: Path) -> None:
    spec = _spec(tmp_path, extra="[population]\nprobabilities = [[0.25, 0.25], [0.25, 0.25]]\n")
    s = load_spec(spec)
    assert s.population.source == "given"
    cert = certify(s)
    assert cert.unfiltered is not None
    assert cert.unfiltered.global_fairness.ratio == pytest.approx(19 / 12, rel=1e-13)  # the uniform hand value


# ----------------------------------------------------------------------------- global black box, X and A dependent


def _lp_worst_global(epsilon: float, pop: np.ndarray) -> float:
    """max over pairs (a, a') and every kernel of E[g | a] / E[g | a'] behind binary RR at ``epsilon``, g = 1{U = 1}.

    E[g | a] = Σ_x P(x | a) Σ_b M[a, b] G[x, b] with G[x, b] = K[x, b, 1] in [0, 1]. Charnes–Cooper: y = t G,
    maximise c_a · y subject to c_a' · y = 1, 0 <= y <= t, t >= 0 (scipy's HiGHS, not fairaudit's cvxpy).
    """
    p = math.exp(epsilon) / (math.exp(epsilon) + 1) if math.isfinite(epsilon) else 1.0
    m = np.array([[p, 1 - p], [1 - p, p]])
    w = pop / pop.sum(axis=0)  # P(x | a), (X, A)
    X, A = pop.shape
    best = 0.0
    for a in range(A):
        for b in range(A):
            if a == b:
                continue
            ca = np.outer(w[:, a], m[a]).ravel()  # over (x, released group)
            cb = np.outer(w[:, b], m[b]).ravel()
            n = X * A
            c = -np.concatenate([ca, [0.0]])
            a_eq = np.concatenate([cb, [0.0]])[None, :]
            a_ub = np.hstack([np.eye(n), -np.ones((n, 1))])  # y - t <= 0
            res = linprog(
                c, A_ub=a_ub, b_ub=np.zeros(n), A_eq=a_eq, b_eq=[1.0], bounds=[(0, None)] * (n + 1), method="highs"
            )
            assert res.status == 0
            best = max(best, -res.fun)
    return math.log(best)


POP = np.array([[40, 10], [10, 40]]) / 100.0  # the records' own P(X, A): rows young, old; columns a, b


def test_global_black_box_on_a_dependent_population_matches_an_lp(tmp_path: Path) -> None:
    for eps in (0.0, 0.3, 1.0):
        cert = certify(_spec(tmp_path, eps))
        worst = cert.black_box.global_fairness
        assert worst.value == pytest.approx(_lp_worst_global(eps, POP), rel=1e-7, abs=1e-9), eps


def test_calibrate_global_on_a_dependent_population_agrees_with_certify(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    floor = _lp_worst_global(0.0, POP)  # groups differ through their contexts: log 2.5 ... whatever the mechanism
    assert floor > 0.5
    target = floor + 0.4
    spec = _spec(tmp_path, 1.0, extra=f"[target]\nglobal = {target!r}\n")
    argv = ["calibrate", "--global", "--spec", str(spec), "--target", repr(target), "--method", "black_box"]
    assert main([*argv, "--format", "json"]) == 0
    out = json.loads(capsys.readouterr().out)
    eps = out["epsilon"]
    assert out["method"] == "black_box" and out["feasible"] and 0 < eps < 1
    # the independent LP at that epsilon gives the target; just past it, more
    assert _lp_worst_global(eps, POP) == pytest.approx(target, rel=1e-7)
    assert _lp_worst_global(eps * (1 + 1e-4), POP) > target
    # certify agrees: met at epsilon, not met just past it
    at = certify(_spec(tmp_path, eps, extra=f"[target]\nglobal = {target!r}\n"))
    past = certify(_spec(tmp_path, eps * (1 + 1e-4), extra=f"[target]\nglobal = {target!r}\n"))
    assert at.targets["global"].met and not past.targets["global"].met
    # certify's own calibration gives the same epsilon and names the target it calibrated
    cert = certify(spec)
    assert cert.calibration is not None and cert.calibration.epsilon == pytest.approx(eps, rel=1e-9)
    assert cert.calibration_targets == ("global",)
    from fairaudit.reports.formats import render

    text = render(cert.to_dict(), "certify", "text")
    assert f"would meet the global target {target:.6g} nats on L-bar for any model (black_box)" in text


def test_calibrate_global_below_the_floor_says_why(tmp_path: Path) -> None:
    spec = load_spec(_spec(tmp_path))
    floor = _lp_worst_global(0.0, POP)
    c = calibrate(floor - 0.1, kind="global", method="black_box", family=spec.sensitive_family,
                  population=spec.population, utility=spec.utility)  # fmt: skip
    assert not c.feasible and c.bound == pytest.approx(floor, rel=1e-7)
    assert "below the floor" in c.reason and "not independent" in c.reason
    for method in ("paper", "tight"):  # L-bar <= L needs X independent of A
        c = calibrate(0.5, kind="global", method=method, utility_class=UtilityClass(tau=0.1), family=spec.sensitive_family, population=spec.population)  # fmt: skip
        assert not c.feasible and "use black_box" in c.reason


# ----------------------------------------------------------------------------- calibrate agrees with certify


@pytest.mark.slow
@pytest.mark.parametrize(
    "kind, method, extra, population",
    [
        ("local", "black_box", "", ""),
        ("local", "black_box", "tau = 0.3\n", ""),
        ("local", "black_box", "values = [1.0, 0.1]\n", ""),
        ("global", "black_box", "", ""),
        ("global", "black_box", "", "[population]\nprobabilities = [[0.3, 0.1], [0.2, 0.4]]\n"),
        ("global", "black_box", "tau = 0.2\n", "[population]\nprobabilities = [[0.3, 0.1], [0.2, 0.4]]\n"),
        ("local", "tight", "tau = 0.3\nlipschitz = 0.1\n", ""),
        ("local", "paper", "tau = 0.3\nlipschitz = 0.1\n", ""),
    ],
)
def test_calibration_agrees_with_certify_at_its_epsilon_and_just_past_it(tmp_path, kind, method, extra, population):
    """The ε calibrate returns meets the target in certify's certificate; for black_box (exact) just past it does not."""
    target = 1.5 if kind == "global" else 0.6  # above log 3, the floor on L-bar of the dependent population
    goal = f"[target]\n{kind} = {target}\n"

    def spec(eps: float) -> Path:
        path = _spec(tmp_path, eps, extra=extra + population + goal)
        text = path.read_text().replace("records = ", "table = ").replace("records.csv", "table.csv")
        (tmp_path / "table.csv").write_text(
            "age,group,hired,probability\n"
            + "".join(f"{x},{a},{u},{pu}\n" for x in ("young", "old") for a in "ab" for u, pu in ((1, 0.5), (0, 0.5)))
        )
        if "values" in extra:  # g in [0.1, 1]: the class's lower end is 0.1
            text = text.replace("decision = 1\n", 'kind = "table"\n')
        if "lipschitz" in extra:  # a utility that depends on the group, within L_A = 0.1
            text = text.replace(
                "decision = 1\n", 'kind = "table"\nvalues = [[[1.0, 0.0], [0.9, 0.0]], [[1.0, 0.0], [0.9, 0.0]]]\n'
            )
        path.write_text(text)
        return path

    s = load_spec(spec(1.0))
    opts = dict(
        utility_class=UtilityClass(tau=s.tau, lipschitz=s.lipschitz, gamma=s.gamma, lower=s.lower),
        population=s.population,
    )
    if kind == "global":
        opts.update(utility=s.utility, context_mechanism=s.context_mechanism)
    c = calibrate(target, kind=kind, method=method, family=s.sensitive_family, **opts)
    assert c.feasible and 0 < c.epsilon < math.inf
    at = certify(spec(c.epsilon))
    assert at.targets[kind].met and at.targets[kind].bound <= target + 1e-9
    if method == "black_box":  # exact: certify's black-box value is the calibrated bound, and grows past it
        value = at.black_box.local_fairness.value if kind == "local" else at.black_box.global_fairness.value
        assert value == pytest.approx(target, rel=1e-8)
        past = certify(spec(c.epsilon * (1 + 1e-5)))
        assert not past.targets[kind].met
