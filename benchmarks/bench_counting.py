"""Benchmark: counting records in files — ``fairaudit.data.counts.count_file`` (DuckDB) against a raw DuckDB GROUP BY.

Records: 10^7 (``--records N``; ``--quick`` 10^5) with 100 integer contexts,
8 string groups ("g0" … "g7") and 5 integer decisions, drawn uniformly and
independently (seeded), written once to two temporary Parquet files (row
groups of 10^6 records): plain columns, and dictionary-encoded ones (every
column an Arrow dictionary, as pandas writes categoricals: ``parquet
(dictionary)``); and, the first 10^6 of them (``--csv-records N``), to a CSV
file and to a headerless ``;``-separated text file
(``pandas.DataFrame.to_csv``). The generator counts the records it writes:
the independent route of the agreement checks.

(a) In process: ``count_file(FILE, sensitive=["group"], outcome="decision",
    context=["context"])`` (a DuckDB GROUP BY, then the labels and checks by
    numpy) against a raw DuckDB ``SELECT "context", "group", "decision",
    count(*) ... GROUP BY ALL`` on a connection opened beforehand, plus
    building the same numpy count array (100 × 8 × 5), for each file (the
    headerless one read with ``CsvFormat(header=False, names=..., sep=";")``);
    polars' lazy ``group_by(...).len()`` too when polars is installed (skipped
    otherwise). Median time, ratio to the raw DuckDB route timed in the same
    run.
(b) End to end, each a child process started through a bare Python wrapper
    that reports its peak RSS (``getrusage(RUSAGE_CHILDREN)``; Linux carries a
    process's high-water RSS across ``exec``, so waiting for the command from
    this process would report this process's peak): the command ``fairaudit
    audit FILE --sensitive group --context context --outcome decision
    --positive 1 --format json`` against ``python -c SCRIPT FILE`` doing the
    raw DuckDB GROUP BY and the same arithmetic (the count array, E[g | x, a]
    with g = 1{u = 1}, L and L̄ by plain numpy). Both include the interpreter's
    start-up and their imports. Median time, peak RSS (max over runs), ratios.

The target of issue 40: on the dictionary-encoded Parquet file, ``count_file``
and ``fairaudit audit`` within 1.5× of the raw DuckDB GROUP BY of the same
run; the report ends with those two ratios.

Agreement: in (a) the count tables must be identical (max absolute difference
0 against the generator's counts); in (b) the audit's n, L and L̄ against the
script's (relative difference at most 1e-7), and the script's count table
against the generator's (absolute difference 0). The script exits with status 1
when one of them fails or a route fails. Performance is reported as ratios to
peers timed in the same run, never asserted.

Usage: ``python benchmarks/bench_counting.py [--quick] [--output FILE.md] [--records N]
[--csv-records N] [--repeats R] [--seed S] [--workdir DIR]``.
"""

from __future__ import annotations

import argparse
import atexit
import json
import math
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _bench_common import (  # noqa: E402
    AGREEMENT_TOL,
    RSS_WRAPPER,
    finish,
    fmt_diff,
    fmt_ratio,
    fmt_time,
    installed_env,
    machine_line,
    median_time,
    rel_diff,
    table,
)

from fairaudit.data.counts import CountTable, count_file
from fairaudit.data.csv_format import CsvFormat  # noqa: E402

N_CONTEXTS = 100
GROUPS = tuple(f"g{i}" for i in range(8))  # sorted as strings
DECISIONS = (0, 1, 2, 3, 4)
POSITIVE = 1
SHAPE = (N_CONTEXTS, len(GROUPS), len(DECISIONS))
ROLES = dict(sensitive=["group"], outcome="decision", context=["context"])
NAMES = ("context", "group", "decision")
HEADERLESS = "text: no header, `;`"  # the CSV records again, as `--no-header --names ... --sep ';'` reads them
HEADERLESS_FORMAT = CsvFormat(header=False, names=NAMES, sep=";")
DICTIONARY = "parquet (dictionary)"  # every column an Arrow dictionary (pandas categoricals)
TARGET = 1.5  # issue 40: fairaudit within 1.5x of the raw DuckDB GROUP BY on the dictionary-encoded file
CHUNK = 10**6
AGREE_ABS = "agreement (max abs. diff)"
AGREE_REL = "agreement (max rel. diff)"

