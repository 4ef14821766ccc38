"""Helpers shared by the benchmark scripts: timing, the machine line, Markdown tables, atomic output.

Not part of the fairaudit package; the scripts put this folder on ``sys.path``.
"""

from __future__ import annotations

import os
import platform
import statistics
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path

AGREEMENT_TOL = 1e-7  # relative; a larger difference between two exact routes is a failure (exit status 1)


def median_time(fn: Callable[[], object], repeats: int, min_seconds: float = 0.005) -> float:
    """Median over ``repeats`` of the time of one call of ``fn`` (seconds).

    Each repeat runs ``fn`` a number of times chosen once so that a repeat lasts
    at least ``min_seconds`` (calls of tens of microseconds are timed in loops,
    like :mod:`timeit`), and divides by that number.
    """
    t0 = time.perf_counter()
    fn()
    one = time.perf_counter() - t0
    number = max(1, int(min_seconds / one) + 1) if one < min_seconds else 1
    times = []
    for _ in range(max(1, repeats)):
        t0 = time.perf_counter()
        for _ in range(number):
            fn()
        times.append((time.perf_counter() - t0) / number)
    return statistics.median(times)


def rel_diff(a: float, b: float) -> float:
    """|a − b| / max(|a|, |b|), 0 when both are 0 or the same infinity."""
    if a == b:
        return 0.0
    scale = max(abs(a), abs(b))
    return abs(a - b) / scale if scale > 0 else 0.0


def _version(module: str) -> str:
    """The version of an installed package (its ``__version__``, else its distribution metadata), or "?"."""
    try:
        return str(__import__(module).__version__)
    except Exception:
        try:
            from importlib.metadata import version

            return version(module)
        except Exception:
            return "?"


def memory_info() -> dict[str, int] | None:
    """Total and available memory in bytes (``/proc/meminfo``: MemTotal, MemAvailable); None where unknown."""
    try:
        fields = dict(line.split(":", 1) for line in Path("/proc/meminfo").read_text().splitlines() if ":" in line)
        return {
            "total": int(fields["MemTotal"].split()[0]) * 1024,
            "available": int(fields["MemAvailable"].split()[0]) * 1024,
        }
    except (OSError, KeyError, ValueError):
        return None


def machine_line(packages: Sequence[str] = ("numpy", "cvxpy", "clarabel"), memory: bool = False) -> str:
    """One Markdown line naming the machine, the versions and the load at the time it is called.

    ``packages`` are the modules whose versions are named; ``memory`` adds the
    total and available RAM (from ``/proc/meminfo``).
    """
    load = ", ".join(f"{x:.2f}" for x in os.getloadavg()) if hasattr(os, "getloadavg") else "n/a"
    ram = ""
    if memory:
        info = memory_info()
        ram = (
            f", {info['total'] / 1e9:.1f} GB RAM ({info['available'] / 1e9:.1f} GB available)"
            if info
            else ", RAM unknown"
        )
    versions = ", ".join(f"{name} {_version(name)}" for name in packages)
    return (
        f"Machine: {platform.machine()} {platform.system()}, {os.cpu_count()} CPUs{ram}, load average {load}; "
        f"Python {platform.python_version()}, {versions}."
    )


def fmt_time(seconds: float) -> str:
    """Seconds as µs, ms or s with three significant digits."""
    if seconds != seconds:
        return "—"
    if seconds < 1e-3:
        return f"{seconds * 1e6:.3g} µs"
    if seconds < 1.0:
        return f"{seconds * 1e3:.3g} ms"
    return f"{seconds:.3g} s"


def fmt_ratio(x: float) -> str:
    return "—" if x != x else (f"{x:.3g}×" if x < 1000 else f"{x:,.0f}×")


def fmt_diff(x: float) -> str:
    return "—" if x != x else ("0" if x == 0 else f"{x:.1e}")


def table(header: Sequence[str], rows: Sequence[Sequence[str]], align: str | None = None) -> str:
    """A Markdown table; ``align`` is one letter per column, ``l`` or ``r`` (default: first left, rest right)."""
    align = align or "l" + "r" * (len(header) - 1)
    rule = ["---" if a == "l" else "---:" for a in align]
    lines = ["| " + " | ".join(header) + " |", "| " + " | ".join(rule) + " |"]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)


def write_atomic(path: str | os.PathLike, text: str) -> None:
    """Write ``text`` to ``path`` atomically (:func:`fairaudit.base.files.write_atomic`), creating its folder."""
    from fairaudit.base.files import write_atomic as _write

    target = Path(path)
    (target.parent if str(target.parent) else Path(".")).mkdir(parents=True, exist_ok=True)
    _write(target, text)


def emit(text: str, output: str | None) -> None:
    """Print the report to stdout and, when asked, write it atomically to ``output``."""
    sys.stdout.write(text if text.endswith("\n") else text + "\n")
    sys.stdout.flush()
    if output:
        write_atomic(output, text if text.endswith("\n") else text + "\n")


def finish(text: str, failures: Sequence[str], output: str | None) -> int:
    """Emit the report (:func:`emit`), print each failure as ``FAIL: ...`` on stderr; the exit status, 1 on any."""
    emit(text, output)
    for failure in failures:
        print(f"FAIL: {failure}", file=sys.stderr)
    return 1 if failures else 0


RSS_WRAPPER = r"""
import json, resource, subprocess, sys, time
report, cmd = sys.argv[1], sys.argv[2:]
t0 = time.perf_counter()
code = subprocess.call(cmd)
seconds = time.perf_counter() - t0
with open(report, "w") as f:
    json.dump({"seconds": seconds, "returncode": code,
               "rss": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss * 1024}, f)
"""
"""A bare interpreter's script that runs a command and reports its wall time, exit status and peak RSS.

Run as ``python -I -c RSS_WRAPPER REPORT.json CMD...``: Linux carries a process's high-water RSS across ``exec``,
so a command started straight from a large benchmark process would report that process's peak; the wrapper (about
12 MB) starts it and reports ``getrusage(RUSAGE_CHILDREN).ru_maxrss``."""


def installed_env(cache: str) -> dict[str, str]:
    """The environment of a timed command: its bytecode cached under ``cache``, as after ``pip install``.

    ``PYTHONDONTWRITEBYTECODE`` is dropped: with it every run would compile fairaudit's modules again.
    """
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env["PYTHONPYCACHEPREFIX"] = cache
    return env
