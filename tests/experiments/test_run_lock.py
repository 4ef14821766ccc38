"""One runner per run folder: ``fairaudit experiment`` holds ``OUT/.fairaudit.lock`` for the whole run.

A second run on the same ``--out`` is refused at once (exit 2, one line naming ``--out``) before it queries or
writes anything; the lock goes with the run however it ends, and the lock file left behind stops no later run.
The holders here are other processes, as in the real case: the lock is the operating system's (``flock``).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from _chat_server import ChatServer
from _cli import run

filelock = pytest.importorskip("filelock")

ROOT = Path(__file__).resolve().parents[2]
ENV = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}
QUICK = ["--samples", "1", "--keep", "0.7", "--no-images", "--no-progress"]  # 192 table queries
HOLDER = "import sys, filelock\nwith filelock.FileLock(sys.argv[1]):\n    print('held', flush=True)\n    sys.stdin.readline()\n"


def _simulated(out: Path, *extra) -> list:
    return ["experiment", "hr-delivery", "--simulated", "prefers-mary", "--out", out, *QUICK, *extra]


def _partial(capsys, out: Path, keep: int = 50) -> bytes:
    """A run cut after its header and ``keep`` answered queries, as an interrupted run leaves it."""
    code, _, err = run(capsys, *_simulated(out))
    assert code == 0, err
    log = out / "queries.jsonl"
    lines = log.read_bytes().splitlines(keepends=True)
    log.write_bytes(b"".join(lines[: 1 + keep]))
    for f in out.iterdir():  # only the log stays, as after a kill
        if f.name not in ("queries.jsonl", ".fairaudit.lock"):
            f.unlink()
    return log.read_bytes()


def _query_ids(log: Path) -> list:
    lines = [json.loads(x) for x in log.read_text().splitlines()]
    return [r["id"] for r in lines if r["type"] == "query"]


def _refused(err: str, out: Path) -> bool:
    return (
        err.startswith("fairaudit: error: --out: is in use by another fairaudit run")
        and err.count("\n") == 1
        and str(out / ".fairaudit.lock") in err
    )


@pytest.mark.slow
def test_a_second_runner_is_refused_at_once_and_runs_after_the_holder_ends(tmp_path, capsys):
    out = tmp_path / "run"
    before = _partial(capsys, out)
    listing = sorted(p.name for p in out.iterdir())
    holder = subprocess.Popen(
        [sys.executable, "-c", HOLDER, str(out / ".fairaudit.lock")],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert holder.stdout.readline() == "held\n"
        t0 = time.monotonic()
        code, stdout, err = run(capsys, *_simulated(out, "--resume"))
        assert time.monotonic() - t0 < 5  # refused at once, not after waiting
        assert code == 2 and stdout == "" and _refused(err, out), err
        assert (out / "queries.jsonl").read_bytes() == before
        assert sorted(p.name for p in out.iterdir()) == listing  # nothing written: no images, tables or report
    finally:
        holder.communicate("release\n", timeout=30)
    assert holder.returncode == 0
    code, report, err = run(capsys, *_simulated(out, "--resume"))
    assert code == 0, err
    assert "192 of 192 queries answered (142 now" in err and report == (out / "report.md").read_text()
    ids = _query_ids(out / "queries.jsonl")
    assert len(ids) == len(set(ids)) == 192


@pytest.mark.slow
def test_two_concurrent_resumes_one_runs_the_other_is_refused(tmp_path, capsys):
    """Both start together on a partial log; the server holds every query until one of them has exited."""
    out = tmp_path / "run"
    gate = threading.Event()
    with ChatServer(fault_fn=lambda n, body: ("status", 500) if n % 3 == 0 else None) as server:
        args = ["experiment", "hr-delivery", "--endpoint", server.url, "--model", "m", "--out", out]
        args += [*QUICK, "--max-retries", "0", "--timeout", "60"]
        code, _, err = run(capsys, *args)
        assert code == 1 and "incomplete: 128 of 192" in err, err
        server.fault_fn = lambda n, body: None if gate.wait(60) else ("status", 500)
        procs = [
            subprocess.Popen(
                [sys.executable, "-m", "fairaudit.cli", *map(str, args), "--resume"],
                env=ENV,
                stdout=subprocess.DEVNULL,
                stderr=subprocess.PIPE,
                text=True,
            )
            for _ in range(2)
        ]
        try:
            deadline = time.monotonic() + 60
            while all(p.poll() is None for p in procs) and time.monotonic() < deadline:
                time.sleep(0.02)
            first = next(p for p in procs if p.poll() is not None)  # the refused one: the other waits on the gate
        finally:
            gate.set()
            for p in procs:
                p.wait(timeout=60)
    errs = {p: p.stderr.read() for p in procs}
    for p in procs:
        p.stderr.close()
    other = next(p for p in procs if p is not first)
    assert first.returncode == 2 and _refused(errs[first], out), errs[first]
    assert other.returncode == 0, errs[other]
    assert "192 of 192 queries answered (64 now" in errs[other]
    assert server.n_chat == 192 + 64  # each missing query asked once, by one runner
    log = out / "queries.jsonl"
    lines = [json.loads(x) for x in log.read_text().splitlines()]
    ok = [r["id"] for r in lines if r["type"] == "query" and r["status"] == "ok"]
    assert len(ok) == len(set(ok)) == 192


@pytest.mark.slow
def test_the_lock_is_released_on_error_and_interrupt_and_is_no_output(tmp_path, capsys, monkeypatch):
    out = tmp_path / "run"
    _partial(capsys, out)
    code, _, err = run(capsys, *_simulated(out, "--resume", "--seed", "9"))  # refused under the lock
    assert code == 2 and "--seed 0, not 9" in err

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr("fairaudit.experiments.kernel.run_queries", interrupted)
    code, _, err = run(capsys, *_simulated(out, "--resume"))
    assert code == 130 and err.startswith("fairaudit: interrupted")
    lock = filelock.FileLock(out / ".fairaudit.lock", timeout=0)
    with lock:  # free again: would raise filelock.Timeout if the run had kept it
        pass
    monkeypatch.undo()

    from fairaudit.experiments.run import ModelSource, RunOptions, run_experiment

    options = RunOptions(samples=1, keeps=[0.7], images=False, resume=True)
    done = run_experiment("hr-delivery", out, ModelSource(simulated="prefers-mary"), options, progress=False)
    assert done.analysis is not None and done.summary is not None and done.summary.asked == 142
    assert (out / ".fairaudit.lock").exists()  # the lock file stays, empty, and stops no later run
    assert all(f.name != ".fairaudit.lock" for f in done.files)
    code, _, err = run(capsys, *_simulated(out))  # a finished run is still never overwritten
    assert code == 2 and "--out: holds a run already" in err
