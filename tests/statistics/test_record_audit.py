"""Python parity with the command line (issue 39, item 7): ``audit(records=RecordOptions(count=))``, ``Audit.law``,
``worst-case``, and ``calibrate``'s target impact ratio. Expected values come from pandas or exact fractions, not
from fairaudit."""

from __future__ import annotations

import contextlib
import inspect
import json
import math
from fractions import Fraction
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from _cli import OFFICE_SPEC, run, run_json

from fairaudit import IntervalOptions, RecordOptions, UtilityClass, audit, randomized_response_family
from fairaudit.base.errors import InputError
from fairaudit.certification.spec import load_spec
from fairaudit.laws.utilities import from_table
from fairaudit.worstcase.calibration import calibrate, impact_ratio_target

# A count table: two contexts, two sensitive columns (intersectional groups), a three-valued outcome.
COUNTS = pd.DataFrame(
    {
        "office": ["north"] * 6 + ["south"] * 6,
        "sex": ["f", "f", "f", "m", "m", "m"] * 2,
        "age": ["old", "young", "young", "old", "young", "old"] * 2,
        "grade": [2, 1, 2, 0, 2, 2, 0, 1, 2, 1, 0, 2],
        "n": [3, 5, 2, 4, 7, 1, 6, 2, 9, 3, 5, 4],
    }
)


# The same counts by office, sex and grade (pandas sums over age): a count table for `sensitive=["sex"]`.
BY_SEX = COUNTS.groupby(["office", "sex", "grade"], as_index=False)["n"].sum()


def expanded(counts: pd.DataFrame) -> pd.DataFrame:
    """One row per record: each row of the count table repeated its count times (pandas' own route)."""
    return counts.loc[counts.index.repeat(counts["n"])].drop(columns="n").reset_index(drop=True)


def as_json(d):
    return json.loads(json.dumps(d, allow_nan=False))


def test_audit_count_equals_the_expanded_records_and_the_cli(tmp_path, capsys):
    kw = dict(
        sensitive=["sex"],
        outcome="grade",
        context=["office"],
        utility="u >= 2",
        intervals=IntervalOptions(confidence=0.9),
    )
    by_count = audit(BY_SEX, records=RecordOptions(count="n"), **kw)
    by_records = audit(expanded(BY_SEX), **kw)
    assert by_count.table.counts.dtype == np.int64
    np.testing.assert_array_equal(by_count.table.counts, by_records.table.counts)
    assert as_json(by_count.to_dict()) == as_json(by_records.to_dict())
    path = tmp_path / "counts.csv"
    BY_SEX.to_csv(path, index=False)
    code, cli, _ = run_json(
        capsys, "audit", path, "--sensitive", "sex", "--outcome", "grade", "--context", "office",
        "--utility", "u >= 2", "--confidence", "0.9", "--count", "n",
    )  # fmt: skip
    assert code == 0 and cli == as_json(by_count.to_dict())
    # the numbers, by hand from the table: E[g | x, a] = P(grade >= 2 | office, sex)
    rec = expanded(COUNTS)
    rate = (rec["grade"] >= 2).groupby([rec["office"], rec["sex"]]).mean()
    ratios = {x: max(rate[x]) / min(rate[x]) for x in ("north", "south")}
    assert by_count.observed.local_fairness.value == pytest.approx(math.log(max(ratios.values())), abs=1e-12)
    # north: f 5/10, m 8/12 (ratio 4/3); south: f 9/17, m 4/12 (ratio 27/17, the larger): L = log(27/17)
    assert by_count.observed.local_fairness.ratio == pytest.approx(float(Fraction(27, 17)), abs=1e-12)
    assert by_count.table.n == int(COUNTS["n"].sum()) == 51


def test_audit_count_intersectional_and_default_utility():
    t = COUNTS.assign(hired=(COUNTS["grade"] == 2).astype(int)).drop(columns="grade")
    t = t.groupby(["office", "sex", "age", "hired"], as_index=False)["n"].sum()
    by_count = audit(t, sensitive=["sex", "age"], outcome="hired", context=["office"], records=RecordOptions(count="n"))
    by_records = audit(expanded(t), sensitive=["sex", "age"], outcome="hired", context=["office"])
    assert as_json(by_count.to_dict()) == as_json(by_records.to_dict())
    rec = expanded(t)
    p = rec.groupby(["sex", "age"])["hired"].mean()  # pooled over offices: the global metric's E[g | a]
    assert by_count.observed.global_fairness.ratio == pytest.approx(p.max() / p.min(), abs=1e-12)


