"""Malformed input to the ``fairaudit`` command: one line on stderr, exit 2, no traceback, nothing written.

A table of bad inputs (and well-formed controls), each run through
``fairaudit.cli.main`` in-process, then a hypothesis property: random
mutations of a valid spec never raise out of ``main`` and exit 2 with one line.
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import os
import time

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fairaudit import InputError, parse_spec
from fairaudit.base.files import write_atomic
from fairaudit.base.labels import as_labels
from fairaudit.cli import main

# A valid spec: two offices behind binary randomized response (keep 0.7), two documents.
SPEC = """\
[sensitive]
name = "office"
values = ["HR_1", "HR_2"]
[context]
name = "document"
values = ["maternity", "holiday"]
distribution = [0.5, 0.5]
[decision]
name = "chosen"
values = ["yes", "no"]
[privacy.sensitive]
mechanism = "randomized_response"
keep = 0.7
[utility]
kind = "indicator"
decision = "yes"
tau = 0.25
"""

TABLE = "document,office,chosen,count\n" + "".join(
    f"{d},{o},{c},{n}\n" for d in ("maternity", "holiday") for o in ("HR_1", "HR_2") for c, n in (("yes", 3), ("no", 7))
)

RECORDS = "s,o,u\n" + "".join(f"{s},{o},{o}\n" for s in "ab" for o in (0, 1, 1))

PRODUCT = """
[privacy.sensitive]
mechanism = "product"
components = [
  {mechanism = "randomized_response", keep = 0.7, values = ["HR_1", "HR_2"]},
  {mechanism = "randomized_response", KEEP, values = [25]},
]
"""


def spec(*edits: tuple[str, str], add: str = "") -> str:
    """SPEC with each (old, new) replaced once (old must occur) and ``add`` appended."""
    text = SPEC
    for old, new in edits:
        assert old in text, old
        text = text.replace(old, new, 1)
    return text + add


def one_group(line: str) -> str:
    return spec(('values = ["HR_1", "HR_2"]', 'values = ["HR_1"]'), ("keep = 0.7", line))


def product(keep: str) -> str:
    text = spec(
        ('values = ["HR_1", "HR_2"]', ""), ('[privacy.sensitive]\nmechanism = "randomized_response"\nkeep = 0.7\n', "")
    )
    return text + PRODUCT.replace("KEEP", keep)


def matrix(rows: str, outputs: str = "") -> str:
    m = f'mechanism = "matrix"\nrows = {rows}\n' + (f"outputs = {outputs}\n" if outputs else "")
    return spec(('mechanism = "randomized_response"\nkeep = 0.7\n', m))


DEEP = "[" * 10_000 + "]" * 10_000
CERTIFY = ["certify", "{dir}/spec.toml", "--output", "{dir}/out.txt"]
AUDIT = ["audit", "{dir}/records.csv", "--sensitive", "s", "--outcome", "o"]

# (id, files {name: text}, argv, allowed exit statuses, text the one stderr line must contain (exit 2))
CASES: list[tuple[str, dict[str, str], list[str], set[int], str | None]] = [
    # -- controls: well-formed, they must pass --------------------------------------------------------
    ("ok", {"spec.toml": SPEC}, CERTIFY, {0}, None),
    ("ok-model-table", {"spec.toml": spec(add='[model]\ntable = "k.csv"\n'), "k.csv": TABLE}, CERTIFY, {0}, None),
    ("ok-int-numbers", {"spec.toml": spec(("keep = 0.7", "keep = 1"), ("tau = 0.25", "tau = 1"))}, CERTIFY, {0}, None),
    ("ok-tuple-label", {"spec.toml": spec(('["HR_1", "HR_2"]', '[["Tom", 25], ["Mary", 55]]'))}, CERTIFY, {0}, None),
    (
        "ok-nested-label",
        {"spec.toml": spec(('["HR_1", "HR_2"]', '[[["Tom"], 25], [["Mary"], 55]]'))},
        CERTIFY,
        {0},
        None,
    ),
    ("ok-int-and-float-labels", {"spec.toml": spec(('["HR_1", "HR_2"]', "[1, 2.5]"))}, CERTIFY, {0}, None),
    ("ok-one-group-epsilon", {"spec.toml": one_group("epsilon = 0.5")}, CERTIFY, {0}, None),
    ("ok-one-group-keep-1", {"spec.toml": one_group("keep = 1")}, CERTIFY, {0}, None),
    ("ok-product-one-value-keep-1", {"spec.toml": product("keep = 1.0")}, CERTIFY, {0}, None),
    ("ok-audit", {"records.csv": RECORDS}, [*AUDIT, "--positive", "1"], {0}, None),
    ("ok-calibrate", {}, ["calibrate", "--target", "0.5"], {0}, None),
    # -- A: strings and booleans are not numbers ------------------------------------------------------
    ("keep-string", {"spec.toml": spec(("keep = 0.7", 'keep = "0.7"'))}, CERTIFY, {2}, "privacy.sensitive.keep"),
    ("keep-bool", {"spec.toml": spec(("keep = 0.7", "keep = true"))}, CERTIFY, {2}, "privacy.sensitive.keep"),
    (
        "epsilon-string",
        {"spec.toml": spec(("keep = 0.7", 'epsilon = "1"'))},
        CERTIFY,
        {2},
        "privacy.sensitive.epsilon: must be a number, not a string (got '1')",
    ),
    ("tau-string", {"spec.toml": spec(("tau = 0.25", 'tau = "0.2"'))}, CERTIFY, {2}, "utility.tau"),
    ("gamma-bool", {"spec.toml": spec(add="gamma = true\n")}, CERTIFY, {2}, "utility.gamma"),
    ("lipschitz-string", {"spec.toml": spec(add='lipschitz = "0"\n')}, CERTIFY, {2}, "utility.lipschitz"),
    (
        "distribution-string",
        {"spec.toml": spec(("[0.5, 0.5]", '[0.5, "0.5"]'))},
        CERTIFY,
        {2},
        "context.distribution[1]: must be a number, not a string (got '0.5')",
    ),
    (
        "probabilities-string",
        {
            "spec.toml": spec(
                ("distribution = [0.5, 0.5]\n", ""),
                add='[population]\nprobabilities = [[0.25, "0.25"], [0.25, 0.25]]\n',
            )
        },
        CERTIFY,
        {2},
        "population.probabilities[0][1]",
    ),
    (
        "group-distribution-bool",
        {"spec.toml": spec(add="[population]\ngroup_distribution = [true, 0.5]\n")},
        CERTIFY,
        {2},
        "population.group_distribution[0]",
    ),
    ("rows-string", {"spec.toml": matrix('[["1", 0], [0, 1]]')}, CERTIFY, {2}, "privacy.sensitive.rows[0][0]"),
    (
        "utility-values-string",
        {"spec.toml": spec(('kind = "indicator"\ndecision = "yes"', 'kind = "table"\nvalues = [1, "0"]'))},
        CERTIFY,
        {2},
        "utility.values[1]",
    ),
    (
        "utility-values-table-bool",
        {
            "spec.toml": spec(
                ('kind = "indicator"\ndecision = "yes"', 'kind = "table"\nvalues = [[[1, 0], [1, false]]]')
            )
        },
        CERTIFY,
        {2},
        "utility.values[0][1][1]",
    ),
    ("metric-string", {"spec.toml": spec(add='metric = [[0, "1"], [1, 0]]\n')}, CERTIFY, {2}, "utility.metric[0][1]"),
    ("target-string", {"spec.toml": spec(add='[target]\nlocal = "1"\n')}, CERTIFY, {2}, "target.local"),
    ("target-bool", {"spec.toml": spec(add="[target]\nglobal = true\n")}, CERTIFY, {2}, "target.global"),
    # -- A: labels are matched by their text, so they must differ as text ---------------------------
    (
        "decision-labels-collide",
        {"spec.toml": spec(('["yes", "no"]', '[1, "1"]'), ('decision = "yes"', "decision = 1"))},
        CERTIFY,
        {2},
        "decision.values: values must be distinct as text; '1' repeats",
    ),
    (
        "sensitive-labels-collide",
        {"spec.toml": spec(('["HR_1", "HR_2"]', '[2, "2"]'))},
        CERTIFY,
        {2},
        "sensitive.values",
    ),
    (
        "context-labels-collide",
        {"spec.toml": spec(('["maternity", "holiday"]', '[["a", "b"], "a & b"]'))},
        CERTIFY,
        {2},
        "context.values: values must be distinct as text; 'a & b' repeats",
    ),
    (
        "labels-equal-values",
        {"spec.toml": spec(('["HR_1", "HR_2"]', "[1, 1.0]"))},
        CERTIFY,
        {2},
        "sensitive.values: values must be distinct; 1 and 1.0 are equal",
    ),
    (
        "component-labels-collide",
        {"spec.toml": product("keep = 0.7").replace("values = [25]", 'values = [25, "25"]')},
        CERTIFY,
        {2},
        "privacy.sensitive.components[1].values",
    ),
    (
        "matrix-outputs-collide",
        {"spec.toml": matrix("[[1, 0], [0, 1]]", '[0, "0"]')},
        CERTIFY,
        {2},
        "privacy.sensitive.outputs",
    ),
    # -- A: one group: randomized response has nothing to randomize ---------------------------------
    ("one-group-keep", {"spec.toml": one_group("keep = 0.7")}, CERTIFY, {2}, "privacy.sensitive.keep"),
    (
        "product-one-value-keep",
        {"spec.toml": product("keep = 0.7")},
        CERTIFY,
        {2},
        "privacy.sensitive.components[1].keep",
    ),
    (
        "one-context-keep",
        {
            "spec.toml": spec(add='[privacy.context]\nmechanism = "randomized_response"\nkeep = 0.6\n').replace(
                'name = "document"\nvalues = ["maternity", "holiday"]\ndistribution = [0.5, 0.5]',
                'name = "document"\nvalues = ["all"]',
            )
        },
        CERTIFY,
        {2},
        "privacy.context.keep",
    ),
    # -- B: nesting and unhashable labels -----------------------------------------------------------
    ("deep-values", {"spec.toml": spec(('["HR_1", "HR_2"]', DEEP))}, CERTIFY, {2}, "spec.toml: is too deeply nested"),
    (
        "deep-inline-table",
        {"spec.toml": spec(add="where = " + "{a = " * 2000 + "1" + "}" * 2000 + "\n")},
        CERTIFY,
        {2},
        "spec.toml: is too deeply nested",
    ),
    (
        "label-inline-table",
        {"spec.toml": spec(('["HR_1", "HR_2"]', '[{a = 1}, "x"]'))},
        CERTIFY,
        {2},
        "sensitive.values[0]",
    ),
    (
        "label-nested-too-deep",
        {"spec.toml": spec(('["HR_1", "HR_2"]', "[" + "[" * 12 + '"a"' + "]" * 12 + ', "x"]'))},
        CERTIFY,
        {2},
        "sensitive.values[0]",
    ),
    ("label-empty-list", {"spec.toml": spec(('["yes", "no"]', '[[], "no"]'))}, CERTIFY, {2}, "decision.values[0]"),
    (
        "decision-inline-table",
        {"spec.toml": spec(('decision = "yes"', "decision = {a = 1}"))},
        CERTIFY,
        {2},
        "utility.decision: a label is a string, number, boolean, date or a list of them, not an inline table",
    ),
    (
        "decision-not-a-value",
        {"spec.toml": spec(('decision = "yes"', 'decision = ["yes", "no"]'))},
        CERTIFY,
        {2},
        "utility.decision: must be one of decision.values ['yes', 'no'] (got ('yes', 'no'))",
    ),
    # -- C: messages that name the field and the value ---------------------------------------------
    (
        "tau-above-max-g",
        {"spec.toml": spec(("tau = 0.25", "tau = 2"))},
        CERTIFY,
        {2},
        "spec.toml: utility.tau: cannot exceed gamma",
    ),
    (
        "tau-above-gamma",
        {"spec.toml": spec(("tau = 0.25", "tau = 2\ngamma = 1"))},
        CERTIFY,
        {2},
        "utility.tau: cannot exceed gamma = 1",
    ),
    (
        "lower-above-gamma",
        {"spec.toml": spec(add="gamma = 1\nlower = 2\n")},
        CERTIFY,
        {2},
        "utility.lower: cannot exceed gamma = 1 (got 2.0)",
    ),
    (
        "count-inf",
        {
            "spec.toml": spec(add='[model]\ntable = "k.csv"\n'),
            "k.csv": TABLE.replace("maternity,HR_2,no,7", "maternity,HR_2,no,inf"),
        },
        CERTIFY,
        {2},
        "model.table: column 'count': must hold finite non-negative numbers; data row 4 (document='maternity', office='HR_2', "
        "chosen='no') is not (got inf)",
    ),
    (
        "probability-inf",
        {
            "spec.toml": spec(add='[model]\ntable = "k.csv"\nprobability_column = "count"\n'),
            "k.csv": TABLE.replace("holiday,HR_1,yes,3", "holiday,HR_1,yes,inf"),
        },
        CERTIFY,
        {2},
        "model.table: column 'count': must hold finite non-negative numbers; data row 5 (document='holiday', office='HR_1'",
    ),
    (
        "audit-count-inf",
        {"counts.csv": "s,o,n\na,0,1\na,1,inf\nb,0,1\nb,1,1\n"},
        ["audit", "{dir}/counts.csv", "--sensitive", "s", "--outcome", "o", "--count", "n", "--positive", "1"],
        {2},
        "column 'n': must hold finite non-negative numbers; data row 2 (s='a', o='1') is not (got inf)",
    ),
    (
        "output-directory",
        {"spec.toml": SPEC},
        ["certify", "{dir}/spec.toml", "--output", "{dir}/outdir/"],
        {2},
        "--output: is a directory (got '",
    ),
    (
        "distribution-sum",
        {"spec.toml": spec(("[0.5, 0.5]", "[0.5, 0.6]"))},
        CERTIFY,
        {2},
        "spec.toml: context.distribution: entries sum to 1.1, not 1",
    ),
    (
        "distribution-sum-with-group-distribution",  # named as context.distribution, not population
        {"spec.toml": spec(("[0.5, 0.5]", "[0.5, 0.6]"), add="[population]\ngroup_distribution = [0.5, 0.5]\n")},
        CERTIFY,
        {2},
        "spec.toml: context.distribution: entries sum to 1.1, not 1",
    ),
    (
        "distribution-length",
        {"spec.toml": spec(("[0.5, 0.5]", "[1.0]"))},
        CERTIFY,
        {2},
        "spec.toml: context.distribution: must have one entry per context (2) (got [1.0])",
    ),
    (
        "group-distribution-negative",
        {"spec.toml": spec(add="[population]\ngroup_distribution = [1.5, -0.5]\n")},
        CERTIFY,
        {2},
        "spec.toml: population.group_distribution[1]: must be a finite number >= 0 (group 'HR_2') (got -0.5)",
    ),
    (
        "probabilities-shape",
        {"spec.toml": spec(("distribution = [0.5, 0.5]\n", ""), add="[population]\nprobabilities = [[1.0]]\n")},
        CERTIFY,
        {2},
        "spec.toml: population.probabilities: must be 2 rows (contexts) of 2 entries (groups)",
    ),
    ("calibrate-groups-20000", {}, ["calibrate", "--target", "0.5", "--groups", "20000"], {0}, None),
    # -- overflow and --utility ---------------------------------------------------------------------
    ("epsilon-710", {"spec.toml": spec(("keep = 0.7", "epsilon = 710"))}, CERTIFY, {0, 1}, None),
    ("calibrate-target-710", {}, ["calibrate", "--target", "710"], {0}, None),
    ("calibrate-target-1e308", {}, ["calibrate", "--target", "1e308"], {0}, None),
    ("audit-utility-string", {"records.csv": RECORDS}, [*AUDIT, "--utility", "'abc'"], {2}, "--utility"),
    ("audit-utility-dunder", {"records.csv": RECORDS}, [*AUDIT, "--utility", "u.__class__"], {2}, "--utility"),
]


def run_main(argv: list[str]) -> tuple[int, str, str]:
    """Exit status, stdout and stderr of ``main(argv)``; an exception other than SystemExit propagates."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = main(argv)
        except SystemExit as exc:  # argparse usage errors
            code = exc.code if isinstance(exc.code, int) else 2
    return code, out.getvalue(), err.getvalue()


