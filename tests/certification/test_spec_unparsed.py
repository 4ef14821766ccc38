"""``[decision] unparsed``: parsing, `fairaudit calibrate --spec` on the upper end, and the experiment's spec files.

The hand-made spec: two offices behind binary randomized response (keep 0.7), two documents, decisions yes
(g = 1), no (g = 0) and unparsed (stated g = 0.5, known only within [min g, max g] = [0, 1]); the model puts
0.2 or 0.3 on unparsed in every cell. The upper end of L at the calibrated ε is checked by brute force over
the vertices of the box of per-cell utilities of unparsed (``proofs/unparsed.md`` §2 and §5: the maximum over
the box is attained at a vertex; one value for all cells does not suffice).
"""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from _cli import run, run_json

from fairaudit import InputError, parse_spec
from fairaudit.certification.spec import load_spec
from fairaudit.laws.closed_forms import randomized_response
from fairaudit.laws.composition import compose
from fairaudit.laws.tables import Kernel
from fairaudit.laws.utilities import from_table
from fairaudit.metrics.fairness import local_fairness
from fairaudit.metrics.utility_range import fairness_range
from fairaudit.worstcase.calibration import calibrate

ROOT = Path(__file__).resolve().parents[2]
LOAN = ROOT / "examples" / "tasks" / "loan.toml"

DECISIONS = ["yes", "no", "unparsed"]
G = [1.0, 0.0, 0.5]
MODEL = {  # (document, office) -> P(yes, no, unparsed)
    ("maternity", "HR_1"): [0.5, 0.3, 0.2],
    ("maternity", "HR_2"): [0.3, 0.5, 0.2],
    ("holiday", "HR_1"): [0.4, 0.4, 0.2],
    ("holiday", "HR_2"): [0.4, 0.3, 0.3],
}

SPEC = """
[sensitive]
name = "office"
values = ["HR_1", "HR_2"]
[context]
name = "document"
values = ["maternity", "holiday"]
[decision]
name = "chosen"
values = ["yes", "no", "unparsed"]
{unparsed}
[privacy.sensitive]
mechanism = "randomized_response"
keep = 0.7
{model}
[utility]
kind = "table"
values = {utility}
"""


def _text(unparsed: str = 'unparsed = "unparsed"', model: bool = True, utility: str = "[1.0, 0.0, 0.5]") -> str:
    return SPEC.format(unparsed=unparsed, model='[model]\ntable = "k.csv"' if model else "", utility=utility)


def _write(tmp_path: Path, unparsed: str = 'unparsed = "unparsed"', name: str = "spec.toml") -> Path:
    rows = [(doc, off, dec, q) for (doc, off), p in MODEL.items() for dec, q in zip(DECISIONS, p, strict=True)]
    pd.DataFrame(rows, columns=["document", "office", "chosen", "probability"]).to_csv(tmp_path / "k.csv", index=False)
    path = tmp_path / name
    path.write_text(_text(unparsed))
    return path


# -- (a) parsing ---------------------------------------------------------------------------------------------


def test_unparsed_is_parsed_and_stored():
    spec = parse_spec(_text(model=False))
    assert spec.unparsed == "unparsed" and spec.decisions.index(spec.unparsed) == 2
    assert parse_spec(_text(unparsed="", model=False)).unparsed is None
    # another decision may be named; the utility is the stated one either way
    spec = parse_spec(_text(unparsed='unparsed = "no"', model=False))
    assert spec.unparsed == "no" and spec.utility.values.tolist() == G


@pytest.mark.parametrize(
    ("line", "shown"),
    [
        ('unparsed = "none of them"', "(got 'none of them')"),
        ("unparsed = 2", "(got 2)"),
        ('unparsed = ["unparsed"]', "(got ['unparsed'])"),
    ],
)
def test_unparsed_not_a_decision_is_an_error(line, shown):
    with pytest.raises(InputError) as exc:
        parse_spec(_text(unparsed=line, model=False))
    message = str(exc.value)
    assert message.startswith("<string>: decision.unparsed: must be a string naming one of decision.values ")
    assert "['yes', 'no', 'unparsed']" in message and message.endswith(shown), message


