"""`fairaudit verify`: exit 0 when every number holds, 1 when one fails, 2 on bad input (one line); --filter."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from _cli import OFFICE_SPEC, run, run_json

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def certificate(capsys, tmp_path) -> Path:
    spec = tmp_path / "office.toml"
    spec.write_text(OFFICE_SPEC + "tau = 0.25\n", encoding="utf-8")
    code, cert, _ = run_json(capsys, "certify", spec)
    assert code == 0
    path = tmp_path / "cert.json"
    path.write_text(json.dumps(cert), encoding="utf-8")
    return path


def test_a_certificate_that_holds_exits_0(capsys, certificate):
    code, out, err = run(capsys, "verify", certificate)
    assert code == 0 and err == ""
    assert re.search(r"^bounds\.tight = 0\.84729786038720\d\d: holds$", out, re.M)  # ln(0.7 / 0.3), its epsilon
    assert out.strip().splitlines()[-1].startswith(f"{certificate}: all ")


def test_one_number_moved_by_1e_7_exits_1_and_says_by_how_much(capsys, certificate):
    cert = json.loads(certificate.read_text())
    cert["bounds"]["paper"] += 1e-7  # the bound is 0.847...: 1e-7 relative to max(1, |value|)
    certificate.write_text(json.dumps(cert))
    code, out, _ = run(capsys, "verify", certificate)
    assert code == 1
    line = next(x for x in out.splitlines() if x.startswith("bounds.paper"))
    assert "fails by 9.9e-08" in line  # 1e-7 less the tolerance, 1e-9 (9.8999999e-8), rounded up to two digits
    # bound_details.paper.value repeats it: it no longer equals the bound, by the float sum's 9.99999999e-8
    assert "bound_details.paper.value" in out and "fails by 1e-07 (bounds.paper)" in out
    assert re.search(r": 2 of \d+ checked numbers fail$", out.strip().splitlines()[-1])


@pytest.mark.parametrize(
    ("ulps", "repeated", "bound"),
    [
        # 0.847... + 0.1: the float sum is 0.09999999999999998 from the bound; the bound's own check 0.1 less 1e-9
        (None, "fails by 0.1 (bounds.tight)", "fails by 0.1 (max over pairs, exactly)"),
        # 16 floats up (16 * 2^-53 = 1.776e-15): within the tolerance of the exact bound, but no longer its repeat
        (16, "fails by 1.8e-15 (bounds.tight)", "holds"),
    ],
)
def test_fails_by_prints_the_distance_rounded_up_to_two_digits(capsys, certificate, ulps, repeated, bound):
    cert = json.loads(certificate.read_text())
    tight = cert["bounds"]["tight"]
    if ulps is None:
        cert["bounds"]["tight"] = tight + 0.1
    else:
        cert["bounds"]["tight"] = tight + ulps * 2.0**-53  # 0.847 is in [1/2, 1): one float step is 2^-53
    certificate.write_text(json.dumps(cert))
    code, out, _ = run(capsys, "verify", certificate)
    assert code == 1 and "fails by inf" not in out
    lines = {x.split(" = ")[0]: x for x in out.splitlines() if " = " in x}
    assert lines["bound_details.tight.value"].endswith(repeated)
    assert lines["bounds.tight"].endswith(bound)


def test_json_report(capsys, certificate):
    code, report, _ = run_json(capsys, "verify", certificate)
    assert code == 0 and report["holds"] is True
    assert {c["name"] for c in report["checks"]} >= {"inputs_sha256", "bounds.paper", "bounds.tight"}


def test_the_deployed_filter(capsys, certificate, tmp_path):
    eps = json.loads(certificate.read_text())["inputs"]["sensitive_mechanism"]["epsilon"]
    data = tmp_path / "records.csv"
    data.write_text("office\nHR_1\nHR_2\n", encoding="utf-8")
    params = tmp_path / "filter.json"
    for value, want in ((eps, 0), (eps * 2, 1)):
        code, _, _ = run(capsys, "filter", data, "--column", "office", "--epsilon", value, "--values", "HR_1,HR_2",
                         "--output", tmp_path / "out.csv", "--parameters", params)  # fmt: skip
        assert code == 0
        code, out, _ = run(capsys, "verify", certificate, "--filter", params)
        assert code == want, out


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (None, "fairaudit: error: CERT.json: cannot be read"),
        ("not json", "fairaudit: error: CERT.json: is not JSON"),
        ("{}", "fairaudit: error: CERT.json format: is required"),
    ],
)
def test_bad_input_exits_2_with_one_line(capsys, tmp_path, content, message):
    path = tmp_path / "cert.json"
    if content is not None:
        path.write_text(content, encoding="utf-8")
    code, out, err = run(capsys, "verify", path)
    assert code == 2 and out == ""
    assert err.startswith(message) and len(err.strip().splitlines()) == 1


@pytest.mark.parametrize(
    ("tolerance", "message"),
    [
        (1e-3, "fairaudit: error: CERT.json tolerance: is greater than the maximum of 1e-06 (got 0.001)"),
        (None, "fairaudit: error: CERT.json tolerance: is required"),  # (None: the key removed)
    ],
)
def test_a_tolerance_beyond_the_schema_or_none_exits_2_naming_it(capsys, certificate, tolerance, message):
    cert = json.loads(certificate.read_text())
    if tolerance is None:
        del cert["tolerance"]
    else:
        cert["tolerance"] = tolerance  # not in inputs: the digest still holds, the schema refuses it
    certificate.write_text(json.dumps(cert))
    code, out, err = run(capsys, "verify", certificate)
    assert code == 2 and out == ""
    assert err.startswith(message) and len(err.strip().splitlines()) == 1


def test_a_tolerance_within_the_schema_is_the_one_judged_to(capsys, certificate):
    # tolerance 1e-7: bounds.paper (0.847...) moved up by 5e-8 holds; with the 1e-9 certify states it fails by 4.9e-8
    cert = json.loads(certificate.read_text())
    cert["bounds"]["paper"] += 5e-8
    cert["bound_details"]["paper"]["value"] = cert["bounds"]["paper"]  # its repeat, moved with it
    for tolerance, code_wanted, verdict in ((1e-7, 0, ": holds"), (1e-9, 1, ": fails by 4.9e-08")):
        cert["tolerance"] = tolerance
        certificate.write_text(json.dumps(cert))
        code, out, _ = run(capsys, "verify", certificate)
        assert code == code_wanted
        line = next(x for x in out.splitlines() if x.startswith("bounds.paper = "))
        assert verdict in line, line


def test_the_filter_a_spec_deploys_is_the_one_it_certifies(capsys, tmp_path):
    # keep = 0.7 in the spec: the certificate's epsilon covers the decimal 7/10 that `fairaudit filter --spec` deploys
    spec = tmp_path / "office.toml"
    spec.write_text(OFFICE_SPEC + "tau = 0.25\n", encoding="utf-8")
    code, cert, _ = run_json(capsys, "certify", spec)
    path = tmp_path / "cert.json"
    path.write_text(json.dumps(cert), encoding="utf-8")
    data, params = tmp_path / "records.csv", tmp_path / "filter.json"
    data.write_text("office\nHR_1\nHR_2\n", encoding="utf-8")
    code, _, _ = run(capsys, "filter", data, "--column", "office", "--spec", spec, "--output", tmp_path / "out.csv",
                     "--parameters", params)  # fmt: skip
    assert code == 0 and json.loads(params.read_text())["keep"] == "7"
    code, out, _ = run(capsys, "verify", path, "--filter", params)
    assert code == 0, out


@pytest.mark.parametrize(
    ("content", "message"),
    [
        ("[" * 10**5 + "]" * 10**5, "CERT.json: is nested deeper than 64 arrays and objects (at character 64)"),
        (
            '{"a":' * 10**6 + "1" + "}" * 10**6,
            "CERT.json: is nested deeper than 64 arrays and objects (at character 320)",
        ),
        ('{"format": NaN}', "CERT.json: holds NaN, which JSON does not allow"),
        ('{"format": Infinity}', "CERT.json: holds Infinity, which JSON does not allow"),
        ('{"format": -Infinity}', "CERT.json: holds -Infinity, which JSON does not allow"),
        ('{"format": 1e400}', "CERT.json: holds the number 1e400, beyond the largest float"),
        ('{"format": -' + "9" * 10**5 + "}", "CERT.json: holds an integer of 100000 digits, beyond the largest float"),
        (
            '{"format": "' + "[" * 10**5 + '"}',
            "CERT.json format_version: is required",
        ),  # a string's brackets
        ("[1]", "CERT.json: must be a JSON object"),
    ],
    ids=[
        "depth 1e5",
        "depth 1e6",
        "NaN",
        "Infinity",
        "-Infinity",
        "1e400",
        "1e5 digits",
        "brackets in a string",
        "list",
    ],
)
def test_malformed_json_of_any_depth_exits_2_with_one_line(capsys, tmp_path, content, message):
    path = tmp_path / "cert.json"
    path.write_text(content, encoding="utf-8")
    code, out, err = run(capsys, "verify", path)
    assert code == 2 and out == ""
    assert err.startswith(f"fairaudit: error: {message}"), err[:300]
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert str(path) in err or not message.startswith("CERT.json:")  # the whole file: named by its path


def test_a_deep_certificate_in_python_is_an_input_error():
    from fairaudit.verification.rederive import verify
    from fairaudit.verification.schema import CertificateError

    deep: dict = {}
    inner = deep
    for _ in range(10**5):
        inner["a"] = {}
        inner = inner["a"]
    with pytest.raises(CertificateError, match=r"^a(\.a){63}: is nested deeper than 64 arrays and objects$"):
        verify({"format": "fairaudit-certificate", **deep})


# the top-level keys of the certificate.json that `fairaudit experiment hr-delivery` writes (fairaudit/experiments/
# report.py, experiment_dict; docs/experiments.md "The files"): a report of the run, not a certificate
EXPERIMENT_REPORT = {
    "experiment": "hr-delivery",
    "model": "prefers-mary",
    "route": "sampled",
    "positions": "balanced",
    "samples": 1,
    "slots": 2,
    "candidates": ["Tom", "Mary"],
    "context": "document",
    "queries": {},
    "utility": {},
    "tau": 0.0,
    "confidence": 0.95,
    "baseline": {},
    "budgets": [],
    "points": [],
    "curve": {},
    "run": {"design": "table"},
}


@pytest.mark.parametrize(
    ("design", "advice"),
    [
        ("table", "certify a spec-eps-<epsilon>.toml the run wrote beside it (fairaudit certify SPEC --format json "
         "--output CERT.json) and verify that certificate"),
        ("paper", "a run of the paper's design alone writes no spec to certify (run --design table or both)"),
    ],
)  # fmt: skip
def test_an_experiment_report_is_named_with_what_to_verify(capsys, tmp_path, design, advice):
    path = tmp_path / "certificate.json"
    path.write_text(json.dumps({**EXPERIMENT_REPORT, "run": {"design": design}}), encoding="utf-8")
    code, out, err = run(capsys, "verify", path)
    assert code == 2 and out == ""
    assert err == (
        "fairaudit: error: CERT.json: is the report of fairaudit experiment (task 'hr-delivery', model 'prefers-mary'), "
        f"not a certificate: {advice} (got '{path}')\n"
    )


def test_filter_parameters_given_as_the_certificate(capsys, tmp_path):
    path = tmp_path / "filter.json"
    path.write_text(json.dumps({"format": "fairaudit-filter", "format_version": 1}), encoding="utf-8")
    code, _, err = run(capsys, "verify", path)
    assert code == 2
    assert err.startswith("fairaudit: error: CERT.json: is a filter's parameters (fairaudit filter --parameters), not "
                          "a certificate: pass it as --filter FILTER.json")  # fmt: skip


@pytest.mark.slow
def test_a_simulated_experiment_run_then_its_spec_certified_and_verified(capsys, tmp_path, monkeypatch):
    # the experiment command is a plug-in (an entry point of the installed package): added here from its module
    from fairaudit.cli import _parser
    from fairaudit.experiments.cli import experiment

    monkeypatch.setattr(_parser, "add_plugin_commands", experiment.add_parser)
    out = tmp_path / "run"
    code, _, err = run(capsys, "experiment", "hr-delivery", "--simulated", "prefers-mary", "--out", out,
                       "--samples", "1", "--keep", "0.7", "--no-images", "--no-progress")  # fmt: skip
    assert code == 0, err
    code, _, err = run(capsys, "verify", out / "certificate.json")
    assert code == 2 and "is the report of fairaudit experiment (task 'hr-delivery'" in err
    (spec,) = out.glob("spec-eps-*.toml")
    code, _, err = run(capsys, "certify", spec, "--format", "json", "--output", tmp_path / "cert.json")
    assert code == 0, err
    code, text, _ = run(capsys, "verify", tmp_path / "cert.json")
    assert code == 0, text


CALIBRATION_SPEC = OFFICE_SPEC.replace('kind = "indicator"\ndecision = "yes"', 'kind = "table"\nvalues = [1.0, 0.5]')
CALIBRATION_SPEC += "[target]\nlocal = 0.26826398659467937\n"  # (calibrated: its section records lower, gamma and tau)


@pytest.mark.parametrize("key", ["lower", "gamma", "tau", "lipschitz"])
@pytest.mark.parametrize("raw", ['"inf"', "-1.0", '"0.5"'])
def test_a_calibration_class_field_not_a_number_exits_2_naming_it(capsys, tmp_path, key, raw):
    spec = tmp_path / "cal.toml"
    spec.write_text(CALIBRATION_SPEC, encoding="utf-8")
    code, cert, _ = run_json(capsys, "certify", spec)
    assert code == 0
    cert["calibration"][key] = "<edited>"  # (not in inputs: the digest still holds, the schema refuses it)
    path = tmp_path / "cert.json"
    path.write_text(json.dumps(cert).replace('"<edited>"', raw), encoding="utf-8")
    code, out, err = run(capsys, "verify", path)
    assert code == 2 and out == ""
    assert err.startswith(f"fairaudit: error: CERT.json calibration.{key}: ") and f"(got {json.loads(raw)!r})" in err
    assert len(err.strip().splitlines()) == 1
