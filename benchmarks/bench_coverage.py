"""Verified coverage of fairaudit's simultaneous intervals on data simulated from known laws (issue 5).

Each dataset is drawn from a KNOWN law: N records i.i.d. from a joint
P(X, A) (one multinomial draw of the whole dataset, so the per-cell counts are
random), then U | X, A from the law Q. For every method of
:func:`fairaudit.fairness_intervals` and each confidence level the script
records whether the true L, L̄, L_dp and L_eo (computed by
:mod:`fairaudit.metrics` on the true law, the global metrics with the true
P(x | a)) lie inside their intervals, separately and all at once
(simultaneous coverage), and the widths. Beside them, on the binary
single-context datasets, fairlearn's percentile bootstrap
(``MetricFrame(..., n_boot, ci_quantiles)``) for L̄ = −log ratio() and for the
DP gap difference().

Usage::

    python benchmarks/bench_coverage.py                 # 1000 datasets, a few minutes
    python benchmarks/bench_coverage.py --quick         # a few seconds
    python benchmarks/bench_coverage.py --datasets 3000 --seed 7 --output coverage.md
"""

import argparse
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _bench_common import emit, machine_line, table  # noqa: E402

from fairaudit import IntervalOptions
from fairaudit.data.counts import CountTable  # noqa: E402
from fairaudit.laws.tables import Law, Population  # noqa: E402
from fairaudit.laws.utilities import from_table, indicator  # noqa: E402
from fairaudit.metrics.fairness import global_fairness, local_fairness  # noqa: E402
from fairaudit.metrics.parity import demographic_parity, equalized_odds  # noqa: E402
from fairaudit.statistics.intervals import fairness_intervals  # noqa: E402

METHODS = ("clopper-pearson", "multinomial", "bayes")
LEVELS = (0.90, 0.95)
METRICS = ("local", "global", "demographic_parity", "equalized_odds")
LABELS = {"local": "L", "global": "L̄", "demographic_parity": "L_dp", "equalized_odds": "L_eo"}
TOL = 1e-9  # absolute slack of the inclusion test (floating-point ties at L = 0)
BAYES_DRAWS = 2000
N_BOOT = 100
DEFAULT_SEED = 20250605
UTILITIES = {2: (0.0, 1.0), 3: (0.0, 0.4, 1.0), 4: (0.0, 0.25, 0.6, 1.0)}  # g(u); K = 2 is the indicator of u = 1


@dataclass(frozen=True)
class Scenario:
    """A family of datasets: the law is drawn once per scenario (from the seed) and then kept fixed."""

    name: str
    contexts: int
    groups: int
    decisions: int  # 2: binary outcome, indicator utility; 3 or 4: bounded utility UTILITIES[K]
    per_cell: int  # mean records per (context, group) cell: N = per_cell · contexts · groups
    regime: str  # "low" (P near 0.02), "mid", "high" (near 0.98), "fair" (mid, all groups equal)


SCENARIOS = (
    Scenario("bin 1x2 n20 mid", 1, 2, 2, 20, "mid"),
    Scenario("bin 1x2 n500 low", 1, 2, 2, 500, "low"),
    Scenario("bin 1x3 n20 low", 1, 3, 2, 20, "low"),
    Scenario("bin 1x4 n20 high", 1, 4, 2, 20, "high"),
    Scenario("bin 1x8 n100 mid", 1, 8, 2, 100, "mid"),
    Scenario("bin 1x2 n500 fair", 1, 2, 2, 500, "fair"),
    Scenario("bin 3x4 n20 mid", 3, 4, 2, 20, "mid"),
    Scenario("bin 5x2 n500 high", 5, 2, 2, 500, "high"),
    Scenario("bin 2x8 n500 low", 2, 8, 2, 500, "low"),
    Scenario("cat3 1x2 n20 mid", 1, 2, 3, 20, "mid"),
    Scenario("cat3 2x3 n500 high", 2, 3, 3, 500, "high"),
    Scenario("cat4 3x4 n500 low", 3, 4, 4, 500, "low"),
    Scenario("cat4 5x8 n20 mid", 5, 8, 4, 20, "mid"),
    Scenario("cat4 4x5 n500 fair", 4, 5, 4, 500, "fair"),
)


