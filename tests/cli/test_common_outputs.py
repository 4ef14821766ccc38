"""Where a command writes: never over its own input, never to an empty path."""

from __future__ import annotations

import pytest
from _cli import run

from fairaudit.cli import main


@pytest.mark.parametrize("command", [["audit", "--sensitive", "sex", "--outcome", "selected", "--dropna"], ["filter"]])
def test_an_output_that_is_the_input_or_empty_is_refused_before_any_work(tmp_path, capsys, command):
    data = tmp_path / "applicants.csv"
    data.write_text("sex,selected\nF,1\nM,0\n")
    before = data.read_bytes()
    extra = ["--column", "sex", "--epsilon", "1"] if command == ["filter"] else []
    for output, why in ((str(data), "is the input DATA: writing there would replace it"), ("", "names no file")):
        code, out, err = run(capsys, command[0], data, *command[1:], *extra, "--output", output)
        assert (code, out) == (2, "") and err.startswith(f"fairaudit: error: --output: {why}") and err.count("\n") == 1
    assert data.read_bytes() == before
    # the same file by another path
    code, _, err = run(capsys, command[0], data, *command[1:], *extra, "--output", str(tmp_path / "." / data.name))
    assert code == 2 and "is the input DATA" in err


def test_a_ctrl_c_right_after_the_report_is_renamed_into_place_is_ignored(tmp_path, capsys, monkeypatch):
    # SIGINT sent to this process the moment write_atomic has renamed the report: the command still ends with its
    # own status and summary, not "interrupted" and 130; the caller's handler is back when main returns
    import os
    import signal

    import fairaudit.base.files as files

    written = files.write_atomic

    def then_ctrl_c(*args, **kwargs):
        written(*args, **kwargs)
        os.kill(os.getpid(), signal.SIGINT)

    monkeypatch.setattr(files, "write_atomic", then_ctrl_c)  # (emit imports it when it writes)
    out = tmp_path / "plan.txt"
    before = signal.getsignal(signal.SIGINT)
    assert main(["plan", "--target", "0.5", "--output", str(out)]) == 0
    assert capsys.readouterr().err == f"queries per cell: clopper-pearson: 171; report written to {out}\n"
    assert out.read_text(encoding="utf-8").startswith("queries per cell to certify L <= 0.5 nats")
    assert signal.getsignal(signal.SIGINT) is before
