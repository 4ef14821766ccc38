"""`verdict_check`: every verdict a certificate states (`certified`, the best valid bound, the assumptions' statuses,
each form's `holds`, X ⊥ A, g by group, a calibration's feasibility) re-derived from its numbers: a flipped one
fails, naming its field, and is accounted for."""

from __future__ import annotations

import copy
import json
from pathlib import Path

import pytest
from _cli import OFFICE_SPEC, run

import fairaudit
from fairaudit.verification.rederive import verify

# binary randomized response keeping 0.7 (epsilon = ln(7/3) = 0.847 nats), tau = 0.25: every bound on L is at least
# 0.75 > 0.1, so the target is not met; the family calibrates to a smaller epsilon
NOT_MET = OFFICE_SPEC + "tau = 0.25\n[target]\nlocal = 0.1\n"
MET = OFFICE_SPEC + "tau = 0.25\n[target]\nlocal = 2.0\n"
# g(yes, a) = 1 for group a, 0.5 for b: g depends on the group, so the corollary's assumption is violated
BY_GROUP = (
    '[sensitive]\nname = "group"\nvalues = ["a", "b"]\n[decision]\nname = "d"\nvalues = ["yes", "no"]\n'
    '[privacy.sensitive]\nmechanism = "randomized_response"\nkeep = 0.7\n'
    '[utility]\nkind = "table"\nvalues = [[[1.0, 0.0], [0.5, 0.0]]]\ntau = 0.25\n'
)
# P(x, a) far from P(x) P(a): X and A dependent (max deviation 0.1)
DEPENDENT = (
    '[sensitive]\nname = "group"\nvalues = ["a", "b"]\n[context]\nname = "job"\nvalues = ["x", "y"]\n'
    '[decision]\nname = "chosen"\nvalues = ["yes", "no"]\n[population]\nprobabilities = [[0.1, 0.3], [0.4, 0.2]]\n'
    '[privacy.sensitive]\nmechanism = "randomized_response"\nkeep = 0.7\n[utility]\ndecision = "yes"\ntau = 0.25\n'
)


def _cert(spec: str, folder: Path) -> dict:
    path = folder / "spec.toml"
    path.write_text(spec, encoding="utf-8")
    return json.loads(json.dumps(fairaudit.certify(path).to_dict()))


@pytest.fixture(scope="module")
def certs(tmp_path_factory) -> dict[str, dict]:
    out = {}
    for name, spec in (("not met", NOT_MET), ("met", MET), ("by group", BY_GROUP), ("dependent", DEPENDENT)):
        out[name] = _cert(spec, tmp_path_factory.mktemp(name.replace(" ", "_")))
    return out


def _failing(cert: dict) -> list[str]:
    return [c.name for c in verify(cert).failures]


def test_the_certificates_hold_and_state_what_the_tests_flip(certs):
    for name, cert in certs.items():
        result = verify(cert)
        assert result.holds, (name, [c.line() for c in result.failures])
        assert [n for n, why in result.not_checked if why == "not re-derived"] == [], name
    assert certs["not met"]["certified"] is False and certs["met"]["certified"] is True
    assert certs["not met"]["targets"]["local"]["bound"] > 0.1
    assert certs["by group"]["utility"]["depends_on_group"] is True
    assert certs["dependent"]["population"]["independent"] is False
    checked = {c.name for c in verify(certs["not met"]).checks}
    assert {"certified", "bounds.best_form", "bound_details.tight.holds", "population.independent"} <= checked
    assert {"utility.depends_on_group", "calibration.feasible", "assumptions[0].status"} <= checked


@pytest.mark.parametrize(
    ("name", "path", "value", "failing"),
    [
        ("not met", ["certified"], True, ["certified"]),  # the user's report: a target not met, certified
        ("met", ["certified"], False, ["certified"]),
        ("not met", ["bounds", "best_form"], "paper", ["bounds.best_form"]),  # (paper = tight here: best is both)
        ("not met", ["bound_details", "tight", "holds"], False, ["bound_details.tight.holds"]),
        ("not met", ["utility", "depends_on_group"], True, ["utility.depends_on_group"]),
        ("not met", ["calibration", "feasible"], False, ["calibration.feasible"]),
        ("by group", ["utility", "depends_on_group"], False, ["utility.depends_on_group"]),
        ("dependent", ["population", "independent"], True, ["population.independent"]),
    ],
)
def test_a_flipped_verdict_fails_naming_its_field(certs, name, path, value, failing):
    cert = copy.deepcopy(certs[name])
    inner = cert
    for key in path[:-1]:
        inner = inner[key]
    assert inner[path[-1]] != value
    inner[path[-1]] = value
    assert _failing(cert) == failing


def test_a_flipped_assumption_status_fails(certs):
    cert = copy.deepcopy(certs["by group"])
    statuses = {a["name"]: (i, a["status"]) for i, a in enumerate(cert["assumptions"])}
    assert statuses["g independent of the group"][1] == "violated"
    assert statuses["g <= gamma"][1] == "checked" and statuses["M_A is differentially private"][1] == "checked"
    i = statuses["g independent of the group"][0]
    cert["assumptions"][i]["status"] = "checked"  # the corollary then holds: its bound would be the best
    cert["bound_details"]["corollary"]["holds"] = True
    failing = _failing(cert)  # read off the statuses as recorded, the corollary is now the best valid bound
    assert failing == [f"assumptions[{i}].status", "bounds.best_form"]
    for flipped, status in (("g <= gamma", "violated"), ("M_A is differentially private", "vouched")):
        cert = copy.deepcopy(certs["by group"])
        cert["assumptions"][statuses[flipped][0]]["status"] = status
        assert f"assumptions[{statuses[flipped][0]}].status" in _failing(cert)
    cert = copy.deepcopy(certs["dependent"])
    i = next(i for i, a in enumerate(cert["assumptions"]) if a["name"] == "X independent of A")
    assert cert["assumptions"][i]["status"] == "violated"
    cert["assumptions"][i]["status"] = "checked"
    assert _failing(cert) == [f"assumptions[{i}].status"]


def test_the_best_form_is_the_smallest_valid_bound(certs):
    # g by group: the corollary (epsilon = 0.847) is below the tight form but not valid; naming it the best fails
    cert = copy.deepcopy(certs["by group"])
    bounds = cert["bounds"]
    assert bounds["corollary"] < bounds["tight"] and bounds["best_form"] != "corollary"
    assert cert["bound_details"]["corollary"]["holds"] is False
    bounds["best_form"], bounds["best"] = "corollary", bounds["corollary"]
    assert _failing(cert) == ["bounds.best_form"]


def test_the_cli_exits_1_naming_the_flipped_verdict(capsys, tmp_path, certs):
    cert = copy.deepcopy(certs["not met"])
    cert["certified"] = True
    path = tmp_path / "cert.json"
    path.write_text(json.dumps(cert), encoding="utf-8")
    code, out, _ = run(capsys, "verify", path)
    assert code == 1
    assert "certified = True: fails (not every target is met: targets.local.bound" in out
    assert out.strip().splitlines()[-1].endswith(f": 1 of {len(verify(cert).checks)} checked numbers fail")