@pytest.mark.parametrize(("files", "argv", "statuses", "field"), [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_bad_input(tmp_path, files, argv, statuses, field):
    for name, text in files.items():
        (tmp_path / name).write_text(text)
    (tmp_path / "outdir").mkdir()
    (tmp_path / "out.txt").write_text("previous report")
    before = sorted(os.listdir(tmp_path))
    code, out, err = run_main([a.format(dir=tmp_path) for a in argv])
    assert "Traceback" not in err
    assert code in statuses, err
    if code == 2:
        assert err.startswith("fairaudit: error: ") and err.count("\n") == 1 and err.endswith("\n"), err
        assert field is not None and field in err, err
        assert out == ""
        assert (tmp_path / "out.txt").read_text() == "previous report"  # nothing half-written
        assert sorted(os.listdir(tmp_path)) == before and os.listdir(tmp_path / "outdir") == []


def test_deep_values_name_the_spec_file(tmp_path):
    (tmp_path / "deep.toml").write_text(spec(('["HR_1", "HR_2"]', DEEP)))
    code, _, err = run_main(["certify", str(tmp_path / "deep.toml")])
    assert (
        code == 2
        and err == f"fairaudit: error: {tmp_path / 'deep.toml'}: is too deeply nested (or too large) to read\n"
    )


# Labels of one list are all of one kind (lists of one length whose entries agree place by place): the field, the
# entry and its value, whatever the list (the kinds are TOML's: 1 and 2.5 are both numbers)
MIXED_LABELS = [
    (
        ('["HR_1", "HR_2"]', '[["Female"], "Male"]'),
        "sensitive.values[1]: is a string, but values[0] is a list of 1 value: all values are of one kind (got 'Male')",
    ),
    (
        ('["HR_1", "HR_2"]', '["Male", ["Female"]]'),
        "sensitive.values[1]: is a list of 1 value, but values[0] is a string: all values are of one kind "
        "(got ['Female'])",
    ),
    (
        ('["HR_1", "HR_2"]', '[25, "55"]'),
        "sensitive.values[1]: is a string, but values[0] is a number: all values are of one kind (got '55')",
    ),
    (
        ('["maternity", "holiday"]', "[true, 2]"),
        "context.values[1]: is a number, but values[0] is a boolean: all values are of one kind (got 2)",
    ),
    (
        ('["yes", "no"]', '["yes", 2024-01-01]'),
        "decision.values[1]: is a date, but values[0] is a string: all values are of one kind "
        "(got datetime.date(2024, 1, 1))",
    ),
    (
        ('["HR_1", "HR_2"]', '[["Tom", 25], ["Mary", "55"]]'),
        "sensitive.values[1][1]: is a string, but values[0][1] is a number: all values are of one kind (got '55')",
    ),
    (
        ('["HR_1", "HR_2"]', '[["Tom", 25], ["Mary"]]'),
        "sensitive.values[1]: is a list of 1 value, but values[0] is a list of 2 values: all values are of one kind "
        "(got ['Mary'])",
    ),
    (
        ('["HR_1", "HR_2"]', "[1979-05-27T07:32:00Z, 1979-05-27T07:32:00]"),
        "sensitive.values[1]: is a local date-time, but values[0] is an offset date-time: all values are of one kind "
        "(got datetime.datetime(1979, 5, 27, 7, 32))",
    ),
]


@pytest.mark.parametrize(("edit", "message"), MIXED_LABELS, ids=[m[0][1] for m in MIXED_LABELS])
def test_labels_of_mixed_kinds_are_refused(tmp_path, edit, message):
    text = spec(edit)
    with pytest.raises(InputError) as info:  # in Python
        parse_spec(text)
    assert str(info.value) == f"<string>: {message}"
    (tmp_path / "spec.toml").write_text(text)
    code, out, err = run_main(["certify", str(tmp_path / "spec.toml")])  # on the command line: one line, exit 2
    assert (code, out, err) == (2, "", f"fairaudit: error: {tmp_path / 'spec.toml'}: {message}\n")


def test_unhashable_labels_are_an_input_error():
    with pytest.raises(InputError, match=r"^groups: a label must be hashable .*not a dict \(got \{'a': 1\}\)$"):
        as_labels(["x", {"a": 1}], "groups")
    assert as_labels([["Tom", 25], ["Mary", [55, "x"]]], "groups") == (("Tom", 25), ("Mary", (55, "x")))


def test_write_atomic_removes_only_stale_temporaries_of_its_target(tmp_path):
    # A writer killed between fsync and rename leaves .NAME.XXXXXXXX.tmpSUFFIX behind; the next write removes it.
    old = time.time() - 3600
    stale = tmp_path / ".report.json.k3j_9abc.tmp.json"
    young = tmp_path / ".report.json.zzzzzzzz.tmp.json"  # another writer's, still at work
    other = tmp_path / ".other.json.k3j_9abc.tmp.json"  # another target's
    near = [
        tmp_path / ".report.json.k3j_9abcd.tmp.json",
        tmp_path / ".report.json.k3j_9abc.tmp",
        tmp_path / "report.json.k3j_9abc.tmp.json",
    ]
    for p in (stale, young, other, *near):
        p.write_bytes(b"x" * 1024)
        if p is not young:
            os.utime(p, (old, old))
    (tmp_path / "sub").mkdir()
    folder_named_like_one = tmp_path / ".report.json.abcdefgh.tmp.json"
    folder_named_like_one.mkdir()
    os.utime(folder_named_like_one, (old, old))
    write_atomic(tmp_path / "report.json", "{}")
    assert (tmp_path / "report.json").read_text() == "{}"
    assert not stale.exists()
    assert young.exists() and other.exists() and all(p.exists() for p in near) and folder_named_like_one.is_dir()


def test_certify_output_replaces_a_stale_temporary(tmp_path):
    (tmp_path / "spec.toml").write_text(SPEC)
    stale = tmp_path / ".out.json.abcdefgh.tmp.json"
    stale.write_bytes(b"\0" * (1 << 20))
    old = time.time() - 120
    os.utime(stale, (old, old))
    code, _, err = run_main(
        ["certify", str(tmp_path / "spec.toml"), "--format", "json", "--output", str(tmp_path / "out.json")]
    )
    assert code == 0, err
    assert json.loads((tmp_path / "out.json").read_text())["certified"] is True
    assert sorted(os.listdir(tmp_path)) == ["out.json", "spec.toml"]


# -- property: random malformed specs ---------------------------------------------------------------------

VALID: dict = {
    "title": "t",
    "sensitive": {"name": "office", "values": ["HR_1", "HR_2"]},
    "context": {"name": "document", "values": ["maternity", "holiday"], "distribution": [0.3, 0.7]},
    "decision": {"name": "chosen", "values": ["yes", "no"]},
    "population": {"group_distribution": [0.4, 0.6]},
    "privacy": {
        "sensitive": {"mechanism": "randomized_response", "keep": 0.7},
        "context": {"mechanism": "matrix", "rows": [[0.9, 0.1], [0.2, 0.8]]},
    },
    "model": {"table": "k.csv"},
    "utility": {"kind": "indicator", "decision": "yes", "tau": 0.2, "gamma": 1.0, "metric": [[0, 1], [1, 0]]},
    "target": {"local": 1.0, "global": 1.0},
}

_KEY = st.text(alphabet="abcdefghijklmnopqrstuvwxyz_", min_size=1, max_size=6)
_SCALAR = st.one_of(
    st.text(alphabet="abcXY01 .-&", max_size=4),
    st.booleans(),
    st.integers(min_value=-(2**64), max_value=2**64),
    st.sampled_from([10**400, -(10**400), 2**63, 0, 1, -1]),
    st.floats(allow_nan=True, allow_infinity=True),
)
_VALUE = st.recursive(
    _SCALAR,
    lambda inner: st.one_of(st.lists(inner, max_size=3), st.dictionaries(_KEY, inner, max_size=2)),
    max_leaves=6,
)


def _toml_key(k: str) -> str:
    return k if k and all(c.isalnum() or c in "_-" for c in k) else json.dumps(k)


def _toml_value(v: object) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf") if math.isinf(v) else repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_toml_key(k)} = {_toml_value(x)}" for k, x in v.items()) + "}"
    raise TypeError(type(v))


def to_toml(d: dict, prefix: tuple[str, ...] = ()) -> str:
    """A tiny TOML writer: plain values first, then each table as a [dotted.header] section."""
    lines = [f"{_toml_key(k)} = {_toml_value(v)}" for k, v in d.items() if not isinstance(v, dict)]
    text = ""
    if prefix:
        text += "[" + ".".join(_toml_key(p) for p in prefix) + "]\n"
    text += "".join(line + "\n" for line in lines)
    for k, v in d.items():
        if isinstance(v, dict):
            text += to_toml(v, (*prefix, k))
    return text


def _paths(v: object, here: tuple = ()) -> list[tuple]:
    """Every path (keys and indices) into the nested dicts and lists of ``v``."""
    out: list[tuple] = [here] if here else []
    items = v.items() if isinstance(v, dict) else enumerate(v) if isinstance(v, list) else ()
    for k, x in items:
        out += _paths(x, (*here, k))
    return out


def _parent(d: object, path: tuple) -> object:
    for p in path[:-1]:
        d = d[p]  # type: ignore[index]
    return d


@st.composite
def malformed_specs(draw) -> dict:
    d = json.loads(json.dumps(VALID))
    for _ in range(draw(st.integers(1, 3))):
        paths = _paths(d)
        if not paths:
            break
        path = draw(st.sampled_from(paths))
        parent, key = _parent(d, path), path[-1]
        kind = draw(st.sampled_from(["delete", "unknown", "replace", "duplicate", "length", "text-duplicate"]))
        if kind == "delete":
            del parent[key]
        elif kind == "unknown":
            target = parent if isinstance(parent, dict) else d
            target[draw(_KEY)] = draw(_VALUE)
        elif kind == "replace":
            parent[key] = draw(st.one_of(_VALUE, st.just([]), st.just([[[[1]]]]), st.just({})))
        elif isinstance(parent[key], list) and parent[key]:
            lst = parent[key]
            if kind == "duplicate":
                lst.append(draw(st.sampled_from(lst)))
            elif kind == "text-duplicate":
                lst.append(_toml_value(lst[0]) if not isinstance(lst[0], str) else lst[0])
            elif draw(st.booleans()):
                lst.pop()
            else:
                lst.append(lst[-1])
    return d


@pytest.fixture(scope="module")
def spec_folder(tmp_path_factory):
    folder = tmp_path_factory.mktemp("property")
    (folder / "k.csv").write_text(TABLE)
    return folder


@pytest.mark.slow
@settings(deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(d=malformed_specs())
def test_malformed_specs_exit_cleanly(spec_folder, d):
    path = spec_folder / "spec.toml"
    path.write_text(to_toml(d))
    code, out, err = run_main(["certify", str(path), "--format", "json"])  # an exception escaping main fails
    assert code in (0, 1, 2), (code, err)
    assert "Traceback" not in err
    if code == 2:
        assert err.startswith("fairaudit: error: ") and err.count("\n") == 1, err
    else:
        json.loads(out)


def test_tiny_toml_writer_round_trips():
    import tomllib

    assert tomllib.loads(to_toml(VALID)) == VALID
    odd = {"a": {"b c": [1.5, math.inf, {"x": True}], "d": {}}, "e": [[], 'q"\\']}
    assert tomllib.loads(to_toml(odd)) == odd


def test_the_command_line_names_the_flag_where_the_library_names_the_parameter():
    from fairaudit import InputError
    from fairaudit.cli import build_parser
    from fairaudit.cli._common import flag_error

    flags = build_parser().parse_args(["calibrate", "--target", "0.1"]).flags
    assert str(flag_error(InputError("confidence", "x", 2), flags)) == "confidence: x (got 2)"  # not a calibrate flag
    assert str(flag_error(InputError("kind", "must be 'local' or 'global'", "g"), flags)).startswith("--global: ")
    assert str(flag_error(InputError("groups column 'a'", "bad"), flags)) == "--groups column 'a': bad"
    audit_flags = build_parser().parse_args(["audit", "x.csv", "--sensitive", "a", "--outcome", "y"]).flags
    assert str(flag_error(InputError("confidence", "x", 2), audit_flags)) == "--confidence: x (got 2)"
    assert str(flag_error(InputError("spec.toml: privacy", "x"), audit_flags)) == "spec.toml: privacy: x"
