"""The certificate's JSON Schema: every shipped example's certificate meets it, and a departure is named by its path."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import pytest
from jsonschema import Draft202012Validator

import fairaudit as fa
from fairaudit.verification.schema import CertificateError, certificate_schema, check_certificate

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ["llm_hiring/gpt35.toml", "llm_hiring/gpt4.toml", "hr_office/hr_office.toml"]
# a utility g(u, x, a) (3-D values) with a metric on the groups, no model; then without tau (no paper or tight bound)
TABLE_SPEC = """
[sensitive]
name = "age"
values = ["young", "middle", "old"]

[decision]
name = "hired"
values = ["yes", "no"]

[privacy.sensitive]
mechanism = "randomized_response"
epsilon = 1.0

[utility]
kind = "table"
values = [[[1.0, 0.0], [0.95, 0.0], [0.9, 0.0]]]
metric = [[0, 1, 2], [1, 0, 1], [2, 1, 0]]
"""


def as_json(cert: fa.Certificate) -> dict:
    """A certificate as a reader gets it: its dictionary through JSON text."""
    return json.loads(json.dumps(cert.to_dict(), allow_nan=False))


@pytest.fixture(scope="module")
def certificates() -> dict[str, dict]:
    out = {name: as_json(fa.certify(ROOT / "examples" / name)) for name in EXAMPLES}
    out["table"] = as_json(fa.certify(fa.parse_spec(TABLE_SPEC + "tau = 0.2\n")))
    out["table without tau"] = as_json(fa.certify(fa.parse_spec(TABLE_SPEC)))
    return out


def test_the_schema_is_a_valid_draft_2020_12_schema():
    schema = certificate_schema()
    Draft202012Validator.check_schema(schema)
    assert schema["$schema"] == "https://json-schema.org/draft/2020-12/schema"


@pytest.mark.slow
def test_every_shipped_example_meets_the_schema(certificates):
    for name, data in certificates.items():
        check_certificate(data)
        assert data["format"] == "fairaudit-certificate" and data["format_version"] == 3, name


def test_the_variants_are_those_the_schema_allows(certificates):
    kinds = {c["inputs"]["sensitive_mechanism"]["kind"] for c in certificates.values()}
    assert kinds == {"randomized_response", "matrix"}
    table = certificates["table"]["inputs"]
    assert table["kernel"] is None and table["utility"]["metric"] == [[0.0, 1.0, 2.0], [1.0, 0.0, 1.0], [2.0, 1.0, 0.0]]
    assert len(table["utility"]["values"]) == 1  # [context][group][decision]
    assert certificates["table without tau"]["inputs"]["utility"]["tau"] is None
    assert certificates["table without tau"]["bounds"]["paper"] is None


def failure(data: dict, change) -> CertificateError:
    changed = copy.deepcopy(data)
    change(changed)
    with pytest.raises(CertificateError) as info:
        check_certificate(changed)
    return info.value


@pytest.mark.parametrize(
    ("change", "field", "value"),
    [
        (lambda d: d.pop("inputs_sha256"), "inputs_sha256", None),
        (lambda d: d.update(inputs_sha256="ABC" + "0" * 61), "inputs_sha256", "ABC" + "0" * 61),
        (lambda d: d.update(format_version=7), "format_version", 7),
        (lambda d: d.update(format="other"), "format", "other"),
        (
            lambda d: d["inputs"]["sensitive_mechanism"].update(kind="laplace"),
            "inputs.sensitive_mechanism.kind",
            "laplace",
        ),
        (lambda d: d["inputs"]["sensitive_mechanism"].pop("epsilon"), "inputs.sensitive_mechanism.epsilon", None),
        (lambda d: d["inputs"]["context_mechanism"].update(epsilon=1.0), "inputs.context_mechanism.epsilon", 1.0),
        (lambda d: d["inputs"]["utility"].update(tau="0.05"), "inputs.utility.tau", "0.05"),
        (lambda d: d["inputs"].update(extra=1), "inputs.extra", 1),
        (
            lambda d: d["inputs"]["population"]["probabilities"][0].__setitem__(1, 1.5),
            "inputs.population.probabilities[0][1]",
            1.5,
        ),
        (
            lambda d: d["inputs"]["kernel"]["probabilities"][0][0].__setitem__(0, -0.1),
            "inputs.kernel.probabilities[0][0][0]",
            -0.1,
        ),
        (lambda d: d["bounds"].update(more=0.1), "bounds.more", 0.1),
        (lambda d: d["bounds"].update(best="low"), "bounds.best", "low"),
        (lambda d: d["privacy"]["sensitive"].pop("delta"), "privacy.sensitive.delta", None),
        (lambda d: d["observed"]["local"].update(value=[0.1]), "observed.local.value", [0.1]),
        # a maximiser's detail (a KeyError traceback before the schema typed them)
        (lambda d: d["observed"]["details"].pop("sup_local"), "observed.details.sup_local", None),
        (
            lambda d: d["observed"]["details"]["sup_global"].pop("decision"),
            "observed.details.sup_global.decision",
            None,
        ),
        (
            lambda d: d["observed"]["details"]["demographic_parity"].update(event="yes"),
            "observed.details.demographic_parity.event",
            "yes",
        ),
        (
            lambda d: d["observed"]["details"]["equalized_odds"].update(context=["x"]),
            "observed.details.equalized_odds.context",
            ["x"],
        ),
    ],
)
def test_a_departure_is_named_by_its_json_path(certificates, change, field, value):
    error = failure(certificates["llm_hiring/gpt35.toml"], change)
    assert error.field == field
    if value is None:  # a missing key: no value to quote
        assert "(got" not in str(error)
    else:
        assert error.value == value


def test_the_message_names_the_path_and_quotes_the_value(certificates):
    data = certificates["llm_hiring/gpt35.toml"]
    assert str(failure(data, lambda d: d.pop("inputs_sha256"))) == "inputs_sha256: is required"
    assert str(failure(data, lambda d: d.update(format_version=7))) == "format_version: must be 3 (got 7)"
    tau = failure(data, lambda d: d["inputs"]["utility"].update(tau="0.05"))
    assert str(tau) == "inputs.utility.tau: must be a number >= 0, or null (got '0.05')"
    kind = failure(data, lambda d: d["inputs"]["sensitive_mechanism"].update(kind="laplace"))
    assert str(kind) == (
        "inputs.sensitive_mechanism.kind: must be one of 'identity', 'randomized_response', 'matrix' (got 'laplace')"
    )


def test_a_matrix_entry_out_of_range_is_named(certificates):
    error = failure(
        certificates["hr_office/hr_office.toml"],
        lambda d: d["inputs"]["sensitive_mechanism"]["matrix"][1].__setitem__(0, 2.0),
    )
    assert error.field == "inputs.sensitive_mechanism.matrix[1][0]" and error.value == 2.0


def test_a_value_that_is_not_an_object_is_refused():
    with pytest.raises(CertificateError, match="^certificate: must be a JSON object"):
        check_certificate([1, 2])  # type: ignore[arg-type]


def test_a_label_given_twice_is_refused(certificates):
    """The checks key their per-context and per-group tables by label: two contexts of one label would merge."""
    data = certificates["llm_hiring/gpt35.toml"]
    contexts = data["inputs"]["kernel"]["contexts"]
    twice = [contexts[0], contexts[0], *contexts[2:]]
    error = failure(data, lambda d: d["inputs"]["kernel"].update(contexts=twice))
    assert error.field == "inputs.kernel.contexts" and error.value == twice
    assert "has non-unique elements" in str(error)
