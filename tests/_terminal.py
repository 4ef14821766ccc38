"""Helpers for the tests of progress bars: a captured stderr that is a terminal, in process or for a subprocess."""

from __future__ import annotations

import fcntl
import io
import os
import pty
import select
import signal
import struct
import subprocess
import sys
import termios
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


class Terminal(io.StringIO):
    """A captured stream that says it is a terminal, as tqdm asks before it draws."""

    def isatty(self) -> bool:
        return True


def on_terminal(monkeypatch) -> Terminal:
    """sys.stderr replaced by a :class:`Terminal` for the rest of the test (call it in the test's body: pytest's
    capture sets sys.stderr again after the fixtures have run)."""
    stream = Terminal()
    monkeypatch.setattr(sys, "stderr", stream)
    return stream


def lines_drawn(text: str) -> list[str]:
    """The lines a bar drew (tqdm starts each with a carriage return and pads it with spaces to the last one's
    length), blank ones (the bar cleared) left out."""
    return [line.rstrip() for line in text.replace("\n", "\r").split("\r") if line.strip()]


@dataclass
class Run:
    """A ``fairaudit`` subprocess run with its stderr on a pseudo-terminal."""

    code: int
    stderr: str  # everything written to the terminal, carriage returns kept
    interrupted_after: float | None  # seconds from SIGINT to the exit, when one was sent


def run_on_terminal(
    argv: Sequence[str], *, interrupt_when: Callable[[str], bool] | None = None, timeout: float = 120.0
) -> Run:
    """Run ``python -m fairaudit.cli *argv`` with stderr on a pseudo-terminal (stdout to the null device), reading
    what it writes; with ``interrupt_when``, send SIGINT as soon as that text (all written so far) satisfies it."""
    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 150, 0, 0))  # 150 columns (a new pty has none)
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen(
        [sys.executable, "-m", "fairaudit.cli", *argv], env=env, stdout=subprocess.DEVNULL, stderr=slave
    )
    os.close(slave)
    written, sent, deadline = b"", None, time.monotonic() + timeout
    try:
        while time.monotonic() < deadline:
            if select.select([master], [], [], 0.02)[0]:
                try:
                    chunk = os.read(master, 65536)
                except OSError:  # (the terminal's other end is closed: the process is gone)
                    chunk = b""
                if not chunk and proc.poll() is not None:
                    break
                written += chunk
            elif proc.poll() is not None:
                break
            if interrupt_when is not None and sent is None and interrupt_when(written.decode(errors="replace")):
                proc.send_signal(signal.SIGINT)
                sent = time.monotonic()
        code = proc.wait(timeout=max(0.0, deadline - time.monotonic()))
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        os.close(master)
    after = None if sent is None else time.monotonic() - sent
    return Run(code, written.decode(errors="replace"), after)