@dataclass(frozen=True)
class Truth:
    scenario: Scenario
    law: Law
    population: Population
    utility: object
    values: dict  # metric -> true value


def _cell_law(rng, regime: str, K: int) -> np.ndarray:
    """One cell's P(U | x, a)."""
    if K == 2:
        p = {"low": (0.01, 0.04), "mid": (0.2, 0.8), "high": (0.96, 0.99), "fair": (0.2, 0.8)}[regime]
        q1 = rng.uniform(*p)
        return np.array([1.0 - q1, q1])
    base = rng.dirichlet(np.full(K, 2.0))
    if regime in ("mid", "fair"):
        return base
    s = rng.uniform(0.02, 0.06)  # mass off the extreme decision
    corner = np.zeros(K)
    corner[0 if regime == "low" else K - 1] = 1.0
    return (1.0 - s) * corner + s * rng.dirichlet(np.ones(K))


def make_truth(scenario: Scenario, seed: int) -> Truth:
    """The known law of a scenario, its population and the true metrics."""
    index = SCENARIOS.index(scenario) if scenario in SCENARIOS else abs(hash(scenario.name)) % 10_000
    rng = np.random.default_rng([seed, 1, index])
    X, A, K = scenario.contexts, scenario.groups, scenario.decisions
    Q = np.empty((X, A, K))
    for x in range(X):
        for a in range(A):
            Q[x, a] = _cell_law(rng, scenario.regime, K)
        if scenario.regime == "fair":
            Q[x, :] = Q[x, 0]
    P = rng.dirichlet(np.full(X * A, 4.0)).reshape(X, A)  # X and A dependent: the truth needs P(x | a)
    contexts, groups, decisions = [f"x{i}" for i in range(X)], [f"a{i}" for i in range(A)], list(range(K))
    law = Law(Q, contexts, groups, decisions)
    pop = Population(P, contexts, groups)
    g = indicator(1, decisions) if K == 2 else from_table(np.array(UTILITIES[K]), decisions, name=f"g{K}")
    values = {
        "local": local_fairness(law, g).value,
        "global": global_fairness(law, g, pop).value,
        "demographic_parity": demographic_parity(law, pop).value,
        "equalized_odds": equalized_odds(law).value,
    }
    return Truth(scenario, law, pop, g, values)


def simulate(truth: Truth, rng) -> CountTable:
    """One dataset: N = per_cell · X · A records i.i.d. from P(X, A), then U | X, A from the law."""
    s = truth.scenario
    X, A, K = s.contexts, s.groups, s.decisions
    n_cells = rng.multinomial(s.per_cell * X * A, truth.population.probabilities.reshape(-1)).reshape(X, A)
    counts = np.zeros((X, A, K), dtype=np.int64)
    for x in range(X):
        for a in range(A):
            counts[x, a] = rng.multinomial(n_cells[x, a], truth.law.probabilities[x, a])
    return CountTable(counts, truth.law.contexts, truth.law.groups, truth.law.decisions, ("x",), ("a",), "u")


def _inside(value: float, lower: float, upper: float) -> bool:
    return bool(lower - TOL <= value <= upper + TOL)


def fairaudit_rows(table_: CountTable, truth: Truth, methods, levels, draws: int, seed: int) -> list[dict]:
    """One row per (method, level, metric) plus a 'simultaneous' row per (method, level)."""
    out = []
    binary_g = truth.scenario.decisions == 2
    for method in methods:
        if method == "clopper-pearson" and not binary_g:
            continue
        for level in levels:
            options = IntervalOptions(confidence=level, method=method, draws=draws, seed=seed)
            iv = fairness_intervals(table_, truth.utility, options)
            all_in = True
            for metric in METRICS:
                interval = {
                    "local": iv.local_fairness,
                    "global": iv.global_fairness,
                    "demographic_parity": iv.demographic_parity,
                    "equalized_odds": iv.equalized_odds,
                }[metric]
                if interval is None:
                    continue
                ok = _inside(truth.values[metric], interval.lower, interval.upper)
                all_in &= ok
                out.append(
                    dict(
                        method=method,
                        level=level,
                        metric=metric,
                        covered=ok,
                        width=interval.upper - interval.lower,
                        infinite=math.isinf(interval.upper),
                    )
                )
            out.append(
                dict(method=method, level=level, metric="simultaneous", covered=all_in, width=math.nan, infinite=False)
            )
    return out


