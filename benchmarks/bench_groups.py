"""Benchmark: many groups. Calibration of k-ary randomized response flat in k; general mechanisms of 1,000 groups.

(a) Black-box calibration of k-ary randomized response (``fairaudit.worstcase.calibration.calibrate``, the API of the
    ``calibrate`` command, ``method="black_box"``): without τ, with τ = 0.1, and on L̄ (``kind="global"``,
    the command's ``--global``), for k = 2, 16, 256, 10^4, 10^6 and 10^9. Time (median of repeats) and its ratio
    to k = 2 (flat in k: about 1×), and tracemalloc's peak of one call (flat in k: the labels stay a ``range``). Agreement: the closed form ``rr_black_box_epsilon`` of ``proofs/black_box.md``
    §3 without τ; with τ an independent bisection of ε on ``black_box_bound(randomized_response(k, ε), tau=0.1)``.
(b) A general mechanism: k × k Dirichlet(1) rows given as a matrix (``from_matrix``), k = 100, 300, 1000
    (``--quick``: 20, 50). ``black_box_bound`` with lower = 0, lower = 0.1 and τ = 0.1, and the full
    ``certify`` of a spec with that mechanism, g = 1{chosen}, τ = 0.1 and a target (paper, tight, black-box
    worst model, corollary, calibration; the spec is parsed before the clock starts). Time, the tracemalloc
    peak of one call as a multiple of the matrix's bytes, and the ratio of the time to a baseline timed in the
    same run: one pass over the pairs (Σ_o max(M[a, o], M[b, o]) for every pair, a tile at a time). Agreement
    with the all-pairs route (every pair solved, as before the pruning) where it fits (k ≤ 300).

(c) Many groups in one audit: records of 10^3, 10^4 and 10^5 groups (``--quick``: 10^3, 10^4), ten a group on
    average, three decisions, g = 1{u = 1}. ``all_metrics`` of the law (L, L̄, L_dp, L_eo, the sups) and the
    whole ``audit`` of the DataFrame, each against a baseline timed in the same run: numpy's max minus min of
    the groups' P(u) and E[g | a] (``np.bincount`` of the codes, then ``max``, ``min``, ``argmax``, ``argmin``
    over the groups and the three events of TV). A pair loop over the groups would grow as the square of the
    ratio; these stay flat. Agreement: L, L_dp and their pairs against the baseline's.

(d) Sample-size plans (``fairaudit.plan``, the ``plan`` command) along the cells, target 1 nat: on L, whose power
    is exact (the counts' order statistics), 1,000 groups (the most ``plan`` takes) in 1, 10, 100 and 1,000
    contexts (``--quick``: 1, 10, 1,000); on L-bar, simulated with 20 tables per n, in 1, 10 and 100 contexts
    (``--quick``: 1, 10). Time, tracemalloc's peak (for the simulated, its ratio to one set of tables, 20 × cells
    × 8 bytes: bounded by the 64 MiB chunks as the cells grow) and the plan's n. Then 10^4, 10^6 and 10^9 groups:
    the refusal, its time and its line (it must name ``groups``).

Times are medians of repeats; ratios between routes timed in the same run are what carries across machines.
The script exits with status 1 when an agreement exceeds 1e-7 (relative).

Usage: ``python benchmarks/bench_groups.py [--quick] [--output FILE.md] [--seed S]``.
"""

from __future__ import annotations

import argparse
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

import fairaudit as fa  # noqa: E402
import fairaudit.worstcase.black_box as black_box_module  # noqa: E402
import fairaudit.worstcase.pair_search as search_module  # noqa: E402
from fairaudit import UtilityClass
from fairaudit.base.pairs import PairPass  # noqa: E402
from fairaudit.certification.certificate import certify  # noqa: E402
from fairaudit.certification.spec import parse_spec  # noqa: E402
from fairaudit.metrics.fairness import all_metrics  # noqa: E402
from fairaudit.worstcase.black_box import black_box_bound  # noqa: E402
from fairaudit.worstcase.calibration import calibrate  # noqa: E402
from fairaudit.worstcase.calibration_methods import rr_black_box_epsilon  # noqa: E402

