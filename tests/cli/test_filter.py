"""`fairaudit filter`: a column of a CSV or Parquet file released, the rest unchanged, written atomically; errors."""

from __future__ import annotations

import json
import os
import subprocess

import pandas as pd
import pytest
from _cli import OFFICE_SPEC, run

from fairaudit.filter.filters import PrivacyFilter

FRAME = pd.DataFrame(
    {
        "id": list(range(1, 201)),
        "office": ["HR_1", "HR_2"] * 100,
        "score": [0.5 * i for i in range(200)],
        "note": ["a, b", 'say "hi"'] * 100,
    }
)


@pytest.fixture
def csv_file(tmp_path):
    path = tmp_path / "records.csv"
    FRAME.to_csv(path, index=False)
    return path


def released(frame: pd.DataFrame, column: str = "office") -> None:
    """The other columns and the rows are unchanged; the released column holds only the alphabet."""
    assert list(frame.columns) == list(FRAME.columns) and len(frame) == len(FRAME)
    others = [c for c in FRAME.columns if c != column]
    pd.testing.assert_frame_equal(frame[others], FRAME[others], check_dtype=False)
    assert set(frame[column]) <= set(FRAME[column])


def test_a_csv_column_is_released_and_the_parameters_read_back(capsys, csv_file, tmp_path):
    out, params = tmp_path / "out.csv", tmp_path / "filter.json"
    code, _, err = run(
        capsys, "filter", csv_file, "--column", "office", "--keep", "3/4", "--values", "HR_1,HR_2",
        "--output", out, "--parameters", params,
    )  # fmt: skip
    assert code == 0 and "released column 'office' of 200 records" in err
    frame = pd.read_csv(out)
    released(frame)
    assert 0 < (frame["office"] != FRAME["office"]).sum() < 200  # some moved (P(none or all) < 1e-24)
    f = PrivacyFilter.from_dict(json.loads(params.read_text()))
    assert (f.keep, f.move, f.denominator, f.inputs) == (3, 1, 4, ("HR_1", "HR_2"))


def test_keep_one_releases_the_column_unchanged_into_parquet(capsys, csv_file, tmp_path):
    out = tmp_path / "out.parquet"
    code, _, _ = run(capsys, "filter", csv_file, "--column", "office", "--keep", "1", "--values", "HR_1,HR_2",
                     "--output", out)  # fmt: skip
    assert code == 0
    pd.testing.assert_frame_equal(pd.read_parquet(out), FRAME, check_dtype=False)


def test_a_parquet_integer_column_keeps_its_type(capsys, tmp_path):
    data, out = tmp_path / "records.parquet", tmp_path / "out.parquet"
    FRAME.to_parquet(data, index=False)
    values = ",".join(str(i) for i in range(1, 201))
    code, _, _ = run(capsys, "filter", data, "--column", "id", "--epsilon", 2, "--values", values, "--output", out)
    assert code == 0
    frame = pd.read_parquet(out)
    released(frame, "id")
    assert frame["id"].dtype.kind == "i" and frame.dtypes.drop("id").equals(FRAME.dtypes.drop("id"))


