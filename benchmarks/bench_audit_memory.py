"""Peak memory of `fairaudit audit` on many groups, against pandas' `groupby` on the same records (issue 83).

For each number of groups n, a CSV of records is written once: every group present, ten records a group on average
(a group id ``g0000042``, an outcome u in {0, 1, 2}, u = 1 at least once a group so that every E[g | a] > 0). Each
route then runs as a fresh process, one after the other, and its peak resident memory is the operating system's
own accounting of that child (``os.wait4``'s ``ru_maxrss``):

- ``fairaudit audit FILE --sensitive group --outcome u --positive 1`` (the command as a user runs it, its text
  report thrown away);
- the peer: ``pandas.read_csv`` of the same file (C parser), ``groupby(["group", "u"]).size()`` and, from those
  counts, L = ln(max_a P(u = 1 | a) / min_a P(u = 1 | a)), printed;
- the floor: ``python -c "import pandas"``, what any pandas route pays before reading a record.

Agreement: fairaudit's L (its JSON report, one more run) against the peer's, relative difference. The goal is
fairaudit's peak at most the peer's at 10^6 groups ("Auditing 10^6 groups peaks at no more than pandas' groupby on
the same records, measured side by side").

Usage::

    python benchmarks/bench_audit_memory.py                      # 10^4, 10^5 and 10^6 groups
    python benchmarks/bench_audit_memory.py --groups 10000000    # any sizes (10^7: about 1.5 GB of CSV)
    python benchmarks/bench_audit_memory.py --quick              # 10^4 groups
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _bench_common import finish, machine_line, rel_diff, table  # noqa: E402

AGREEMENT_TOL = 1e-12
"""L from fairaudit's counts and from pandas' counts: the same ratio of two rationals, up to rounding."""

PEER = """
import math, sys
import pandas as pd
frame = pd.read_csv(sys.argv[1])
counts = frame.groupby(["group", "u"]).size().unstack(fill_value=0)
rate = counts[1] / counts.sum(axis=1)
print(repr(math.log(rate.max() / rate.min())))
"""


def write_records(path: Path, groups: int, seed: int) -> int:
    """The CSV of ``groups`` groups, ten records a group on average; returns the number of records."""
    rng = np.random.default_rng([seed, groups])
    codes = np.concatenate([np.arange(groups), rng.integers(0, groups, 9 * groups)])
    u = rng.integers(0, 3, codes.size)
    u[:groups] = 1
    with path.open("w", encoding="utf-8") as f:
        f.write("group,u\n")
        for start in range(0, codes.size, 1_000_000):  # in blocks: the writer's own memory stays small
            block = codes[start : start + 1_000_000]
            f.writelines(f"g{c:08d},{v}\n" for c, v in zip(block.tolist(), u[start : start + 1_000_000].tolist()))
    return int(codes.size)


def peak(cmd: list[str]) -> tuple[float, float, str]:
    """(peak resident memory in MiB, wall seconds, standard output) of one run of ``cmd`` as a child process."""
    start = time.perf_counter()
    with tempfile.TemporaryFile() as out:
        proc = subprocess.Popen(cmd, stdout=out, stderr=subprocess.DEVNULL)
        _, status, usage = os.wait4(proc.pid, 0)
        proc.returncode = os.waitstatus_to_exitcode(status)
        seconds = time.perf_counter() - start
        out.seek(0)
        text = out.read().decode()
    if proc.returncode not in (0, 1):  # (audit exits 1 when a target is not met: none is set here)
        raise RuntimeError(f"{' '.join(cmd)} exited {proc.returncode}")
    return usage.ru_maxrss / 1024, seconds, text  # ru_maxrss is in KiB on Linux


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--groups", type=int, nargs="+", default=[10**4, 10**5, 10**6], help="numbers of groups")
    parser.add_argument("--quick", action="store_true", help="10^4 groups only")
    parser.add_argument("--seed", type=int, default=20261129)
    parser.add_argument("--output", help="write the report there (Markdown) as well")
    args = parser.parse_args(argv)
    sizes = [10**4] if args.quick else args.groups
    py = sys.executable
    audit = [py, "-m", "fairaudit.cli", "audit"]
    rows, failures = [], []
    with tempfile.TemporaryDirectory() as tmp:
        floor, _, _ = peak([py, "-c", "import pandas"])
        for groups in sizes:
            path = Path(tmp) / f"records-{groups}.csv"
            records = write_records(path, groups, args.seed)
            flags = [str(path), "--sensitive", "group", "--outcome", "u", "--positive", "1"]
            mine, mine_s, _ = peak([*audit, *flags])
            theirs, theirs_s, printed = peak([py, "-c", PEER, str(path)])
            _, _, report = peak([*audit, *flags, "--format", "json"])
            diff = rel_diff(json.loads(report)["local"]["value"], float(printed))
            if not diff <= AGREEMENT_TOL:
                failures.append(f"{groups:,} groups: L differs from pandas' by {diff:.3g}")
            rows.append([f"{groups:,}", f"{records:,}", f"{mine:,.0f}", f"{theirs:,.0f}", f"{mine / theirs:.2f}",
                         f"{mine_s:.1f}", f"{theirs_s:.1f}", f"{diff:.3g}"])  # fmt: skip
            path.unlink()
    header = ["groups", "records", "audit peak (MiB)", "pandas groupby peak (MiB)", "audit / pandas", "audit s",
              "pandas s", "agreement (max rel. diff)"]  # fmt: skip
    text = "\n".join(
        [
            "# Peak memory of `fairaudit audit` against pandas' `groupby`, many groups",
            "",
            machine_line(("numpy", "pandas", "duckdb"), memory=True),
            "",
            f'Peak resident memory of each route as a fresh process (`ru_maxrss`); `python -c "import pandas"` '
            f"alone peaks at {floor:,.0f} MiB.",
            "",
            table(header, rows, "rrrrrrrr"),
            "",
        ]
    )
    return finish(text, failures, args.output)


if __name__ == "__main__":
    sys.exit(main())