FULL = dict(records=10**7, csv_records=10**6, repeats=5, command_repeats=3)
QUICK = dict(records=10**5, csv_records=10**5, repeats=1, command_repeats=1)


# ----------------------------------------------------------------------------------------------------
# the records
# ----------------------------------------------------------------------------------------------------
def write_records(
    parquet: Path, dictionary_parquet: Path, csv: Path, headerless: Path, n: int, n_csv: int, seed: int
) -> tuple[np.ndarray, np.ndarray]:
    """Write ``n`` records to Parquet (plain and dictionary-encoded columns) and the first ``n_csv`` to CSV, and
    again without a header, separated by ``;``; return their counts (generator's layout)."""
    import pandas as pd
    import pyarrow as pa
    import pyarrow.parquet as pq

    rng = np.random.default_rng([seed, n])
    schema = pa.schema([("context", pa.int64()), ("group", pa.string()), ("decision", pa.int64())])
    values = [pa.array(np.arange(N_CONTEXTS)), pa.array(GROUPS, type=pa.string()), pa.array(DECISIONS)]
    encoded = pa.schema([(name, pa.dictionary(pa.int32(), v.type)) for name, v in zip(NAMES, values)])
    counts, csv_counts = np.zeros(math.prod(SHAPE), np.int64), np.zeros(math.prod(SHAPE), np.int64)
    written = 0
    with pq.ParquetWriter(parquet, schema) as writer, pq.ParquetWriter(dictionary_parquet, encoded) as coded:
        for start in range(0, n, CHUNK):
            m = min(CHUNK, n - start)
            x = rng.integers(0, N_CONTEXTS, m)
            a = rng.integers(0, len(GROUPS), m)
            u = rng.integers(0, len(DECISIONS), m)
            flat = (x * len(GROUPS) + a) * len(DECISIONS) + u
            counts += np.bincount(flat, minlength=counts.size)
            columns = [
                pa.DictionaryArray.from_arrays(pa.array(c.astype(np.int32)), v) for c, v in zip((x, a, u), values)
            ]
            coded.write_table(pa.table(columns, schema=encoded))
            writer.write_table(pa.table([pa.array(x), columns[1].cast(pa.string()), pa.array(u)], schema=schema))
            k = min(m, n_csv - written)
            if k > 0:
                frame = pd.DataFrame({"context": x[:k], "group": np.array(GROUPS)[a[:k]], "decision": u[:k]})
                frame.to_csv(csv, mode="a" if written else "w", header=not written, index=False)
                frame.to_csv(headerless, mode="a" if written else "w", header=False, index=False, sep=";")
                csv_counts += np.bincount(flat[:k], minlength=counts.size)
                written += k
    return counts.reshape(SHAPE), csv_counts.reshape(SHAPE)


# ----------------------------------------------------------------------------------------------------
# (a) in process
# ----------------------------------------------------------------------------------------------------
def table_array(t: CountTable) -> np.ndarray:
    """A CountTable's counts in the generator's layout (contexts 0…99, groups g0…g7, decisions 0…4)."""
    out = np.zeros(SHAPE, dtype=np.int64)
    ix = np.ix_([int(c) for c in t.contexts], [GROUPS.index(g) for g in t.groups], [int(d) for d in t.decisions])
    out[ix] = t.counts
    return out


def _source(kind: str) -> str:
    if kind == HEADERLESS:
        return "read_csv(?, header = false, delim = ';', names = ['context', 'group', 'decision'])"
    return "read_parquet(?)" if kind.startswith("parquet") else "read_csv(?, header = true)"


