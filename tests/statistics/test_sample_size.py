"""fairaudit.plan and `fairaudit plan`: hand values by scipy's exact binomial test, an independent re-simulation,
the vectorised path against fairness_intervals, infeasible plans, errors, and the command line."""

from __future__ import annotations

import json
import math
import re
from functools import cache

import numpy as np
import pytest
from _cli import run, run_json
from scipy import stats

import fairaudit as fa
from fairaudit.cli import main
from fairaudit.data.counts import CountTable
from fairaudit.statistics.sample_size import SamplePlan, _Certifier, plan


@cache
def exact_ci(k: int, n: int, level: float):
    ci = stats.binomtest(k, n).proportion_ci(confidence_level=level, method="exact")
    return ci.low, ci.high


def upper_by_binomtest(ks, n, confidence):
    """Upper end of L for one context and groups ks: Bonferroni over the m = len(ks) cells, exact intervals."""
    level = 1 - (1 - confidence) / len(ks)
    cis = [exact_ci(int(k), n, level) for k in ks]
    ratios = [
        hi / lo if lo > 0 else math.inf for i, (_, hi) in enumerate(cis) for j, (lo, _) in enumerate(cis) if i != j
    ]
    return math.log(max(max(ratios), 1.0))


def table(k, n):
    k = np.asarray(k)
    X, A = k.shape
    return CountTable(np.stack([k, n - k], -1), tuple(range(X)), tuple(range(A)), (1, 0), ("x",), ("a",), "u")


# -- hand values -------------------------------------------------------------------------------------------


@pytest.mark.parametrize("n,p,conf", [(100, 0.5, 0.95), (400, 0.3, 0.9), (37, 0.2, 0.99)])
def test_expected_counts_match_binomtest(n, p, conf):
    # counts (k, k) with k = n p: the upper end is log(hi / lo) of one exact interval at level 1 - alpha / 2
    k = round(n * p)
    lo, hi = exact_ci(k, n, 1 - (1 - conf) / 2)
    cert = _Certifier(2, 1, conf, "clopper-pearson", None, "local", 0)
    assert cert.fast(np.array([[[k, k]]]), n)[0] == pytest.approx(math.log(hi / lo), rel=1e-9)
    iv = fa.fairness_intervals(
        table([[k, k]], n), fa.indicator(1, (1, 0)), fa.IntervalOptions(confidence=conf, method="clopper-pearson")
    )
    assert iv.local_fairness.upper == pytest.approx(math.log(hi / lo), rel=1e-9)


def test_planned_n_by_enumerating_every_table_with_binomtest():
    # L without a filter: the power is exact (order statistics of the counts). Independently: every pair of counts
    # (k0, k1) of two groups, weighted by its binomial probabilities, its upper end from scipy's exact binomial test;
    # the power at n >= 0.8 and at n - 1 < 0.8, and the median of the upper end, each to the last digits.
    pl = plan(0.5, base_rate=0.3, seed=3)
    assert isinstance(pl, SamplePlan) and pl.feasible and pl.n_total == 2 * pl.n_per_cell and pl.datasets is None

    def power(n):
        ups = np.array([[upper_by_binomtest((k0, k1), n, 0.95) for k1 in range(n + 1)] for k0 in range(n + 1)])
        pmf = stats.binom.pmf(np.arange(n + 1), n, 0.3)
        weights = np.outer(pmf, pmf).ravel()
        order = np.argsort(ups.ravel(), kind="stable")
        median = ups.ravel()[order][np.searchsorted(np.cumsum(weights[order]), 0.5)]
        return float(weights[ups.ravel() <= 0.5].sum()), float(median)

    p_n, med = power(pl.n_per_cell)
    assert p_n >= 0.8 and p_n == pytest.approx(pl.achieved_power, abs=1e-12)
    assert med == pytest.approx(pl.expected_upper, rel=1e-9)
    assert power(pl.n_per_cell - 1)[0] < 0.8