def bootstrap_rows(table_: CountTable, truth: Truth, levels, n_boot: int, seed: int) -> list[dict]:
    """fairlearn's percentile bootstrap for L̄ = −log ratio() and L_dp = difference(), binary single context only."""
    from fairlearn.metrics import MetricFrame, selection_rate

    counts = table_.counts[0]  # (A, 2)
    a = np.repeat(np.repeat(np.arange(counts.shape[0]), 2), counts.reshape(-1))
    y = np.repeat(np.tile(np.arange(2), counts.shape[0]), counts.reshape(-1))
    qs = []
    for level in levels:
        alpha = 1.0 - level
        qs += [alpha / 2, 1 - alpha / 2]
    mf = MetricFrame(
        metrics=selection_rate,
        y_true=y,
        y_pred=y,
        sensitive_features=a,
        n_boot=n_boot,
        ci_quantiles=qs,
        random_state=seed,
    )
    ratio_ci = [float(v) for v in mf.ratio_ci()]
    diff_ci = [float(v) for v in mf.difference_ci()]
    out = []
    for i, level in enumerate(levels):
        r_lo, r_hi = ratio_ci[2 * i], ratio_ci[2 * i + 1]
        with np.errstate(divide="ignore"):
            lb_lo, lb_hi = -math.log(r_hi) if r_hi > 0 else math.inf, -math.log(r_lo) if r_lo > 0 else math.inf
        if math.isnan(r_lo) or math.isnan(r_hi):
            lb_lo = lb_hi = math.nan
        d_lo, d_hi = diff_ci[2 * i], diff_ci[2 * i + 1]
        ok_g = _inside(truth.values["global"], lb_lo, lb_hi)
        ok_d = _inside(truth.values["demographic_parity"], d_lo, d_hi)
        out.append(
            dict(
                method="fairlearn bootstrap",
                level=level,
                metric="global",
                covered=ok_g,
                width=lb_hi - lb_lo,
                infinite=math.isinf(lb_hi),
                undefined=math.isnan(lb_lo),
            )
        )
        out.append(
            dict(
                method="fairlearn bootstrap",
                level=level,
                metric="demographic_parity",
                covered=ok_d,
                width=d_hi - d_lo,
                infinite=False,
                undefined=math.isnan(d_lo),
            )
        )
    return out


class _Progress:
    """tqdm when installed, else a line on stderr every 10%."""

    def __init__(self, total: int, enabled: bool):
        self.total, self.enabled, self.done, self.next_mark = total, enabled, 0, 0.1
        self.bar = None
        self.t0 = time.perf_counter()
        if enabled:
            try:
                import tqdm

                self.bar = tqdm.tqdm(total=total, file=sys.stderr, desc="datasets")
            except ImportError:
                self.bar = None

    def step(self) -> None:
        self.done += 1
        if not self.enabled:
            return
        if self.bar is not None:
            self.bar.update(1)
            return
        while self.done >= self.next_mark * self.total - 1e-9 and self.next_mark <= 1.0 + 1e-9:
            print(
                f"bench_coverage: {self.done}/{self.total} datasets ({self.next_mark:.0%}), "
                f"{time.perf_counter() - self.t0:.0f} s",
                file=sys.stderr,
                flush=True,
            )
            self.next_mark += 0.1

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def run_datasets(
    n_datasets: int,
    seed: int,
    *,
    scenarios=SCENARIOS,
    methods=METHODS,
    levels=LEVELS,
    draws: int = BAYES_DRAWS,
    n_boot: int | None = N_BOOT,
    progress: bool = False,
) -> list[dict]:
    """Simulate ``n_datasets`` (round-robin over ``scenarios``) and return one row per checked interval.

    Each row: scenario, dataset, method, level, metric ("local", "global",
    "demographic_parity", "equalized_odds" or "simultaneous"), covered, width,
    infinite (upper end +inf), records. ``n_boot=None`` skips fairlearn.
    """
    truths = [make_truth(s, seed) for s in scenarios]
    rows: list[dict] = []
    bar = _Progress(n_datasets, progress)
    for i in range(n_datasets):
        truth = truths[i % len(truths)]
        rng = np.random.default_rng([seed, 2, i])
        t = simulate(truth, rng)
        new = fairaudit_rows(t, truth, methods, levels, draws, seed + i)
        s = truth.scenario
        if n_boot and s.decisions == 2 and s.contexts == 1:
            new += bootstrap_rows(t, truth, levels, n_boot, seed + i)
        for r in new:
            r.update(scenario=s.name, dataset=i, records=t.n)
            r.setdefault("undefined", False)
        rows += new
        bar.step()
    bar.close()
    return rows


