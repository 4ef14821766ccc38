"""The ``--utility`` expression language: values by hand, a corpus of escape attempts, the CLI, a property."""

from __future__ import annotations

import ast
import math
import string
import time

import numpy as np
import pandas as pd
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fairaudit.base.errors import InputError
from fairaudit.cli import main
from fairaudit.laws.utility_expression import MAX_DEPTH, MAX_LENGTH, evaluate_utility_expression
from fairaudit.statistics.record_audit import utility_from_expression

NUMBERS = [1, 2, 3, 4, 5, 10]

# -- values fixed by hand ------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "expression, values, expected",
    [
        ("u >= 5", [1, 4, 5, 10], [0, 0, 1, 1]),
        ("11 - u", [1, 10], [10, 1]),
        ("u in [1, 3]", NUMBERS, [1, 0, 1, 0, 0, 0]),
        ("u not in (1, 3)", NUMBERS, [0, 1, 0, 1, 1, 1]),
        ("not (u < 2) and u != 4", NUMBERS, [0, 1, 1, 0, 1, 1]),
        ("u < 2 or u == 10", NUMBERS, [1, 0, 0, 0, 0, 1]),
        ("min(u, 3)", NUMBERS, [1, 2, 3, 3, 3, 3]),
        ("max(u, 3, 4)", NUMBERS, [4, 4, 4, 4, 5, 10]),
        ("abs(u - 5)", NUMBERS, [4, 3, 2, 1, 0, 5]),
        ("1 < u <= 3", NUMBERS, [0, 1, 1, 0, 0, 0]),
        ("u if u > 3 else 0", NUMBERS, [0, 0, 0, 4, 5, 10]),
        ("u ** 2 / 4 + u // 3 + u % 3", [1, 2, 3], [0.25 + 0 + 1, 1 + 0 + 2, 2.25 + 1 + 0]),
        ("-u + 10", [1, 10], [9, 0]),
        ("+u", [2.5], [2.5]),
        ("(u > 2) + (u > 4)", NUMBERS, [0, 0, 1, 1, 2, 2]),
        ("True", [1, 2], [1, 1]),
        ("u > 100", [1, 2], [0, 0]),
        ("1e-3 * u", [1000], [1]),
        ('u == "high"', ["low", "medium", "high"], [0, 0, 1]),
        ('u in ["high", "medium"]', ["low", "medium", "high"], [0, 1, 1]),
        ("u != 'low' and u < 'm'", ["low", "medium", "high"], [0, 0, 1]),
        ("u", [True, False], [1, 0]),
        ("u == 1", ["1", "2"], [1, 0]),  # every value parses as a number: u is numeric
    ],
)
def test_values_by_hand(expression, values, expected):
    assert evaluate_utility_expression(expression, values).tolist() == pytest.approx(expected)
    assert utility_from_expression(expression, values).values.tolist() == pytest.approx(expected)


def test_log_and_exp_against_math():
    values = [0.5, 1, 2, 10]
    assert evaluate_utility_expression("log(u)", values).tolist() == [math.log(v) for v in values]
    assert evaluate_utility_expression("exp(u)", values).tolist() == [math.exp(v) for v in values]
    assert evaluate_utility_expression("exp(-u) * log(u + 1)", [3]).tolist() == [math.exp(-3) * math.log(4)]


def test_booleans_become_zero_one():
    out = evaluate_utility_expression("u >= 5", [1, 4, 5, 10])
    assert out.dtype == np.float64 and out.tolist() == [0.0, 0.0, 1.0, 1.0]


@pytest.mark.parametrize(
    "expression, values, words",
    [
        ("log(u - 1)", [1, 2], "log of a non-positive number (0) (at u = 1)"),
        ("u / (u - 2)", [2, 3], "division by zero in 2 / 0 (at u = 2)"),
        ("u % 0", [1], "division by zero"),
        ("exp(1000)", [1], "exp(1000) is too large"),
        ("(-8) ** (1 / 3)", [1], "(-8) ** 0.3333333333333333 has no real value"),
        ("0 ** -1", [1], "has no real value"),
        ("u + 1", ["a", "b"], "'+' needs numbers; got text 'a' (at u = a)"),
        ("u == 1", ["a", "b"], "compares text 'a' with 1; text compares only with text"),
        ("u == 'a'", [1, 2], "compares 1 with text 'a'"),
        ("u in ['a', 1]", ["a", "b"], "'in' looks for text 'a' among 1"),
        ("u", ["a", "b"], "gives text 'a', not a number, at u = a"),
        ("u - 5", [1, 10], "must be finite and non-negative; it is not at u = 1"),
        ("1e308 * 10", [1], "must be finite and non-negative"),
        ("abs(u, 1)", [1], "abs() takes 1 argument, got 2"),
        ("min(u)", [1], "min() takes 2 to 32 arguments, got 1"),
    ],
)
def test_value_errors_name_the_problem(expression, values, words):
    with pytest.raises(InputError) as info:
        utility_from_expression(expression, values)
    assert info.value.field == "utility" and info.value.value == expression
    assert words in str(info.value)


