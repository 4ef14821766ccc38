"""Coverage of the impact-ratio intervals and size of the tests of equal rates (issue 81), computed exactly.

Not a timing: for two categories of n applicants each (n from 20 to 2,000) and rates p1, p2 from 0.05 to 0.95, the
exact coverage of the score interval on p1/p2 (``fairaudit.statistics.rate_ratio.ratio_interval``: Miettinen and
Nurminen, and Koopman without their factor) is the probability of every outcome (x1, x2) whose interval holds
p1/p2, which is where the two-sided score test of θ = p1/p2 accepts: |z(θ; x1, x2)| ≤ z_(α/2). The outcomes with
probability below 1e-13 are left out (their mass, under 1e-8, is added to the coverage as an upper end: the
minimum reported is a lower end within 1e-8). Levels: 0.95 alone (``--adjustment none``) and 1 − 0.05/m with m = 5
(Holm's intervals at Bonferroni's level). The exact size of Fisher's test at α = 0.05 (conditional on the total
selected: at most α given each total, so at most α) and of the pooled z test at equal rates p1 = p2 = p: the
probability of every outcome whose p-value is at most α.

Usage::

    python benchmarks/bench_impact_ratio.py             # n = 20, 50, 200, 1000, 2000
    python benchmarks/bench_impact_ratio.py --quick     # n = 20, 50
    python benchmarks/bench_impact_ratio.py --output impact_ratio.md

The report's last column is the agreement check: Fisher's size minus α (never above 0: exit 1 otherwise).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _bench_common import emit, machine_line, table  # noqa: E402

from fairaudit.statistics.rate_ratio import score_statistic  # noqa: E402

RATES = (0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 0.8, 0.9, 0.95)
ALPHA = 0.05
AGREEMENT_TOL = 0.0
"""Fisher's size may not exceed α at all (the agreement column is its excess, 0 when it does not)."""


def coverage(n: int, p1: float, p2: float, level: float, correction: bool) -> float:
    """The exact coverage of the score interval at (p1, p2), two samples of n (outcomes under 1e-13 left out)."""
    from scipy.stats import binom, norm

    z = norm.isf((1 - level) / 2)
    x = np.arange(n + 1)
    w1, w2 = binom.pmf(x, n, p1), binom.pmf(x, n, p2)
    k1, k2 = w1 > 1e-13, w2 > 1e-13
    x1, x2 = np.meshgrid(x[k1], x[k2], indexing="ij")
    with np.errstate(all="ignore"):
        s = score_statistic(p1 / p2, x1, n, x2, n, correction)
    return float((w1[k1][:, None] * w2[k2][None, :] * (np.abs(s) <= z)).sum())


def fisher_size(n: int, p: float) -> tuple[float, float]:
    """The exact size of Fisher's two-sided test and of the pooled z test at α, rates p and p, samples of n."""
    from scipy.stats import binom, hypergeom, norm

    x = np.arange(n + 1)
    w = binom.pmf(x, n, p)
    fisher = ztest = 0.0
    for total in range(2 * n + 1):
        lo, hi = max(0, total - n), min(n, total)
        x1 = np.arange(lo, hi + 1)
        cond = hypergeom.pmf(x1, 2 * n, total, n)  # X1 given the total selected
        order = np.sort(cond)
        tail = np.cumsum(order)  # P(pmf ≤ pmf(x1)): scipy's rule, with its relative tolerance 1e-7
        pvalue = tail[np.searchsorted(order, cond * (1 + 1e-7), side="right") - 1]
        joint = w[x1] * w[total - x1]
        fisher += float(joint[pvalue <= ALPHA].sum())
        pooled = total / (2 * n)
        se = np.sqrt(pooled * (1 - pooled) * 2 / n)
        with np.errstate(all="ignore"):
            zp = np.where(se > 0, 2 * norm.sf(np.abs(x1 / n - (total - x1) / n) / se), 1.0)
        ztest += float(joint[zp <= ALPHA].sum())
    return fisher, ztest


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="n = 20 and 50 only")
    parser.add_argument("--output", help="write the report there (Markdown) as well")
    args = parser.parse_args(argv)
    sizes = (20, 50) if args.quick else (20, 50, 200, 1000, 2000)
    rows, worst_fisher = [], -1.0
    for n in sizes:
        for level, name in ((1 - ALPHA, "0.95 alone"), (1 - ALPHA / 5, "Holm, m = 5")):
            for correction in (True, False):
                covers = [(coverage(n, a, b, level, correction), a, b) for a in RATES for b in RATES]
                low = min(covers)
                below = sum(c < level for c, _, _ in covers)
                mean = float(np.mean([c for c, _, _ in covers]))
                method = "Miettinen-Nurminen" if correction else "Koopman"
                rows.append([str(n), name, method, f"{mean:.4f}", f"{low[0]:.4f} at ({low[1]}, {low[2]})",
                             f"{below} of {len(covers)}", "—"])  # fmt: skip
        sizes_at = [(fisher_size(n, p), p) for p in RATES]
        fisher = max(s[0] for s, _ in sizes_at)
        ztest = max(s[1] for s, _ in sizes_at)
        worst_fisher = max(worst_fisher, fisher - ALPHA)
        rows.append([str(n), "size at 0.05", "Fisher / z", f"{fisher:.4f} / {ztest:.4f}", "—", "—",
                     f"{max(0.0, fisher - ALPHA):.4g}"])  # fmt: skip
    head = ["n per category", "level", "interval or test", "mean coverage (size)", "least coverage at (p1, p2)",
            "grid points below the level", "agreement (max rel. diff)"]  # fmt: skip
    text = "\n".join([f"# Impact-ratio intervals and tests, exactly ({machine_line()})", "", table(head, rows), ""])
    emit(text, args.output)
    return 0 if worst_fisher <= 0 else 1


if __name__ == "__main__":
    sys.exit(main())
