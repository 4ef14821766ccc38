"""Benchmark: the metrics of a law — building a Law, L + L̄ and every metric against plain numpy.

A law P(U | X, A) with 10^6 contexts (``--contexts N``; 10^4 with ``--quick``), 8 groups and 4 decisions
(Dirichlet(1) rows, seeded), utility g = 1{u = 1}, uniform population. Timed (medians of repeats):

* building the :class:`~fairaudit.laws.tables.Law` from the float64 array with ``range(n)`` contexts: from a
  writable array (one copy, made block by block while the table is checked), from a read-only array (no
  copy), and with the labels given as numpy arrays;
* L + L̄ (``local_fairness`` + ``global_fairness``), and again for a utility with four non-zero values;
* every metric (``certify.observe``: L, L̄, demographic parity, equalized odds, the sups over g);

against two baselines timed in the same run: "one read of the table" (``table.sum()``) and a tuned numpy
L + L̄ (E = Q @ g by a chunked reshape-matmul: the table viewed as (contexts·groups, decisions) @ g in
chunks that stay in cache, no transposed copy of the table; max and min over the group axis per chunk on
E's transposed chunk; then the largest ratio, its context and pair, and E[g | a] = Σ_x P(x | a) E[g | x, a]).
Each time is also given as a multiple of both baselines, with the peak memory traced during one call (a
multiple of the table's size). Agreement: L and L̄ (value, context and pair of groups) against the numpy
baseline; the built law against the array. The script exits with status 1 when a relative difference
exceeds 1e-7 or a maximising context or pair differs.

Usage: ``python benchmarks/bench_law.py [--quick] [--contexts N] [--seed S] [--output FILE.md]``.
"""

from __future__ import annotations

import argparse
import gc
import math
import os
import sys
import time
import tracemalloc
from collections.abc import Callable

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _bench_common import (  # noqa: E402
    AGREEMENT_TOL,
    finish,
    fmt_diff,
    fmt_ratio,
    fmt_time,
    machine_line,
    median_time,
    rel_diff,
    table,
)

import fairaudit  # noqa: E402
from fairaudit.laws.tables import Law, Population  # noqa: E402
from fairaudit.metrics.observed import observe  # noqa: E402

GROUPS = tuple(f"g{i}" for i in range(8))
DECISIONS = (0, 1, 2, 3)
INDICATOR = (0.0, 1.0, 0.0, 0.0)  # g = 1{u = 1}
GENERAL = (0.3, 1.0, 0.2, 0.5)  # a utility with every term non-zero
BASELINE_CONTEXTS = 2048  # contexts per chunk of the numpy baseline (16384 rows of E, 512 kB of the table)
FULL = dict(contexts=10**6, repeats=5)
QUICK = dict(contexts=10**4, repeats=3)
GOAL_BASELINE = 2.0  # L + L̄ within 2x of the tuned numpy version
GOAL_READ = 4.0  # every metric within 4x of one read of the table


def law_array(n: int, seed: int) -> np.ndarray:
    """P(U | X, A) of shape (n, 8, 4): Dirichlet(1) rows (normalised exponentials), seeded by (seed, n)."""
    rng = np.random.default_rng([seed, n])
    q = rng.standard_exponential((n, len(GROUPS), len(DECISIONS)))
    q /= q.sum(axis=-1, keepdims=True)
    return q


def _log(r: float) -> float:
    return math.inf if r == math.inf else (math.nan if r != r else math.log(r))


def _ratio(hi: np.ndarray, lo: np.ndarray) -> np.ndarray:
    """hi / lo with 0/0 = 1 and c/0 = inf."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(hi == 0, 1.0, np.where(lo == 0, np.inf, hi / lo))


def matmul_pass(q: np.ndarray, g: np.ndarray) -> np.ndarray:
    """One matmul pass over the table: E = Q @ g by the baseline's chunked reshape-matmul, nothing else."""
    n, a, k = q.shape
    flat, e = q.reshape(n * a, k), np.empty(n * a)
    for start in range(0, n * a, BASELINE_CONTEXTS * a):
        np.matmul(flat[start : start + BASELINE_CONTEXTS * a], g, out=e[start : start + BASELINE_CONTEXTS * a])
    return e


