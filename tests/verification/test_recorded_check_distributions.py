"""`recorded_check.distribution_checks`: every row of a recorded kernel and mechanism, and the population, is a distribution (entries
>= 0, exact sum within 1e-9 of 1, certify's input rule); an edited one fails naming the input and the row, even where
its inputs_sha256 is recomputed and every number re-derived from it still agrees."""

from __future__ import annotations

import copy
import json

import pytest
from _cli import run

import fairaudit
from fairaudit.base.json_values import canonical_digest
from fairaudit.verification.rederive import verify

# one context, two groups behind binary randomized response; g = 1{yes} reads only the "yes" column
SPEC = """
[sensitive]
name = "group"
values = ["a", "b"]
[decision]
name = "chosen"
values = ["yes", "no"]
[privacy.sensitive]
mechanism = "matrix"
rows = [[0.75, 0.25], [0.25, 0.75]]
[utility]
decision = "yes"
tau = 0.1
[model]
table = "table.csv"
"""
TABLE = "group,chosen,probability\na,yes,0.5\na,no,0.5\nb,yes,0.25\nb,no,0.75\n"


@pytest.fixture(scope="module")
def cert(tmp_path_factory) -> dict:
    folder = tmp_path_factory.mktemp("dist")
    (folder / "table.csv").write_text(TABLE, encoding="utf-8")
    (folder / "spec.toml").write_text(SPEC, encoding="utf-8")
    data = json.loads(json.dumps(fairaudit.certify(folder / "spec.toml").to_dict()))
    assert data["inputs"]["kernel"]["probabilities"] == [[[0.5, 0.5], [0.25, 0.75]]]
    return data


def _edited(cert: dict, edit) -> dict:
    out = copy.deepcopy(cert)
    edit(out["inputs"])
    out["inputs_sha256"] = canonical_digest(out["inputs"])  # the editor recomputes the digest
    return out


def _no_column_shift(inputs):
    # every row's "no" entry raised by 0.2: g, the gaps between groups and every metric stay as they were
    for row in inputs["kernel"]["probabilities"][0]:
        row[1] += 0.2


def test_the_certificate_holds_and_checks_each_distribution(cert):
    result = verify(cert)
    assert result.holds
    names = {c.name for c in result.checks}
    assert {
        "inputs.population.probabilities",
        "inputs.kernel.probabilities",
        "inputs.sensitive_mechanism.matrix",
    } <= names


def test_kernel_rows_summing_to_1_2_fail_naming_the_first_row(cert):
    edited = _edited(cert, _no_column_shift)
    assert edited["inputs"]["kernel"]["probabilities"][0][0] == [0.5, 0.7]
    failures = verify(edited).failures
    assert [c.name for c in failures] == ["inputs.kernel.probabilities[0][0]"]  # nothing else shows it
    assert (
        failures[0].line()
        == "inputs.kernel.probabilities[0][0] = 1.2: fails by 0.2 (a row sums to 1.2, not 1 within 1e-9)"
    )


def test_a_mechanism_row_and_the_population_are_distributions(cert):
    def matrix(inputs):
        inputs["sensitive_mechanism"]["matrix"][1][1] = 0.76  # (epsilon stays ln 3: the largest ratio is 0.75/0.25)

    failing = [c.name for c in verify(_edited(cert, matrix)).failures]
    assert "inputs.sensitive_mechanism.matrix[1]" in failing and "inputs.sensitive_mechanism.matrix" not in failing

    def population(inputs):
        inputs["population"]["probabilities"] = [[0.5, 0.6]]

    failing = [c.name for c in verify(_edited(cert, population)).failures]
    assert "inputs.population.probabilities" in failing


@pytest.mark.parametrize(("excess", "holds"), [(5e-10, True), (2e-9, False)])
def test_a_row_within_1e_9_of_1_is_a_distribution(cert, excess, holds):
    def edit(inputs):
        inputs["kernel"]["probabilities"][0][1][1] = 0.75 + excess  # exact sum 1 + excess (to the float's rounding)

    checks = {c.name: c for c in verify(_edited(cert, edit)).checks}
    if holds:
        assert checks["inputs.kernel.probabilities"].holds
    else:
        assert not checks["inputs.kernel.probabilities[0][1]"].holds


def test_the_cli_exits_1_naming_the_input_and_row(capsys, tmp_path, cert):
    path = tmp_path / "cert.json"
    path.write_text(json.dumps(_edited(cert, _no_column_shift)), encoding="utf-8")
    code, out, _ = run(capsys, "verify", path)
    assert code == 1
    assert "inputs.kernel.probabilities[0][0] = 1.2: fails by 0.2 (a row sums to 1.2, not 1 within 1e-9)" in out


def test_rows_of_a_calibrated_member_are_checked():
    from fairaudit.verification.recorded_check import distribution_checks

    member = {"inputs": ["a", "b"], "outputs": ["a", "b"], "kind": "matrix", "matrix": [[0.5, 0.5], [0.25, 0.25]]}
    checks = distribution_checks({"calibration": {"black_box": member, "white_box": None}})
    assert [(c.name, c.holds) for c in checks] == [("inputs.calibration.black_box.matrix[1]", False)]
    assert (
        checks[0].line()
        == "inputs.calibration.black_box.matrix[1] = 0.5: fails by 0.5 (a row sums to 0.5, not 1 within 1e-9)"
    )
