"""`recorded_check` and `accounting`: the numbers a certificate repeats or reads off its inputs, and every number
accounted for (re-derived, or listed with the reason)."""

from __future__ import annotations

import copy
import json
from fractions import Fraction
from pathlib import Path

import pytest

import fairaudit
from fairaudit.verification.accounting import unaccounted
from fairaudit.verification.rederive import verify

ROOT = Path(__file__).resolve().parents[2]
HR_OFFICE = str(ROOT / "examples/hr_office/hr_office.toml")
GPT35 = str(ROOT / "examples/llm_hiring/gpt35.toml")
DEPENDENT = """
[sensitive]
name = "group"
values = ["a", "b"]
[context]
name = "job"
values = ["x", "y"]
[decision]
name = "chosen"
values = ["yes", "no"]
[population]
probabilities = [[0.1, 0.3], [0.4, 0.2]]
[utility]
decision = "yes"
"""


@pytest.fixture(scope="module")
def certificates() -> dict[str, dict]:
    return {p: json.loads(json.dumps(fairaudit.certify(p).to_dict())) for p in (HR_OFFICE, GPT35)}


def _failing(cert: dict) -> list[str]:
    return [c.name for c in verify(cert).failures]


def _raised(v: float) -> float:
    """``v`` moved up by 1e-7·max(1, |v|): clearly beyond the certificate's tolerance, 1e-9."""
    return v + 1e-7 * max(1.0, abs(v))


@pytest.mark.slow
def test_the_keep_probability_of_the_product_is_its_smallest_diagonal_entry(certificates):
    # three binary randomized responses keeping 7/10 each: min_a M[a, a] = 0.7^3 = 0.343 (the product's floats)
    cert = certificates[HR_OFFICE]
    rows = cert["inputs"]["sensitive_mechanism"]["matrix"]
    assert min(Fraction(rows[i][i]) for i in range(8)) == Fraction(cert["privacy"]["sensitive"]["keep_probability"])
    assert abs(cert["privacy"]["sensitive"]["keep_probability"] - 0.343) < 1e-15
    assert {"privacy.sensitive.keep_probability", "utility.tau", "population.max_deviation"} <= {
        c.name for c in verify(cert).checks
    }


@pytest.mark.slow
@pytest.mark.parametrize(
    "path, change, failing",
    [
        (("utility", "tau"), lambda v: v + 1e-9, "utility.tau"),
        (("utility", "gamma"), lambda v: v * 2, "utility.gamma"),
        (("privacy", "sensitive", "keep_probability"), _raised, "privacy.sensitive.keep_probability"),
        (("privacy", "sensitive", "inputs"), lambda v: v + 1, "privacy.sensitive.inputs"),
        (("privacy", "context", "outputs"), lambda v: v - 1, "privacy.context.outputs"),
        (("privacy", "sensitive", "delta"), lambda v: 1e-9, "privacy.sensitive.delta"),
        (("population", "max_deviation"), _raised, "population.max_deviation"),
        (("bound_details", "tight", "value"), lambda v: v + 1e-9, "bound_details.tight.value"),
        (("bound_details", "corollary", "epsilon"), lambda v: v - 1e-9, "bound_details.corollary.epsilon"),
        (("bound_details", "black_box", "ratio"), lambda v: v * (1 - 1e-9), "bound_details.black_box.ratio"),
        (("bound_details", "black_box", "witness"), lambda v: v + 1e-6, "bound_details.black_box.witness"),
        (("bound_details", "black_box", "gap"), lambda v: v - 1e-9, "bound_details.black_box.gap"),
    ],
)
def test_a_changed_number_fails(certificates, path, change, failing):
    cert = copy.deepcopy(certificates[HR_OFFICE])
    where = cert
    for key in path[:-1]:
        where = where[key]
    where[path[-1]] = change(where[path[-1]])
    assert failing in _failing(cert)


def test_the_deviation_names_where_it_is_attained(tmp_path):
    # P(x) = (0.4, 0.6), P(a) = (0.5, 0.5): |0.1 - 0.2| = |0.3 - 0.2| = |0.4 - 0.3| = |0.2 - 0.3| = 0.1 everywhere
    (tmp_path / "spec.toml").write_text(DEPENDENT, encoding="utf-8")
    cert = json.loads(json.dumps(fairaudit.certify(tmp_path / "spec.toml").to_dict()))
    assert abs(cert["population"]["max_deviation"] - 0.1) < 1e-15
    assert "population.max_deviation (its context and group)" in {c.name for c in verify(cert).checks}
    assert verify(cert).holds
    cert["population"]["max_deviation"] = 0.1 + 1e-7  # beyond the certificate's tolerance, 1e-9
    assert "population.max_deviation" in _failing(cert)


@pytest.mark.slow
def test_every_number_is_re_derived_or_listed(certificates):
    for cert in certificates.values():
        result = verify(cert)
        assert [n for n, why in result.not_checked if why == "not re-derived"] == []


def test_a_number_no_check_covers_is_listed_under_its_path():
    cert = {"format_version": 2, "inputs": {"x": 1.0}, "bounds": {"new": 0.5, "tight": "inf"}, "flag": True}
    listed = [("bounds.new", "not re-derived"), ("bounds.tight", "not re-derived"), ("flag", "not re-derived")]
    assert unaccounted(cert, [], []) == listed  # a boolean is a verdict: accounted for like a number
    assert unaccounted(cert, [], [("bounds", "a reason")]) == [("flag", "not re-derived")]