def numpy_baseline(q: np.ndarray, g: np.ndarray, p_xa: np.ndarray) -> dict:
    """L (with its context and pair) and L̄ (with its pair) by plain numpy, as a tuned script would.

    E = Q @ g by a chunked reshape-matmul into one (n, A) array; per chunk the max and min over groups
    on E's transposed chunk (contiguous rows); the largest ratio by argmax. E[g | a] = Σ_x P(x | a) E[x, a].
    """
    n, a, k = q.shape
    flat = q.reshape(n * a, k)  # a view: no copy
    e = np.empty((n, a))
    e_flat = e.reshape(-1)
    hi, lo = np.empty(n), np.empty(n)
    for start in range(0, n, BASELINE_CONTEXTS):
        stop = min(n, start + BASELINE_CONTEXTS)
        np.matmul(flat[start * a : stop * a], g, out=e_flat[start * a : stop * a])
        chunk_t = e[start:stop].T.copy()  # (groups, chunk)
        np.max(chunk_t, axis=0, out=hi[start:stop])
        np.min(chunk_t, axis=0, out=lo[start:stop])
    ratio = _ratio(hi, lo)
    x = int(np.argmax(ratio))
    eg = np.einsum("xa,xa->a", p_xa / p_xa.sum(axis=0), e)
    return {
        "local": _log(float(ratio[x])),
        "context": x,
        "group": int(np.argmax(e[x])),
        "other_group": int(np.argmin(e[x])),
        "global": _log(float(_ratio(eg.max(), eg.min()))),
        "global_group": int(np.argmax(eg)),
        "global_other_group": int(np.argmin(eg)),
    }


def local_global(law: Law, g: fairaudit.Utility, pop: Population) -> tuple:
    return fairaudit.local_fairness(law, g, pop), fairaudit.global_fairness(law, g, pop)


def compare(loc, glo, base: dict) -> tuple[float, list[str]]:
    """Largest relative difference of L and L̄ from the baseline's, and the cells where they differ."""
    diff = max(rel_diff(loc.value, base["local"]), rel_diff(glo.value, base["global"]))
    wrong = []
    if (loc.context, loc.group, loc.other_group) != (
        base["context"],
        GROUPS[base["group"]],
        GROUPS[base["other_group"]],
    ):
        wrong.append(f"L's context and pair {loc.context, loc.group, loc.other_group} differ from numpy's")
    if (glo.group, glo.other_group) != (GROUPS[base["global_group"]], GROUPS[base["global_other_group"]]):
        wrong.append(f"L̄'s pair {glo.group, glo.other_group} differs from numpy's")
    return diff, wrong


def peak_memory(fn: Callable[[], object]) -> int:
    """Peak memory traced (numpy reports its buffers to tracemalloc) during one call, in bytes."""
    gc.collect()
    tracemalloc.start()
    try:
        fn()
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def warm_up(seed: int) -> None:
    """Every timed call once on a 3-context law: imports and first-call set-up stay out of the measures."""
    q = law_array(3, seed)
    law = Law(q, range(3), GROUPS, DECISIONS)
    pop = Population.uniform(law.contexts, law.groups)
    for values in (INDICATOR, GENERAL):
        g = fairaudit.from_table(list(values), DECISIONS)
        local_global(law, g, pop)
        observe(law, g, pop)
        numpy_baseline(q, np.array(values), pop.probabilities)


class Rows:
    """The timed rows of the report, each time divided by the references measured in the same run."""

    def __init__(self, repeats: int, size: int, read: float, matmul: float) -> None:
        self.repeats, self.size, self.read, self.matmul = repeats, size, read, matmul
        self.rows: list[list[str]] = []

    def add(
        self, operation: str, fn: Callable[[], object], base: float, agreement: float | None, t: float | None = None
    ) -> float:
        """Time ``fn`` (median of the repeats; ``t`` when timed already), trace its peak memory, add its row."""
        t = median_time(fn, self.repeats) if t is None else t
        self.rows.append(
            [
                operation,
                fmt_time(t),
                fmt_ratio(t / base),
                fmt_ratio(t / self.read),
                fmt_ratio(t / self.matmul),
                f"{peak_memory(fn) / self.size:.2f}×",
                "—" if agreement is None else fmt_diff(agreement),
            ]
        )
        return t