# -- escape attempts -----------------------------------------------------------------------------------------------

# MARKER is replaced by the path of a file that must not exist afterwards
ESCAPES = [
    ("u.__init__.__globals__['sys'].modules['os'].system('touch MARKER')", "attribute access '.__init__'"),
    ("u.to_csv('MARKER')", "attribute access '.to_csv'"),
    ("__import__('os').system('touch MARKER')", "call of '__import__'"),
    ("open('MARKER', 'w')", "call of 'open'"),
    ("open('MARKER', 'w').write('x')", "call of 'open'"),
    ("eval(\"open('MARKER', 'w')\")", "call of 'eval'"),
    ("exec(\"open('MARKER', 'w')\")", "call of 'exec'"),
    ("compile('1', 'MARKER', 'eval')", "call of 'compile'"),
    ("getattr(u, 'to_csv')('MARKER')", "call of 'getattr'"),
    ("(lambda: open('MARKER', 'w'))()", "lambda"),
    ("[x for x in ().__class__.__base__.__subclasses__()]", "comprehension"),
    ("{x: 1 for x in 'MARKER'}", "comprehension"),
    ("(x for x in [1])", "generator expression"),
    ("u[0]", "subscript 'u[0]'"),
    ("'MARKER'[0]", "subscript"),
    ("().__class__", "attribute access '.__class__'"),
    ("''.join", "attribute access '.join'"),
    ("(1).real", "attribute access '.real'"),
    ("min(u, 2).__class__", "attribute access '.__class__'"),
    ("globals()", "call of 'globals'"),
    ("locals()", "call of 'locals'"),
    ("vars()", "call of 'vars'"),
    ("breakpoint()", "call of 'breakpoint'"),
    ("print('MARKER')", "call of 'print'"),
    ("u()", "call of 'u'"),
    ("min(u, 2)(3)", "call of 'min(u, 2)'"),
    ("min(u, key=open)", "keyword argument"),
    ("min(*[u, 1])", "unpacking"),
    ("min", "function 'min' without a call"),
    ("os", "name 'os'"),
    ("__builtins__", "name '__builtins__'"),
    ("f'{u}'", "f-string"),
    ('f\'{open("MARKER", "w")}\'', "f-string"),
    ("(x := 1)", "assignment ':='"),
    ("import os", "a statement (import)"),
    ("x = 1", "a statement (assign)"),
    ("u; open('MARKER', 'w')", "not a valid expression"),
    ("9**9**9**9", "9 ** 387420489 is too large"),
    ("10**10**10", "is too large"),
    ("2**100000", "2 ** 100000 is too large"),
    ("u ** 10 ** 6", "is too large"),
    ("'a' * 10**9", "text 'a' outside a comparison"),
    ("[1] * 10**9", "list or tuple [1] outside 'in [...]'"),
    ("(1,) * 10**9", "outside 'in [...]'"),
    ("u in [1] * 10**9", "outside 'in [...]'"),
    ("u if 1 else __import__('os').system('touch MARKER')", "call of '__import__'"),
    ("u or open('MARKER', 'w')", "call of 'open'"),
    ("{1: 2}", "dict literal"),
    ("u in {1, 2}", "set literal"),
    ("u is 1", "operator 'is'"),
    ("u & 1", "operator '&'"),
    ("u << 100000", "operator '<<'"),
    ("~u", "operator '~'"),
    ("u @ u", "operator '@'"),
    ("None", "literal None"),
    ("1j", "literal 1j"),
    ("b'MARKER'", "literal b"),
    ("...", "literal ..."),
    ("await u", "await"),
    ("(yield)", "yield"),
    ("'abc'", "text 'abc' outside a comparison"),
    ("", "is empty"),
    ("   ", "is empty"),
    ("u >=", "not a valid expression"),
    ("u\x00", "not a valid expression"),
    ("u" * 100_000, "is too long (100000 characters"),
    ("(" * 1000 + "u" + ")" * 1000, "is too long"),
    ("(" * 400 + "u" + ")" * 400, "not a valid expression (too many nested parentheses)"),
    ("-" * 1500 + "u", f"nested too deeply (more than {MAX_DEPTH} levels)"),
    ("not " * 400 + "u", "nested too deeply"),
    ("u" + "+u" * 900, "nested too deeply"),
    ("abs(" * 150 + "u" + ")" * 150, "nested too deeply"),
]