def raw_duckdb(con, path: Path, kind: str) -> np.ndarray:
    """The raw route: one DuckDB GROUP BY on an open connection, then the numpy count array."""
    query = f'SELECT "context", "group", "decision", count(*) FROM {_source(kind)} GROUP BY ALL'
    ctx, grp, dec, n = con.execute(query, [str(path)]).fetchnumpy().values()
    counts = np.zeros(SHAPE, dtype=np.int64)
    counts[np.asarray(ctx), np.searchsorted(np.array(GROUPS), np.asarray(grp, dtype=str)), np.asarray(dec)] = n
    return counts


def polars_route(path: Path, kind: str) -> np.ndarray:
    import polars as pl

    if kind == HEADERLESS:
        scan = pl.scan_csv(path, has_header=False, separator=";", new_columns=list(NAMES))
    else:
        scan = pl.scan_parquet(path) if kind.startswith("parquet") else pl.scan_csv(path)
    out = scan.group_by(["context", "group", "decision"]).len().collect()
    counts = np.zeros(SHAPE, dtype=np.int64)
    groups = np.searchsorted(np.array(GROUPS), out["group"].to_numpy().astype(str))
    counts[out["context"].to_numpy(), groups, out["decision"].to_numpy()] = out["len"].to_numpy()
    return counts


def _diff(a: np.ndarray, b: np.ndarray) -> float:
    return math.inf if a.shape != b.shape else float(np.abs(a - b).max(initial=0))


def part_in_process(files: dict, repeats: int, failures: list[str], ratios: dict[str, float]) -> str:
    """Table (a): count_file, raw DuckDB and polars on each file, times and ratios to raw DuckDB (``ratios``:
    count_file's of each file)."""
    import duckdb

    try:
        import polars  # noqa: F401

        routes_polars = True
    except ImportError:
        routes_polars = False
    con = duckdb.connect()
    rows = []
    for kind, (path, n, expected) in files.items():
        fmt = HEADERLESS_FORMAT if kind == HEADERLESS else None
        routes: list[tuple[str, Callable[[], np.ndarray]]] = [
            ("raw DuckDB GROUP BY + numpy array", lambda: raw_duckdb(con, path, kind)),
            ("`count_file`", lambda: table_array(count_file(path, csv=fmt, **ROLES))),
        ]
        if routes_polars:
            routes.append(("polars `group_by().len()` + numpy array", lambda: polars_route(path, kind)))
        base = math.nan
        for name, fn in routes:
            try:
                seconds = median_time(fn, repeats)
                diff = _diff(fn(), expected)
            except Exception as exc:  # noqa: BLE001 - a failing route is reported, not fatal
                rows.append([kind, f"{n:,}", name, f"failed: {type(exc).__name__}: {exc}"[:120], "—", "—"])
                failures.append(f"(a) {kind} {name}: {exc}")
                continue
            base = seconds if math.isnan(base) else base
            if name == "`count_file`":
                ratios[kind] = seconds / base
            rows.append([kind, f"{n:,}", name, fmt_time(seconds), fmt_ratio(seconds / base), fmt_diff(diff)])
            if diff != 0:
                failures.append(f"(a) {kind} {name}: counts differ from the generator's by {diff}")
    con.close()
    text = table(["file", "records", "route", "median time", "ratio to raw DuckDB", AGREE_ABS], rows, "lrlrrr")
    if not routes_polars:
        text += "\n\npolars is not installed: its route is skipped."
    return text


