"""Coverage of the impact-ratio intervals and size of the tests of equal rates (issue 81), computed exactly.

Not a timing: for two categories of n applicants each (n from 20 to 2,000) and rates p1, p2 from 0.05 to 0.95, the
exact coverage of the melded interval on p1/p2 (``fairaudit.statistics.rate_ratio.ratio_interval``: Fay, Proschan
and Brittain 2015) is one minus the probability of the outcomes (x1, x2) whose lower end is above p1/p2 and of
those whose upper end is below it (``lower_miss``). The outcomes with probability below 1e-13 are left out (their
mass, under 1e-8, could only add to the coverage: the minimum reported is a lower end within 1e-8). Levels: 0.95
alone (``--adjustment none``) and 1 − 0.05/m with m = 5 (Holm's intervals at Bonferroni's level). The exact size
of Fisher's test (two-sided by the central rule; conditional on the total selected, so at most α given each total)
and of the pooled z test at equal rates p1 = p2 = p, at α = 0.05 and at α/m (Holm's first step): the probability
of every outcome whose p-value is at most the level.

Usage::

    python benchmarks/bench_impact_ratio.py             # n = 20, 50, 200, 1000, 2000
    python benchmarks/bench_impact_ratio.py --quick     # n = 20, 50
    python benchmarks/bench_impact_ratio.py --output impact_ratio.md

The report's last column is the agreement check: the least coverage's shortfall under its level, Fisher's size's
excess over its level (both 0 where they hold: exit 1 otherwise).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _bench_common import emit, machine_line, table  # noqa: E402

from fairaudit.statistics.rate_ratio import _below  # noqa: E402

RATES = (0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 0.8, 0.9, 0.95)
ALPHA = 0.05
AGREEMENT_TOL = 0.0
"""Neither may the least coverage fall under its level nor Fisher's size exceed its level, at all (the agreement column
is the shortfall or the excess, 0 when they hold)."""


def lower_miss(n: int, p1: float, p2: float, level: float) -> float:
    """P(the melded interval's lower end is above p1/p2), two samples of n, exactly (outcomes under 1e-13 left out).

    The end L(x1, x2) is above θ exactly when P(W1⁻ ≤ θ W2⁺) < α/2, which falls as x1 grows and rises with x2: the
    outcomes it misses are x1 ≥ c(x2), with c non-decreasing in x2, found by one walk up the staircase."""
    from scipy.stats import binom

    theta, half = p1 / p2, (1 - level) / 2
    x = np.arange(n + 1)
    w1, w2 = binom.pmf(x, n, p1), binom.pmf(x, n, p2)
    rows, cols = x[w1 > 1e-13], x[w2 > 1e-13]
    first, last = int(rows[0]), int(rows[-1])
    miss, c = 0.0, first
    for x2 in cols:
        while c <= last and (c == 0 or _below(theta, c, n - c + 1, x2 + 1, n - x2) >= half):
            c += 1
        miss += float(w2[x2] * w1[c : last + 1].sum())
    return miss


def fisher_size(n: int, p: float, alpha: float) -> tuple[float, float]:
    """The exact size of Fisher's two-sided test and of the pooled z test at ``alpha``, rates p and p, samples of n."""
    from scipy.stats import binom, hypergeom, norm

    x = np.arange(n + 1)
    w = binom.pmf(x, n, p)
    fisher = ztest = 0.0
    for total in range(2 * n + 1):
        lo, hi = max(0, total - n), min(n, total)
        x1 = np.arange(lo, hi + 1)
        cond = hypergeom.pmf(x1, 2 * n, total, n)  # X1 given the total selected
        below, above = np.cumsum(cond), np.cumsum(cond[::-1])[::-1]  # P(X1 ≤ x1), P(X1 ≥ x1)
        pvalue = np.minimum(1.0, 2 * np.minimum(below, above))  # the central rule: twice the smaller tail
        joint = w[x1] * w[total - x1]
        fisher += float(joint[pvalue <= alpha].sum())
        pooled = total / (2 * n)
        se = np.sqrt(pooled * (1 - pooled) * 2 / n)
        with np.errstate(all="ignore"):
            zp = np.where(se > 0, 2 * norm.sf(np.abs(x1 / n - (total - x1) / n) / se), 1.0)
        ztest += float(joint[zp <= alpha].sum())
    return fisher, ztest


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="n = 20 and 50 only")
    parser.add_argument("--output", help="write the report there (Markdown) as well")
    args = parser.parse_args(argv)
    sizes = (20, 50) if args.quick else (20, 50, 200, 1000, 2000)
    rows, worst_fisher, worst_cover = [], -1.0, 1.0
    for n in sizes:
        for level, name in ((1 - ALPHA, "0.95 alone"), (1 - ALPHA / 5, "Holm, m = 5")):
            miss = {(a, b): lower_miss(n, a, b, level) for a in RATES for b in RATES}
            # the upper end misses p1/p2 where the lower end of the swapped pair misses p2/p1 (the interval is
            # symmetric: U(x1, x2) = 1 / L(x2, x1))
            covers = [(1 - miss[a, b] - miss[b, a], a, b) for a in RATES for b in RATES]
            low = min(covers)
            worst_cover = min(worst_cover, low[0] - level)
            below = sum(c < level for c, _, _ in covers)
            mean = float(np.mean([c for c, _, _ in covers]))
            rows.append([str(n), name, "melded", f"{mean:.4f}", f"{low[0]:.4f} at ({low[1]}, {low[2]})",
                         f"{below} of {len(covers)}", f"{max(0.0, level - low[0]):.4g}"])  # fmt: skip
        for alpha in (ALPHA, ALPHA / 5):
            sizes_at = [fisher_size(n, p, alpha) for p in RATES]
            fisher, ztest = max(s[0] for s in sizes_at), max(s[1] for s in sizes_at)
            worst_fisher = max(worst_fisher, fisher - alpha)
            rows.append([str(n), f"size at {alpha:g}", "Fisher / z", f"{fisher:.4f} / {ztest:.4f}", "—", "—",
                         f"{max(0.0, fisher - alpha):.4g}"])  # fmt: skip
    head = ["n per category", "level", "interval or test", "mean coverage (size)", "least coverage at (p1, p2)",
            "grid points below the level", "agreement (max rel. diff)"]  # fmt: skip
    text = "\n".join([f"# Impact-ratio intervals and tests, exactly ({machine_line()})", "", table(head, rows), ""])
    emit(text, args.output)
    return 0 if worst_fisher <= 0 and worst_cover >= 0 else 1


if __name__ == "__main__":
    sys.exit(main())