FULL = dict(
    groups=(2, 16, 256, 10**4, 10**6, 10**9),
    general=(100, 300, 1000),
    repeats=5,
    big_repeats=2,
    old_up_to=300,
    audit_groups=(10**3, 10**4, 10**5),
    plan_contexts=(1, 10, 100, 1000),
    plan_simulated=(1, 10, 100),
)
QUICK = dict(
    groups=(2, 16, 256, 10**4, 10**6, 10**9),
    general=(20, 50),
    repeats=1,
    big_repeats=1,
    old_up_to=50,
    audit_groups=(10**3, 10**4),
    plan_contexts=(1, 10, 1000),
    plan_simulated=(1, 10),
)
TARGET = 0.5
BISECT_UP_TO = 10**6
"""The largest k of the independent bisection with τ: it evaluates ``black_box_bound`` of RR_k, which is O(k)."""
TAU = 0.1


def _bisect(k: int, tau: float | None, target: float) -> float:
    """The largest ε with black_box_bound(RR_k(ε), tau=τ).value ≤ target, by plain bisection (independent route)."""

    family = fa.randomized_response_family(range(k))

    def value(eps: float) -> float:
        return black_box_bound(family(eps), utility_class=UtilityClass(tau=tau)).value

    lo, hi = 0.0, 1.0
    while value(hi) <= target:
        lo, hi = hi, 2 * hi
        if hi > 1e3:
            return math.inf
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if value(mid) <= target else (lo, mid)
        if hi - lo <= 1e-13 * max(1.0, hi):
            break
    return lo


def calibration_rows(cfg: dict, failures: list[str]) -> str:
    """Part (a): calibration of k-ary RR along k."""
    cases = (
        ("black_box", {}),
        ("black_box, tau = 0.1", {"utility_class": UtilityClass(tau=TAU)}),
        ("black_box, --global", {"kind": "global"}),
    )
    rows = []
    for name, kw in cases:
        base = math.nan
        for k in cfg["groups"]:
            t = median_time(
                lambda: calibrate(TARGET, family=fa.randomized_response_family(range(k)), method="black_box", **kw),
                cfg["repeats"],
            )
            base = t if k == 2 else base
            tracemalloc.start()
            eps = calibrate(TARGET, family=fa.randomized_response_family(range(k)), method="black_box", **kw).epsilon
            peak = tracemalloc.get_traced_memory()[1]
            tracemalloc.stop()
            diff: float | None = None
            if "utility_class" in kw and k > BISECT_UP_TO:
                how = f"— (the bisection reads black_box_bound, O(k): run to k = {BISECT_UP_TO:,})"
            elif "utility_class" in kw:
                want, how = _bisect(k, TAU, TARGET), "bisection on black_box_bound"
            else:
                want, how = rr_black_box_epsilon(TARGET, k, 0.0, 1.0), "closed form rr_black_box_epsilon"
            if not how.startswith("—"):
                diff = rel_diff(eps, want)
                if not diff <= AGREEMENT_TOL:
                    failures.append(f"calibration {name}, k = {k}: epsilon {eps!r} against {how} {want!r}")
            rows.append([name, f"{k:,}", fmt_time(t), fmt_ratio(t / base), f"{peak / 2**10:,.0f} KiB", f"{eps:.6g}",
                         how, "—" if diff is None else fmt_diff(diff)])  # fmt: skip
    header = ["calibration", "groups k", "time", "÷ k = 2", "peak memory", "epsilon", "checked against", "agreement"]
    return table(header, rows, "lrrrrrlr")