@pytest.mark.parametrize(
    ("change", "kwargs", "needle"),
    [
        (
            lambda t: t.assign(n=[-1] + list(t["n"][1:])),
            {},
            "column 'n': must hold finite non-negative numbers; data row 1 (office='north', sex='f', grade='1') is not (got -1)",
        ),
        (
            lambda t: t.assign(n=["x"] + list(t["n"][1:])),
            {},
            "column 'n': must hold finite non-negative numbers; data row 1 (office='north', sex='f', grade='1') is not (got 'x')",
        ),
        (lambda t: t, {"count": "m"}, "count: unknown column; the data has: office, sex, grade, n (got 'm')"),
        (lambda t: pd.concat([t, t.iloc[:1]]), {}, "count table: lists the same (context, group, decision) twice"),
    ],
)
def test_audit_count_errors_are_the_cli_errors(tmp_path, capsys, change, kwargs, needle):
    data = change(BY_SEX)
    count = kwargs.get("count", "n")
    with pytest.raises(InputError) as exc:
        audit(
            data,
            sensitive=["sex"],
            outcome="grade",
            context=["office"],
            utility="u >= 2",
            records=RecordOptions(count=count),
        )
    assert str(exc.value).startswith(needle), str(exc.value)
    path = tmp_path / "counts.csv"
    data.to_csv(path, index=False)
    code, out, err = run(
        capsys, "audit", path, "--sensitive", "sex", "--outcome", "grade", "--context", "office",
        "--utility", "u >= 2", "--count", count,
    )  # fmt: skip
    flag = "--" + needle if needle.startswith("count") else needle  # the library's parameter as the CLI's flag
    assert code == 2 and out == "" and err.startswith(f"fairaudit: error: {flag}") and err.count("\n") == 1, err


def test_audit_takes_at_most_12_parameters():
    """Issue 81, item 5: how records are read is one RecordOptions (records=), not five parameters and sample_weight."""
    parameters = inspect.signature(audit).parameters
    assert len(parameters) <= 12
    assert "records" in parameters and not {"dropna", "weights", "count", "min_count", "sample_weight"} & set(
        parameters
    )


def test_audit_count_refuses_what_it_cannot_mean():
    kw = dict(sensitive=["sex"], outcome="grade", context=["office"], utility="u >= 2")
    with pytest.raises(InputError, match=r"^weights: a count table \(`count`\) is counted already"):
        audit(BY_SEX, records=RecordOptions(count="n", weights="n"), **kw)
    table = audit(BY_SEX, records=RecordOptions(count="n"), **kw).table
    with pytest.raises(InputError, match=r"^count: is for a DataFrame of counts; a CountTable is counted already"):
        audit(table, records=RecordOptions(count="n"))
    with pytest.raises(InputError, match=r"^count: is the count column of a DataFrame `data`"):
        audit(y_pred=[1, 0], sensitive_features=["a", "b"], records=RecordOptions(count="n"))


def test_audit_law_is_the_documented_law_of_the_metrics():
    a = audit(
        BY_SEX,
        sensitive=["sex"],
        outcome="grade",
        context=["office"],
        utility="u >= 2",
        records=RecordOptions(count="n"),
    )
    law = a.law
    assert law is a.observed.law
    assert law.probabilities.shape == (2, 2, 3)  # (contexts, groups, decisions)
    assert (law.contexts, law.groups, law.decisions) == (("north", "south"), ("f", "m"), (0, 1, 2))
    rec = expanded(COUNTS)
    by_pandas = pd.crosstab([rec["office"], rec["sex"]], rec["grade"], normalize="index")
    np.testing.assert_allclose(law.probabilities.reshape(4, 3), by_pandas.to_numpy(), rtol=0, atol=1e-15)
    # with min_count the cell left out has no records in the law either
    records = RecordOptions(count="n", min_count=11)
    small = audit(BY_SEX, sensitive=["sex"], outcome="grade", context=["office"], utility="u >= 2", records=records)
    assert small.law.empty_cells == (("north", "f"),)
    assert np.isnan(small.law.probabilities[0, 0]).all()