def test_the_spec_gives_the_mechanism_and_the_values(capsys, csv_file, tmp_path):
    spec, out, params = tmp_path / "spec.toml", tmp_path / "out.csv", tmp_path / "f.json"
    spec.write_text(OFFICE_SPEC)  # binary randomized response, keep = 0.7: 7/10 exactly, as the spec wrote it
    code, _, _ = run(capsys, "filter", csv_file, "--column", "office", "--spec", spec, "--output", out,
                     "--parameters", params)  # fmt: skip
    assert code == 0
    released(pd.read_csv(out))
    d = json.loads(params.read_text())
    assert (d["keep"], d["move"], d["denominator"], d["values"]) == ("7", "3", "10", ["HR_1", "HR_2"])


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--keep", "3/4", "--values", "HR_1,HR_3"], "DATA column 'office': holds a value that is not among the "
         "filter's values (got 'HR_2')"),
        (["--keep", "1/4", "--values", "HR_1,HR_2"], "--keep: must be a keep probability in [1/k, 1]"),
        (["--keep", "three quarters", "--values", "HR_1,HR_2"], "--keep: is not a rational number"),
        (["--keep", "3/4"], "--values: are needed with --epsilon or --keep"),
        (["--epsilon", "1", "--values", "1,x", "--column", "id"], "--values: must be integers"),
        (["--epsilon", "1", "--values", "a", "--column", "nope"], "--column: is not a column of DATA"),
    ],
)  # fmt: skip
def test_bad_input_is_one_line_and_leaves_an_existing_output_whole(capsys, csv_file, tmp_path, argv, message):
    out = tmp_path / "out.csv"
    out.write_text("the previous output\n")
    argv = ["--column", "office", *argv] if "--column" not in argv else argv
    code, stdout, err = run(capsys, "filter", csv_file, *argv, "--output", out)
    assert code == 2 and stdout == "" and err.startswith(f"fairaudit: error: {message}") and err.count("\n") == 1
    assert out.read_text() == "the previous output\n"
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []  # no temporary file left


def test_a_product_spec_and_values_with_a_spec_are_refused(capsys, csv_file, tmp_path):
    spec = tmp_path / "spec.toml"
    spec.write_text(OFFICE_SPEC)
    code, _, err = run(capsys, "filter", csv_file, "--column", "office", "--spec", spec, "--values", "HR_1",
                       "--output", tmp_path / "o.csv")  # fmt: skip
    assert code == 2 and "--values: come from the spec's [sensitive] values" in err
    product = OFFICE_SPEC.replace(
        'mechanism = "randomized_response"\nkeep = 0.7\n',
        'mechanism = "product"\n[[privacy.sensitive.components]]\nmechanism = "randomized_response"\n'
        'values = ["HR_1", "HR_2"]\nkeep = 0.7\n',
    ).replace('values = ["HR_1", "HR_2"]\n[context]', "[context]")
    spec.write_text(product)
    code, _, err = run(capsys, "filter", csv_file, "--column", "office", "--spec", spec, "--output", tmp_path / "o.csv")
    assert code == 2 and "has a product mechanism" in err, err


def test_a_missing_value_is_refused(capsys, tmp_path):
    data = tmp_path / "r.csv"
    data.write_text("office\nHR_1\n\nHR_2\n")
    data.write_text("office,x\nHR_1,1\n,2\nHR_2,3\n")
    code, _, err = run(capsys, "filter", data, "--column", "office", "--keep", "1/2", "--values", "HR_1,HR_2",
                       "--output", tmp_path / "o.csv")  # fmt: skip
    assert code == 2 and "DATA column 'office': has a missing value (data row 2)" in err


def test_into_text_the_other_columns_are_written_as_they_were(capsys, tmp_path):
    # "NA", "null" and an empty field, "007" and "1.50" pass through as written: only the released column is read as
    # labels (fairaudit's reader takes NA for missing and would have written it empty)
    data = tmp_path / "r.csv"
    data.write_text("office,note,code,amount\nHR_1,NA,007,1.50\nHR_2,,010,NA\nHR_1,null,x,2\n")
    out = tmp_path / "o.csv"
    code, _, _ = run(capsys, "filter", data, "--column", "office", "--keep", "1/2", "--values", "HR_1,HR_2",
                     "--output", out)  # fmt: skip
    assert code == 0
    written = pd.read_csv(out, dtype=str, keep_default_na=False)
    assert written[["note", "code", "amount"]].values.tolist() == [
        ["NA", "007", "1.50"], ["", "010", "NA"], ["null", "x", "2"]
    ]  # fmt: skip
    assert set(written["office"]) <= {"HR_1", "HR_2"}


