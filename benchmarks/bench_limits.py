"""Every ratio of issue 22 ("close to the limit") in one command: start-up, counting, the metrics of a law, many groups.

Runs, one after the other (never two at once: they time the same cores), ``bench_startup.py``,
``bench_counting.py``, ``bench_law.py`` and ``bench_groups.py``, each in its own interpreter, and prints their
reports one after the other (the table in docs/performance.md is this output). ``--quick`` passes ``--quick`` on to
each (a smoke run of a few seconds each); ``--output FILE`` writes the whole report atomically. Exit status 1 when
any script fails (a disagreement between routes, or an error), after running all of them.

Run from the repository root: ``python benchmarks/bench_limits.py`` (a few minutes on 2 cores).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _bench_common import emit, fmt_time, machine_line  # noqa: E402

HERE = Path(__file__).resolve().parent
SCRIPTS = ("bench_startup.py", "bench_counting.py", "bench_law.py", "bench_groups.py")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="pass --quick to every script (smoke run)")
    parser.add_argument("--output", help="also write the whole report to this file (atomically)")
    args = parser.parse_args(argv)
    parts = ["# Close to the limit: every ratio of issue 22", machine_line(("numpy", "scipy", "duckdb"), memory=True)]
    failed = []
    for script in SCRIPTS:
        t0 = time.perf_counter()
        proc = subprocess.run(
            [sys.executable, str(HERE / script), *(["--quick"] if args.quick else [])],
            capture_output=True,
            text=True,
            cwd=HERE.parent,
        )
        took = time.perf_counter() - t0
        print(f"bench_limits: {script} exit {proc.returncode} in {fmt_time(took)}", file=sys.stderr)
        if proc.returncode != 0:
            failed.append(script)
            sys.stderr.write(proc.stderr[-3000:])
        parts.append(f"---\n\n<!-- {script}: exit {proc.returncode}, {fmt_time(took)} -->\n\n{proc.stdout.strip()}")
    emit("\n\n".join(parts), args.output)
    if failed:
        print(f"bench_limits: failed: {', '.join(failed)}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