# ----------------------------------------------------------------------------------------------------
# (b) end to end, child processes
# ----------------------------------------------------------------------------------------------------
RAW_SCRIPT = r"""
import json, math, sys
import duckdb
import numpy as np

path, kind, positive = sys.argv[1], sys.argv[2], int(sys.argv[3])
source = "read_parquet(?)" if kind.startswith("parquet") else "read_csv(?, header = true)"
con = duckdb.connect()
query = f'SELECT "context", "group", "decision", count(*) FROM {source} GROUP BY ALL'
ctx, grp, dec, n = con.execute(query, [path]).fetchnumpy().values()
contexts, cx = np.unique(np.asarray(ctx), return_inverse=True)
groups, ca = np.unique(np.asarray(grp, dtype=str), return_inverse=True)
decisions, cu = np.unique(np.asarray(dec), return_inverse=True)
counts = np.zeros((contexts.size, groups.size, decisions.size), dtype=np.int64)
counts[cx, ca, cu] = n
cells = counts.sum(axis=-1).astype(float)
hits = counts[..., int(np.flatnonzero(decisions == positive)[0])].astype(float)


def ratio(e):
    present = ~np.isnan(e)
    hi, lo = np.where(present, e, -np.inf).max(axis=-1), np.where(present, e, np.inf).min(axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where(hi == 0, 1.0, np.where(lo == 0, np.inf, hi / lo))
    return np.where(present.sum(axis=-1) >= 2, r, np.nan)


with np.errstate(divide="ignore", invalid="ignore"):
    e = np.where(cells > 0, hits / cells, np.nan)
    w = cells / cells.sum(axis=0)
local = float(np.log(np.nanmax(ratio(e))))
glob = float(np.log(ratio(np.nansum(w * np.nan_to_num(e), axis=0))))
print(json.dumps({"n": int(counts.sum()), "local": local, "global": glob, "counts": counts.tolist(),
                  "contexts": contexts.tolist(), "groups": groups.tolist(), "decisions": decisions.tolist()}))
"""


_BYTECODE = tempfile.mkdtemp(prefix="fairaudit-bench-pycache-")
atexit.register(shutil.rmtree, _BYTECODE, ignore_errors=True)


def run_command(cmd: list[str], timeout: float = 1800.0) -> dict:
    """Run ``cmd`` through a bare Python wrapper: wall time, the command's peak RSS, exit status, output.

    The command's bytecode is cached under a temporary ``PYTHONPYCACHEPREFIX``, as after ``pip install``
    (:func:`_bench_common.installed_env`); :func:`timed_runs` makes one untimed run first, which writes it.
    """
    env = installed_env(_BYTECODE)
    with tempfile.TemporaryDirectory(prefix="fairaudit-bench-cmd-") as tmp:
        report = Path(tmp) / "report.json"
        try:
            proc = subprocess.run(
                [sys.executable, "-I", "-c", RSS_WRAPPER, str(report), *cmd],
                capture_output=True,
                text=True,
                timeout=timeout,
                env=env,
            )
        except subprocess.TimeoutExpired:
            return {"returncode": -9, "stdout": "", "stderr": f"stopped at the time limit of {timeout:g} s"}
        if not report.is_file():
            return {"returncode": proc.returncode, "stdout": proc.stdout, "stderr": proc.stderr or "the wrapper failed"}
        result = json.loads(report.read_text(encoding="utf-8"))
        result.update(stdout=proc.stdout, stderr=proc.stderr)
        return result


def audit_command(path: Path) -> list[str]:
    """The ``fairaudit audit`` command line (the console script next to this Python, else ``python -c``)."""
    args = ["audit", str(path), "--sensitive", "group", "--context", "context", "--outcome", "decision"]
    args += ["--positive", str(POSITIVE), "--format", "json"]
    script = Path(sys.executable).with_name("fairaudit")
    if script.is_file() and os.access(script, os.X_OK):
        return [str(script), *args]
    return [sys.executable, "-c", "import sys; from fairaudit.cli import main; sys.exit(main())", *args]


def _number(value) -> float:
    """A JSON number of the audit report ("inf" for infinity, null for NaN)."""
    return math.nan if value is None else float(value)


def timed_runs(cmd: list[str], repeats: int) -> dict:
    """Median time and peak RSS (max over runs) of ``cmd``, after one untimed run; its last output parsed as JSON."""
    run_command(cmd)  # (writes the bytecode and warms the file cache)
    runs = []
    for _ in range(max(1, repeats)):
        r = run_command(cmd)
        if r["returncode"] != 0:
            tail = (r["stderr"].strip().splitlines() or ["(no message)"])[-1][:200]
            return {"error": f"exit status {r['returncode']}: {tail}"}
        runs.append(r)
    return {
        "seconds": statistics.median(r["seconds"] for r in runs),
        "rss": max(r["rss"] for r in runs),
        "json": json.loads(runs[-1]["stdout"]),
    }