UTILITIES = (("g = 1{u = 1}", INDICATOR), ("g = (0.3, 1, 0.2, 0.5)", GENERAL))


def time_metrics(q: np.ndarray, law: Law, pop: Population, rows: Rows, base_times: dict) -> tuple[dict, list]:
    """L + L̄ and every metric for each utility, against the numpy baseline; the ratios and the failures."""
    ratios, failures = {}, []
    for name, values in UTILITIES:
        gv, g = np.array(values), fairaudit.from_table(list(values), DECISIONS)
        base = numpy_baseline(q, gv, pop.probabilities)
        baseline = base_times[name]
        rows.add(
            f"tuned numpy L + L̄, {name}",
            lambda gv=gv: numpy_baseline(q, gv, pop.probabilities),
            baseline,
            None,
            baseline,
        )
        diff, wrong = compare(*local_global(law, g, pop), base)
        failures += [f"L + L̄, {name}: {w}" for w in wrong]
        t = rows.add(
            f"`local_fairness` + `global_fairness`, {name}",
            lambda g=g: local_global(law, g, pop),
            base_times[name],
            diff,
        )
        ratios[f"L + L̄ / numpy L + L̄, {name}"] = (t / base_times[name], GOAL_BASELINE)
        obs = observe(law, g, pop)
        diff_obs, wrong = compare(obs.local_fairness, obs.global_fairness, base)
        failures += [f"observe, {name}: {w}" for w in wrong]
        t = rows.add(f"every metric (`observe`), {name}", lambda g=g: observe(law, g, pop), base_times[name], diff_obs)
        ratios[f"observe / one read, {name}"] = (t / rows.read, GOAL_READ)
        ratios[f"observe / one matmul pass, {name}"] = (t / rows.matmul, GOAL_READ)
        for label, d in ((f"L + L̄, {name}", diff), (f"observe, {name}", diff_obs)):
            if not d <= AGREEMENT_TOL:
                failures.append(f"{label}: relative difference {d:.3g} from numpy above {AGREEMENT_TOL:g}")
    return ratios, failures


def time_builds(q: np.ndarray, law: Law, rows: Rows, base: float) -> list[str]:
    """Building the law from a writable array, a read-only one, and with label arrays; the failures."""
    n = q.shape[0]
    frozen = q.copy()
    frozen.setflags(write=False)
    context_array, group_array, decision_array = np.arange(n), np.array(GROUPS), np.array(DECISIONS)
    labelled = Law(q, context_array, group_array, decision_array)
    same = labelled.contexts == law.contexts and labelled.groups == law.groups and labelled.decisions == law.decisions
    kept = np.array_equal(law.probabilities, q) and np.array_equal(
        Law(frozen, range(n), GROUPS, DECISIONS).probabilities, q
    )
    rows.add(
        "`Law(table, range(n), ...)`, writable table (one copy)",
        lambda: Law(q, range(n), GROUPS, DECISIONS),
        base,
        0.0 if kept else math.inf,
    )
    rows.add(
        "`Law(table, range(n), ...)`, read-only table (no copy)",
        lambda: Law(frozen, range(n), GROUPS, DECISIONS),
        base,
        0.0 if kept else math.inf,
    )
    rows.add(
        "`Law(table, ...)`, labels given as numpy arrays",
        lambda: Law(q, context_array, group_array, decision_array),
        base,
        0.0 if same else math.inf,
    )
    failures = [] if kept else ["a built law's table differs from the array"]
    return failures + ([] if same else ["the law with label arrays has other labels than with range(n)"])