@pytest.mark.parametrize("command", [["calibrate", "--target", "0.1", "--spec"], ["certify"]])
def test_a_misspelled_unparsed_exits_2_with_one_line_and_writes_nothing(command, tmp_path, capsys):
    path = _write(tmp_path, unparsed='unparsed = "unparesd"')
    out = tmp_path / "out.json"
    code, stdout, err = run(capsys, *command, path, "--format", "json", "--output", out)
    assert code == 2 and stdout == "" and err.count("\n") == 1, err
    assert err == (
        f"fairaudit: error: {path}: decision.unparsed: must be a string naming one of decision.values "
        "['yes', 'no', 'unparsed'] (got 'unparesd')\n"
    )
    assert not out.exists()


def test_unparsed_needs_a_utility_of_the_decision_only():
    per_cell = "[[[1.0, 0.0, 0.5], [1.0, 0.0, 0.5]], [[1.0, 0.0, 0.5], [1.0, 0.0, 0.5]]]"
    assert parse_spec(_text(unparsed="", model=False, utility=per_cell)).unparsed is None
    with pytest.raises(InputError, match=r"^<string>: decision\.unparsed: needs a utility of the decision only"):
        parse_spec(_text(model=False, utility=per_cell))


def test_calibration_options_pass_the_index_for_white_box_only(tmp_path):
    spec = load_spec(_write(tmp_path))
    assert spec.calibration_options()["unparsed_decision"] == 2
    assert spec.calibration_options(method="white_box")["unparsed_decision"] == 2
    for method in ("black_box", "tight", "paper"):
        options = spec.calibration_options(method=method)
        assert options["kernel"] is None and "unparsed_decision" not in options, method
    assert "unparsed_decision" not in parse_spec(_text(model=False)).calibration_options()  # no model


# -- (b) calibrate --spec on the upper end -------------------------------------------------------------------


def _upper_end_by_vertices(epsilon: float) -> float:
    """max over every per-cell utility of unparsed in {0, 1} (the box's vertices) of L behind RR at ``epsilon``.

    Each assignment is a kernel whose unparsed mass goes to a decision of utility 0 or 1 in each cell.
    """
    docs, offices = ["maternity", "holiday"], ["HR_1", "HR_2"]
    m = randomized_response(offices, epsilon)
    g = from_table([1.0, 0.0, 0.0, 1.0], ["yes", "no", "low", "high"])
    cells = list(itertools.product(range(2), range(2)))
    worst = -math.inf
    for ends in itertools.product((0, 1), repeat=len(cells)):
        p = np.zeros((2, 2, 4))
        for (x, a), end in zip(cells, ends, strict=True):
            yes, no, unparsed = MODEL[(docs[x], offices[a])]
            p[x, a, :2] = yes, no
            p[x, a, 2 + end] = unparsed
        law = compose(Kernel(p, docs, offices, ["yes", "no", "low", "high"]), m)
        worst = max(worst, local_fairness(law, g).value)
    return worst


@pytest.mark.parametrize("target", [0.1, 0.3])
def test_calibrate_spec_is_the_upper_end(tmp_path, capsys, target):
    with_field = _write(tmp_path)
    without = _write(tmp_path, unparsed="", name="stated.toml")
    code, d, err = run_json(capsys, "calibrate", "--target", target, "--spec", with_field)
    assert code == 0 and err == "" and d["method"] == "white_box"
    assert d["unparsed"] == {"decision": "unparsed", "range": [0.0, 1.0]}
    spec = load_spec(with_field)
    options = {k: v for k, v in spec.calibration_options().items() if k != "unparsed_decision"}
    python = calibrate(target, unparsed_decision=2, **options)
    assert d["epsilon"] == python.epsilon and d["bound"] == python.bound
    code, stated, _ = run_json(capsys, "calibrate", "--target", target, "--spec", without)
    assert code == 0 and "unparsed" not in stated
    assert stated["epsilon"] == calibrate(target, **options).epsilon
    assert d["epsilon"] < stated["epsilon"] - 0.1  # the field is not ignored
    # independently: at the answer the upper end meets the target, and reaches it (the first crossing);
    # at the stated default's answer the range overturns it
    upper = _upper_end_by_vertices(d["epsilon"])
    assert upper <= target + 1e-12 and upper == pytest.approx(target, abs=1e-9)
    assert _upper_end_by_vertices(stated["epsilon"]) > target + 0.05
    r = fairness_range(
        spec.kernel(), spec.utility, 2, sensitive_mechanism=randomized_response(["HR_1", "HR_2"], d["epsilon"])
    )
    assert r.local_fairness.upper == pytest.approx(upper, abs=1e-12)