def _script_counts(data: dict) -> np.ndarray:
    out = np.zeros(SHAPE, dtype=np.int64)
    ix = np.ix_(data["contexts"], [GROUPS.index(g) for g in data["groups"]], data["decisions"])
    out[ix] = np.array(data["counts"], dtype=np.int64)
    return out


def part_commands(files: dict, repeats: int, failures: list[str], ratios: dict[str, float]) -> str:
    """Table (b): the audit command against the raw DuckDB script, child processes, time and peak RSS (``ratios``:
    the command's time ratio of each file)."""
    rows = []
    for kind, (path, n, expected) in files.items():
        raw = timed_runs([sys.executable, "-c", RAW_SCRIPT, str(path), kind, str(POSITIVE)], repeats)
        audit = timed_runs(audit_command(path), repeats)
        for name, r in (("`python -c` raw DuckDB + numpy", raw), ("`fairaudit audit --format json`", audit)):
            if "error" in r:
                rows.append([kind, f"{n:,}", name, r["error"], "—", "—", "—", "—"])
                failures.append(f"(b) {kind} {name}: {r['error']}")
        if "error" in raw or "error" in audit:
            continue
        script, report = raw["json"], audit["json"]
        counts_diff = _diff(_script_counts(script), expected)
        agreement = max(
            rel_diff(float(report["n"]), float(script["n"])),
            rel_diff(_number(report["local"]["value"]), script["local"]),
            rel_diff(_number(report["global"]["value"]), script["global"]),
        )
        ratios[kind] = audit["seconds"] / raw["seconds"]
        if counts_diff != 0:
            failures.append(f"(b) {kind}: the script's counts differ from the generator's by {counts_diff}")
        if not agreement <= AGREEMENT_TOL:
            failures.append(f"(b) {kind}: the audit's n, L, L-bar differ from the script's by {agreement:.1e}")
        rows.append(
            [kind, f"{n:,}", "`python -c` raw DuckDB + numpy", fmt_time(raw["seconds"]), "1×", fmt_mb(raw["rss"]), "1×"]
            + [fmt_diff(counts_diff)]
        )
        rows.append(
            [kind, f"{n:,}", "`fairaudit audit --format json`", fmt_time(audit["seconds"])]
            + [fmt_ratio(audit["seconds"] / raw["seconds"]), fmt_mb(audit["rss"]), fmt_ratio(audit["rss"] / raw["rss"])]
            + [fmt_diff(agreement)]
        )
    header = ["file", "records", "command", "median time", "time ratio", "peak RSS", "RSS ratio", AGREE_REL]
    return table(header, rows, "lrlrrrrr")


def target_line(n: int, in_process: float | None, command: float | None) -> str:
    """The two ratios of the dictionary-encoded file against the target (each measured in this run)."""

    def verdict(ratio: float | None) -> str:
        if ratio is None:
            return "not measured (the route failed)"
        return f"{fmt_ratio(ratio)} ({'met' if ratio <= TARGET else 'not met'})"

    return (
        f"{n:,} records, target ≤ {TARGET:g}×: `count_file` / raw DuckDB GROUP BY in process {verdict(in_process)}; "
        f"`fairaudit audit` / `python -c` raw DuckDB script, end to end {verdict(command)}."
    )


def fmt_mb(n: float) -> str:
    return f"{n / 1e6:.0f} MB"


