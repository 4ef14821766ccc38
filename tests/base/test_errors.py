"""Issue 39, error lines: no numpy reprs, echoed values cut at 80 characters with their length, no empty field."""

from __future__ import annotations

import os
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from fairaudit import count_records
from fairaudit.base.checks import real
from fairaudit.base.errors import ECHO_LIMIT, InputError, cut, echo
from tests._cli import OFFICE_SPEC, run


def test_echo_turns_numpy_scalars_into_python_numbers():
    assert echo(np.float64("nan")) == "nan"
    assert echo(np.int64(3)) == "3"
    assert echo(np.bool_(True)) == "True"
    assert echo([np.float32(0.5), "a"]) == "[0.5, 'a']"
    assert str(InputError("tau", "must be positive", np.float64(-0.5))) == "tau: must be positive (got -0.5)"


def test_echo_cuts_long_text_after_80_characters_and_gives_its_length():
    label = "é" * 50_000_000  # a 50 MB label (100 MB in UTF-8)
    text = echo(label)
    assert text == repr("é" * ECHO_LIMIT) + "… (50000000 characters)"
    assert echo("a" * 80) == repr("a" * 80)  # at the limit: whole
    assert echo("a" * 81) == repr("a" * 80) + "… (81 characters)"
    assert cut("b" * 81) == "b" * 80 + "… (81 characters)"
    long_list = list(range(1000))
    assert echo(long_list) == repr(long_list)[:80] + f"… ({len(repr(long_list))} characters)"


def test_a_path_is_echoed_whole():
    path = "/tmp/" + "deep/" * 30 + "records.csv"
    assert echo(path) == repr(path)


def test_numpy_nan_in_a_count_column_is_quoted_as_nan(tmp_path, capsys):
    """numpy 2 printed ``(got np.float64(nan))``: a blank count field is read as NaN by pandas."""
    path = tmp_path / "counts.csv"
    path.write_text("g,y,n\na,1,3\nb,1,\nb,0,2\na,0,1\n")
    code, _, err = run(capsys, "audit", path, "--sensitive", "g", "--outcome", "y", "--count", "n")
    assert (code, err) == (
        2,
        "fairaudit: error: column 'n': must hold finite non-negative numbers; data row 2 (g='b', y='1') is not (got nan)\n",
    )


def test_numpy_values_checked_in_python_are_quoted_as_python_numbers():
    with pytest.raises(InputError) as info:
        real(np.float64("inf"), "gamma")
    assert "np." not in str(info.value) and str(info.value).endswith("(got inf)")


def test_a_1_mb_label_is_not_echoed_in_full(capsys, tmp_path):
    big = "L" * 1_000_000
    path = tmp_path / "r.csv"
    path.write_text(f"g,{big}\na,1\nb,0\n")
    code, _, err = run(capsys, "audit", path, "--sensitive", "g", "--outcome", "y")
    assert code == 2
    assert err == (
        "fairaudit: error: --outcome: unknown column; the data has: g, "
        + "L" * 80
        + "… (1000000 characters) (got 'y')\n"
    )
    code, _, err = run(capsys, "audit", path, "--sensitive", "g", "--outcome", big[:200])
    assert code == 2 and err.endswith(f"(got {'L' * 80!r}… (200 characters))\n") and len(err) < 300


def test_a_line_longer_than_duckdb_reads_is_refused_naming_it(capsys, tmp_path):
    path = tmp_path / "r.csv"
    path.write_text(f"g,y\na,1\nb,{'L' * 3_000_000}\n")
    code, _, err = run(capsys, "audit", path, "--sensitive", "g", "--outcome", "y")
    assert (code, err) == (
        2,
        "fairaudit: error: DATA: cannot be read by DuckDB (line 3: Maximum line size of 2000000 bytes exceeded. "
        f"Actual Size:3000002 bytes.) (got {str(path)!r})\n",
    )


def test_a_long_positive_value_and_outcome_labels_are_cut(capsys, tmp_path):
    big = "yes" + "s" * 1000
    path = tmp_path / "r.csv"
    path.write_text(f"g,y\na,{big}\nb,no\n")
    code, _, err = run(capsys, "audit", path, "--sensitive", "g", "--outcome", "y", "--positive", "x" * 500)
    assert code == 2
    assert err == (
        f"fairaudit: error: --positive: is not a value of the outcome column; it has 'no', {big[:80]!r}… "
        f"(1003 characters) (got {'x' * 80!r}… (500 characters))\n"
    )