def _spec(M: np.ndarray, tau: float) -> object:
    k = len(M)
    rows = "[" + ",\n".join("[" + ",".join(repr(float(x)) for x in r) + "]" for r in M) + "]"
    labels = "[" + ", ".join(f'"g{i}"' for i in range(k)) + "]"
    text = (
        f'[sensitive]\nname = "group"\nvalues = {labels}\n[decision]\nname = "chosen"\nvalues = ["yes", "no"]\n'
        f'[privacy.sensitive]\nmechanism = "matrix"\nrows = {rows}\n[utility]\ndecision = "yes"\ntau = {tau}\n'
        "[target]\nlocal = 1.0\n"
    )
    return parse_spec(text)


def _peak(fn: Callable[[], object]) -> float:
    """tracemalloc peak of one call, in bytes (the caches of the pair passes emptied first)."""
    _clear()
    tracemalloc.start()
    try:
        fn()
        return float(tracemalloc.get_traced_memory()[1])
    finally:
        tracemalloc.stop()


def _clear() -> None:
    import fairaudit.base.pairs as pairs_module

    search_module._CACHE.clear()
    pairs_module._CANDIDATES_CACHE.clear()


def _all_pairs_route(fn: Callable[[], object]) -> object:
    """``fn()`` with every pair solved (the route before the pruning)."""

    def every(matrix, lower, upper, floor=None):
        return search_module._all_pairs(matrix, float(lower), float(upper), floor)

    saved = black_box_module.box_pairs, search_module.box_pairs
    black_box_module.box_pairs = search_module.box_pairs = every
    try:
        return fn()
    finally:
        black_box_module.box_pairs, search_module.box_pairs = saved


def _one_pass(M: np.ndarray) -> None:
    """The baseline: Σ_o max(M[a, o], M[b, o]) for every ordered pair, a tile at a time."""
    PairPass(M).run(lambda: 1.0, lambda rows, cols, sums, lam: None)


def general_rows(cfg: dict, seed: int, failures: list[str]) -> str:
    """Part (b): a general k x k mechanism."""
    rows = []
    for k in cfg["general"]:
        M = np.random.default_rng([seed, k]).dirichlet(np.ones(k), size=k)
        mech = fa.from_matrix(M, [f"g{i}" for i in range(k)])
        spec = _spec(M, TAU)
        reps = cfg["repeats"] if k <= 300 else cfg["big_repeats"]
        base = median_time(lambda: _one_pass(M), reps)
        cases: list[tuple[str, Callable[[], float]]] = [
            ("black_box_bound, lower = 0", lambda: black_box_bound(mech).value),
            (
                "black_box_bound, lower = 0.1",
                lambda: black_box_bound(mech, utility_class=UtilityClass(lower=0.1)).value,
            ),
            ("black_box_bound, tau = 0.1", lambda: black_box_bound(mech, utility_class=UtilityClass(tau=TAU)).value),
            ("certify (tau = 0.1, target)", lambda: certify(spec).black_box.local_fairness.value),  # type: ignore[arg-type]
        ]
        for name, fn in cases:

            def fresh(fn: Callable[[], float] = fn) -> float:
                _clear()
                return fn()

            t = median_time(fresh, reps)
            peak = _peak(fn)
            value = fn()
            if k <= cfg["old_up_to"]:
                old = _all_pairs_route(fn)
                diff = rel_diff(value, float(old))  # type: ignore[arg-type]
                if not diff <= AGREEMENT_TOL:
                    failures.append(f"{name}, k = {k}: {value!r} against the all-pairs route {old!r}")
                agree = fmt_diff(diff)
            else:
                agree = "— (all pairs: too slow)"
            rows.append(
                [name, f"{k:,}", fmt_time(t), fmt_ratio(t / base), f"{peak / M.nbytes:.1f}×", f"{value:.6g}", agree]
            )
        rows.append(["(baseline: one pass over the pairs)", f"{k:,}", fmt_time(base), "1×", "", "", ""])
    header = ["route", "groups k", "time", "÷ one pass", "peak ÷ matrix", "value (nats)", "agreement"]
    return table(header, rows, "lrrrrrr")


