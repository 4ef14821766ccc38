"""Ctrl-C inside DuckDB's counting: exit 130 within a second, the one ``interrupted`` line after the progress bar,
nothing written.

DuckDB takes SIGINT during a query itself: it interrupts the query and raises ``RuntimeError("Query interrupted")``
(a traceback and exit status 1 before :func:`fairaudit.data.record_files.interrupts_raised`).
"""

from __future__ import annotations

import time

import pytest
from _terminal import lines_drawn, run_on_terminal

from fairaudit.cli import CLEAR_LINE


@pytest.fixture(scope="module")
def many_records(tmp_path_factory):
    """3 · 10^7 records of 1000 groups, 7 contexts and a binary outcome (about 240 MB; seconds to count)."""
    import duckdb

    path = tmp_path_factory.mktemp("records") / "records.csv"
    query = "SELECT i % 1000 AS g, i % 7 AS x, CAST(i % 3 = 0 AS INT) AS y FROM range(30000000) t(i)"
    duckdb.connect().execute(f"COPY ({query}) TO '{path}' (HEADER)")
    return path


def _after(seconds: float):
    """A condition on what the process wrote that holds ``seconds`` after it is first asked."""
    start: list[float] = []

    def ready(written: str) -> bool:
        start.append(time.monotonic())
        return start[-1] - start[0] > seconds

    return ready


@pytest.mark.slow
@pytest.mark.parametrize("command", ["audit", "filter"])
@pytest.mark.parametrize("progress", [True, False])
def test_ctrl_c_inside_duckdb_ends_the_command_with_130_and_nothing_written(tmp_path, many_records, command, progress):
    out = tmp_path / ("report.txt" if command == "audit" else "released.csv")
    flags = ["--sensitive", "g", "--outcome", "y", "--context", "x"] if command == "audit" else []
    if command == "filter":
        flags = ["--column", "g", "--epsilon", "1", "--values", ",".join(map(str, range(1000)))]
    flags += [] if progress else ["--no-progress"]
    run = run_on_terminal([command, str(many_records), *flags, "--output", str(out)], interrupt_when=_after(1.5))
    assert run.interrupted_after is not None and run.interrupted_after < 2.0, run.stderr
    assert run.code == 130 and run.stderr.endswith(f"{CLEAR_LINE}fairaudit: interrupted\r\n"), run.stderr
    # DuckDB's progress through the file, drawn after half a second (none with --no-progress), cleared at the end
    shown = [int(line.split(":")[1].split("%")[0]) for line in lines_drawn(run.stderr) if line.startswith("reading")]
    assert (len(shown) > 0) == progress and all(0 <= p <= 100 for p in shown), shown
    if not progress:
        assert run.stderr == f"{CLEAR_LINE}fairaudit: interrupted\r\n"
    assert list(tmp_path.iterdir()) == []  # no output, no temporary file