def run(n: int, seed: int, repeats: int, quick: bool) -> tuple[str, list[str]]:
    start = time.perf_counter()
    warm_up(seed)
    q = law_array(n, seed)
    law = Law(q, range(n), GROUPS, DECISIONS)
    pop = Population.uniform(law.context_labels, law.group_labels)
    g1 = np.array(INDICATOR)
    read, matmul = median_time(lambda: q.sum(), repeats), median_time(lambda: matmul_pass(q, g1), repeats)
    base_times = {
        name: median_time(lambda v=v: numpy_baseline(q, np.array(v), pop.probabilities), repeats)
        for name, v in UTILITIES
    }
    rows = Rows(repeats, q.nbytes, read, matmul)
    rows.add("one read of the table: `table.sum()`", lambda: q.sum(), base_times[UTILITIES[0][0]], None, read)
    rows.add(
        "one matmul pass: E = Q @ g, chunked reshape-matmul",
        lambda: matmul_pass(q, g1),
        base_times[UTILITIES[0][0]],
        None,
        matmul,
    )
    ratios, failures = time_metrics(q, law, pop, rows, base_times)
    failures += time_builds(q, law, rows, base_times[UTILITIES[0][0]])
    total = time.perf_counter() - start

    header = [
        "operation",
        "median time",
        "/ numpy L + L̄",
        "/ one read",
        "/ one matmul pass",
        "peak memory / table",
        "agreement (max rel. diff)",
    ]
    goals = [
        f"{label}: {fmt_ratio(r)} (goal ≤ {goal:g}×, {'met' if r <= goal else 'not met'})"
        for label, (r, goal) in ratios.items()
    ]
    lines = [
        f"# The metrics of a law: {n:,} contexts × {len(GROUPS)} groups × {len(DECISIONS)} decisions"
        + (" (quick)" if quick else ""),
        "",
        machine_line(("numpy", "fairaudit")),
        f"Law: Dirichlet(1) rows, seed {seed}, {q.nbytes / 1e6:.1f} MB of float64; uniform population. Times are "
        f"medians of {repeats} repeat(s) (calls shorter than 5 ms are timed in loops), after one warm-up call. "
        "`/ numpy L + L̄` divides by the tuned numpy L + L̄ for the same utility (chunked reshape-matmul, "
        f"{BASELINE_CONTEXTS} contexts per chunk) or, for the other rows, for g = 1{{u = 1}}; `/ one read` by "
        "`table.sum()`; `/ one matmul pass` by E = Q @ g alone (g = 1{u = 1}, the baseline's first step). Peak "
        "memory: traced during one call (numpy reports its buffers), as a multiple of the table.",
        "Agreement: L and L̄ (value, maximising context and pair) against the numpy baseline; a built law's "
        f"table and labels against the array's. The run fails above {AGREEMENT_TOL:g} or on another cell.",
        "",
        table(header, rows.rows),
        "",
        "Ratios: " + "; ".join(goals) + ".",
        "",
        f"Total benchmark time {total:.1f} s. "
        + ("Every agreement is within tolerance." if not failures else f"{len(failures)} FAILURE(S)."),
    ]
    return "\n".join(lines) + "\n", failures


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--quick", action="store_true", help="10^4 contexts and three repeats (a few seconds)")
    parser.add_argument("--contexts", type=int, metavar="N", help="contexts of the law (default 10^6; 10^4 quick)")
    parser.add_argument("--repeats", type=int, metavar="R", help="repeats per timing (default 5; 3 quick)")
    parser.add_argument("--seed", type=int, default=20250611, help="seed of the law (default 20250611)")
    parser.add_argument("--output", metavar="FILE.md", help="also write the Markdown report here (atomically)")
    args = parser.parse_args(argv)
    preset = QUICK if args.quick else FULL
    n = args.contexts or preset["contexts"]
    if n < 1:
        parser.error("--contexts must be at least 1")
    report, failures = run(n, args.seed, args.repeats or preset["repeats"], args.quick)
    return finish(report, failures, args.output)


if __name__ == "__main__":
    sys.exit(main())
