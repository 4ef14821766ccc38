"""`fairaudit.verification.rederive.verify`: the shipped certificates hold; one changed number, a swapped witness, an edited
input table or a changed epsilon fails; the re-derived values against hand calculations."""

from __future__ import annotations

import copy
import hashlib
import json
import math
from fractions import Fraction
from pathlib import Path

import pytest
from _cli import OFFICE_SPEC

from fairaudit.base import json_values
from fairaudit.certification.certificate import certify
from fairaudit.certification.spec import parse_spec
from fairaudit.filter.filters import PrivacyFilter
from fairaudit.verification.enclosures import RecordedMechanism
from fairaudit.verification.rederive import _filter_check, canonical_digest, verify
from fairaudit.verification.schema import CertificateError

ROOT = Path(__file__).resolve().parents[2]
SHIPPED = ["examples/llm_hiring/gpt35.toml", "examples/llm_hiring/gpt4.toml", "examples/hr_office/hr_office.toml"]

OFFICE = OFFICE_SPEC + "tau = 0.25\n"  # binary randomized response keeping 0.7, g = 1{yes}

MATRIX = """
[sensitive]
name = "group"
values = ["a", "b", "c"]
[context]
name = "job"
values = ["x", "y"]
[decision]
name = "chosen"
values = ["yes", "no"]
[privacy.sensitive]
mechanism = "matrix"
rows = [[0.5, 0.25, 0.25], [0.25, 0.5, 0.25], [0.125, 0.375, 0.5]]
[utility]
decision = "yes"
tau = 0.1
[model]
table = "table.csv"
[target]
local = 1.0
"""


TABLE = """job,group,chosen,probability
x,a,yes,0.9
x,a,no,0.1
x,b,yes,0.4
x,b,no,0.6
x,c,yes,0.2
x,c,no,0.8
y,a,yes,0.5
y,a,no,0.5
y,b,yes,0.7
y,b,no,0.3
y,c,yes,0.3
y,c,no,0.7
"""


def _cert(text_or_path: str, folder: Path | None = None) -> dict:
    if "\n" not in text_or_path:
        spec = str(ROOT / text_or_path)
    elif folder is None:
        spec = parse_spec(text_or_path)
    else:
        (folder / "table.csv").write_text(TABLE, encoding="utf-8")
        (folder / "spec.toml").write_text(text_or_path, encoding="utf-8")
        spec = str(folder / "spec.toml")
    return json.loads(json.dumps(certify(spec).to_dict()))  # as a file holds it


@pytest.fixture(scope="module")
def certificates(tmp_path_factory) -> dict[str, dict]:
    out = {name: _cert(name) for name in [*SHIPPED, OFFICE]}
    out[MATRIX] = _cert(MATRIX, tmp_path_factory.mktemp("matrix"))
    return out


def _failing(cert: dict) -> list[str]:
    return [c.name for c in verify(cert).failures]


@pytest.mark.slow
def test_every_shipped_certificate_holds(certificates):
    for name, cert in certificates.items():
        result = verify(cert)
        assert result.holds, (name[:40], [c.line() for c in result.failures])
        assert len(result.checks) >= 7
        assert result.lines()[-1].endswith(f"all {len(result.checks)} checked numbers hold")


def test_the_tight_bound_is_re_derived_by_hand():
    # binary randomized response keeping 0.7, tau = 0.25, g = 1{yes}: min(1 + 0.4/0.25, e^eps = 7/3), so ln(7/3) = eps
    cert = _cert(OFFICE)
    eps = cert["inputs"]["sensitive_mechanism"]["epsilon"]
    assert eps == pytest.approx(math.log(7 / 3), rel=1e-15)
    tight = next(c for c in verify(cert).checks if c.name == "bounds.tight")
    assert tight.derived_low == tight.derived_high == eps == cert["bounds"]["tight"]


def test_the_matrix_tight_bound_is_re_derived_by_hand(certificates):
    # tau = 0.1, L_A = 0, gamma = 1: per pair, min over t >= 1 of t + 10 δ_aa'(t), at t = 1 or a ratio >= 1
    rows = [[Fraction(2, 4), Fraction(1, 4), Fraction(1, 4)], [Fraction(1, 4), Fraction(2, 4), Fraction(1, 4)],
            [Fraction(1, 8), Fraction(3, 8), Fraction(4, 8)]]  # fmt: skip

    def pair_min(a, b):
        ts = {Fraction(1)} | {x / y for x, y in zip(rows[a], rows[b]) if x >= y}
        return min(t + 10 * sum(max(Fraction(0), x - t * y) for x, y in zip(rows[a], rows[b])) for t in ts)

    want = max(pair_min(a, b) for a in range(3) for b in range(3) if a != b)
    tight = next(c for c in verify(certificates[MATRIX]).checks if c.name == "bounds.tight")
    assert tight.derived_low <= math.log(want) <= tight.derived_high
    assert certificates[MATRIX]["bounds"]["tight"] >= math.log(want)