@pytest.mark.parametrize(
    "n, groups, contexts, base, disparity, target",
    [(6, 2, 1, 0.5, 0.0, 1.5), (5, 3, 1, 0.4, 0.2, 2.0), (4, 2, 2, 0.5, 0.1, 2.5), (6, 2, 1, 0.7, -0.3, 1.2)],
)
def test_exact_power_is_the_simulated_certificate_summed_over_every_table(n, groups, contexts, base, disparity, target):
    # every table of counts, weighted by its probability, certified by the simulation's own vectorised certificate
    import itertools

    from fairaudit.statistics import sample_size

    rates = np.full((contexts, groups), base)
    rates[:, 0] = base * math.exp(disparity)
    tables = np.array(list(itertools.product(range(n + 1), repeat=contexts * groups))).reshape(-1, contexts, groups)
    certify = _Certifier(groups=groups, contexts=contexts, confidence=0.95, method="clopper-pearson", mechanism=None,
                         kind="local", seed=0)  # fmt: skip
    ups = certify.fast(tables, n)
    weights = np.prod(stats.binom.pmf(tables, n, rates[None]), axis=(1, 2))
    order = np.argsort(ups, kind="stable")
    median = ups[order][np.searchsorted(np.cumsum(weights[order]), 0.5 - 1e-12)]
    inputs = {"contexts": contexts, "groups": groups, "confidence": 0.95, "target": target}
    power, upper = sample_size._order_power(n, inputs, rates)
    assert power == pytest.approx(float(weights[ups <= target].sum()), abs=1e-15)
    assert upper == median


def test_exact_power_agrees_with_a_simulation_of_the_tables():
    # 20 groups in 10 contexts: the power at n against the fraction of 4000 simulated tables (within 4 standard errors)
    from fairaudit.statistics import sample_size

    rates = np.full((10, 20), 0.5)
    inputs = {"contexts": 10, "groups": 20, "confidence": 0.95, "target": 0.5}
    certify = _Certifier(groups=20, contexts=10, confidence=0.95, method="clopper-pearson", mechanism=None,
                         kind="local", seed=0)  # fmt: skip
    for n in (500, 560):
        power, _ = sample_size._order_power(n, inputs, rates)
        simulated = float(np.mean(certify.fast(np.random.default_rng(n).binomial(n, rates, (4000, 10, 20)), n) <= 0.5))
        assert abs(power - simulated) <= 4 * math.sqrt(max(power * (1 - power), 1e-4) / 4000), (n, power, simulated)


def test_a_million_cell_plan_is_computed_exactly_in_bounded_memory():
    # the plan: 1000 groups x 1000 contexts, target 0.001 nats: no n up to max_n reaches the power, said
    # at once (the exact power needs the counts' window, not the tables)
    import tracemalloc

    tracemalloc.start()
    far = plan(0.001, groups=1000, contexts=1000)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert far.reason == "max_n = 1000000 queries per cell give power 0 < 0.8" and peak < 64 * 2**20
    near = plan(0.2, groups=1000, contexts=1000, max_n=20_000)
    assert near.feasible and near.achieved_power >= 0.8 and near.expected_upper <= 0.2


def test_disparity_needs_more_and_multinomial_coincides_for_binary():
    fair = plan(0.6, datasets=80)
    unfair = plan(0.6, disparity=0.2, datasets=80)
    assert unfair.n_per_cell > fair.n_per_cell and unfair.true_value == pytest.approx(0.2, rel=1e-12)
    multi = plan(0.6, datasets=80, method="multinomial")
    assert (multi.n_per_cell, multi.achieved_power) == (fair.n_per_cell, fair.achieved_power)


@pytest.mark.parametrize("X,A,eps", [(1, 2, None), (2, 3, None), (1, 2, 0.8), (2, 3, 1.5)])
@pytest.mark.parametrize("kind", ["local", "global"])
def test_vectorised_upper_ends_equal_fairness_intervals(X, A, eps, kind):
    rng = np.random.default_rng(X * 10 + A)
    mech = None if eps is None else fa.randomized_response(tuple(range(A)), eps)
    n = 60
    k = rng.binomial(n, rng.uniform(0.05, 0.95, (X, A)), size=(6, X, A))
    k[0] = 0  # zero counts: +inf upper end (finite behind a filter, which mixes the groups)
    for method in ("clopper-pearson", "multinomial"):
        cert = _Certifier(A, X, 0.9, method, mech, kind, 0)
        pop = fa.Population.uniform(tuple(range(X)), tuple(range(A)))
        ref = [
            getattr(
                fa.fairness_intervals(
                    table(kk, n),
                    fa.indicator(1, (1, 0)),
                    fa.IntervalOptions(confidence=0.9, method=method),
                    sensitive_mechanism=mech,
                    population=pop,
                ),
                f"{kind}_fairness",
            ).upper
            for kk in k
        ]
        np.testing.assert_allclose(cert.fast(k, n), ref, rtol=1e-9)
    assert math.isinf(ref[0]) == (eps is None)