# ---------------------------------------------------------------- summaries


def coverage(rows, **where) -> tuple[float, float, int]:
    """(coverage, binomial standard error, number of intervals) over the rows matching ``where``."""
    sel = [r["covered"] for r in rows if all(r[k] == v for k, v in where.items())]
    n = len(sel)
    if n == 0:
        return math.nan, math.nan, 0
    p = sum(sel) / n
    return p, math.sqrt(max(p * (1 - p), 0.0) / n) if n else math.nan, n


def _cov_cell(rows, **where) -> str:
    p, se, n = coverage(rows, **where)
    return "—" if n == 0 else f"{p:.3f} ± {se:.3f}"


def _width_cell(rows, **where) -> str:
    sel = [r for r in rows if all(r[k] == v for k, v in where.items())]
    if not sel:
        return "—"
    finite = [r["width"] for r in sel if math.isfinite(r["width"])]
    inf = sum(r["infinite"] for r in sel) / len(sel)
    w = f"{np.mean(finite):.3f}" if finite else "∞"
    return w + (f" ({inf:.1%} ∞)" if inf > 0 else "")


def _report_tables(rows, level: float, scenarios) -> str:
    methods = [m for m in METHODS if any(r["method"] == m for r in rows)]
    header = (
        ["method", "datasets"]
        + [f"coverage {LABELS[m]}" for m in METRICS]
        + ["simultaneous"]
        + [f"width {LABELS[m]}" for m in METRICS]
    )
    body = []
    for m in methods:
        n = coverage(rows, method=m, level=level, metric="simultaneous")[2]
        body.append(
            [m, str(n)]
            + [_cov_cell(rows, method=m, level=level, metric=k) for k in METRICS]
            + [_cov_cell(rows, method=m, level=level, metric="simultaneous")]
            + [_width_cell(rows, method=m, level=level, metric=k) for k in METRICS]
        )
    parts = [table(header, body)]
    boot = [r for r in rows if r["method"] == "fairlearn bootstrap" and r["level"] == level]
    if boot:
        subset = sorted({r["scenario"] for r in boot})
        sub = [r for r in rows if r["scenario"] in subset and r["level"] == level]
        header2 = [
            "method (binary, one context)",
            "datasets",
            "coverage L̄",
            "coverage L_dp",
            "width L̄",
            "width L_dp",
            "undefined",
        ]
        body2 = []
        for m in methods + ["fairlearn bootstrap"]:
            n = coverage(sub, method=m, metric="global")[2]
            undef = [r["undefined"] for r in sub if r["method"] == m and r["metric"] == "global"]
            body2.append(
                [
                    m,
                    str(n),
                    _cov_cell(sub, method=m, metric="global"),
                    _cov_cell(sub, method=m, metric="demographic_parity"),
                    _width_cell(sub, method=m, metric="global"),
                    _width_cell(sub, method=m, metric="demographic_parity"),
                    f"{np.mean(undef):.0%}" if undef else "—",
                ]
            )
        parts += [
            "",
            f"Same datasets (the {len(subset)} binary single-context scenarios), against fairlearn's bootstrap:",
            "",
            table(header2, body2),
        ]
    header3 = (
        ["scenario", "datasets", "mean records"]
        + [f"{m} simult." for m in methods]
        + (["bootstrap L̄", "bootstrap L_dp"] if boot else [])
    )
    body3 = []
    for s in scenarios:
        sr = [r for r in rows if r["scenario"] == s.name and r["level"] == level]
        if not sr:
            continue
        ds = {r["dataset"]: r["records"] for r in sr}
        line = [s.name, str(len(ds)), f"{np.mean(list(ds.values())):.0f}"]
        line += [_cov_cell(sr, method=m, metric="simultaneous") for m in methods]
        if boot:
            line += [_cov_cell(sr, method="fairlearn bootstrap", metric=k) for k in ("global", "demographic_parity")]
        body3.append(line)
    parts += ["", "Simultaneous coverage per scenario (bootstrap: per metric):", "", table(header3, body3)]
    return "\n".join(parts)