NUMBERS = [
    ("privacy", "sensitive", "epsilon"),
    ("bounds", "paper"),
    ("bounds", "tight"),
    ("bounds", "corollary"),
    ("observed", "local", "value"),
    ("observed", "global", "value"),
]


@pytest.mark.parametrize("path", NUMBERS, ids=".".join)
@pytest.mark.parametrize("name", [SHIPPED[0], MATRIX], ids=["gpt35", "matrix"])
def test_one_number_changed_by_1e_7_fails(certificates, name, path):
    # 1e-7 relative: clearly beyond the certificate's tolerance, 1e-9
    cert = copy.deepcopy(certificates[name])
    where = cert
    for key in path[:-1]:
        where = where[key]
    where[path[-1]] += 1e-7 * max(1.0, abs(where[path[-1]]))
    failing = _failing(cert)
    assert ".".join(path) in failing or any(f.startswith(".".join(path[:2])) for f in failing), failing


def test_a_number_lowered_below_its_exact_value_fails(certificates):
    cert = copy.deepcopy(certificates[MATRIX])
    cert["bounds"]["tight"] = math.nextafter(cert["bounds"]["tight"], 0) - 1e-15
    assert "bounds.tight" in _failing(cert)


@pytest.mark.parametrize(
    "path", [("bounds", "tight"), ("bounds", "black_box"), ("bound_details", "black_box", "value")]
)
def test_a_finite_bound_replaced_by_inf_fails(certificates, path):
    # +inf bounds everything, but it is not the number re-derived (verify passed it before)
    cert = copy.deepcopy(certificates[MATRIX])
    where = cert
    for key in path[:-1]:
        where = where[key]
    assert where[path[-1]] not in (None, "inf")
    where[path[-1]] = "inf"
    assert ".".join(path) in _failing(cert)


def test_a_swapped_witness_fails(certificates):
    cert = copy.deepcopy(certificates[MATRIX])
    local = cert["observed"]["local"]
    local["group"], local["other_group"] = local["other_group"], local["group"]
    assert _failing(cert) == ["observed.local (its context and groups)"]
    cert = copy.deepcopy(certificates[MATRIX])
    cert["observed"]["local"]["context"] = "y" if cert["observed"]["local"]["context"] == "x" else "x"
    assert _failing(cert) == ["observed.local (its context and groups)"]


def test_the_black_box_names_a_pair_that_reaches_its_worst_case(certificates):
    cert = copy.deepcopy(certificates[MATRIX])
    detail = cert["bound_details"]["black_box"]
    names = {c.name: c for c in verify(cert).checks}
    assert names["bound_details.black_box (its context and groups)"].holds
    assert names["bound_details.black_box.global (its groups)"].holds
    # rows a and c of the matrix: the worst ratio of a over c is not the worst of c over a (M is not symmetric)
    detail["group"], detail["other_group"] = detail["other_group"], detail["group"]
    assert "bound_details.black_box (its context and groups)" in _failing(cert)
    cert = copy.deepcopy(certificates[MATRIX])
    cert["bound_details"]["black_box"]["global"]["group"] = "nobody"
    assert _failing(cert) == ["bound_details.black_box.global (its groups)"]


def test_an_edited_input_table_fails(certificates):
    cert = copy.deepcopy(certificates[MATRIX])
    cell = cert["inputs"]["kernel"]["probabilities"][0][0]
    cell[0], cell[1] = cell[0] - 0.05, cell[1] + 0.05
    failing = _failing(cert)
    assert "inputs_sha256" in failing and "observed.local.value" in failing


