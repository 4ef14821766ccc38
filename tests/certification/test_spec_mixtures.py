"""``[privacy.family] mixtures``: a family whose groups are weighted mixtures of the product's rows.

Two groups, two binary components at ε each: group a is the row (0, 0) with weight 0.7 and (0, 1) with 0.3, group b
(1, 1) with 0.6 and (1, 0) with 0.4. The members, the calibrated ε and the errors are checked against numpy and
scipy's brentq here, not the package's family.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from _cli import run, run_json
from _spec_head import HEAD
from scipy.optimize import brentq

import fairaudit as fa
from fairaudit import InputError, parse_spec

MIXTURES = [[(0.7, [0, 0]), (0.3, [0, 1])], [(0.6, [1, 1]), (0.4, [1, 0])]]


def _member(t: float, mixtures=MIXTURES) -> np.ndarray:
    """The mixture of the product's rows, each component binary randomized response at t / 2."""
    p, q = 1 / (1 + math.exp(-t / 2)), 1 / (1 + math.exp(t / 2))  # (q, not 1 - p: no cancellation)
    rr = np.array([[p, q], [q, p]])
    return np.array([sum(w * np.kron(rr[r[0]], rr[r[1]]) for w, r in mix) for mix in mixtures])


def _epsilon(m: np.ndarray) -> float:
    return float(np.max(np.log(m.max(axis=0) / m.min(axis=0))))


def _scale(eps: float) -> float:
    """t with ε(member at t) = eps (ε grows without bound: a's first component is 0, b's 1)."""
    return 0.0 if eps == 0 else brentq(lambda t: _epsilon(_member(t)) - eps, 1e-9, 200.0, xtol=1e-14, rtol=1e-14)


def _toml(mixtures) -> str:
    """``mixtures`` as the TOML value of ``[privacy.family] mixtures``."""
    return (
        "["
        + ", ".join("[" + ", ".join(f"{{weight = {w}, input = {r}}}" for w, r in mix) + "]" for mix in mixtures)
        + "]"
    )


def _spec(at: float = 1.6, mixtures: str | None = None, extra: str = "") -> str:
    """The spec of the member at scale ``at`` with the family ``mixtures`` (TOML; default :data:`MIXTURES`)."""
    comp = '{mechanism = "randomized_response", values = [0, 1], epsilon = 1.0}'
    return (HEAD + "tau = 0.5\n").replace("[sensitive]\n", '[sensitive]\nvalues = ["a", "b"]\n') + (
        f'[privacy.sensitive]\nmechanism = "matrix"\noutputs = ["00", "01", "10", "11"]\n'
        f"rows = {json.dumps(_member(at).tolist())}\n"
        f"[privacy.family]\ncomponents = [{comp}, {comp}]\nmixtures = {mixtures or _toml(MIXTURES)}\n{extra}"
    )


def test_a_family_of_mixtures_is_the_mixture_of_the_products_rows():
    spec = parse_spec(_spec())
    family, m_a = spec.sensitive_family, spec.sensitive_mechanism
    assert family is not None and family.inputs == ("a", "b") and not family.mixing
    assert np.max(np.abs(family(m_a.epsilon).matrix - m_a.matrix)) <= 1e-9  # it passes through the spec's matrix
    assert m_a.epsilon == pytest.approx(_epsilon(_member(1.6)), rel=1e-12)
    for eps in (0.0, 0.3, 1.0, 4.0):
        t = _scale(eps)
        np.testing.assert_allclose(family(eps).matrix, _member(t), rtol=0, atol=1e-12)
        assert family(eps).epsilon == pytest.approx(eps, abs=1e-10)
        p = 1 / (1 + math.exp(-t / 2))
        assert family.keep_probability(eps) == pytest.approx(p * p, rel=1e-10)  # both components kept
    np.testing.assert_array_equal(family(math.inf).matrix, _member(math.inf))