# ----------------------------------------------------------------------------------------------------
# the run
# ----------------------------------------------------------------------------------------------------
def run(args) -> tuple[str, list[str]]:
    cfg = dict(QUICK if args.quick else FULL)
    n = args.records or cfg["records"]
    n_csv = min(n, args.csv_records or cfg["csv_records"])
    repeats = args.repeats or cfg["repeats"]
    failures: list[str] = []
    with tempfile.TemporaryDirectory(prefix="fairaudit-bench-counting-", dir=args.workdir) as tmp:
        parquet, csv = Path(tmp) / "records.parquet", Path(tmp) / "records.csv"
        coded, headerless = Path(tmp) / "dictionary.parquet", Path(tmp) / "records.data"
        counts, csv_counts = write_records(parquet, coded, csv, headerless, n, n_csv, args.seed)
        files = {"parquet": (parquet, n, counts), DICTIONARY: (coded, n, counts), "csv": (csv, n_csv, csv_counts)}
        sizes = ", ".join(
            f"{name} {path.stat().st_size / 1e6:.1f} MB"
            for name, path in (("Parquet", parquet), ("dictionary-encoded Parquet", coded), ("CSV", csv))
        )
        in_process: dict[str, float] = {}
        commands: dict[str, float] = {}
        part_a = part_in_process({**files, HEADERLESS: (headerless, n_csv, csv_counts)}, repeats, failures, in_process)
        part_b = part_commands(files, args.command_repeats or cfg["command_repeats"], failures, commands)
    packages = ["numpy", "pandas", "pyarrow", "duckdb", "fairaudit"]
    try:
        import polars  # noqa: F401

        packages.append("polars")
    except ImportError:
        pass
    lines = [
        "# Counting records in files: `count_file` (DuckDB) against a raw DuckDB GROUP BY",
        "",
        machine_line(packages, memory=True),
        "",
        f"{n:,} records in Parquet, plain and dictionary-encoded, and the first {n_csv:,} in CSV ({sizes}), and again "
        "without a header, "
        f"separated by `;` (read with `CsvFormat(header=False, names=..., sep=';')`); {N_CONTEXTS} integer contexts, "
        f"{len(GROUPS)} string groups, {len(DECISIONS)} integer decisions, uniform (seed {args.seed}).",
        "",
        "## (a) In process: `count_file` against a raw DuckDB GROUP BY",
        "",
        f"Median of {repeats} calls after one untimed call; the raw route's connection is opened beforehand "
        "(`count_file` opens a connection to its own in-memory database, made on its first call). "
        "Agreement: the count table against the generator's counts.",
        "",
        part_a,
        "",
        "## (b) End to end: `fairaudit audit` against a `python -c` raw DuckDB script",
        "",
        "Child processes, interpreter start-up and imports included; peak RSS of the child "
        "(through a bare wrapper, `getrusage(RUSAGE_CHILDREN)`). The script builds the same count array and "
        "computes L and L̄ (g = 1{u = 1}) by plain numpy. Agreement: the audit's n, L, L̄ against the script's "
        "(the script's row: its count table against the generator's).",
        "",
        part_b,
        "",
        "## The target: dictionary-encoded Parquet within 1.5× of a raw DuckDB GROUP BY",
        "",
        target_line(n, in_process.get(DICTIONARY), commands.get(DICTIONARY)),
    ]
    if failures:
        lines += ["", f"**{len(failures)} failure(s)**: " + "; ".join(failures)]
    return "\n".join(lines) + "\n", failures


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--quick", action="store_true", help="10^5 records, one repeat, a few seconds (smoke test)")
    parser.add_argument("--output", metavar="FILE.md", help="also write the Markdown report here (atomically)")
    parser.add_argument("--records", type=int, metavar="N", help="records in the Parquet file (default 10^7)")
    parser.add_argument("--csv-records", type=int, metavar="N", help="records in the CSV file (default 10^6)")
    parser.add_argument("--repeats", type=int, metavar="R", help="timed calls of each route in (a) (default 5)")
    parser.add_argument("--command-repeats", type=int, metavar="R", help="runs of each command in (b) (default 3)")
    parser.add_argument("--seed", type=int, default=20250610, help="seed of the records")
    parser.add_argument("--workdir", metavar="DIR", help="where the temporary files go (default the system's)")
    args = parser.parse_args(argv)
    for name in ("records", "csv_records", "repeats", "command_repeats"):
        value = getattr(args, name)
        if value is not None and value < 1:
            parser.error(f"--{name.replace('_', '-')} must be at least 1: {value}")
    if args.workdir and not Path(args.workdir).is_dir():
        parser.error(f"--workdir is not a folder: {args.workdir}")
    report, failures = run(args)
    return finish(report, failures, args.output)


if __name__ == "__main__":
    sys.exit(main())
