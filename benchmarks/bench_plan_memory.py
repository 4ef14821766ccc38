"""The memory `fairaudit plan` plans against what it uses (issue 83): its estimate bounds tracemalloc's peak.

`fairaudit.plan` estimates the memory of its simulated tables before drawing them
(``fairaudit.statistics.sample_size._memory``: :data:`CELL_BYTES` per cell without a filter, :data:`PAIR_BYTES` per
entry of the threshold rule behind one, :data:`DRAW_BYTES` per posterior draw and cell with ``"bayes"``) and draws
them in chunks that fit the limit. Those constants were measured; this script measures them again: for each setting
it runs ``plan`` with every table in one chunk under tracemalloc (after one untraced run, which loads the modules
``plan`` imports where it uses them) and reports the peak beside the estimate for that chunk. The agreement column is how far the peak exceeds the estimate, relative (0 when the estimate holds: exit
status 1 otherwise). The per-cell figure is the peak over the cells (minus the fixed part), to compare with the
constants.

Without a filter the settings of a frequentist method plan L̄ (``kind="global"``): L's power there is exact
(:func:`fairaudit.statistics.sample_size._order_power`), no table is simulated, so there is nothing to measure.

Usage::

    python benchmarks/bench_plan_memory.py            # 10^2 to 10^4 cells, filter and bayes
    python benchmarks/bench_plan_memory.py --quick
"""

from __future__ import annotations

import argparse
import sys
import tracemalloc
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _bench_common import emit, machine_line, table  # noqa: E402

import fairaudit as fa  # noqa: E402
from fairaudit.statistics import sample_size  # noqa: E402

AGREEMENT_TOL = 0.0
"""The peak may not exceed the estimate at all (the agreement column is the excess, 0 where the estimate holds)."""


def measure(
    groups: int, contexts: int, *, epsilon: float | None, method: str, datasets: int, kind: str
) -> tuple[int, int, int]:
    """(tracemalloc's peak, the estimate for one chunk of every table, its fixed part), bytes, of one ``plan``."""
    inputs = {"groups": groups, "contexts": contexts, "datasets": datasets, "method": method, "epsilon": epsilon,
              "kind": kind}  # fmt: skip
    fixed, per_table = sample_size._memory(inputs)  # type: ignore[arg-type]

    def run() -> None:
        fa.plan(0.5, groups=groups, contexts=contexts, epsilon=epsilon, method=method, datasets=datasets, max_n=2000,
                disparity=0.2, max_memory="64G", kind=kind)  # fmt: skip

    run()  # once untraced: the modules plan imports where used, and their caches, are not what a table costs
    tracemalloc.start()
    run()
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return peak, fixed + per_table * datasets, fixed


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="the smallest settings only")
    parser.add_argument("--output", help="write the report there (Markdown) as well")
    args = parser.parse_args(argv)
    settings = [
        ((10, 10), None, "clopper-pearson", 50),
        ((4, 4), 1.0, "clopper-pearson", 20),
        ((2, 4), None, "bayes", 2),
    ]
    if not args.quick:
        settings += [((100, 100), None, "clopper-pearson", 50), ((8, 8), 1.0, "clopper-pearson", 20),
                     ((4, 25), None, "bayes", 2)]  # fmt: skip
    rows, worst = [], 0.0
    for (groups, contexts), epsilon, method, datasets in settings:
        # (L without a filter by a frequentist method is not simulated, its power exact: L-bar is, with the same cells)
        kind = "global" if epsilon is None and method != "bayes" else "local"
        peak, estimate, fixed = measure(groups, contexts, epsilon=epsilon, method=method, datasets=datasets, kind=kind)
        cells = groups * contexts * (datasets if method != "bayes" else 4000)
        excess = max(0.0, peak / estimate - 1)
        worst = max(worst, excess)
        rows.append([f"{groups} x {contexts}", "none" if epsilon is None else f"{epsilon:g}", method, str(datasets), kind,
                     f"{peak / 2**20:.2f}", f"{estimate / 2**20:.2f}", f"{max(0, peak - fixed) / cells:.0f}",
                     f"{excess:.3g}"])  # fmt: skip
    head = ["groups x contexts", "epsilon", "method", "tables", "kind", "peak (MiB)", "estimate (MiB)",
            "peak per cell (bytes)", "agreement (max rel. diff)"]  # fmt: skip
    consts = (f"CELL_BYTES {sample_size.CELL_BYTES}, PAIR_BYTES {sample_size.PAIR_BYTES}, "
              f"DRAW_BYTES {sample_size.DRAW_BYTES}")  # fmt: skip
    text = "\n".join([f"# The memory plan plans ({machine_line(('numpy',))}; {consts})", "", table(head, rows), ""])
    emit(text, args.output)
    return 1 if worst > 0 else 0


if __name__ == "__main__":
    sys.exit(main())