def test_a_point_mass_written_as_mixtures_is_the_family_of_its_rows():
    rows = [[(1.0, [0, 0])], [(1.0, [1, 1])]]
    head = _spec(mixtures=_toml(rows))
    head = head.replace(json.dumps(_member(1.6).tolist()), json.dumps(_member(1.6, rows).tolist()))
    by_mixtures = parse_spec(head).sensitive_family
    by_inputs = parse_spec(head.replace(head[head.index("mixtures = ") :], "inputs = [[0, 0], [1, 1]]\n"))
    assert by_mixtures is not None and by_inputs.sensitive_family is not None
    for eps in (0.0, 0.7, 3.0):
        np.testing.assert_array_equal(by_mixtures(eps).matrix, by_inputs.sensitive_family(eps).matrix)
        assert by_mixtures(eps).epsilon == pytest.approx(eps, abs=1e-12)  # ε(M) = t: the closed form


def test_calibrate_moves_along_the_mixtures(tmp_path, capsys):
    path = tmp_path / "spec.toml"
    path.write_text(_spec())
    code, cal, err = run_json(capsys, "calibrate", "--spec", path, "--target", "0.5", "--method", "black_box")
    assert code == 0 and cal["feasible"], err
    utility_class = fa.UtilityClass(gamma=1.0, lower=0.0, tau=0.5)  # τ binds: the bound is not ε

    def bound(eps: float) -> float:
        member = fa.from_matrix(_member(_scale(eps)), ["a", "b"], ["00", "01", "10", "11"])
        return fa.black_box_bound(member, utility_class=utility_class).value - 0.5

    expected = brentq(bound, 0.01, 10.0, xtol=1e-14, rtol=1e-14)
    assert cal["epsilon"] == pytest.approx(expected, rel=1e-9)
    assert cal["family"] == "matrix on profile" and cal["bound"] == pytest.approx(0.5, abs=1e-9)


def test_a_certificate_along_the_mixtures_verifies(tmp_path, capsys):
    path = tmp_path / "spec.toml"
    path.write_text(_spec(extra="[target]\nlocal = 0.5\n"))
    code, cert, err = run_json(capsys, "certify", path)
    assert code in (0, 1) and cert["calibration"]["family"] == "matrix on profile", err
    (tmp_path / "cert.json").write_text(json.dumps(cert))
    code, out, err = run(capsys, "verify", tmp_path / "cert.json")
    assert code == 0 and "checked numbers hold" in out, (out, err)


@pytest.mark.parametrize(
    ("mixtures", "needle"),
    [
        (
            "[[{weight = 0.7, input = [0, 0]}, {weight = 0.4, input = [0, 1]}], [{weight = 1, input = [1, 1]}]]",
            "privacy.family.mixtures[0]: weights must sum to 1 (to 1e-9) (got [0.7, 0.4])",
        ),
        (
            "[[{weight = 1.5, input = [0, 0]}, {weight = -0.5, input = [0, 1]}], [{weight = 1, input = [1, 1]}]]",
            "privacy.family.mixtures[0][1].weight: ",
        ),
        (
            "[[{weight = 1, input = [0, 0]}], [{weight = 0.5, input = [1, 1]}, {weight = 0.5, input = [1]}]]",
            "privacy.family.mixtures[1][1].input: needs one value per component (2) (got [1])",
        ),
        (
            "[[{weight = 1, input = [0, 0]}], [{weight = 1, input = [1, 1]}]]\ninputs = [[0, 0], [1, 1]]",
            "privacy.family: give exactly one of inputs (one row per group) and mixtures (weighted rows per group)",
        ),
        (
            "[[{weight = 1, input = [0, 0]}]]",
            "privacy.family.mixtures: needs one mixture per group (2, the inputs of [privacy.sensitive]) (got 1)",
        ),
        (
            "[[{weight = 1, input = [0, 0]}], [{weight = 1, input = [0, 0]}, {weight = 0, input = [1, 1]}]]",
            "privacy.family: mixture: the inputs' mixtures stay within epsilon 0 at every scale",
        ),
    ],
)
def test_errors_are_one_line_naming_the_field(tmp_path, capsys, mixtures, needle):
    path = tmp_path / "spec.toml"
    path.write_text(_spec(mixtures=mixtures))
    with pytest.raises(InputError):
        parse_spec(path.read_text())
    code, out, err = run(capsys, "calibrate", "--spec", path, "--target", "0.5")
    assert code == 2 and out == "" and err.count("\n") == 1 and "Traceback" not in err, err
    assert needle in err, err