def test_a_label_outside_a_given_alphabet_is_cut_with_the_alphabet():
    from fairaudit.data.counts import _label_codes

    frame = pd.DataFrame({"g": ["a", "z" * 300]})
    with pytest.raises(InputError) as info:
        _label_codes(frame, ["g"], ["a", "b" * 200], "sensitive")
    assert str(info.value) == (
        f"column 'g': value not among the sensitive values ['a', '{'b' * 80}… (200 characters)'] "
        f"(got {'z' * 80!r}… (300 characters))"
    )


def test_count_records_names_a_long_column_cut():
    name = "w" * 120
    frame = pd.DataFrame({"g": ["a", "b"], "y": [1, 0], name: ["x", "y"]})
    with pytest.raises(InputError) as info:
        count_records(frame, sensitive="g", outcome="y", weights=name)
    assert str(info.value).startswith(f"column {'w' * 80!r}… (120 characters): must hold finite non-negative numbers")


TASK_FILES = sorted(
    str(p)
    for folder in ("examples/tasks", "fairaudit/experiments/tasks")
    for p in (Path(__file__).resolve().parents[2] / folder).glob("*.toml")
)


@pytest.mark.parametrize("task", TASK_FILES, ids=[Path(t).name for t in TASK_FILES])
def test_certify_on_a_task_file_says_what_to_run(task, capsys):
    """It said ``sensitive: is required``."""
    code, out, err = run(capsys, "certify", task)
    assert (code, out) == (2, "")
    assert err == (
        f"fairaudit: error: {task}: is a task file (it has [task] and [prompt]), not a spec: run `fairaudit "
        f"experiment {task} --out DIR` with a model, which writes the specs (DIR/spec-eps-*.toml) that certify reads\n"
    )


def test_calibrate_with_a_task_file_as_spec_says_so_too(capsys, tmp_path):
    task = tmp_path / "mine.toml"  # the least a task file has: its [task] and [prompt]
    task.write_text('[task]\ncandidates = 2\ndecision = "choose"\n[prompt]\nuser = "Pick one."\n')
    code, _, err = run(capsys, "calibrate", "--target", "1", "--spec", task)
    assert code == 2 and err.startswith(f"fairaudit: error: {task}: is a task file (it has [task] and [prompt])")
    assert err.count("\n") == 1


def test_a_spec_with_its_sensitive_table_is_not_taken_for_a_task_file(tmp_path, capsys):
    spec = tmp_path / "spec.toml"
    spec.write_text(OFFICE_SPEC + '[task]\nname = "x"\n')  # a stray [task] table beside [sensitive]
    code, _, err = run(capsys, "certify", spec)
    assert code == 2 and "task file" not in err and "task" in err


HUGE_EPSILON_SPEC = OFFICE_SPEC.replace("keep = 0.7", "epsilon = 1e308") + "tau = 0.1\n"


@pytest.mark.slow
def test_a_huge_epsilon_draws_the_html_figure_without_a_warning(tmp_path):
    """``epsilon = 1e308`` printed matplotlib's ``RuntimeWarning: overflow encountered in multiply`` on stderr."""
    pytest.importorskip("matplotlib")
    spec = tmp_path / "spec.toml"
    spec.write_text(HUGE_EPSILON_SPEC)
    root = Path(__file__).resolve().parents[2]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(root), os.environ.get("PYTHONPATH", "")])}
    script = "import sys; from fairaudit.cli import main; sys.exit(main(sys.argv[1:]))"
    done = subprocess.run(
        [sys.executable, "-c", script, "certify", str(spec), "--format", "html", "--output", "r.html"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    assert done.stderr == (  # the black-box bound: ln(1 / tau) = ln 10, whatever epsilon
        "certified: yes; best bound 2.302585092994046 nats (black_box); report written to r.html\n"
    )
    assert "<svg" in (tmp_path / "r.html").read_text()


def test_a_huge_epsilon_curve_is_refused_in_one_line_not_a_traceback(tmp_path, capsys):
    """``--plot`` ended in matplotlib's OverflowError (a traceback) after its RuntimeWarnings."""
    pytest.importorskip("matplotlib")
    spec = tmp_path / "spec.toml"
    spec.write_text(HUGE_EPSILON_SPEC)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # any warning would be an error here
        code, out, err = run(capsys, "certify", spec, "--plot", tmp_path / "c.png", "--epsilons", "0:3:5")
    assert (code, out) == (2, "")
    assert err == (
        "fairaudit: error: --epsilons: the curve's grid of epsilon reaches 1e+308 nats (the spec's own epsilon, "
        "always on it), beyond what a figure's axis can show (1e+300 nats): no figure of this spec's curve\n"
    )
    assert not (tmp_path / "c.png").exists()