def test_filtered_true_value_and_bayes():
    # binary randomized response at eps keeps with p = e^eps / (e^eps + 1): Q_0 = p r0 + (1 - p) r1
    eps, r1 = 1.0, 0.4
    r0 = r1 * math.exp(0.5)
    p = math.exp(eps) / (math.exp(eps) + 1)
    true = math.log((p * r0 + (1 - p) * r1) / ((1 - p) * r0 + p * r1))
    below = plan(true * 0.99, base_rate=r1, disparity=0.5, epsilon=eps)
    assert below.n_per_cell is None and below.true_value == pytest.approx(true, rel=1e-12)
    assert "not above the true L" in below.reason
    # bayes loops over fairness_intervals; the reported power is that of those intervals
    seen = []
    b = plan(1.0, method="bayes", datasets=8, epsilon=1.0, kind="global", progress=lambda n, pw: seen.append(n))
    assert b.feasible and b.datasets == 8 and b.achieved_power >= 0.8 and b.n_per_cell in seen
    assert plan(1.0, method="bayes", max_n=1).datasets == 40


def test_max_n_not_reached():
    pl = plan(0.3, max_n=50, datasets=50)
    assert pl.n_per_cell is None and pl.n_total is None and pl.achieved_power < 0.8
    assert pl.reason.startswith("max_n = 50 queries per cell give power")


@pytest.mark.parametrize(
    "kwargs,field",
    [
        (dict(target=-1), "target"),
        (dict(target=math.inf), "target"),
        (dict(groups=1), "groups"),
        (dict(groups=2.0), "groups"),
        (dict(contexts=0), "contexts"),
        (dict(base_rate=0), "base_rate"),
        (dict(base_rate=0.6, disparity=1.0), "disparity"),
        (dict(confidence=1), "confidence"),
        (dict(method="wald"), "method"),
        (dict(power=0), "power"),
        (dict(epsilon=-0.1), "epsilon"),
        (dict(kind="both"), "kind"),
        (dict(datasets=0), "datasets"),
        (dict(seed=-1), "seed"),
        (dict(max_n=0), "max_n"),
    ],
)
def test_invalid_arguments_name_the_argument(kwargs, field):
    kwargs = {"target": 0.5, **kwargs}
    target = kwargs.pop("target")
    with pytest.raises(fa.InputError) as exc:
        plan(target, **kwargs)
    assert exc.value.field == field and "(got " in str(exc.value)


# -- command line ----------------------------------------------------------------------------------------


def test_cli_json_keys_and_exit_0(capsys):
    code, d, _ = run_json(capsys, "plan", "--target", 0.6, "--datasets", 60)
    assert code == 0
    for key in ("target", "confidence", "power", "plans"):
        assert key in d
    (p,) = d["plans"]
    assert set(p) >= {"method", "n_per_cell", "n_total", "achieved_power", "expected_upper", "reason"}
    ref = plan(0.6, datasets=60)
    assert (p["method"], p["n_per_cell"], p["n_total"]) == ("clopper-pearson", ref.n_per_cell, ref.n_total)
    assert p["achieved_power"] == ref.achieved_power and p["reason"] == ""


def test_cli_all_methods_text_and_markdown(capsys):
    argv = ("plan", "--target", 1.5, "--datasets", 6, "--method", "all", "--epsilon", 1, "--global")
    code, d, _ = run_json(capsys, *argv)
    assert code == 0 and [p["method"] for p in d["plans"]] == ["clopper-pearson", "multinomial", "bayes"]
    assert d["kind"] == "global" and d["epsilon"] == 1.0
    code, out, _ = run(capsys, *argv)
    assert code == 0 and out.startswith("queries per cell to certify L-bar <= 1.5 nats at confidence 0.95")
    assert len(out.splitlines()) == 6
    code, md, _ = run(capsys, *argv, "--format", "markdown")
    assert md.startswith("# fairaudit plan\n") and "| method | n per cell |" in md


