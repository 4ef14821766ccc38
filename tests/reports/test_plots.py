"""`fairaudit certify --plot / --plot-data / --epsilons`: valid images, the curve's data, exit statuses, errors."""

from __future__ import annotations

import json
import math
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from _cli import run

from fairaudit.certification.curves import COLUMNS
from fairaudit.cli import main

ROOT = Path(__file__).resolve().parents[2]
HR_SPEC = ROOT / "examples" / "hr_office" / "hr_office.toml"
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"

SPEC = """
title = "binary randomized response, a model that chooses the candidates shown as HR_2"
[sensitive]
name = "office"
values = ["HR_1", "HR_2"]
[decision]
name = "outcome"
values = ["chosen", "not chosen"]
[privacy.sensitive]
mechanism = "randomized_response"
keep = 0.7
[model]
table = "kernel.csv"
[utility]
decision = "chosen"
tau = 0.2
[target]
local = {target}
"""

KERNEL = "office,outcome,probability\nHR_1,chosen,0\nHR_1,not chosen,1\nHR_2,chosen,1\nHR_2,not chosen,0\n"


@pytest.fixture
def spec(tmp_path):
    """A spec whose target 1.0 nats is met (ε = ln(7/3) = 0.847)."""
    (tmp_path / "kernel.csv").write_text(KERNEL)
    path = tmp_path / "office.toml"
    path.write_text(SPEC.format(target=1.0))
    return path


def test_png_is_a_valid_image_and_the_report_is_unchanged(capsys, spec, tmp_path):
    code0, out0, _ = run(capsys, "certify", spec)
    png = tmp_path / "curve.png"
    code, out, err = run(capsys, "certify", spec, "--plot", png)
    assert code == code0 == 0
    assert out == out0  # the report on stdout does not change
    assert png.read_bytes()[:8] == PNG_MAGIC and png.stat().st_size > 10_000
    assert err.strip() == f"fairness-privacy curve: 61 values of epsilon; plot written to {png}"
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temporary file left behind


def test_svg_is_a_valid_svg_document_with_labelled_axes(capsys, spec, tmp_path):
    svg = tmp_path / "curve.svg"
    code, _, _ = run(capsys, "certify", spec, "--plot", svg, "--format", "json")
    assert code == 0
    root = ET.parse(svg).getroot()
    assert root.tag == "{http://www.w3.org/2000/svg}svg"
    text = svg.read_text(encoding="utf-8")
    assert "privacy budget ε (nats)" in text and "local g-fairness L (nats)" in text


def test_csv_columns_and_the_row_at_the_spec_epsilon_equal_the_certificate(capsys, spec, tmp_path):
    csv = tmp_path / "curve.csv"
    code, out, err = run(capsys, "certify", spec, "--plot-data", csv, "--format", "json", "--epsilons", "0:2:21")
    assert code == 0
    cert = json.loads(out)
    frame = pd.read_csv(csv)
    assert tuple(frame.columns) == COLUMNS
    assert len(frame) == 22  # 21 grid values and the spec's ε = ln(7/3)
    row = frame[frame["is_spec_epsilon"]]
    assert len(row) == 1
    row = row.iloc[0]
    assert row["epsilon_nats"] == pytest.approx(math.log(7 / 3), rel=1e-12)
    assert row["epsilon_nats"] == pytest.approx(cert["privacy"]["sensitive"]["epsilon"], rel=1e-12)
    assert row["keep_probability"] == pytest.approx(0.7, rel=1e-12)
    for form in ("paper", "tight", "black_box"):
        assert row[f"{form}_nats"] == pytest.approx(cert["bounds"][form], rel=1e-7), form
    assert row["observed_local_nats"] == pytest.approx(cert["observed"]["local"]["value"], rel=1e-9)
    assert row["observed_global_nats"] == pytest.approx(cert["observed"]["global"]["value"], rel=1e-9)
    # the model that outputs the released group: L = ε at every grid point (p/(1-p) = e^ε)
    np.testing.assert_allclose(frame["observed_local_nats"], frame["epsilon_nats"], rtol=1e-9, atol=1e-12)
    # its smallest E[g | x, a] is 1 - p, so τ = 0.2 holds iff p <= 0.8, i.e. ε <= ln 4; the bounds hold there
    np.testing.assert_array_equal(frame["tau_holds"], frame["epsilon_nats"] <= math.log(4) + 1e-12)
    ok = frame[frame["tau_holds"]]
    assert (ok["black_box_nats"] >= ok["observed_local_nats"] - 1e-9).all()
    assert (frame["tight_nats"] <= frame["paper_nats"] + 1e-12).all()
    assert "curve data written to" in err


