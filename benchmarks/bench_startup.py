"""Start-up of the ``fairaudit`` command and of ``import fairaudit``, against ``python -c "import numpy"``.

Every row is a fresh interpreter started as a child process (wall-clock time, median of ``--repeats`` runs after one
untimed run that warms the file cache and writes the bytecode to a temporary cache), so the time includes what a user waits for: the interpreter, the imports and
the work. The baselines are timed in the same run: ``python -c pass`` (the interpreter alone),
``python -c "import numpy"`` and the libraries the certificate loads (numpy, scipy.special, highspy, python-flint,
pydantic, DuckDB), so that the certificate's time splits into theirs and fairaudit's. The k-th runs of all rows are taken
back to back (round-robin), so that a slower spell of the machine weighs on every row alike. Each row also lists the heavy modules the child imported (read from ``-X importtime``
in one extra run): pandas, pyarrow, scipy.stats, cvxpy, matplotlib, httpx, duckdb.

The goals (issue 40): ``fairaudit --help`` within 2x of ``import numpy``; ``fairaudit certify`` on the shipped
example (examples/llm_hiring/gpt35.toml: observed metrics with 95% intervals, every bound, budgets) within 1.3x of
the time to import the libraries it needs (the row "libraries the certificate loads"), both ratios measured in the
same run.

Run from the repository root: ``python benchmarks/bench_startup.py`` (about 30 s), ``--quick`` for 2 repeats.
Exit status 1 when a command fails or prints a result that differs from the in-process API's.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _bench_common import emit, fmt_ratio, fmt_time, installed_env, machine_line, rel_diff, table  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
HEAVY = ("pandas", "pyarrow", "scipy.stats", "cvxpy", "matplotlib", "httpx", "duckdb")
GPT35 = "examples/llm_hiring/gpt35.toml"
PY = sys.executable
# What the certificate cannot do without: the libraries `fairaudit certify` loads for the shipped example (numpy;
# scipy.special for the Clopper-Pearson intervals; highspy and python-flint for the exact linear programs; pydantic
# for the spec, one model built so that its plug-in scan runs; DuckDB for its model table, one in-memory database
# opened so that its engine starts, about 20 ms that any use of DuckDB pays once), with nothing of fairaudit's.
FLOOR = (
    "import numpy, scipy.special, highspy, flint, tomllib, duckdb\n"
    "from pydantic import BaseModel\n"
    "class Spec(BaseModel):\n"
    "    x: float\n"
    "duckdb.connect(':memory:').close()"
)
FLOOR_LABEL = "libraries the certificate loads"
ROWS: list[tuple[str, list[str], str]] = [
    ("python -c pass", [PY, "-c", "pass"], "baseline"),
    ('python -c "import numpy"', [PY, "-c", "import numpy"], "baseline"),
    (FLOOR_LABEL, [PY, "-c", FLOOR], "baseline"),
    ('python -c "import fairaudit"', [PY, "-c", "import fairaudit"], "import"),
    ("fairaudit --help", [PY, "-m", "fairaudit.cli", "--help"], "help"),
    ("fairaudit certify --help", [PY, "-m", "fairaudit.cli", "certify", "--help"], "help"),
    (f"fairaudit certify {GPT35}", [PY, "-m", "fairaudit.cli", "certify", GPT35], "certify"),
    (
        f"fairaudit certify {GPT35} --format json",
        [PY, "-m", "fairaudit.cli", "certify", GPT35, "--format", "json"],
        "certify",
    ),
    (
        "fairaudit calibrate --target 0.5 --groups 8 --tau 0.1",
        [PY, "-m", "fairaudit.cli", "calibrate", "--target", "0.5", "--groups", "8", "--tau", "0.1"],
        "calibrate",
    ),
]


ENV: dict[str, str] = {}


def _run(cmd: list[str]) -> tuple[float, subprocess.CompletedProcess[str]]:
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, timeout=600, env=ENV or None)
    return time.perf_counter() - t0, proc


def _heavy(cmd: list[str]) -> list[str]:
    """The heavy modules a run of ``cmd`` imports (its ``-X importtime`` report)."""
    proc = subprocess.run(
        [cmd[0], "-X", "importtime", *cmd[1:]], capture_output=True, text=True, cwd=ROOT, env=ENV or None
    )
    names = {line.rsplit("|", 1)[1].strip() for line in proc.stderr.splitlines() if line.startswith("import time:")}
    return sorted(h for h in HEAVY if h in names)


def _check_certify(stdout: str) -> float:
    """Relative difference between the command's JSON certificate and the in-process API's (bounds and L)."""
    from fairaudit import certify

    mine = json.loads(stdout)
    ref = json.loads(json.dumps(certify(ROOT / GPT35).to_dict(), default=str))
    worst = 0.0
    for key in ("best", "paper", "tight", "black_box"):
        a, b = mine["bounds"].get(key), ref["bounds"].get(key)
        if isinstance(a, (int, float)) and isinstance(b, (int, float)):
            worst = max(worst, rel_diff(float(a), float(b)))
    return worst


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7, help="timed runs per command (default 7)")
    parser.add_argument("--quick", action="store_true", help="2 timed runs per command (the smoke test)")
    parser.add_argument("--output", help="also write the report to this file (atomically)")
    args = parser.parse_args(argv)
    repeats = 2 if args.quick else max(1, args.repeats)
    head = machine_line(("numpy", "scipy", "pandas", "pydantic"))
    with tempfile.TemporaryDirectory(prefix="fairaudit-bench-pyc-") as cache:
        ENV.update(installed_env(cache))
        text, failures = _measure(head, repeats)
    emit(text, args.output)
    for failure in failures:
        print(f"bench_startup: {failure}", file=sys.stderr)
    return 1 if failures else 0


def _measure(head: str, repeats: int) -> tuple[str, list[str]]:
    """Time every row; the report and the failures."""
    times: dict[str, float] = {}
    rows, failures = [], []
    runs: dict[str, list[float]] = {label: [] for label, _, _ in ROWS}
    last: dict[str, subprocess.CompletedProcess[str]] = {}
    for _, cmd, _ in ROWS:
        _run(cmd)  # warm the file cache
    # Round-robin: the k-th run of every command back to back, so that a slower spell of the machine weighs on
    # every row alike rather than on whichever command it fell on (the rows are compared as ratios).
    for _ in range(repeats):
        for label, cmd, _ in ROWS:
            seconds, last[label] = _run(cmd)
            if last[label].returncode not in (0, 1):  # certify exits 1 when a target is not met
                failures.append(f"{label}: exit {last[label].returncode}: {last[label].stderr.strip()[-300:]}")
            runs[label].append(seconds)
    for label, cmd, kind in ROWS:
        times[label] = statistics.median(runs[label])
        agreement = "—"
        if label.endswith("--format json"):
            diff = _check_certify(last[label].stdout)
            agreement = f"{diff:.1e}" if diff else "0"
            if diff > 1e-12:
                failures.append(f"{label}: the command's bounds differ from the API's by {diff:.1e}")
        rows.append([label, kind, times[label], ", ".join(_heavy(cmd)) or "none", agreement])
    numpy_time, bare = times['python -c "import numpy"'], times["python -c pass"]
    body = [
        [label, fmt_time(t), fmt_ratio(t / numpy_time), fmt_time(max(t - bare, 0.0)), heavy, agreement]
        for label, _, t, heavy, agreement in rows
    ]
    help_ratio = times["fairaudit --help"] / numpy_time
    certify_time = times[f"fairaudit certify {GPT35}"]
    own = certify_time - times[FLOOR_LABEL]
    certify_ratio = certify_time / times[FLOOR_LABEL]
    text = "\n\n".join(
        [
            "# Start-up: the command and the package against import numpy",
            head,
            f"Wall-clock time of a fresh interpreter per command, median of {repeats} runs (taken round-robin over "
            "the rows) after one untimed run "
            "that warms the file cache and writes the bytecode (to a temporary `PYTHONPYCACHEPREFIX`, as `pip install` "
            "compiles a package; with `PYTHONDONTWRITEBYTECODE` every start would compile fairaudit's modules again). "
            "*net* subtracts the bare interpreter (`python -c pass`). *heavy modules* are those of "
            f"{', '.join(HEAVY)} that the run imported (`-X importtime`). The certificate of the JSON run is "
            "compared with the in-process API's (agreement: largest relative difference of its bounds).",
            table(
                ["command", "median time", "/ import numpy", "net of the interpreter", "heavy modules", "agreement"],
                body,
                "lrrrlr",
            ),
            f"Goals: `fairaudit --help` within 2x of `import numpy`: {fmt_ratio(help_ratio)} "
            f"({'met' if help_ratio <= 2 else 'not met'}); `fairaudit certify {GPT35}` within 1.3x of the "
            f"libraries it needs: {fmt_ratio(certify_ratio)} ({'met' if certify_ratio <= 1.3 else 'not met'}): "
            f"{fmt_time(certify_time)}, of which {fmt_time(times[FLOOR_LABEL])} loads the libraries "
            f"({fmt_ratio(times[FLOOR_LABEL] / numpy_time)} `import numpy`) and {fmt_time(max(own, 0.0))} is "
            "fairaudit's: its modules and the work.",
        ]
    )
    return text, failures


if __name__ == "__main__":
    sys.exit(main())