def _paragraph(rows, level: float, scenarios) -> tuple[str, list[str]]:
    """Sentences generated from the numbers; also the undercoverage alarms of the guaranteed methods."""
    alarms = []
    sentences = []
    for m in [m for m in METHODS if any(r["method"] == m for r in rows)]:
        p, se, n = coverage(rows, method=m, level=level, metric="simultaneous")
        per = []
        for k in METRICS:
            pk, _, nk = coverage(rows, method=m, level=level, metric=k)
            if nk:
                per.append(f"{LABELS[k]} {pk - level:+.3f}")
        per_s = []
        for s in scenarios:
            ps, ses, ns = coverage(rows, method=m, level=level, metric="simultaneous", scenario=s.name)
            if ns:
                per_s.append((ps, ses, ns, s.name))
        lo = min(per_s)
        hi = max(per_s)
        inf = [r["infinite"] for r in rows if r["method"] == m and r["level"] == level and r["metric"] == "local"]
        kind = "guaranteed" if m != "bayes" else "not guaranteed: a credible band"
        se0 = math.sqrt(level * (1 - level) / n)  # the binomial SE at the nominal level
        verdict = (
            "conservative"
            if p - level > 2 * se0
            else ("within 2 SE of nominal" if p - level >= -2 * se0 else "undercovers")
        )
        sentences.append(
            f"**{m}** ({kind}): simultaneous coverage {p:.3f} ± {se:.3f} over {n} datasets, {p - level:+.3f} against "
            f"the nominal {level:.2f} ({verdict}); per metric {', '.join(per)}. "
            + (
                f"Across scenarios it ranges from {lo[0]:.3f} ({lo[3]}, {lo[0] - level:+.3f}) to {hi[0]:.3f} "
                f"({hi[3]}, {hi[0] - level:+.3f})"
                if lo[0] != hi[0]
                else f"It is {lo[0]:.3f} in every scenario"
            )
            + f"; the upper end of L is +∞ in {np.mean(inf):.1%} of datasets."
        )
        if m != "bayes":
            for ps, ses, ns, name in per_s:
                se0 = math.sqrt(level * (1 - level) / ns)
                if ps < level - 3 * se0:
                    alarms.append(
                        f"{m} at {level:.2f}: scenario '{name}' simultaneous coverage {ps:.3f} over {ns} "
                        f"datasets < nominal − 3 SE ({level - 3 * se0:.3f})"
                    )
            for k in METRICS:
                pk, _, nk = coverage(rows, method=m, level=level, metric=k)
                if nk and pk < level - 3 * math.sqrt(level * (1 - level) / nk):
                    alarms.append(f"{m} at {level:.2f}: {LABELS[k]} coverage {pk:.3f} over {nk} intervals")
    boot = [r for r in rows if r["method"] == "fairlearn bootstrap" and r["level"] == level]
    if boot:
        under = []
        for s in scenarios:
            for k in ("global", "demographic_parity"):
                ps, _, ns = coverage(boot, scenario=s.name, metric=k)
                if ns and ps < level - 2 * math.sqrt(level * (1 - level) / ns):
                    under.append(f"{LABELS[k]} in '{s.name}' {ps:.3f} ({ps - level:+.3f})")
        pg, seg, ng = coverage(boot, metric="global")
        pd_, sed, _ = coverage(boot, metric="demographic_parity")
        undef = np.mean([r["undefined"] for r in boot if r["metric"] == "global"])
        text = (
            f"**fairlearn bootstrap** (percentile, {ng} datasets, one interval per metric, not simultaneous): "
            f"coverage of L̄ {pg:.3f} ({pg - level:+.3f}) and of L_dp {pd_:.3f} ({pd_ - level:+.3f})"
        )
        text += (
            f"; it undercovers (more than 2 binomial SE below nominal) for {'; '.join(under)}"
            if under
            else "; no scenario undercovers by more than 2 binomial SE"
        )
        if undef > 0:
            text += f"; its L̄ interval is undefined (0/0 selection rates in the resamples) in {undef:.0%} of datasets"
        sentences.append(text + ".")
    return "\n\n".join(sentences), alarms