# -- calibrate: a target impact ratio ----------------------------------------------------------------------------

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@pytest.mark.parametrize(
    "kw",
    [
        {},
        {"family": randomized_response_family(range(8))},
        {"family": randomized_response_family(range(3)), "kind": "global"},
        {"method": "tight", "utility_class": UtilityClass(tau=0.4, lipschitz=0.01)},
        {"family": randomized_response_family(range(5)), "utility_class": UtilityClass(tau=0.3)},
    ],
)
def test_target_impact_ratio_is_exactly_the_nats_target(kw):
    by_ratio = calibrate(target_impact_ratio=0.8, **kw)
    by_nats = calibrate(math.log(1.25), **kw)
    assert by_ratio.target == math.log(1.25) and by_ratio.target_impact_ratio == 0.8
    assert by_ratio.epsilon == by_nats.epsilon and by_ratio.keep_probability == by_nats.keep_probability
    assert by_ratio.feasible and by_nats.target_impact_ratio is None
    assert by_ratio.to_dict() == {**by_nats.to_dict(), "target_impact_ratio": 0.8}


def test_target_impact_ratio_two_groups_by_hand():
    # two groups in [0, 1]: the worst model's L is epsilon, so epsilon = ln(1/0.8) = ln(5/4), keep = (5/4)/(9/4) = 5/9
    c = calibrate(target_impact_ratio=0.8)
    assert c.epsilon == math.log(1.25)
    assert c.keep_probability == pytest.approx(float(Fraction(5, 9)), abs=1e-15)
    assert calibrate(target_impact_ratio=1.0).epsilon == 0.0  # equal rates: no information may pass
    assert impact_ratio_target(0.5) == math.log(2.0)


def test_target_impact_ratio_white_box_keeps_every_ratio_above_it():
    """GPT-3.5 behind 8-ary randomized response at the calibrated epsilon: every job's worst impact ratio >= 0.8."""
    spec = load_spec(EXAMPLES / "llm_hiring" / "gpt35.toml")
    opts = spec.calibration_options()
    c = calibrate(target_impact_ratio=0.8, **opts)
    assert c.method == "white_box" and c.feasible
    assert c.epsilon == calibrate(math.log(1.25), **opts).epsilon
    # an independent route: the filtered selection rates by numpy, rate[x, a] = sum_b M[a, b] K[x, b, "1"]
    keep = c.keep_probability
    k = 8
    m = np.full((k, k), (1 - keep) / (k - 1))
    np.fill_diagonal(m, keep)
    first = opts["kernel"].probabilities[:, :, 0]  # P(rank 1 | job, shown group)
    rate = first @ m.T
    worst = (rate.min(axis=1) / rate.max(axis=1)).min()
    assert worst == pytest.approx(0.8, abs=1e-9) and worst >= 0.8 - 1e-12


def test_target_impact_ratio_errors():
    with pytest.raises(InputError, match=r"^target_impact_ratio: give `target` \(nats\) or `target_impact_ratio`"):
        calibrate(0.2, target_impact_ratio=0.8)
    with pytest.raises(InputError, match=r"^target: give a target on L in nats, or `target_impact_ratio`"):
        calibrate()
    for bad in (0.0, 1.5, -0.2, math.nan, math.inf):
        with pytest.raises(InputError, match=r"^target_impact_ratio: must be an impact ratio in \(0, 1\]"):
            calibrate(target_impact_ratio=bad)
    with pytest.raises(InputError, match=r"^gamma: a target impact ratio is for a selection indicator"):
        calibrate(target_impact_ratio=0.8, utility_class=UtilityClass(gamma=2.0))
    with pytest.raises(InputError, match=r"^lower: a target impact ratio is for a selection indicator"):
        calibrate(target_impact_ratio=0.8, utility_class=UtilityClass(lower=0.1))
    score = from_table([1.0, 0.5, 0.0], ("hire", "wait", "reject"), name="score")
    with pytest.raises(InputError, match=r"^utility: .*takes the value 0.5: give `target` in nats \(got 'score'\)"):
        calibrate(target_impact_ratio=0.8, utility=score)