@pytest.mark.parametrize("template, words", ESCAPES, ids=[f"{i}: {t[:40]}" for i, (t, _) in enumerate(ESCAPES)])
def test_escape_attempts_are_refused(template, words, tmp_path):
    marker = tmp_path / "marker"
    expression = template.replace("MARKER", str(marker))
    start = time.monotonic()
    with pytest.raises(InputError) as info:
        utility_from_expression(expression, [1, 2, 5])
    assert time.monotonic() - start < 1.0
    assert info.value.field == "utility" and info.value.value == expression
    assert words in str(info.value)
    assert "\n" not in str(info.value)
    assert not marker.exists() and list(tmp_path.iterdir()) == []


def test_escape_corpus_is_large():
    assert len(ESCAPES) >= 25
    assert MAX_LENGTH < 100_000


@pytest.mark.parametrize("error", [RecursionError, MemoryError])
def test_parser_limits_become_input_errors(error, monkeypatch):
    def boom(*args, **kwargs):
        raise error()

    monkeypatch.setattr(ast, "parse", boom)
    with pytest.raises(InputError, match="nested too deeply or too complex to parse"):
        evaluate_utility_expression("u", [1])


def test_text_and_numbers_follow_the_values():
    # one value that is not a number makes u text for every value
    with pytest.raises(InputError, match="compares text '1' with 1"):
        evaluate_utility_expression("u == 1", [1, "x"])
    assert evaluate_utility_expression("u == '1'", [1, "x"]).tolist() == [1.0, 0.0]


# -- the command line ----------------------------------------------------------------------------------------------


@pytest.fixture
def tiny_csv(tmp_path):
    path = tmp_path / "data" / "tiny.csv"
    path.parent.mkdir()
    pd.DataFrame({"grp": list("aabb"), "score": [1, 5, 2, 10]}).to_csv(path, index=False)
    return path


@pytest.mark.parametrize(
    "template",
    [
        "u.__init__.__globals__['sys'].modules['os'].system('touch MARKER')",
        "u.to_csv('MARKER')",
        "9**9**9**9",
    ],
)
def test_cli_refuses_an_escape_in_one_line(template, tiny_csv, tmp_path, capsys):
    marker = tmp_path / "marker"
    expression = template.replace("MARKER", str(marker))
    start = time.monotonic()
    code = main(["audit", str(tiny_csv), "--sensitive", "grp", "--outcome", "score", "--utility", expression])
    out, err = capsys.readouterr()
    assert time.monotonic() - start < 5.0
    assert code == 2 and out == ""
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("fairaudit: error: --utility:")
    assert "Traceback" not in err
    assert not marker.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["data"]
    assert [p.name for p in tiny_csv.parent.iterdir()] == ["tiny.csv"]


def test_cli_accepts_the_language(tiny_csv, capsys):
    code = main(["audit", str(tiny_csv), "--sensitive", "grp", "--outcome", "score", "--utility", "u in [5, 10]"])
    out, err = capsys.readouterr()
    assert code == 0 and "1{" not in err
    assert "u in [5, 10]" in out


# -- property: InputError or a finite non-negative number, never anything else, never slow ------------------------

TOKENS = [
    "u", "u", "u", ".", "(", ")", "[", "]", "{", "}", "__", "_", "class", "os", "import", ",", ":", "=", ":=",
    "0", "1", "2", "5", "9", "10", "1e308", "0.5", "-", "+", "*", "**", "/", "//", "%", "<", "<=", ">", ">=",
    "==", "!=", "and", "or", "not", "in", "is", "if", "else", "lambda", "for", "min", "max", "abs", "log", "exp",
    "'a'", '"high"', "f'", "'", "~", "&", "@", "None", "True", "open", "__import__", "__class__", "x",
]  # fmt: skip


def _check(expression, values):
    start = time.monotonic()
    try:
        g = utility_from_expression(expression, values)
    except InputError as exc:
        assert exc.field == "utility"
        assert "\n" not in str(exc)
    else:
        assert g.values.shape == (len(values),)
        assert np.all(np.isfinite(g.values)) and np.all(g.values >= 0)
    assert time.monotonic() - start < 1.0


@given(st.text(alphabet=string.printable, max_size=60), st.sampled_from([[1, 2, 5, 10], ["low", "high"], [0.5]]))
def test_random_text_is_a_number_or_an_input_error(expression, values):
    _check(expression, values)


@given(
    st.lists(st.sampled_from(TOKENS), min_size=1, max_size=25),
    st.sampled_from(["", " "]),
    st.sampled_from([[1, 2, 5, 10], ["low", "high"]]),
)
def test_random_token_strings_are_a_number_or_an_input_error(tokens, separator, values):
    _check(separator.join(tokens), values)