def _numpy_extremes(codes: np.ndarray, u: np.ndarray, A: int) -> tuple[float, int, int, float, int, int]:
    """The baseline: P(u | a) by ``np.bincount``, then L = log(max / min) of E[g | a] = P(u = 1 | a) and
    L_dp = the largest max − min over groups of P(S | a), S over {u0}, {u1}, {u0, u1} (a subset and its
    complement give the same range), with argmax and argmin (first maxima). Returns L, its pair, L_dp, its pair.
    """
    n = np.bincount(codes, minlength=A).astype(float)
    p = [np.bincount(codes, weights=(u == k).astype(float), minlength=A) / n for k in range(3)]
    e = p[1]
    hi, lo = int(np.argmax(e)), int(np.argmin(e))
    best, pair = -1.0, (0, 1)
    for s in (p[0], p[1], p[0] + p[1]):
        a, b = int(np.argmax(s)), int(np.argmin(s))
        if s[a] - s[b] > best:
            best, pair = float(s[a] - s[b]), (min(a, b), max(a, b))
    return math.log(e[hi] / e[lo]), hi, lo, best, *pair


def audit_rows(cfg: dict, seed: int, failures: list[str]) -> str:
    """Part (c): many groups in one audit, against numpy's max minus min."""
    import pandas as pd

    rows = []
    for A in cfg["audit_groups"]:
        rng = np.random.default_rng([seed, A])
        codes = np.concatenate([np.arange(A), rng.integers(0, A, 9 * A)])  # every group present, ten a group
        u = rng.integers(0, 3, codes.size)
        u[:A] = 1  # E[g | a] > 0 in every group: L finite
        labels = np.array([f"g{i:06d}" for i in range(A)])
        frame = pd.DataFrame({"group": labels[codes], "u": u})
        counts = np.zeros((1, A, 3))
        np.add.at(counts, (0, codes, u), 1.0)
        law = fa.Law.from_counts(counts, ["all"], list(labels), [0, 1, 2])
        g = fa.indicator(1, law.decisions)
        reps = cfg["repeats"] if A <= 10**4 else cfg["big_repeats"]
        base = median_time(lambda: _numpy_extremes(codes, u, A), reps)
        L, hi, lo, dp, a, b = _numpy_extremes(codes, u, A)
        metrics = all_metrics(law, g)
        result = fa.audit(frame, sensitive=["group"], outcome="u", positive=1)
        diff = max(rel_diff(metrics["local"].value, L), rel_diff(metrics["demographic_parity"].value, dp))
        same_pairs = (metrics["local"].group, metrics["local"].other_group) == (labels[hi], labels[lo]) and (
            metrics["demographic_parity"].group,
            metrics["demographic_parity"].other_group,
        ) == (labels[a], labels[b])
        if (
            not diff <= AGREEMENT_TOL
            or not same_pairs
            or result.observed.local_fairness.value != metrics["local"].value
        ):
            failures.append(f"many groups, {A:,} groups: L, L_dp or their pairs differ from numpy's extremes")

        def from_frame() -> object:
            codes, _ = pd.factorize(frame["group"], sort=True)
            return _numpy_extremes(codes, frame["u"].to_numpy(), A)

        frame_base = median_time(from_frame, reps)
        size = f"{codes.size:,}"
        t = median_time(lambda: all_metrics(law, g), reps)
        rows.append(["all_metrics(law, g)", f"{A:,}", size, fmt_time(t), fmt_ratio(t / base), fmt_diff(diff)])
        rows.append(["(baseline: numpy max minus min)", f"{A:,}", size, fmt_time(base), "1×", ""])
        t = median_time(lambda: fa.audit(frame, sensitive=["group"], outcome="u", positive=1), reps)
        rows.append(["audit(DataFrame)", f"{A:,}", size, fmt_time(t), fmt_ratio(t / frame_base), fmt_diff(diff)])
        rows.append(["(baseline: pandas factorize, then numpy)", f"{A:,}", size, fmt_time(frame_base), "1×", ""])
    header = ["route", "groups", "records", "time", "÷ its baseline", "agreement"]
    return table(header, rows, "lrrrrr")