def test_cli_calibrate_target_impact_ratio(capsys):
    code, d, _ = run_json(capsys, "calibrate", "--target-impact-ratio", "0.8", "--groups", "8")
    assert code == 0 and d["target_impact_ratio"] == 0.8 and d["target"] == math.log(1.25)
    assert d["epsilon"] == calibrate(math.log(1.25), family=randomized_response_family(range(8))).epsilon
    code, out, _ = run(capsys, "calibrate", "--target-impact-ratio", "0.8")
    assert code == 0 and out.startswith(
        "largest epsilon of 2-ary randomized response meeting L <= 0.223144 nats "
        "(every impact ratio >= 0.8: L is -ln of the worst impact ratio): 0.223144 nats\n"
    )
    code, out, _ = run(
        capsys, "calibrate", "--target-impact-ratio", "0.8", "--spec", EXAMPLES / "llm_hiring" / "gpt35.toml"
    )
    assert code == 0 and "(every impact ratio >= 0.8: L is -ln of the worst impact ratio)" in out


SCORE_SPEC = """
[sensitive]
name = "office"
values = ["HR_1", "HR_2"]
[decision]
name = "grade"
values = ["high", "mid", "low"]
[privacy.sensitive]
mechanism = "randomized_response"
keep = 0.7
[utility]
kind = "table"
values = [1.0, 0.5, 0.0]
"""


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["--target-impact-ratio", "0"], "fairaudit: error: --target-impact-ratio: must be an impact ratio in (0, 1] (got 0.0)"),
        (["--target-impact-ratio", "1.25"], "fairaudit: error: --target-impact-ratio: must be an impact ratio in (0, 1] (got 1.25)"),
        (["--target-impact-ratio", "0.8", "--gamma", "2"], "fairaudit: error: --gamma: a target impact ratio is for a selection indicator, g in {0, 1}: gamma must be 1; give --target in nats"),
        (["--target-impact-ratio", "0.8", "--target", "0.2"], "fairaudit calibrate: error: argument --target: not allowed with argument --target-impact-ratio"),
        ([], "fairaudit calibrate: error: one of the arguments --target --target-impact-ratio is required"),
        (["--target-impact-ratio", "0.8", "--spec", "SCORE"], "fairaudit: error: --spec: a target impact ratio is for a selection indicator, g in {0, 1}; this utility takes the value 0.5: give --target in nats"),
    ],
)  # fmt: skip
def test_cli_calibrate_target_impact_ratio_errors(tmp_path, capsys, argv, needle):
    spec = tmp_path / "score.toml"
    spec.write_text(SCORE_SPEC)
    argv = [str(spec) if a == "SCORE" else a for a in argv]
    with pytest.raises(SystemExit) if "calibrate: error" in needle else contextlib.nullcontext():
        code, out, err = run(capsys, "calibrate", *argv)
        assert code == 2 and out == ""
    err = capsys.readouterr().err if "calibrate: error" in needle else err
    assert err.startswith(needle) and err.count("\n") == 1, err


# -- fairaudit worst-case SPEC ------------------------------------------------------------------------------------


def gpt35_law() -> np.ndarray:
    """GPT-3.5's ranking law behind 8-ary randomized response at epsilon 0.5, by pandas and numpy from the counts."""
    t = pd.read_csv(EXAMPLES / "llm_hiring" / "gpt_rank_counts.csv", dtype={"rank": str})
    t = t[t["model"] == "gpt-3.5-turbo"]
    jobs = ["HR specialist", "financial analyst", "retail", "software engineer"]
    demos = ["A_M", "A_W", "B_M", "B_W", "H_M", "H_W", "W_M", "W_W"]
    ranks = ["1", "2", "3", "4", "5", "6", "7", "8", "unranked"]
    n = t.pivot_table(index=["job", "demo"], columns="rank", values="count", aggfunc="sum", fill_value=0)
    n = n.reindex(columns=ranks, fill_value=0).reindex(pd.MultiIndex.from_product([jobs, demos]))
    kernel = (n.to_numpy(float) / n.to_numpy(float).sum(axis=1, keepdims=True)).reshape(4, 8, 9)
    e = math.exp(0.5)
    m = np.full((8, 8), 1 / (e + 7))
    np.fill_diagonal(m, e / (e + 7))
    return np.einsum("ab,xbu->xau", m, kernel)