def test_calibrate_spec_text_names_the_decision_and_the_interval(tmp_path, capsys):
    code, out, err = run(capsys, "calibrate", "--target", 0.3, "--spec", _write(tmp_path))
    assert code == 0 and err == ""
    line = (
        "unparsed decision unparsed: calibrated on the upper end of L over every utility of it in [0, 1], "
        "chosen per cell of the model, not on its stated utility"
    )
    assert line in out.splitlines()
    assert "exact upper end of L over every utility of 'unparsed'" in out


def test_black_box_and_closed_forms_ignore_the_field(tmp_path, capsys):
    with_field, without = _write(tmp_path), _write(tmp_path, unparsed="", name="stated.toml")
    for method in ("black_box", "tight", "paper"):
        extra = [] if method == "black_box" else ["--tau", "0.2"]
        _, a, _ = run_json(capsys, "calibrate", "--target", 0.3, "--spec", with_field, "--method", method, *extra)
        _, b, _ = run_json(capsys, "calibrate", "--target", 0.3, "--spec", without, "--method", method, *extra)
        assert a["method"] == method and a["feasible"] and "unparsed" not in a and a == b, method


def test_certify_keeps_the_stated_default(tmp_path, capsys):
    with_field, without = _write(tmp_path), _write(tmp_path, unparsed="", name="stated.toml")
    extra = "[target]\nlocal = 0.3\n"
    for p in (with_field, without):
        p.write_text(p.read_text() + extra)
    code, a, _ = run_json(capsys, "certify", with_field)
    code_b, b, _ = run_json(capsys, "certify", without)
    assert code == code_b
    for key in ("observed", "bounds", "targets", "calibration"):
        assert a[key] == b[key], key
    _, stated, _ = run_json(capsys, "calibrate", "--target", 0.3, "--spec", without)
    assert a["calibration"]["white_box"]["epsilon"] == stated["epsilon"]  # not the upper end's


# -- (c) the experiment's spec files -------------------------------------------------------------------------


@pytest.mark.slow
def test_experiment_spec_names_the_unparsed_outcome(tmp_path, capsys):
    out = tmp_path / "loan"
    code, _, err = run(capsys, "experiment", LOAN, "--samples", "4", "--out", out, "--no-images", "--no-progress")
    assert code == 0, err
    specs = sorted(out.glob("spec-eps-*.toml"))
    assert specs
    for path in specs:
        spec = load_spec(path)
        assert spec.unparsed == "unparsed" and spec.decisions[-1] == "unparsed"
        code, d, err = run_json(capsys, "calibrate", "--target", 0.3, "--spec", path)
        assert code == 0 and err == "" and d["method"] == "white_box"
        assert d["unparsed"] == {"decision": "unparsed", "range": [0.0, 1.0]}  # loan: g = 1, 0 and 0.5
        # the simulated model never replies unparsed: the upper end is L itself, the answer the stated one
        stated = path.with_name("stated.toml")
        stated.write_text(path.read_text().replace('unparsed = "unparsed"\n', ""))
        assert load_spec(stated).unparsed is None
        _, s, _ = run_json(capsys, "calibrate", "--target", 0.3, "--spec", stated)
        assert "unparsed" not in s and s["epsilon"] == d["epsilon"]
