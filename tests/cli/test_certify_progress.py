"""``fairaudit certify``: progress bars on stderr where it is a terminal (unless ``--no-progress``), and Ctrl-C.

The long specs are the families of ``benchmarks/spec_families.py``: 18 intersectional groups (the worst case's pair
search, about 20 s) and groups from counts behind randomized response (the intervals behind the filter). A SIGINT is
sent once the step's bar is on the terminal, so that it lands inside that step.
"""

from __future__ import annotations

import os
import subprocess
import sys

import pytest
from _spec_families import write_spec
from _terminal import ROOT, lines_drawn, on_terminal, run_on_terminal

import fairaudit.worstcase.pair_search as pair_search
from fairaudit.cli import CLEAR_LINE, build_parser, main


def test_no_progress_flag():
    parser = build_parser("certify")
    assert parser.parse_args(["certify", "s.toml"]).progress is True
    assert parser.parse_args(["certify", "s.toml", "--no-progress"]).progress is False


def test_certify_draws_the_search_bar_on_a_terminal_unless_no_progress(monkeypatch, tmp_path):
    # 4 groups behind a product of randomized responses, 3 contexts: L's search over 3 x 12 programs, then L-bar's
    # over 12 (then the calibration's black-box bounds, over 12 each)
    spec = write_spec("near_tie", 1, tmp_path, small=True)
    terminal = on_terminal(monkeypatch)
    monkeypatch.setattr(pair_search, "STEP_DELAY", 0.0)
    assert main(["certify", str(spec), "--output", str(tmp_path / "quiet.txt"), "--no-progress"]) == 1
    quiet = terminal.getvalue()
    assert not quiet.startswith("\r") and quiet.count("\n") == 1 and "programs" not in quiet
    terminal.truncate(0), terminal.seek(0)
    assert main(["certify", str(spec), "--output", str(tmp_path / "shown.txt")]) == 1
    drawn = lines_drawn(terminal.getvalue())
    assert drawn[0] == "worst case: 0/36 programs [00:00]"
    assert "worst case: 0/12 programs [00:00]" in drawn
    assert drawn[-1] == quiet.strip().replace("quiet.txt", "shown.txt")  # (each bar cleared before the summary)
    assert (tmp_path / "quiet.txt").read_text() == (tmp_path / "shown.txt").read_text()


@pytest.mark.slow
def test_no_bar_where_stderr_is_not_a_terminal(tmp_path):
    # 80 groups from counts: the intervals take seconds, long enough for their bar on a terminal
    spec = write_spec("counts", 1, tmp_path, groups=80)
    shown = run_on_terminal(["certify", str(spec), "--output", str(tmp_path / "shown.txt")])
    assert shown.code == 1
    assert any(line.startswith("intervals: ") and "/24 [" in line for line in lines_drawn(shown.stderr))
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    out = tmp_path / "piped.txt"
    piped = subprocess.run(
        [sys.executable, "-m", "fairaudit.cli", "certify", str(spec), "--output", str(out)],
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert piped.returncode == 1
    summary = lines_drawn(shown.stderr)[-1].replace("shown.txt", "piped.txt")
    assert piped.stderr == summary + "\n"
    assert out.read_text() == (tmp_path / "shown.txt").read_text()


@pytest.mark.slow
@pytest.mark.parametrize(
    ("family", "groups", "step"),
    [("intersectional", 18, "worst case: "), ("counts", 80, "intervals: ")],
    ids=["pair-search", "intervals"],
)
def test_ctrl_c_ends_certify_at_once_with_status_130_and_no_report(tmp_path, family, groups, step):
    spec = write_spec(family, 1, tmp_path, groups=groups)
    out = tmp_path / "report.json"
    run = run_on_terminal(
        ["certify", str(spec), "--format", "json", "--output", str(out)],
        interrupt_when=lambda written: step in written,
    )
    assert run.interrupted_after is not None, run.stderr  # (the step's bar was drawn, then SIGINT was sent)
    assert run.interrupted_after < 5.0
    assert run.code == 130
    assert "Traceback" not in run.stderr and "KeyboardInterrupt" not in run.stderr
    assert run.stderr.endswith(f"{CLEAR_LINE}fairaudit: interrupted\r\n")  # (on a blank line, whatever the bar drew)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["counts.csv", spec.name])  # no report, no temporary