PLAN_TABLES = 20
"""Simulated tables per n in part (d) (``plan``'s ``datasets``; its default, 200, takes ten times as long)."""


def plan_rows(cfg: dict, failures: list[str]) -> str:
    """Part (d): sample-size plans along the cells, exact (L) and simulated (L-bar), and the refusal beyond the
    groups ``plan`` takes."""
    rows = []
    cases = [(1000, c, "local") for c in cfg["plan_contexts"]] + [(1000, c, "global") for c in cfg["plan_simulated"]]
    cases += [(k, 1, "local") for k in (10**4, 10**6, 10**9)]
    for k, contexts, kind in cases:
        cells = k * contexts
        t0 = time.perf_counter()
        tracemalloc.start()
        try:
            plan = fa.plan(1.0, groups=k, contexts=contexts, datasets=PLAN_TABLES, kind=kind)
            answer = f"n = {plan.n_per_cell:,} per cell"
            route = "exact" if plan.datasets is None else f"simulated, {plan.datasets} tables"
        except fa.InputError as exc:
            answer, route = f"refused: {exc}", ""
            if not str(exc).startswith("groups"):
                failures.append(f"plan, {k:,} groups: the refusal does not name groups ({exc})")
        finally:
            peak = tracemalloc.get_traced_memory()[1]
            tracemalloc.stop()
        t = time.perf_counter() - t0
        ratio = f"{peak / (PLAN_TABLES * cells * 8):.2g}×" if route.startswith("simulated") else ""
        name = "L" if kind == "local" else "L-bar"
        rows.append([name, f"{k:,}", f"{contexts:,}", f"{cells:,}", route, fmt_time(t), f"{peak / 2**20:,.1f} MiB",
                     ratio, answer])  # fmt: skip
    header = ["on", "groups k", "contexts", "cells", "power", "time", "peak memory", "peak ÷ one set of tables", "plan"]
    return table(header, rows, "lrrrlrrrl")


def run(quick: bool, seed: int) -> tuple[str, list[str]]:
    cfg = QUICK if quick else FULL
    failures: list[str] = []
    # (imports and first calls out of the timings)
    calibrate(TARGET, family=fa.randomized_response_family(range(3)), method="black_box")
    fa.plan(1.0, datasets=2, kind="global"), fa.plan(1.0)  # (scipy.stats, imported by plan where used)
    parts = [
        "# Many groups",
        "",
        machine_line(("numpy",), memory=True),
        "",
        "## (a) Calibration of k-ary randomized response",
        "",
        f'Target {TARGET} nats on L (or L-bar), utilities in [0, 1], `calibrate(method="black_box")`.',
        "",
        calibration_rows(cfg, failures),
        "",
        "## (b) A general mechanism (Dirichlet rows, k x k)",
        "",
        "Peak: tracemalloc peak of one call (caches emptied) over the bytes of the matrix (8 k^2).",
        "",
        general_rows(cfg, seed, failures),
        "",
        "## (c) Many groups in one audit (one context, three decisions, g = 1{u = 1})",
        "",
        audit_rows(cfg, seed, failures),
        "",
        f"## (d) Sample-size plans along the cells (target 1 nat; L exact, L-bar from {PLAN_TABLES} tables per n)",
        "",
        plan_rows(cfg, failures),
        "",
        f"Failures (agreement above {AGREEMENT_TOL:g}): {len(failures)}.",
    ]
    return "\n".join(parts), failures


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--quick", action="store_true", help="20 and 50 groups in (b), one repeat (a few seconds)")
    parser.add_argument("--output", metavar="FILE.md", help="also write the Markdown report here (atomically)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the random mechanisms (default 0)")
    args = parser.parse_args(argv)
    t0 = time.perf_counter()
    report, failures = run(args.quick, args.seed)
    report += f"\n\nTotal time {time.perf_counter() - t0:.1f} s.\n"
    return finish(report, failures, args.output)


if __name__ == "__main__":
    sys.exit(main())
