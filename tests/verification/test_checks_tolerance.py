"""The tolerance a certificate states (``tolerance``, 1e-9 as certify writes it) is the one `fairaudit verify` judges
its numbers to: a number within it holds, one beyond it fails by its real distance; the schema bounds it (a number
above 0, at most 1e-6) and requires it."""

from __future__ import annotations

import copy
import json
from fractions import Fraction

import pytest
from _cli import OFFICE_SPEC

from fairaudit.certification.certificate import TOLERANCE, certify
from fairaudit.certification.spec import parse_spec
from fairaudit.verification import checks
from fairaudit.verification.enclosures import Enclosure
from fairaudit.verification.rederive import verify
from fairaudit.verification.schema import CertificateError

# binary randomized response keeping 0.7, tau = 0.25: epsilon = bounds.* = ln(7/3) = 0.847..., the black box's ratio
# e^epsilon = 7/3 (above 1: its tolerance is relative), keep_probability 0.7 (a measured value: either side)
NUMBERS = [
    (("privacy", "sensitive", "epsilon"), 1),
    (("bound_details", "black_box", "ratio"), 1),
    (("privacy", "sensitive", "keep_probability"), 1),
    (("privacy", "sensitive", "keep_probability"), -1),
]


@pytest.fixture(scope="module")
def certificate() -> dict:
    return json.loads(json.dumps(certify(parse_spec(OFFICE_SPEC + "tau = 0.25\n")).to_dict()))


def _moved(cert: dict, path: tuple[str, ...], relative: float) -> tuple[dict, float]:
    """A copy of ``cert`` with the number at ``path`` moved by ``relative``·max(1, |v|), and the number's value v."""
    out = copy.deepcopy(cert)
    where = out
    for key in path[:-1]:
        where = where[key]
    value = where[path[-1]]
    where[path[-1]] = value + relative * max(1.0, abs(value))
    return out, value


def test_certify_states_its_tolerance(certificate):
    assert certificate["tolerance"] == TOLERANCE == 1e-9
    assert list(certificate)[:3] == ["format", "format_version", "tolerance"]
    assert "tolerance" not in certificate["inputs"]  # not in the digest: the data, not how the claims are judged
    assert verify(certificate).holds
    assert "tolerance" not in {name for name, _ in verify(certificate).not_checked}  # not a claim


@pytest.mark.parametrize(("path", "sign"), NUMBERS, ids=lambda x: ".".join(x) if isinstance(x, tuple) else str(x))
def test_a_number_within_the_tolerance_holds_and_one_beyond_it_fails_by_its_distance(certificate, path, sign):
    name = ".".join(path)
    within, _ = _moved(certificate, path, sign * 5e-10)
    assert verify(within).holds, [c.line() for c in verify(within).failures]
    beyond, value = _moved(certificate, path, sign * 2e-9)
    (failed,) = verify(beyond).failures
    assert failed.name == name
    # moved 2e-9·max(1, |v|): 1e-9·max(1, |v|) beyond the tolerance's end (to the float's rounding), not inf
    assert failed.fails_by == pytest.approx(1e-9 * max(1.0, abs(value)), rel=1e-5)
    assert failed.line().startswith(f"{name} = ") and " fails by " in failed.line()


def test_the_stated_tolerance_is_the_one_judged_to(certificate):
    # 1e-7 (within the schema's 1e-6): a number moved by 5e-8 relative holds, one moved by 2e-7 fails by 1e-7
    cert = copy.deepcopy(certificate)
    cert["tolerance"] = 1e-7
    within, _ = _moved(cert, ("bound_details", "black_box", "ratio"), 5e-8)
    assert verify(within).holds, [c.line() for c in verify(within).failures]
    beyond, ratio = _moved(cert, ("bound_details", "black_box", "ratio"), 2e-7)
    (failed,) = verify(beyond).failures
    assert failed.name == "bound_details.black_box.ratio"
    assert failed.fails_by == pytest.approx(1e-7 * ratio, rel=1e-5)
    # the same number against the 1e-9 certify states fails, by about 5e-8 - 1e-9 relative
    within["tolerance"] = 1e-9
    (failed,) = verify(within).failures
    assert failed.fails_by == pytest.approx(4.9e-8 * ratio, rel=1e-5)
    assert checks.tolerance() == Fraction(checks.TOLERANCE)  # verify's tolerance lasts as long as verify


@pytest.mark.parametrize(
    ("value", "message"),
    [
        (1e-3, "tolerance: is greater than the maximum of 1e-06 (got 0.001)"),
        (0.0, "tolerance: is less than or equal to the minimum of 0 (got 0.0)"),
        ("1e-9", "tolerance: is not of type 'number' (got '1e-9')"),
        (None, "tolerance: is not of type 'number' (got None)"),
    ],
)
def test_a_tolerance_beyond_the_schema_is_refused(certificate, value, message):
    cert = copy.deepcopy(certificate)
    cert["tolerance"] = value
    with pytest.raises(CertificateError) as raised:
        verify(cert)
    assert str(raised.value) == message and raised.value.field == "tolerance"


def test_a_certificate_without_a_tolerance_is_refused(certificate):
    cert = copy.deepcopy(certificate)
    del cert["tolerance"]
    with pytest.raises(CertificateError, match=r"^tolerance: is required$"):
        verify(cert)


def test_the_stated_tolerance_is_reset_however_the_block_ends():
    third = Enclosure(Fraction(1, 3), Fraction(1, 3))
    moved = 1 / 3 + 1e-8
    assert not checks.judge("x", moved, third, "upper").holds  # 1e-8 beyond 1/3: beyond the default 1e-9
    with checks.stated_tolerance(1e-7) as stated:
        assert stated == Fraction(1e-7) and checks.judge("x", moved, third, "upper").holds
    with pytest.raises(RuntimeError), checks.stated_tolerance(1e-7):
        raise RuntimeError
    assert checks.tolerance() == Fraction(1e-9) and not checks.judge("x", moved, third, "upper").holds
