"""Task files beyond two candidates: one person per prompt, and a ranking of three, end to end, with hand values."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from _cli import run

from fairaudit.experiments.analysis import analyse_kernel
from fairaudit.experiments.slots import epsilon_from_keep
from fairaudit.experiments.taskfile import load_task
from fairaudit.experiments.vlm.models import simulated_model
from fairaudit.laws.tables import Kernel

ROOT = Path(__file__).resolve().parents[2]
LOAN = ROOT / "examples" / "tasks" / "loan.toml"
RANKING = ROOT / "examples" / "tasks" / "ranking.toml"


def _exact(task, name):
    """The simulated model's own kernel (probabilities) in the table design's layout."""
    p = simulated_model(task, name).probabilities
    groups = list(range(int(np.prod(p.shape[1:-1]))))
    return Kernel(p.reshape(len(task.contexts), len(groups), -1), task.contexts, groups, task.decisions)


@pytest.mark.slow
def test_one_person_per_prompt_by_hand():
    """prefers-first approves with probability the share of the 2 attributes shown as (Emily Walsh, 25-34).

    Behind randomized response keeping each attribute with p = 0.8: E[approve | Emily, 25-34] = p and
    E[approve | Lakisha, 55-64] = 1 - p, so L = ln(0.8 / 0.2) = ln 4; population "all": the candidate's ε is the
    profile's, 2 ln 4 (the corollary), and without a filter L = ln(1 / 0) = +inf.
    """
    task = load_task(LOAN)
    assert task.slots == 1 and task.population == "all" and len(task.candidates) == 4
    eps = epsilon_from_keep(task, 0.8)
    assert eps == pytest.approx(2 * math.log(4), abs=1e-12)
    a = analyse_kernel(task, _exact(task, "prefers-first"), model="m", epsilons=[eps], confidence=None)
    point = a.points[0]
    assert point.local_fairness.value == pytest.approx(math.log(4), abs=1e-12)
    assert point.corollary == pytest.approx(2 * math.log(4), abs=1e-12)
    assert point.black_box_local <= point.corollary + 1e-12
    assert a.baseline.local_fairness.value == math.inf and a.split is None
    assert a.population.contexts == task.contexts  # no slot in the context


@pytest.mark.slow
def test_ranking_of_three_by_hand():
    """prefers-first ranks Emily first and the two others in either order: mean rank 1 against 2.5."""
    task = load_task(RANKING)
    assert task.slots == 3 and task.kind == "order" and len(task.decisions) == 7
    a = analyse_kernel(task, _exact(task, "prefers-first"), model="m", epsilons=[1.0], confidence=None)
    assert a.baseline.local_fairness.value == pytest.approx(math.log(2.5), abs=1e-12)
    m = a.split.expected_utility
    np.testing.assert_allclose(m[:, 0], 1.0, atol=1e-12)  # Emily in every slot
    np.testing.assert_allclose(m[:, 1:], 2.5, atol=1e-12)
    assert a.split.overall_position == pytest.approx(0.0, abs=1e-12)
    assert a.split.overall_group == pytest.approx(math.log(1 / 2.5), abs=1e-12)
    fair = analyse_kernel(task, _exact(task, "position-biased"), model="m", epsilons=[1.0], confidence=None)
    assert fair.baseline.local_fairness.value == pytest.approx(0.0, abs=1e-12)  # position bias, every slot balanced
    assert fair.baseline.global_fairness.value == pytest.approx(0.0, abs=1e-12)


@pytest.mark.slow
@pytest.mark.parametrize("path", [LOAN, RANKING], ids=["loan", "ranking"])
def test_task_files_run_end_to_end_on_the_simulated_model(tmp_path, capsys, path):
    out = tmp_path / "run"
    code, _, err = run(capsys, "experiment", str(path), "--samples", "2", "--out", str(out), "--no-progress")
    assert code == 0, err
    cert = json.loads((out / "certificate.json").read_text())
    task = load_task(path)
    assert cert["slots"] == task.slots and len(cert["points"]) == len(task.keeps)
    assert cert["queries"]["table"] == len(task.contexts) * len(task.profiles) ** task.slots * 2
    records = pd.read_csv(out / "records.csv")
    expected = {1: ["loan", "profile", "outcome"], 3: ["role", "position", "profile", "rivals", "outcome"]}
    assert list(records.columns) == expected[task.slots]
    assert len(records) == cert["queries"]["table"] * task.slots
    assert not (out / "route-1.png").exists()  # route images belong to the paper's navigation tasks
    assert (out / "report.md").read_text().count("## ") >= 3


@pytest.mark.slow
def test_positions_latin_from_the_command_line(tmp_path, capsys):
    """--positions latin: the three cyclic shifts of the listed order, in the certificate and the records."""
    out = tmp_path / "latin"
    code, _, err = run(
        capsys, "experiment", str(RANKING), "--positions", "latin", "--samples", "2", "--keep", "0.8",
        "--out", out, "--no-progress",
    )  # fmt: skip
    assert code == 0, err
    cert = json.loads((out / "certificate.json").read_text())
    assert cert["positions"] == "latin"
    assert cert["queries"]["table"] == 2 * 3**3 * 2  # the table design asks every shown cell; latin weighs the truth