def test_a_column_the_header_names_twice_is_refused_where_its_copies_differ(capsys, tmp_path):
    # the file is written with one column per name: a second copy that differs would be lost without a word
    data, out = tmp_path / "r.csv", tmp_path / "o.csv"
    data.write_text("office,score,score\nHR_1,1,1\nHR_2,3,4\n")
    code, _, err = run(capsys, "filter", data, "--column", "office", "--keep", "1/2", "--values", "HR_1,HR_2",
                       "--output", out)  # fmt: skip
    assert code == 2 and "names column 'score' 2 times, with different values" in err and not out.exists()
    data.write_text("office,score,score\nHR_1,1,1\nHR_2,3,3\n")  # the same values: written once, and said so
    code, _, err = run(capsys, "filter", data, "--column", "office", "--keep", "1/2", "--values", "HR_1,HR_2",
                       "--output", out)  # fmt: skip
    assert code == 0 and "the header names 'score' (2 times) with the same values: written once" in err
    assert pd.read_csv(out).columns.tolist() == ["office", "score"]


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="named pipes are POSIX")
@pytest.mark.parametrize("command", [["audit", "--sensitive", "office", "--outcome", "chosen"], ["filter", "--column", "office", "--keep", "3/4", "--values", "HR_1,HR_2"]])  # fmt: skip
def test_a_named_pipe_with_a_writer_is_refused_in_one_line_not_read_in_part(capsys, csv_file, tmp_path, command):
    # a writer waits on the pipe: reading it would take its first record, then block on the second open
    fifo = tmp_path / "stream.csv"
    os.mkfifo(fifo)
    writer = subprocess.Popen(["sh", "-c", f"cat {csv_file} > {fifo}"])
    try:
        output = ["--output", tmp_path / "out.csv"] if command[0] == "filter" else []
        code, stdout, err = run(capsys, command[0], fifo, *command[1:], *output)
    finally:
        writer.kill()
        writer.wait()
    assert code == 2 and stdout == "" and err.count("\n") == 1
    assert err.startswith("fairaudit: error: DATA: is a named pipe, not a regular file: DuckDB reads a file more")


def _ctrl_c_after(monkeypatch, what):
    """Send SIGINT to this process right after ``what`` happens (``"records"``: the output's records are written;
    ``"rename"``: the output is renamed into place)."""
    import signal

    import fairaudit.cli.filter as command

    if what == "records":
        written = command._write

        def then_ctrl_c(frame, path, output):
            written(frame, path, output)
            os.kill(os.getpid(), signal.SIGINT)

        monkeypatch.setattr(command, "_write", then_ctrl_c)
    else:
        replaced = os.replace

        def renamed_then_ctrl_c(src, dst, *args, **kwargs):
            replaced(src, dst, *args, **kwargs)
            if str(dst).endswith("out.csv"):
                os.kill(os.getpid(), signal.SIGINT)

        monkeypatch.setattr(os, "replace", renamed_then_ctrl_c)


def test_output_and_parameters_are_written_together_or_not_at_all(capsys, csv_file, tmp_path, monkeypatch):
    # a Ctrl-C taken inside the records' write: neither file is replaced, no temporary file is left, exit 130
    out, params = tmp_path / "out.csv", tmp_path / "filter.json"
    out.write_text("old output\n")
    params.write_text("old parameters\n")
    argv = ["filter", csv_file, "--column", "office", "--keep", "3/4", "--values", "HR_1,HR_2", "--output", out,
            "--parameters", params]  # fmt: skip
    with monkeypatch.context() as m:
        _ctrl_c_after(m, "records")
        code, _, err = run(capsys, *argv)
    assert (code, err.splitlines()[-1]) == (130, "fairaudit: interrupted")
    assert (out.read_text(), params.read_text()) == ("old output\n", "old parameters\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["filter.json", "out.csv", "records.csv"]
    # a Ctrl-C between the output's rename and the parameters': ignored, both written (it used to leave the
    # new output beside the old parameters, exit 130)
    with monkeypatch.context() as m:
        _ctrl_c_after(m, "rename")
        code, _, err = run(capsys, *argv)
    assert code == 0 and "released column 'office' of 200 records" in err
    released(pd.read_csv(out))
    assert PrivacyFilter.from_dict(json.loads(params.read_text())).keep == 3
    assert sorted(p.name for p in tmp_path.iterdir()) == ["filter.json", "out.csv", "records.csv"]