def test_plot_does_not_change_a_failing_exit_status(capsys, tmp_path):
    (tmp_path / "kernel.csv").write_text(KERNEL)
    path = tmp_path / "office.toml"
    path.write_text(SPEC.format(target=0.5))  # 0.5 < ln(7/3): not met
    png = tmp_path / "curve.png"
    code, out, _ = run(capsys, "certify", path, "--plot", png, "--plot-data", tmp_path / "c.csv")
    assert code == 1 and "certified: no" in out
    assert png.read_bytes()[:8] == PNG_MAGIC


@pytest.mark.slow
def test_hr_example_plot_and_data(capsys, tmp_path):
    svg, csv = tmp_path / "hr.svg", tmp_path / "hr.csv"
    code, _, _ = run(capsys, "certify", HR_SPEC, "--plot", svg, "--plot-data", csv, "--epsilons", "0:6:25")
    assert code == 0
    assert ET.parse(svg).getroot().tag == "{http://www.w3.org/2000/svg}svg"
    frame = pd.read_csv(csv)
    p = 1 / (1 + np.exp(-frame["epsilon_nats"] / 3))
    np.testing.assert_allclose(frame["observed_local_nats"], 3 * np.log(p / (1 - p)), rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("name", ["curve.pdf", "curve", "curve.png.txt"])
def test_bad_suffix_exits_2_with_one_line(capsys, spec, tmp_path, name):
    code, out, err = run(capsys, "certify", spec, "--plot", tmp_path / name)
    assert code == 2 and out == ""
    assert err == f"fairaudit: error: --plot: must end in .png or .svg (got '{tmp_path / name}')\n"
    assert not (tmp_path / name).exists()


@pytest.mark.parametrize(
    "flag, value, message",
    [
        ("--plot", "missing/curve.svg", "fairaudit: error: --plot: folder does not exist (got 'missing')"),
        ("--plot-data", "missing/curve.csv", "fairaudit: error: --plot-data: folder does not exist (got 'missing')"),
    ],
)
def test_missing_folder_exits_2(capsys, spec, monkeypatch, tmp_path, flag, value, message):
    monkeypatch.chdir(tmp_path)
    code, out, err = run(capsys, "certify", spec, flag, value)
    assert code == 2 and out == "" and err.strip() == message


@pytest.mark.parametrize("grid", ["0:5", "a:b:c", "2:1:5", "0:5:0", "-1:2:3", "0:inf:3"])
def test_bad_epsilons_exit_2(capsys, spec, tmp_path, grid):
    with pytest.raises(SystemExit) as exc:  # argparse's own one-line usage error
        main(["certify", str(spec), "--plot-data", str(tmp_path / "c.csv"), f"--epsilons={grid}"])
    out, err = capsys.readouterr()
    assert exc.value.code == 2 and out == ""
    assert err.count("\n") == 1 and "argument --epsilons" in err and repr(grid) in err
    assert not (tmp_path / "c.csv").exists()


def test_epsilons_without_plot_exits_2(capsys, spec):
    code, out, err = run(capsys, "certify", spec, "--epsilons", "0:1:3")
    assert code == 2 and out == ""
    assert err.strip() == (
        "fairaudit: error: --epsilons: is the grid of the curve: give --plot FILE or --plot-data FILE.csv too"
    )


def test_missing_matplotlib_is_a_clear_error(capsys, spec, tmp_path, monkeypatch):
    for mod in [m for m in sys.modules if m == "matplotlib" or m.startswith("matplotlib.")]:
        monkeypatch.delitem(sys.modules, mod)
    monkeypatch.setitem(sys.modules, "matplotlib", None)  # import matplotlib -> ImportError
    code, out, err = run(capsys, "certify", spec, "--plot", tmp_path / "curve.png")
    assert code == 2 and out == ""
    assert err.strip() == (
        "fairaudit: error: --plot: needs matplotlib, which is not installed: pip install 'fairness-certify[plot]'"
    )
