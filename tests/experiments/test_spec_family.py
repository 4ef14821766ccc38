"""``fairaudit calibrate --spec`` on the specs an experiment writes: the family their ``[privacy.family]`` names.

The calibrated ε is checked by another route: the experiment run again at that ε writes its spec from its own
filter (``TaskFilter.for_candidates``, not the spec's family), and ``fairaudit certify`` of that spec meets the
target there and misses it just above.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from _cli import run, run_json

from fairaudit.certification.spec import load_spec
from fairaudit.experiments.taskfile import load_task
from fairaudit.experiments.vlm.filter import candidate_family

RUNS = [("hr-delivery", "prefers-mary"), ("package-delivery", "low-complaint-first")]


def _experiment(capsys, out, task, model, epsilon):
    """The one spec of an experiment of ``task`` with the simulated ``model`` at ``epsilon``."""
    args = ("experiment", task, "--simulated", model, "--epsilon", repr(epsilon), "--out", out, "--no-progress")
    code, _, err = run(capsys, *args, "--no-images")
    assert code == 0, err
    (spec,) = out.glob("spec-eps-*.toml")
    return spec


def _certified(capsys, spec):
    code, cert, err = run_json(capsys, "certify", spec)
    assert code == 0, err
    return cert


@pytest.mark.slow
@pytest.mark.parametrize(("task", "model"), RUNS)
def test_calibrate_spec_moves_along_the_runs_family(tmp_path, capsys, task, model):
    spec = _experiment(capsys, tmp_path / "run", task, model, 1.0)
    family = load_spec(spec).sensitive_family
    assert family is not None and family(1.0).epsilon == pytest.approx(1.0, abs=1e-12)
    for method, read in (("black_box", lambda c: c["bounds"]["black_box"]), ("white_box", _upper_local)):
        code, cal, err = run_json(capsys, "calibrate", "--target", "0.5", "--spec", spec, "--method", method)
        assert code == 0 and cal["feasible"], err
        eps = cal["epsilon"]
        at = _certified(capsys, _experiment(capsys, tmp_path / f"{method}-at", task, model, eps))
        above = _certified(capsys, _experiment(capsys, tmp_path / f"{method}-above", task, model, eps * (1 + 1e-6)))
        assert at["privacy"]["sensitive"]["epsilon"] == pytest.approx(eps, rel=1e-12)
        assert read(at) <= 0.5 + 1e-9 < read(above), (method, eps)


def _upper_local(cert):
    """The certificate's observed L (the simulated models here leave no reply unparsed: it is the upper end)."""
    return cert["observed"]["local"]["value"]


@pytest.mark.slow
def test_the_family_is_named_and_checked(tmp_path, capsys):
    spec = _experiment(capsys, tmp_path / "run", "hr-delivery", "prefers-mary", 1.0)
    text = spec.read_text()
    assert "[privacy.family]" in text
    wrong = tmp_path / "wrong" / spec.name
    wrong.parent.mkdir()
    (wrong.parent / "candidates.csv").write_text((spec.parent / "candidates.csv").read_text())
    wrong.write_text(
        text.replace('["Tom", 25, "Asian", "Mary", 55, "American"]', '["Tom", 25, "Asian", "Tom", 55, "American"]')
    )
    code, _, err = run(capsys, "calibrate", "--target", "0.5", "--spec", wrong)
    assert code == 2 and err.count("\n") == 1 and len(err) < 300, err
    assert "privacy.family: does not pass through the mechanism of [privacy.sensitive]" in err
    bare = tmp_path / "bare" / spec.name
    bare.parent.mkdir()
    (bare.parent / "candidates.csv").write_text((spec.parent / "candidates.csv").read_text())
    bare.write_text(text[: text.index("[privacy.family]")] + text[text.index("[model]") :])
    code, _, err = run(capsys, "calibrate", "--target", "0.5", "--spec", bare)
    assert code == 2 and err.count("\n") == 1 and len(err) < 400, err
    assert "privacy.family: is needed to calibrate on the model: [privacy.sensitive] releases 64 values" in err
    assert _certified(capsys, bare)["privacy"]["sensitive"]["epsilon"] == pytest.approx(1.0)


RANKING = Path(__file__).resolve().parents[2] / "examples" / "tasks" / "ranking.toml"


@pytest.mark.slow
def test_a_design_that_mixes_views_writes_its_mixtures(tmp_path, capsys):
    # Three names in all six orders: each candidate is shown with its rivals in either order, half the time each.
    # calibrate --spec gives the ε of the experiment's own analysis (certificate.json's budgets, along
    # candidate_family), and the spec's family is candidate_family.
    run_dir = tmp_path / "run"
    code, _, err = run(
        capsys, "experiment", RANKING, "--samples", "3", "--epsilon", "1.0", "--out", run_dir, "--no-images"
    )
    assert code == 0, err
    (spec,) = run_dir.glob("spec-eps-*.toml")
    assert "\nmixtures = [\n  [{weight = 0.5, input = " in spec.read_text()
    family, own = load_spec(spec).sensitive_family, candidate_family(load_task(RANKING), "balanced")
    assert family is not None
    for eps in (0.0, 0.4, 1.0, 3.0):
        np.testing.assert_allclose(family(eps).matrix, own(eps).matrix, rtol=0, atol=1e-9)
    budgets = json.loads((run_dir / "certificate.json").read_text())["budgets"]
    for b in (b for b in budgets if b["kind"] == "local" and b["target"] in (0.1, 0.25)):
        for method, expected in (("white_box", b["this_model"]["stated_default"]), ("black_box", b["any_model"])):
            code, cal, err = run_json(capsys, "calibrate", "--spec", spec, "--target", b["target"], "--method", method)
            assert code == 0 and cal["feasible"] and expected["feasible"], err
            assert cal["epsilon"] == pytest.approx(expected["epsilon"], rel=1e-9), (method, b["target"])
    code, _, err = run(capsys, "certify", spec, "--plot", tmp_path / "curve.png")  # a curve along the family
    assert code == 0 and (tmp_path / "curve.png").stat().st_size > 0, err
    targeted = spec.with_name("targeted.toml")
    targeted.write_text(spec.read_text() + "\n[target]\nlocal = 0.25\n")
    code, cert, err = run_json(capsys, "certify", targeted)
    assert code in (0, 1) and cert["calibration"]["epsilon"] > 0, err
    (tmp_path / "cert.json").write_text(json.dumps(cert))
    code, out, err = run(capsys, "verify", tmp_path / "cert.json")
    assert code == 0 and "checked numbers hold" in out, (out, err)