def test_worst_case_matches_a_brute_force_over_every_0_1_utility(capsys):
    """Without tau the worst utility in [0, 1]^9 is at a vertex: try all 511 nonzero 0/1 utilities by numpy."""
    q = gpt35_law()
    best_local, best_global = (-1.0, None), (-1.0, None)
    for bits in range(1, 2**9):
        g = np.array([(bits >> i) & 1 for i in range(9)], dtype=float)
        e = q @ g  # E[g | x, a]
        local = np.log(e.max(axis=1) / e.min(axis=1)).max()
        pooled = e.mean(axis=0)  # every (job, group) has 1,000 records: P(x | a) is uniform
        best_local = max(best_local, (local, tuple(g)))
        best_global = max(best_global, (np.log(pooled.max() / pooled.min()), tuple(g)))
    code, d, err = run_json(capsys, "worst-case", EXAMPLES / "llm_hiring" / "gpt35.toml", "--tau", "0")
    assert code == 0 and err == ""
    assert d["local"]["value"] == pytest.approx(best_local[0], abs=1e-12)
    assert d["global"]["value"] == pytest.approx(best_global[0], abs=1e-12)
    assert tuple(d["local"]["utility"]) == best_local[1] and tuple(d["global"]["utility"]) == best_global[1]
    assert d["decisions"] == ["1", "2", "3", "4", "5", "6", "7", "8", "unranked"] and d["tau"] == 0.0
    # g = 1{unranked}: L is largest between B_W and H_M for software engineers
    assert best_local[1] == (0.0,) * 8 + (1.0,)
    assert (d["local"]["context"], d["local"]["group"], d["local"]["other_group"]) == (
        "software engineer",
        "B_W",
        "H_M",
    )
    # the spec's own utility, 1{rank 1}, on the same law
    e = q[:, :, 0]
    assert d["spec_utility"]["local"] == pytest.approx(np.log(e.max(axis=1) / e.min(axis=1)).max(), abs=1e-12)


def test_worst_case_with_tau_by_hand(capsys, tmp_path):
    """HR_2's profile is always chosen: behind p = 0.7 on three attributes HR_2 is chosen with 0.7^3, HR_1 with 0.3^3.

    Every utility with g(not chosen) = 0 (and tau met) gives the ratio 343/27; the LP (tau = 0.02) finds it.
    """
    spec = EXAMPLES / "hr_office" / "hr_office.toml"
    code, d, _ = run_json(capsys, "worst-case", spec)
    assert code == 0 and d["tau"] == 0.02 and d["local"]["method"] == "lp"
    for key in ("local", "global"):
        assert d[key]["ratio"] == pytest.approx(float(Fraction(343, 27)), rel=1e-9)
        assert (d[key]["group"], d[key]["other_group"]) == ("Mary & 55 & American", "Tom & 25 & Asian")
        chosen, not_chosen = d[key]["utility"]
        assert not_chosen == pytest.approx(0.0, abs=1e-9) and chosen * 0.3**3 >= 0.02 - 1e-9
    code, out, _ = run(capsys, "worst-case", spec)
    assert code == 0 and "worst utility for L: g = " in out and "; 0 on not chosen\n" in out
    assert (
        "  L = 2.54189 nats, ratio 12.7037 (Mary & 55 & American vs Tom & 25 & Asian in context maternity leave)" in out
    )
    # --output: written atomically, the summary on stderr
    target = tmp_path / "worst.json"
    code, out, err = run(capsys, "worst-case", spec, "--format", "json", "--output", target)
    assert code == 0 and out == "" and json.loads(target.read_text()) == d
    assert err.startswith("worst case: L = ") and err.endswith(f"report written to {target}\n")
    for fmt in ("markdown", "html"):
        code, out, _ = run(capsys, "worst-case", spec, "--format", fmt)
        assert code == 0 and "worst utility for L-bar" in out


def test_worst_case_errors(capsys, tmp_path):
    bare = tmp_path / "bare.toml"
    bare.write_text(OFFICE_SPEC)
    spec = EXAMPLES / "hr_office" / "hr_office.toml"
    for argv, needle in (
        ([bare], f"fairaudit: error: {bare}: model: worst-case needs a decision model"),
        ([tmp_path / "none.toml"], "fairaudit: error: SPEC: no such file"),
        ([spec, "--tau", "2"], "fairaudit: error: --tau: exceeds gamma = 1"),
    ):
        code, out, err = run(capsys, "worst-case", *argv)
        assert code == 2 and out == "" and err.startswith(needle) and err.count("\n") == 1, err
    with pytest.raises(SystemExit):
        run(capsys, "worst-case", spec, "--lower", "-1")
    err = capsys.readouterr().err
    assert err.startswith("fairaudit worst-case: error: argument --lower: expected a finite number >= 0, got '-1'")