def test_a_changed_epsilon_fails(certificates):
    cert = copy.deepcopy(certificates[OFFICE])
    cert["privacy"]["sensitive"]["epsilon"] = 0.9
    assert _failing(cert) == ["privacy.sensitive.epsilon"]
    cert = copy.deepcopy(certificates[SHIPPED[0]])
    cert["inputs"]["sensitive_mechanism"]["epsilon"] = 0.6  # the mechanism itself: hash and every bound
    failing = _failing(cert)
    assert {"inputs_sha256", "privacy.sensitive.epsilon", "bounds.tight", "bounds.corollary"} <= set(failing)


def test_a_target_verdict_must_follow_from_the_numbers(certificates):
    cert = copy.deepcopy(certificates[MATRIX])
    cert["targets"]["local"]["met"] = not cert["targets"]["local"]["met"]
    assert _failing(cert) == ["targets.local.met"]


def test_the_deployed_filter_is_checked_against_the_certificate(certificates):
    cert = certificates[OFFICE]
    eps = cert["inputs"]["sensitive_mechanism"]["epsilon"]
    same = PrivacyFilter.randomized_response(["HR_1", "HR_2"], epsilon=eps)
    assert verify(cert, privacy_filter=same).holds
    stronger = PrivacyFilter.randomized_response(["HR_1", "HR_2"], epsilon=eps / 2)
    assert verify(cert, privacy_filter=stronger).holds  # a garbling: every bound still holds
    weaker = PrivacyFilter.randomized_response(["HR_1", "HR_2"], epsilon=eps + 1e-9)
    assert [c.name for c in verify(cert, privacy_filter=weaker).failures] == ["filter"]
    other = PrivacyFilter.randomized_response(["HR_1", "HR_3"], epsilon=eps)
    assert [c.name for c in verify(cert, privacy_filter=other).failures] == ["filter"]
    matrix = certificates[MATRIX]
    rows = matrix["inputs"]["sensitive_mechanism"]["matrix"]
    assert verify(matrix, privacy_filter=PrivacyFilter.from_matrix(rows, ["a", "b", "c"])).holds
    nearby = [[0.5, 0.25, 0.25], [0.25, 0.5, 0.25], [0.125, 0.4375, 0.4375]]
    assert not verify(matrix, privacy_filter=PrivacyFilter.from_matrix(nearby, ["a", "b", "c"])).holds


def test_the_digest_is_the_one_certify_records(certificates):
    # verification's own canonical JSON and SHA-256 against certify's (fairaudit.base.json_values) and the recorded one
    for cert in certificates.values():
        assert canonical_digest(cert["inputs"]) == json_values.canonical_digest(cert["inputs"]) == cert["inputs_sha256"]
    value = {"é": [0.1, 1e-300, 2, None, True], "a": {"z": "inf", "b": -0.0}}
    assert canonical_digest(value) == json_values.canonical_digest(value)
    assert (
        canonical_digest(value)
        == hashlib.sha256('{"a":{"b":-0.0,"z":"inf"},"é":[0.1,1e-300,2,null,true]}'.encode()).hexdigest()
    )


def test_the_filter_is_read_from_its_parameters(certificates):
    # verify reads the parameters `fairaudit filter --parameters` writes itself: the same verdict from the dictionary
    # as from the PrivacyFilter; e^epsilon = keep/move exactly (7/3 = the certificate's, 3/1 beyond it)
    cert = certificates[OFFICE]
    same = PrivacyFilter.randomized_response(["HR_1", "HR_2"], keep="7/10").to_dict()
    assert (same["keep"], same["move"]) == ("7", "3") and verify(cert, privacy_filter=same).holds
    weaker = {**same, "keep": "3", "move": "1", "denominator": "4"}
    assert [c.name for c in verify(cert, privacy_filter=weaker).failures] == ["filter"]
    with pytest.raises(
        CertificateError, match=r"^privacy_filter: must have rows .* summing to its denominator \(got 5\)$"
    ):
        verify(cert, privacy_filter={**same, "denominator": "5"})  # 7 + 3 is not 5
    with pytest.raises(CertificateError, match=r"^privacy_filter: is not a filter's parameters .*KeyError\('keep'\)$"):
        verify(cert, privacy_filter={k: v for k, v in same.items() if k != "keep"})


