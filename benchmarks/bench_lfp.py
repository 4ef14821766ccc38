"""Benchmark: the threshold fast path against the Charnes–Cooper LP (cvxpy + Clarabel), same instances.

(a) One program max (p·h)/(q·h) over a box lower ≤ h ≤ upper with m cells:
    ``threshold_max`` (and ``threshold_max_many`` on a batch) against
    ``lp_max`` (the LP built and solved per call) and a ``FractionalProgram``
    compiled once and re-solved. A single program has m cells only; the number
    of groups enters in (b).
(b) The whole search: the exact max over every ordered pair of groups of a
    random mechanism with n groups and m outputs, for utilities in [0.1, 1]:
    ``black_box_bound(mech, utility_class=UtilityClass(lower=0.1))`` (threshold path, all pairs vectorised)
    against solving every pair with one compiled ``FractionalProgram`` in a
    loop. For n ≥ 16 the loop solves a random sample of pairs (always with the
    maximising pair) and the time for all pairs is extrapolated per pair.

Every optimal value of one route is compared with the other's; the agreement
column is the largest relative difference, and the script exits with status 1
when it exceeds 1e-7. Times are medians of repeats, ratios are between routes
timed in the same run: compare ratios across machines, not absolute times.

Usage: ``python benchmarks/bench_lfp.py [--quick] [--output FILE.md] [--seed S]``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _bench_common import (
    AGREEMENT_TOL,
    finish,
    fmt_diff,
    fmt_ratio,
    fmt_time,
    machine_line,  # noqa: E402
    median_time,
    rel_diff,
    table,
)

from fairaudit import UtilityClass
from fairaudit.base.linear_fractional import FractionalProgram, FractionalResult  # noqa: E402
from fairaudit.base.threshold_rule import threshold_max_many  # noqa: E402
from fairaudit.laws.mechanisms import from_matrix  # noqa: E402
from fairaudit.worstcase.black_box import black_box_bound  # noqa: E402

LOWER = 0.1  # the utility class of (b): g in [0.1, 1]
GAMMA = 1.0

FULL = dict(
    cells=(2, 10, 100), groups=(2, 4, 8, 16, 32, 64), programs=20, repeats=7, lp_repeats=3, sample_from=16, sample=128
)
QUICK = dict(cells=(2, 10), groups=(2, 16), programs=3, repeats=1, lp_repeats=1, sample_from=16, sample=6)


class _Value:
    """A threshold value with the fields the comparisons read."""

    def __init__(self, value: float) -> None:
        self.value, self.status, self.method, self.reason = value, "optimal", "threshold", ""


def threshold_max(p, q, lower, upper) -> _Value:
    """One box program by the threshold rule (the package's single-program ``threshold_max``, removed in issue 80)."""
    return _Value(float(threshold_max_many(p, q, lower, upper)[0]))


def lp_max(p, q, *, lower, upper) -> FractionalResult:
    """One program built and solved per call (what the package's ``lp_max``, removed in issue 80, did on a box)."""
    return FractionalProgram(len(p), lower=lower, upper=upper).solve(p, q)


def _warm_up() -> None:
    """The first cvxpy solve of a process loads and sets up the solver (about a second): keep it out of the timings."""
    lp_max([0.7, 0.3], [0.3, 0.7], lower=0.5, upper=1.0)
    FractionalProgram(2, lower=0.5, upper=1.0).solve([0.7, 0.3], [0.3, 0.7])


def single_programs(cfg: dict, seed: int, failures: list[str]) -> str:
    """Part (a): per-program times and agreement, one row per number of cells m."""
    rows = []
    for m in cfg["cells"]:
        rng = np.random.default_rng([seed, 0, m])
        k = cfg["programs"]
        lower = rng.uniform(0.0, 0.5, m)  # one random box per m, shared by the k programs
        upper = lower + rng.uniform(0.05, 1.0, m)
        P = rng.dirichlet(np.ones(m), size=k)
        Q = rng.dirichlet(np.ones(m), size=k)
        t0 = time.perf_counter()
        prog = FractionalProgram(m, lower=lower, upper=upper)
        t_compile = time.perf_counter() - t0
        t_thr, t_lp, t_solve, agree = [], [], [], 0.0
        batch_values = threshold_max_many(P, Q, lower, upper)[0]
        for i in range(k):
            p, q = P[i], Q[i]
            thr = threshold_max(p, q, lower, upper)
            lp = lp_max(p, q, lower=lower, upper=upper)
            sv = prog.solve(p, q)
            for r in (thr, lp, sv):
                if r.status != "optimal":
                    failures.append(f"(a) m={m} program {i}: {r.method} status {r.status} ({r.reason})")
            agree = max(
                agree,
                rel_diff(thr.value, lp.value),
                rel_diff(thr.value, sv.value),
                rel_diff(float(batch_values[i]), lp.value),
            )
            t_thr.append(median_time(lambda: threshold_max(p, q, lower, upper), cfg["repeats"]))
            t_lp.append(median_time(lambda: lp_max(p, q, lower=lower, upper=upper), cfg["lp_repeats"], 0.0))
            t_solve.append(median_time(lambda: prog.solve(p, q), cfg["lp_repeats"], 0.0))
        t_batch = median_time(lambda: threshold_max_many(P, Q, lower, upper), cfg["repeats"]) / k
        if not agree <= AGREEMENT_TOL:
            failures.append(f"(a) m={m}: threshold and LP differ by {agree:.3g} (relative) > {AGREEMENT_TOL:g}")
        thr_med, lp_med, sv_med = (statistics.median(t) for t in (t_thr, t_lp, t_solve))
        rows.append(
            [
                str(m),
                str(k),
                fmt_time(thr_med),
                fmt_time(t_batch),
                fmt_time(lp_med),
                f"{fmt_time(sv_med)} (+{fmt_time(t_compile)} once)",
                fmt_ratio(lp_med / thr_med),
                fmt_ratio(sv_med / thr_med),
                fmt_ratio(sv_med / t_batch),
                fmt_diff(agree),
            ]
        )
    header = [
        "m (cells)",
        "programs",
        "threshold_max",
        "threshold_max_many, per program",
        "lp_max (build + solve)",
        "FractionalProgram.solve (compiled)",
        "lp_max / threshold",
        "solve / threshold",
        "solve / batched threshold",
        "agreement (max rel. diff)",
    ]
    return table(header, rows)


def whole_search(cfg: dict, seed: int, failures: list[str]) -> tuple[str, bool]:
    """Part (b): the max over all ordered pairs, vectorised threshold against a loop of LPs."""
    rows = []
    sampled_any = False
    for n in cfg["groups"]:
        for m in cfg["cells"]:
            rng = np.random.default_rng([seed, 1, n, m])
            M = rng.dirichlet(np.ones(m), size=n)
            mech = from_matrix(M, list(range(n)), list(range(m)), name=f"random {n}x{m}")
            cert = black_box_bound(mech, utility_class=UtilityClass(lower=LOWER, gamma=GAMMA))
            t_bb = median_time(
                lambda: black_box_bound(mech, utility_class=UtilityClass(lower=LOWER, gamma=GAMMA)), cfg["repeats"]
            )
            cert_lp = black_box_bound(mech, utility_class=UtilityClass(lower=LOWER, gamma=GAMMA), method="lp")
            t_bb_lp = median_time(
                lambda: black_box_bound(mech, utility_class=UtilityClass(lower=LOWER, gamma=GAMMA), method="lp"),
                cfg["lp_repeats"],
                0.0,
            )
            pair_values = threshold_max_many(M[:, None, :], M[None, :, :], LOWER, GAMMA)[0]
            pairs = [(a, b) for a in range(n) for b in range(n) if a != b]
            best = (int(cert.group), int(cert.other_group))
            sampled = n >= cfg["sample_from"] and len(pairs) > cfg["sample"]
            if sampled:
                sampled_any = True
                others = [pr for pr in pairs if pr != best]
                pick = rng.choice(len(others), size=cfg["sample"] - 1, replace=False)
                solve_pairs = [best] + [others[i] for i in pick]
            else:
                solve_pairs = pairs
            t0 = time.perf_counter()
            prog = FractionalProgram(m, lower=LOWER, upper=GAMMA)
            t_compile = time.perf_counter() - t0
            results = []

            def loop():
                results[:] = [prog.solve(M[a], M[b]) for a, b in solve_pairs]

            t_loop = median_time(loop, cfg["lp_repeats"], 0.0)
            t_lp_all = t_compile + t_loop / len(solve_pairs) * len(pairs)
            agree = rel_diff(cert_lp.ratio, cert.ratio)
            for (a, b), r in zip(solve_pairs, results):
                if r.status != "optimal":
                    failures.append(f"(b) n={n} m={m} pair ({a}, {b}): LP status {r.status} ({r.reason})")
                agree = max(agree, rel_diff(r.value, float(pair_values[a, b])))
            agree = max(agree, rel_diff(max(r.value for r in results), cert.ratio))
            if not agree <= AGREEMENT_TOL:
                failures.append(
                    f"(b) n={n} m={m}: threshold and LP differ by {agree:.3g} (relative) > {AGREEMENT_TOL:g}"
                )
            solved = f"{len(solve_pairs)} of {len(pairs)}" + (" (sample)" if sampled else "")
            lp_time = fmt_time(t_lp_all) + ("*" if sampled else "")
            rows.append(
                [
                    str(n),
                    str(m),
                    f"{cert.value:.6f}",
                    solved,
                    fmt_time(t_bb),
                    lp_time,
                    fmt_ratio(t_lp_all / t_bb) + ("*" if sampled else ""),
                    f"{fmt_time(t_bb_lp)} ({cert_lp.programs_solved} LP)",
                    fmt_ratio(t_bb_lp / t_bb),
                    fmt_diff(agree),
                ]
            )
    header = [
        "n (groups)",
        "m (outputs)",
        "max L (nats)",
        "pairs solved by LP",
        "black_box_bound (threshold)",
        "LP loop, all pairs",
        "LP loop / threshold",
        'black_box_bound(method="lp")',
        "method=lp / threshold",
        "agreement (max rel. diff)",
    ]
    return table(header, rows), sampled_any


def run(quick: bool, seed: int) -> tuple[str, list[str]]:
    cfg = QUICK if quick else FULL
    failures: list[str] = []
    _warm_up()
    start = time.perf_counter()
    machine = machine_line()
    part_a = single_programs(cfg, seed, failures)
    part_b, sampled = whole_search(cfg, seed, failures)
    total = time.perf_counter() - start
    lines = [
        "# Threshold fast path vs Charnes–Cooper LP" + (" (quick)" if quick else ""),
        "",
        machine,
        f"Seed {seed}; times are medians of repeats ({cfg['repeats']} for the threshold routes, {cfg['lp_repeats']} "
        f"for the LP routes; calls shorter than 5 ms are timed in loops); the first cvxpy solve of the process is done "
        f"before timing. Agreement: largest relative difference between the optimal ratios (p·h)/(q·h) of the two "
        f"routes; the run fails above {AGREEMENT_TOL:g}.",
        "",
        "## (a) One program: max (p·h)/(q·h) over a box, m cells",
        "",
        f"{cfg['programs']} programs per m: p, q Dirichlet(1) rows, one random box per m (lower ~ U(0, 0.5), "
        "upper = lower + U(0.05, 1), per cell). A single program does not depend on the number of groups. "
        "`lp_max` builds the cvxpy problem on every call; `FractionalProgram` is compiled once per m "
        "(compile time in brackets) and re-solved for each (p, q). Per-program times are medians over the programs.",
        "",
        part_a,
        "",
        f"## (b) Whole search: max over all ordered pairs of groups, utilities in [{LOWER:g}, {GAMMA:g}]",
        "",
        "A random mechanism with n groups and m outputs (Dirichlet(1) rows). `black_box_bound(mech, utility_class=UtilityClass(lower=0.1))` "
        "solves every pair at once by the vectorised threshold; the LP loop compiles one `FractionalProgram` and "
        'solves each pair; `black_box_bound(method="lp")` is the library\'s own LP route (pairs in decreasing order '
        "of the threshold value, stopping when no pair left can win; LPs solved in brackets). Agreement covers every "
        "LP-solved pair against its threshold value, the max of the LP values against the certificate, and "
        'method="lp" against the threshold certificate.',
    ]
    if sampled:
        lines.append(
            f"* For n ≥ {cfg['sample_from']} the loop solves a random sample of {cfg['sample']} ordered "
            "pairs (always including the maximising pair); the time for all pairs is extrapolated: "
            "compile + (loop time / sampled pairs) × all pairs."
        )
    lines += [
        "",
        part_b,
        "",
        f"Total benchmark time {total:.1f} s. "
        + ("Every agreement is within tolerance." if not failures else f"{len(failures)} FAILURE(S)."),
    ]
    return "\n".join(lines) + "\n", failures


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--quick", action="store_true", help="tiny sizes and one repeat (smoke test)")
    parser.add_argument("--output", metavar="FILE.md", help="also write the Markdown report here (atomically)")
    parser.add_argument("--seed", type=int, default=20250601, help="seed of the random instances")
    args = parser.parse_args(argv)
    report, failures = run(args.quick, args.seed)
    return finish(report, failures, args.output)


if __name__ == "__main__":
    sys.exit(main())
