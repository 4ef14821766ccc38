"""Coverage of the intervals of weighted records (Kish's effective sample size), on simulated survey samples.

A known population: two groups (a, b), two strata (urban, rural) whose shares differ by group, and a selection
rate that depends on group and stratum. A sample draws each stratum with its own inclusion probability (urban 0.6,
rural 0.15 by default), so the unweighted rates are biased toward the urban ones; each record's weight is 1 / its
inclusion probability (Horvitz–Thompson). For each sample the script audits the records with the weights
(``fairaudit.audit(..., records=RecordOptions(weights=...), intervals=IntervalOptions(confidence=...))``), and
without them, and records whether the population's true E[g | a] of both groups and its L̄ lie inside the
intervals (each, and all at once). Kish's n_eff = (Σ w)² / Σ w² is an approximation: the table shows how close
to the nominal level it comes, beside the unweighted intervals that miss the biased truth.

Usage::

    python benchmarks/bench_weights.py               # 1000 samples per level, about a minute
    python benchmarks/bench_weights.py --quick       # 60 samples, a few seconds
    python benchmarks/bench_weights.py --samples 3000 --seed 7 --output weights.md
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _bench_common import emit, machine_line, table  # noqa: E402

import fairaudit as fa  # noqa: E402

GROUPS = ("a", "b")
URBAN_SHARE = {"a": 0.7, "b": 0.3}  # P(urban | group)
RATE = {("a", "urban"): 0.55, ("a", "rural"): 0.25, ("b", "urban"): 0.45, ("b", "rural"): 0.30}
INCLUSION = {"urban": 0.6, "rural": 0.15}
POPULATION = 4000  # records per group in the finite population each sample is drawn from (fresh each time)
LEVELS = (0.90, 0.95)


def true_rates() -> dict[str, float]:
    """E[g | a] of the (super)population: P(urban | a) r(a, urban) + P(rural | a) r(a, rural)."""
    return {a: URBAN_SHARE[a] * RATE[(a, "urban")] + (1 - URBAN_SHARE[a]) * RATE[(a, "rural")] for a in GROUPS}


def sample(rng: np.random.Generator) -> dict[str, np.ndarray]:
    """One Poisson sample of a fresh population: each record kept with its stratum's inclusion probability."""
    group = np.repeat(np.array(GROUPS), POPULATION)
    urban = rng.random(group.size) < np.where(group == "a", URBAN_SHARE["a"], URBAN_SHARE["b"])
    stratum = np.where(urban, "urban", "rural")
    rate = np.select([(group == a) & (stratum == s) for a, s in RATE], [RATE[key] for key in RATE], default=np.nan)
    y = (rng.random(group.size) < rate).astype(int)
    pi = np.where(urban, INCLUSION["urban"], INCLUSION["rural"])
    kept = rng.random(group.size) < pi
    return {"y": y[kept], "group": group[kept], "weight": 1.0 / pi[kept]}


def covered(r: fa.Audit, truth: dict[str, float], truth_global: float) -> tuple[bool, bool, bool]:
    """(both groups' E[g | a] inside their intervals, L̄ inside its interval, all at once)."""
    iv = r.intervals
    assert iv is not None
    lower, upper = np.asarray(iv.group_lower).reshape(-1), np.asarray(iv.group_upper).reshape(-1)
    cells = all(lower[j] <= truth[a] <= upper[j] for j, a in enumerate(r.table.groups))
    glob = iv.global_fairness.lower <= truth_global <= iv.global_fairness.upper
    return cells, glob, cells and glob


def run(samples: int, seed: int) -> str:
    truth = true_rates()
    truth_global = abs(math.log(truth["a"] / truth["b"]))
    rng = np.random.default_rng(seed)
    data = [sample(rng) for _ in range(samples)]
    sizes = [len(d["y"]) for d in data]
    sections = []
    for level in LEVELS:
        rows = []
        for name, weighted in (("weighted (Kish n_eff)", True), ("unweighted", False)):
            hits = np.zeros(3)
            for d in data:
                r = fa.audit(
                    y_pred=d["y"],
                    sensitive_features=d["group"],
                    records=fa.RecordOptions(weights=d["weight"] if weighted else None),
                    intervals=fa.IntervalOptions(confidence=level),
                )
                hits += covered(r, truth, truth_global)
            rows.append([name, str(samples), *(f"{h / samples:.3f}" for h in hits)])
        header = ["intervals", "samples", "coverage E[g ∣ a], both groups", "coverage L̄", "simultaneous"]
        sections.append(f"## Confidence {level:.2f}\n\n" + table(header, rows))
    head = (
        "# Coverage of weighted intervals (Kish's effective sample size)\n\n"
        + machine_line(("numpy", "scipy", "pandas"))
        + f"\n\nPopulation: E[g | a] = {truth['a']:.4f}, E[g | b] = {truth['b']:.4f}, L̄ = {truth_global:.4f} nats; "
        f"samples of {int(np.mean(sizes))} records on average (inclusion urban {INCLUSION['urban']}, rural "
        f"{INCLUSION['rural']}); seed {seed}.\n"
    )
    return head + "\n" + "\n\n".join(sections) + "\n"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--samples", type=int, default=1000, help="samples per confidence level (default 1000)")
    p.add_argument("--quick", action="store_true", help="60 samples: a smoke run")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--output", help="also write the report to this file (atomically)")
    args = p.parse_args(argv)
    emit(run(60 if args.quick else args.samples, args.seed), args.output)
    return 0


if __name__ == "__main__":
    sys.exit(main())