def test_cli_infeasible_exits_1(capsys):
    code, d, _ = run_json(capsys, "plan", "--target", 0.1, "--disparity", 0.2)
    assert code == 1 and d["plans"][0]["n_per_cell"] is None and "not above" in d["plans"][0]["reason"]
    code, out, _ = run(capsys, "plan", "--target", 0.3, "--max-n", 10, "--datasets", 20)
    assert code == 1 and "clopper-pearson: max_n = 10" in out


@pytest.mark.parametrize(
    "argv,needle",
    [
        (["--target", "-1"], "--target: must be a finite number >= 0"),
        (["--target", "0.5", "--base-rate", "1.5"], "--base-rate: must be a number in (0, 1) (got 1.5)"),
        (["--target", "0.5", "--disparity", "1"], "--disparity: gives group 0 the rate"),
        (["--target", "0.5", "--groups", "1"], "--groups: must be a whole number >= 2"),
        (["--target", "0.5", "--power", "1"], "--power: must be a number in (0, 1) (got 1.0)"),
        (["--target", "0.5", "--epsilon", "-1"], "--epsilon: must be a finite number >= 0"),
        (["--target", "0.5", "--max-n", "0"], "--max-n: must be a whole number >= 1 (got 0)"),
        (["--target", "0.5", "--output", "/no/such/dir/p.json"], "--output: folder does not exist"),
    ],
)
def test_cli_invalid_input_is_one_line_exit_2(capsys, argv, needle):
    code, out, err = run(capsys, "plan", *argv)
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and needle in err and "Traceback" not in err


@pytest.mark.parametrize(
    "argv,needle",
    [
        (["--target", "x"], "argument --target: invalid float value: 'x'"),
        (["--target", "0.5", "--method", "wald"], "argument --method: invalid choice: 'wald'"),
        (["--groups", "2"], "the following arguments are required: --target"),
    ],
)
def test_cli_usage_errors_exit_2(capsys, argv, needle):
    with pytest.raises(SystemExit) as exc:
        main(["plan", *argv])
    out, err = capsys.readouterr()
    assert exc.value.code == 2 and out == "" and err.count("\n") == 1 and needle in err


def test_cli_output_written_atomically(tmp_path, capsys):
    target = tmp_path / "plan.json"
    target.write_text("old")
    code, out, err = run(capsys, "plan", "--target", 0.6, "--datasets", 30, "--format", "json", "--output", target)
    assert code == 0 and out == "" and "report written to" in err and err.startswith("queries per cell: ")
    assert json.loads(target.read_text())["plans"][0]["n_per_cell"] == plan(0.6, datasets=30).n_per_cell
    assert sorted(p.name for p in tmp_path.iterdir()) == ["plan.json"]  # no temporary file left


# -- memory: chunks that fit the limit, and the refusal ------------------------------------------------------


@pytest.mark.parametrize(
    "kwargs",
    [
        dict(target=0.5, groups=3, contexts=2, datasets=50, kind="global"),
        dict(target=0.8, groups=3, contexts=2, datasets=30, epsilon=2.0),
        dict(target=0.8, groups=3, contexts=2, datasets=30, epsilon=2.0, kind="global"),
    ],
)
def test_chunked_plan_equals_one_draw(kwargs, monkeypatch):
    from fairaudit.statistics import sample_size

    whole = plan(**kwargs)
    chunks = []
    certify = sample_size._Certifier.__call__
    monkeypatch.setattr(
        sample_size._Certifier, "__call__", lambda self, k, n: chunks.append(len(k)) or certify(self, k, n)
    )
    keys = ("contexts", "groups", "datasets", "method", "epsilon", "kind")
    fixed, per_table = sample_size._memory({k: getattr(whole, k) for k in keys})  # type: ignore[arg-type]
    small = plan(**kwargs, max_memory=fixed + 3 * per_table)
    assert small == whole
    assert max(chunks) == 3 and len(chunks) > len(set(chunks))  # drawn three tables at a time


