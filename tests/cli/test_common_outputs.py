"""Where a command writes: never over its own input, never to an empty path."""

from __future__ import annotations

import pytest
from _cli import run


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