def test_a_product_filter_is_its_components_kronecker_rows():
    # randomized response keeping 3/4 on (a, b) times keeping 1/2 on (0, 1): rows over 8, labels "a & 0", ...
    f = PrivacyFilter.product(
        *(PrivacyFilter.randomized_response(v, keep=k) for v, k in ((["a", "b"], "3/4"), ([0, 1], "1/2")))
    )
    labels = ("a & 0", "a & 1", "b & 0", "b & 1")
    rows = [[3, 3, 1, 1], [3, 3, 1, 1], [1, 1, 3, 3], [1, 1, 3, 3]]  # (3/4, 1/4) x (1/2, 1/2), by hand
    certified = RecordedMechanism("matrix", labels, labels, rows=tuple(tuple(Fraction(n, 8) for n in r) for r in rows))
    assert _filter_check(certified, f.to_dict()).holds
    rows[0] = [4, 2, 1, 1]
    other = RecordedMechanism("matrix", labels, labels, rows=tuple(tuple(Fraction(n, 8) for n in r) for r in rows))
    assert not _filter_check(other, f.to_dict()).holds
    assert not _filter_check(RecordedMechanism("matrix", labels[::-1], labels, rows=certified.rows), f.to_dict()).holds


def test_what_is_not_re_derived_is_listed(certificates):
    listed = dict(verify(certificates[SHIPPED[0]]).not_checked)
    assert listed["observed.intervals"] == "statistical intervals are estimates, not certified numbers"
    assert listed["programs_solved"] == "a count of the programs solved, not a certified number"
    assert "bound_details.black_box.worst_model" in listed and "population.records" in listed
    assert [n for n, why in listed.items() if why == "not re-derived"] == []  # every other number is re-derived
    cert = copy.deepcopy(certificates[SHIPPED[0]])
    del cert["inputs"]["calibration"]  # a certificate without the calibrated member (the digest then fails too)
    assert ("calibration", "the certificate records no calibrated mechanism") in verify(cert).not_checked


@pytest.mark.slow
@pytest.mark.parametrize("name", [SHIPPED[0], SHIPPED[2], MATRIX], ids=["gpt35", "hr_office", "matrix"])
def test_the_black_box_is_re_derived_and_a_moved_one_fails(certificates, name):
    cert = copy.deepcopy(certificates[name])
    names = [c.name for c in verify(cert).checks]
    assert "bounds.black_box" in names and "bound_details.black_box.global.value" in names
    moved = cert["bounds"]["black_box"] + 1e-7 * max(1.0, cert["bounds"]["black_box"])  # beyond the tolerance, 1e-9
    cert["bounds"]["black_box"] = cert["bound_details"]["black_box"]["value"] = moved
    assert "bounds.black_box" in _failing(cert)
    cert = copy.deepcopy(certificates[name])
    cert["bound_details"]["black_box"]["global"]["value"] -= 1e-9  # below: an upper bound has no tolerance there
    assert "bound_details.black_box.global.value" in _failing(cert)


def test_a_certificate_that_is_not_one_is_refused(certificates):
    cert = copy.deepcopy(certificates[OFFICE])
    del cert["inputs"]
    with pytest.raises(CertificateError):
        verify(cert)


def test_a_kernel_with_an_empty_cell_no_group_reaches_verifies():
    # a released group no group reaches (the matrix's third column is 0): its cell has no records, and certify writes
    # its row as nulls; the schema reads it, the distribution check sets it aside, every number holds
    spec = parse_spec("""
[sensitive]
name = "office"
values = ["HR_1", "HR_2"]
[decision]
name = "chosen"
values = ["yes", "no"]
[privacy.sensitive]
mechanism = "matrix"
outputs = ["HR_1", "HR_2", "other"]
rows = [[0.75, 0.25, 0.0], [0.25, 0.75, 0.0]]
[utility]
decision = "yes"
tau = 0.25
""")
    from fairaudit.laws.tables import Kernel

    labels = (spec.context_mechanism.outputs, spec.sensitive_mechanism.outputs, spec.decisions)
    spec._kernel = Kernel.from_counts([[[3, 1], [1, 1], [0, 0]]], *labels)  # (no spec file leaves a cell empty)
    cert = json.loads(json.dumps(certify(spec).to_dict()))
    assert cert["inputs"]["kernel"]["probabilities"] == [[[0.75, 0.25], [0.5, 0.5], [None, None]]]
    result = verify(cert)
    assert result.holds, [c.line() for c in result.failures]
    row_check = next(c for c in result.checks if c.name == "inputs.kernel.probabilities")
    assert row_check.holds
    cert["inputs"]["kernel"]["probabilities"][0][2] = [None, 0.5]  # a row half empty is no empty cell
    with pytest.raises(CertificateError, match=r"inputs\.kernel\.probabilities\[0\]\[2\]"):
        verify(cert)