def test_binomial_draws_chunk_by_chunk_are_one_draw():
    rates = np.array([[0.2, 0.5, 0.9], [0.1, 0.3, 0.7]])
    one = np.random.default_rng(7).binomial(40, rates, size=(7, 2, 3))
    rng = np.random.default_rng(7)
    assert np.array_equal(one, np.concatenate([rng.binomial(40, rates, size=(m, 2, 3)) for m in (3, 3, 1)]))


def test_plan_refuses_beyond_the_limit_before_simulating(monkeypatch):
    monkeypatch.setenv("FAIRAUDIT_MAX_MEMORY", "1K")
    with pytest.raises(fa.InputError, match=r"^memory: one simulated table would need .* more than the limit of 1 KiB"):
        plan(0.5, kind="global")
    assert plan(0.1, disparity=0.2, kind="global").reason  # nothing to simulate: no refusal
    assert plan(0.5).feasible  # L without a filter is not simulated: its exact power needs no tables
    assert plan(0.5, datasets=20, max_memory="1M", kind="global").feasible  # the argument overrides the environment


def test_cli_refuses_with_the_planned_resource_line(capsys, monkeypatch):
    monkeypatch.setenv("FAIRAUDIT_MAX_MEMORY", "100M")
    code, out, err = run(capsys, "plan", "--target", "0.001", "--groups", "1000", "--contexts", "1000", "--global")
    assert (code, out) == (2, "")
    assert err == (
        "fairaudit: error: memory: one simulated table would need 244 MiB (--groups 1000 x --contexts 1000), "
        "more than the limit of 100 MiB (FAIRAUDIT_MAX_MEMORY=100M; --max-memory overrides it): "
        "give fewer --groups or --contexts\n"
    )
    code, out, err = run(capsys, "plan", "--target", "0.5", "--max-memory", "1G", "--datasets", "20", "--global")
    assert code == 0
    code, out, err = run(capsys, "plan", "--target", "0.5", "--max-memory", "many")
    assert code == 2 and err.startswith("fairaudit: error: --max-memory: must be a size such as 4G") and "\n" == err[-1]
    assert err.count("\n") == 1
    monkeypatch.setenv("FAIRAUDIT_MAX_MEMORY", "many")
    code, out, err = run(capsys, "plan", "--target", "0.5")
    assert (
        code == 2 and err.startswith("fairaudit: error: FAIRAUDIT_MAX_MEMORY: must be a size") and err.count("\n") == 1
    )


def test_cli_refuses_the_filtered_plan_of_a_large_table(capsys):
    code, out, err = run(
        capsys, "plan", "--target", "0.001", "--groups", "1000", "--contexts", "1000", "--epsilon", "1"
    )
    assert code == 2 and out == ""
    assert err.startswith("fairaudit: error: memory: one simulated table behind the filter would need ")
    assert "(--groups^3 x --contexts^2 = 1000^3 x 1000^2 behind --epsilon)" in err and err.count("\n") == 1


def _under_address_space_limit(*argv: str, seconds: float) -> tuple[int | None, str]:
    """Exit status (None: still running after ``seconds``, then stopped) and stderr of ``fairaudit *argv`` in a
    process whose address space is limited to 4 GB (``ulimit -v``)."""
    import os
    import resource
    import subprocess
    import sys

    def limit() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (4 * 10**9, 4 * 10**9))

    env = {k: v for k, v in os.environ.items() if k != "FAIRAUDIT_MAX_MEMORY"}
    with subprocess.Popen(
        [sys.executable, "-m", "fairaudit.cli", *argv],
        preexec_fn=limit,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    ) as proc:
        try:
            _, err = proc.communicate(timeout=seconds)
            return proc.returncode, err
        except subprocess.TimeoutExpired:
            proc.kill()
            _, err = proc.communicate()
            return None, err


@pytest.mark.slow
def test_under_4gb_address_space_the_filtered_plan_refuses_at_once():
    code, err = _under_address_space_limit(
        "plan", "--target", "0.001", "--groups", "1000", "--contexts", "1000", "--epsilon", "1", seconds=30
    )
    assert code == 2 and err.startswith("fairaudit: error: memory: ") and err.count("\n") == 1