def run(n_datasets: int, seed: int, quick: bool, progress: bool = True) -> tuple[str, list[str]]:
    draws = 400 if quick else BAYES_DRAWS
    n_boot = 20 if quick else N_BOOT
    machine = machine_line()
    start = time.perf_counter()
    rows = run_datasets(n_datasets, seed, draws=draws, n_boot=n_boot, progress=progress)
    total = time.perf_counter() - start
    lines = [
        "# Coverage of the simultaneous intervals on simulated data" + (" (quick)" if quick else ""),
        "",
        machine,
        f"{n_datasets} datasets, seed {seed}, round-robin over {len(SCENARIOS)} scenarios (a scenario's law is "
        f"drawn once from the seed and kept; 'bin'/'catK': binary outcome with g = 1{{u = 1}}, or K outcomes "
        f"with the bounded utility g = {UTILITIES[3]} / {UTILITIES[4]}; 'XxA': contexts × groups; 'nN': mean "
        f"records per cell; low/mid/high: P(U = extreme | x, a) near 0.02, in [0.2, 0.8], near 0.98; fair: all "
        f"groups share each cell's law, L = 0). Records are drawn i.i.d. from a joint P(X, A) ~ Dirichlet(4) "
        f"(X and A dependent), then U | X, A. Truth: fairaudit.metrics on the true law, global metrics with the "
        f"true P(x | a). Methods: clopper-pearson (binary outcomes only), multinomial, bayes ({draws} draws, "
        f"concentration 1); intervals pooled over the records' own groups (no population given). Coverage ± one "
        f"binomial standard error; widths are means over finite intervals (nats for L, L̄; probability for "
        f"L_dp, L_eo), the share with an infinite upper end in brackets. Simultaneous: every computed interval "
        f"among L, L̄, L_dp, L_eo holds at once (for clopper-pearson with a binary outcome all four are "
        f"computed). fairlearn: MetricFrame(selection_rate, n_boot={n_boot}), percentile intervals of ratio() "
        f"(L̄ = −log ratio) and difference() (L_dp), on the binary single-context datasets; an undefined "
        f"interval counts as a miss.",
    ]
    alarms_all = []
    for level in LEVELS:
        para, alarms = _paragraph(rows, level, SCENARIOS)
        alarms_all += alarms
        lines += ["", f"## Confidence {level:.2f}", "", _report_tables(rows, level, SCENARIOS), "", para]
    lines += [
        "",
        f"Total benchmark time {total:.1f} s."
        + (
            " Guaranteed methods: no undercoverage beyond 3 binomial SE."
            if not alarms_all
            else f" {len(alarms_all)} UNDERCOVERAGE ALARM(S) of a guaranteed method: " + "; ".join(alarms_all)
        ),
    ]
    return "\n".join(lines) + "\n", alarms_all


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--datasets", type=int, default=1000, help="number of simulated datasets (default 1000)")
    parser.add_argument("--seed", type=int, default=DEFAULT_SEED, help="seed of the laws and the datasets")
    parser.add_argument(
        "--quick",
        action="store_true",
        help="one dataset per scenario, 400 Bayesian draws, 20 bootstrap resamples (seconds)",
    )
    parser.add_argument("--output", metavar="FILE.md", help="also write the Markdown report here (atomically)")
    args = parser.parse_args(argv)
    n = len(SCENARIOS) if args.quick else args.datasets
    report, alarms = run(n, args.seed, args.quick)
    emit(report, args.output)
    for a in alarms:
        print(f"WARNING: {a}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