@pytest.mark.slow
def test_under_4gb_address_space_the_million_cell_plan_answers_within_10_s():
    # the issue's command: L without a filter, its power exact from the counts' window: answered (no n up to max_n
    # reaches the power: exit 1) well within 10 s
    code, err = _under_address_space_limit(
        "plan", "--target", "0.001", "--groups", "1000", "--contexts", "1000", seconds=10
    )
    assert (code, err) == (1, ""), err  # (the report, on stdout, says why)


@pytest.mark.slow
def test_under_4gb_address_space_the_large_simulated_plan_streams_without_a_memory_error():
    # L-bar: 200 simulated tables of 10^6 cells, about 244 MiB a table, streamed in chunks under half the address
    # space left. It takes minutes per sample size: within 30 s it must not have failed.
    code, err = _under_address_space_limit(
        "plan", "--target", "0.001", "--groups", "1000", "--contexts", "1000", "--global", seconds=30
    )
    assert "Traceback" not in err and "MemoryError" not in err
    assert code is None or code in (0, 1) or (code == 2 and err.startswith("fairaudit: error: memory: "))


# -- progress and Ctrl-C ----------------------------------------------------------------------------------------


def test_plan_draws_a_bar_per_sample_size_on_a_terminal_unless_no_progress(monkeypatch, tmp_path):
    from _terminal import lines_drawn, on_terminal

    from fairaudit.statistics import sample_size

    pytest.importorskip("tqdm")
    monkeypatch.setattr(sample_size, "STEP_DELAY", 0.0)
    monkeypatch.setattr(sample_size, "CHUNK_BYTES", 4 * sample_size.CELL_BYTES * 2)  # four tables of 2 cells a chunk
    terminal = on_terminal(monkeypatch)
    argv = ["plan", "--target", "0.5", "--datasets", "10", "--global"]  # (L-bar is simulated: a bar per sample size)
    assert main([*argv, "--output", str(tmp_path / "quiet.txt"), "--no-progress"]) == 0
    quiet = terminal.getvalue()
    n = int(quiet.split(": ")[2].split(";")[0])
    assert quiet == f"queries per cell: clopper-pearson: {n}; report written to {tmp_path / 'quiet.txt'}\n"
    terminal.truncate(0), terminal.seek(0)
    assert main([*argv, "--output", str(tmp_path / "shown.txt")]) == 0
    drawn = lines_drawn(terminal.getvalue())
    # n = 1, 2, 4, ... until the power is reached, then bisection; each n's 10 tables in chunks of 4, 4 and 2 (tqdm
    # redraws at most every 0.1 s: not every chunk is drawn)
    bars = [line for line in drawn if line.startswith("plan: n = ")]
    assert len(bars) == len(drawn) - 1 and all(re.search(r"\| (0|4|8)/10 \[", line) for line in bars)
    tried = list(dict.fromkeys(int(line.split(":")[1].split("=")[1]) for line in bars))
    doubled = [m for m in tried if m & (m - 1) == 0]
    assert tried[: len(doubled)] == doubled == [2**i for i in range(len(doubled))] and n in tried
    assert drawn[-1] == quiet.strip().replace("quiet.txt", "shown.txt")
    assert (tmp_path / "quiet.txt").read_text() == (tmp_path / "shown.txt").read_text()


@pytest.mark.slow
def test_ctrl_c_ends_a_million_cell_plan_at_once_with_status_130_and_no_report(tmp_path):
    from _terminal import run_on_terminal

    pytest.importorskip("tqdm")
    out = tmp_path / "plan.json"
    run = run_on_terminal(
        ["plan", "--target", "0.001", "--groups", "1000", "--contexts", "1000", "--global", "--output", str(out)],
        interrupt_when=lambda written: "plan: n = 1:" in written and "1/200" in written,
    )
    assert run.interrupted_after is not None, run.stderr  # (a table was certified, then SIGINT was sent)
    assert run.interrupted_after < 2.0  # a chunk is one table of 10^6 cells: about 0.1 s of work on one core
    assert run.code == 130 and "Traceback" not in run.stderr
    assert run.stderr.endswith("fairaudit: interrupted\r\n")
    assert list(tmp_path.iterdir()) == []  # no report, no temporary file
