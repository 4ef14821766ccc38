"""A safe expression language for utilities in ``u`` (``fairaudit audit --utility``).

:func:`evaluate_utility_expression` evaluates an expression such as
``"u >= 5"`` or ``"min(u, 3) / 3"`` once per outcome value. The grammar is a
small allowlist checked on the parsed tree before anything is evaluated, and
the evaluation itself runs in :mod:`simpleeval` with only those node handlers,
operators and functions; nothing can reach attributes, subscripts, imports,
other names or other calls.
"""

from __future__ import annotations

import ast
import math
import operator
from collections.abc import Callable, Hashable, Sequence
from contextlib import suppress
from typing import Any

import numpy as np
import simpleeval  # type: ignore[import-untyped]

from fairaudit.base.arrays import FloatArray
from fairaudit.base.errors import InputError
from fairaudit.base.labels import format_label

__all__ = [
    # evaluating and checking an expression
    "evaluate_utility_expression",
    "parse_expression",
    # the language and its limits
    "FUNCTIONS",
    "GRAMMAR",
    "MAX_DEPTH",
    "MAX_LENGTH",
]

MAX_LENGTH = 2000
"""Longest accepted expression, in characters."""
MAX_DEPTH = 60
"""Deepest accepted nesting of the parsed expression (operators, calls, parentheses)."""
FIELD = "utility"
"""The parameter every error names (the command line shows it as ``--utility``)."""
GRAMMAR = "u, numbers, + - * / // % **, comparisons, and/or/not, in [...], a if c else b, min max abs log exp"
"""The allowed pieces, named in every error about a piece that is not allowed."""


class _Refused(Exception):
    """A value-level failure inside the evaluation (division by zero, overflow, text in arithmetic...)."""


def _number(x: object, what: str) -> float:
    if isinstance(x, (int, float)):
        return float(x)
    raise _Refused(f"{what} needs numbers; got {_show(x)}")


def _show(x: object) -> str:
    if isinstance(x, str):
        return f"text {x!r}"
    if isinstance(x, (list, tuple)):
        return "a list"
    if isinstance(x, float):
        return _fmt(x)
    return repr(x)


def _arithmetic(symbol: str, fn: Callable[[float, float], float]) -> Callable[[object, object], float]:
    def apply(a: object, b: object) -> float:
        x, y = _number(a, f"'{symbol}'"), _number(b, f"'{symbol}'")
        try:
            return fn(x, y)
        except ZeroDivisionError:
            raise _Refused(f"division by zero in {_fmt(x)} {symbol} {_fmt(y)}") from None

    return apply


def _power(a: object, b: object) -> float:
    """``a ** b`` in floating point: a result too large for a float is refused at once (no big integers)."""
    x, y = _number(a, "'**'"), _number(b, "'**'")
    try:
        return math.pow(x, y)
    except OverflowError:
        raise _Refused(f"{_fmt(x, paren=True)} ** {_fmt(y, paren=True)} is too large") from None
    except ValueError:  # 0 ** negative, negative ** fraction
        raise _Refused(f"{_fmt(x, paren=True)} ** {_fmt(y, paren=True)} has no real value") from None


def _comparison(symbol: str, fn: Callable[[Any, Any], bool]) -> Callable[[object, object], bool]:
    def apply(a: object, b: object) -> bool:
        if isinstance(a, str) != isinstance(b, str):
            raise _Refused(f"'{symbol}' compares {_show(a)} with {_show(b)}; text compares only with text")
        return fn(a, b)

    return apply


def _membership(negate: bool) -> Callable[[object, object], bool]:
    def apply(a: object, b: object) -> bool:
        if not isinstance(b, (list, tuple)):
            raise _Refused(f"'in' needs a list such as [1, 2]; got {_show(b)}")
        for item in b:
            if isinstance(a, str) != isinstance(item, str):
                raise _Refused(f"'in' looks for {_show(a)} among {_show(item)}; text compares only with text")
        return (a not in b) if negate else (a in b)

    return apply


def _fmt(x: float, paren: bool = False) -> str:
    text = str(int(x)) if x.is_integer() and abs(x) < 1e16 else repr(x)
    return f"({text})" if paren and x < 0 else text


OPERATORS: dict[type, Callable[..., object]] = {
    ast.Add: _arithmetic("+", operator.add),
    ast.Sub: _arithmetic("-", operator.sub),
    ast.Mult: _arithmetic("*", operator.mul),
    ast.Div: _arithmetic("/", operator.truediv),
    ast.FloorDiv: _arithmetic("//", operator.floordiv),
    ast.Mod: _arithmetic("%", operator.mod),
    ast.Pow: _power,
    ast.USub: lambda a: -_number(a, "unary '-'"),
    ast.UAdd: lambda a: +_number(a, "unary '+'"),
    ast.Not: operator.not_,
    ast.Eq: _comparison("==", operator.eq),
    ast.NotEq: _comparison("!=", operator.ne),
    ast.Lt: _comparison("<", operator.lt),
    ast.LtE: _comparison("<=", operator.le),
    ast.Gt: _comparison(">", operator.gt),
    ast.GtE: _comparison(">=", operator.ge),
    ast.In: _membership(negate=False),
    ast.NotIn: _membership(negate=True),
}


def _log(x: object) -> float:
    value = _number(x, "log")
    if value <= 0:
        raise _Refused(f"log of a non-positive number ({_fmt(value)})")
    return math.log(value)


def _exp(x: object) -> float:
    value = _number(x, "exp")
    try:
        return math.exp(value)
    except OverflowError:
        raise _Refused(f"exp({_fmt(value)}) is too large") from None


FUNCTIONS: dict[str, tuple[Callable[..., float], int, int]] = {
    "min": (lambda *xs: min(_number(x, "min") for x in xs), 2, 32),
    "max": (lambda *xs: max(_number(x, "max") for x in xs), 2, 32),
    "abs": (lambda x: abs(_number(x, "abs")), 1, 1),
    "log": (_log, 1, 1),
    "exp": (_exp, 1, 1),
}
"""The allowed functions: name → (function, fewest arguments, most arguments). ``log`` is the natural logarithm."""

_REFUSED_OPERATORS = {
    ast.BitAnd: "&",
    ast.BitOr: "|",
    ast.BitXor: "^",
    ast.LShift: "<<",
    ast.RShift: ">>",
    ast.MatMult: "@",
    ast.Invert: "~",
    ast.Is: "is",
    ast.IsNot: "is not",
}
_KINDS = {
    ast.Lambda: "lambda",
    ast.ListComp: "comprehension",
    ast.SetComp: "comprehension",
    ast.DictComp: "comprehension",
    ast.GeneratorExp: "generator expression",
    ast.NamedExpr: "assignment ':='",
    ast.JoinedStr: "f-string",
    ast.FormattedValue: "f-string",
    ast.Dict: "dict literal",
    ast.Set: "set literal",
    ast.Starred: "unpacking '*'",
    ast.Slice: "slice",
    ast.Await: "await",
    ast.Yield: "yield",
    ast.YieldFrom: "yield",
}


class _Checker:
    """Walks the parsed tree and refuses any node outside the grammar, naming it."""

    def __init__(self, source: str) -> None:
        self.source = source

    def refuse(self, what: str) -> InputError:
        return InputError(FIELD, f"not allowed: {what}; an expression may use {GRAMMAR}", self.source)

    def text(self, node: ast.AST) -> str:
        segment = ast.get_source_segment(self.source, node) or type(node).__name__
        segment = " ".join(segment.split())
        return segment if len(segment) <= 40 else segment[:37] + "..."

    def check(self, node: ast.AST, depth: int = 0, *, text_ok: bool = False, list_ok: bool = False) -> None:
        if depth > MAX_DEPTH:
            raise InputError(FIELD, f"is nested too deeply (more than {MAX_DEPTH} levels)", self.source)
        deeper = depth + 1
        if isinstance(node, ast.Expression):
            self.check(node.body, deeper)
        elif isinstance(node, ast.Constant):
            value = node.value
            if isinstance(value, str):
                if not text_ok:
                    raise self.refuse(f"text {self.text(node)} outside a comparison (text compares with a text u)")
            elif isinstance(value, complex) or not isinstance(value, (int, float)):
                raise self.refuse(f"literal {self.text(node)}")
        elif isinstance(node, ast.Name):
            if node.id in FUNCTIONS:
                raise self.refuse(f"function '{node.id}' without a call")
            if node.id != "u":
                raise self.refuse(f"name '{node.id}'")
        elif isinstance(node, ast.BinOp):
            if type(node.op) not in OPERATORS:  # (its binary operators: + - * / // % **)
                raise self.refuse(f"operator '{_REFUSED_OPERATORS.get(type(node.op), type(node.op).__name__)}'")
            self.check(node.left, deeper)
            self.check(node.right, deeper)
        elif isinstance(node, ast.UnaryOp):
            if isinstance(node.op, ast.Invert):
                raise self.refuse("operator '~'")
            self.check(node.operand, deeper)
        elif isinstance(node, ast.BoolOp):
            for operand in node.values:
                self.check(operand, deeper)
        elif isinstance(node, ast.Compare):
            self.check(node.left, deeper, text_ok=True)
            for op, comparator in zip(node.ops, node.comparators, strict=True):
                if type(op) in _REFUSED_OPERATORS:
                    raise self.refuse(f"operator '{_REFUSED_OPERATORS[type(op)]}'")
                self.check(comparator, deeper, text_ok=True, list_ok=isinstance(op, (ast.In, ast.NotIn)))
        elif isinstance(node, (ast.List, ast.Tuple)):
            if not list_ok:
                raise self.refuse(f"list or tuple {self.text(node)} outside 'in [...]'")
            for element in node.elts:
                self.check(element, deeper, text_ok=True)
        elif isinstance(node, ast.IfExp):
            for part in (node.test, node.body, node.orelse):
                self.check(part, deeper)
        elif isinstance(node, (ast.Call, ast.Attribute, ast.Subscript)):
            self.check_chain(node, deeper)
        else:
            kind = _KINDS.get(type(node), type(node).__name__)
            raise self.refuse(f"{kind} {self.text(node)!r}")

    def check_chain(self, node: ast.expr, depth: int) -> None:
        """A chain such as ``a.b[c](d)``: its pieces from the innermost out, so the first offending one is named."""
        chain = [node]
        while isinstance(chain[-1], (ast.Call, ast.Attribute, ast.Subscript)):
            last = chain[-1]
            chain.append(last.func if isinstance(last, ast.Call) else last.value)
        for piece in reversed(chain[:-1]):
            if isinstance(piece, ast.Attribute):
                raise self.refuse(f"attribute access '.{piece.attr}'")
            if isinstance(piece, ast.Subscript):
                raise self.refuse(f"subscript {self.text(piece)!r}")
            if isinstance(piece, ast.Call):
                if isinstance(piece.func, ast.Name):
                    self.check_call(piece, piece.func.id, depth)
                elif isinstance(piece.func, ast.Lambda):
                    raise self.refuse(f"lambda {self.text(piece.func)!r}")
                else:
                    raise self.refuse(f"call of {self.text(piece.func)!r}")

    def check_call(self, node: ast.Call, name: str, depth: int) -> None:
        if name not in FUNCTIONS:
            raise self.refuse(f"call of '{name}'")
        if node.keywords:
            raise self.refuse(f"keyword argument in {self.text(node)!r}")
        for arg in node.args:
            if isinstance(arg, ast.Starred):
                raise self.refuse(f"unpacking {self.text(arg)!r}")
        _, fewest, most = FUNCTIONS[name]
        if not fewest <= len(node.args) <= most:
            count = (
                f"{fewest} argument" + ("" if fewest == 1 else "s")
                if fewest == most
                else f"{fewest} to {most} arguments"
            )
            raise InputError(FIELD, f"{name}() takes {count}, got {len(node.args)}", self.source)
        for arg in node.args:
            self.check(arg, depth)


def parse_expression(expression: object) -> ast.Expression:
    """Parse and check ``expression`` against the grammar; nothing is evaluated.

    Raises
    ------
    InputError
        If it is not a string, is empty, too long, not valid syntax, nested too
        deeply, or holds any piece outside the grammar (named in the message).
    """
    if not isinstance(expression, str):
        raise InputError(FIELD, "must be a string", expression)
    if not expression.strip():
        raise InputError(FIELD, "is empty; give an expression in u such as 'u >= 5'", expression)
    if len(expression) > MAX_LENGTH:
        raise InputError(FIELD, f"is too long ({len(expression)} characters; at most {MAX_LENGTH})", expression)
    try:
        tree = ast.parse(expression.strip(), mode="eval")
    except SyntaxError as exc:
        raise InputError(FIELD, f"is not a valid expression ({_syntax_problem(expression, exc)})", expression) from None
    except (RecursionError, MemoryError, ValueError, OverflowError):  # the parser's own limits; NUL characters
        raise InputError(FIELD, "is nested too deeply or too complex to parse", expression) from None
    _Checker(expression.strip()).check(tree)
    return tree


def _syntax_problem(expression: str, exc: SyntaxError) -> str:
    with suppress(SyntaxError, RecursionError, MemoryError, ValueError, OverflowError):
        module = ast.parse(expression.strip(), mode="exec")  # a statement (import, assignment) parses: name it
        if module.body and not isinstance(module.body[0], ast.Expr):
            return f"a statement ({type(module.body[0]).__name__.lower()}), not an expression"
    return exc.msg


class _Evaluator(simpleeval.EvalWithCompoundTypes):
    """simpleeval with only the grammar's node handlers, operators and functions."""

    nodes: dict[type, Callable[[Any], object]]
    functions: dict[str, Callable[..., object]]
    names: dict[str, object]

    ALLOWED_NODES = (
        ast.Name,
        ast.Constant,
        ast.UnaryOp,
        ast.BinOp,
        ast.BoolOp,
        ast.Compare,
        ast.IfExp,
        ast.Call,
        ast.List,
        ast.Tuple,
    )

    def __init__(self) -> None:
        super().__init__(operators=dict(OPERATORS), functions={}, names={"u": 0.0})
        self.functions = {name: fn for name, (fn, _, _) in FUNCTIONS.items()}  # drops list/tuple/dict/set
        self.nodes = {kind: self.nodes[kind] for kind in self.ALLOWED_NODES}  # no Attribute, Subscript, Dict, ...
        self.nodes[ast.Constant] = self._constant

    @staticmethod
    def _constant(node: ast.Constant) -> object:
        value = node.value
        if isinstance(value, int) and not isinstance(value, bool):
            try:
                return float(value)
            except OverflowError:
                raise _Refused("a number is too large for a float (above about 1.8e308)") from None
        return value


def _outcome_values(values: Sequence[Hashable]) -> list[float] | list[str]:
    """The values that ``u`` takes: numbers when every value parses as one (:func:`pandas.to_numeric`), else text."""
    import pandas as pd  # imported here, on first use: pandas adds a third of a second to the command's start

    series = pd.Series(list(values))
    numeric = pd.to_numeric(series, errors="coerce")
    if not numeric.isna().any():
        return [float(v) for v in numeric]
    return [str(v) for v in series.astype(str)]


def evaluate_utility_expression(expression: str, values: Sequence[Hashable]) -> FloatArray:
    """Evaluate a utility expression in ``u`` at every outcome value.

    ``u`` is numeric when every value parses as a number, else text. The
    expression is parsed and checked against the grammar below first; then it
    is evaluated once per value (the outcome alphabet, not the table's cells).

    Grammar (nothing else is accepted):

    * ``u``; numbers (``3``, ``0.5``, ``1e-3``), ``True``/``False``;
    * arithmetic ``+ - * / // % **`` and unary ``-``/``+`` on numbers;
    * comparisons ``== != < <= > >=``, chained as in ``1 < u <= 3``;
    * ``and``, ``or``, ``not``; ``a if condition else b``;
    * ``u in [1, 2, 3]`` and ``not in``, with a list or tuple literal;
    * text literals only inside a comparison with a text ``u``
      (``u == "high"``, ``u in ("a", "b")``); text never compares with numbers;
    * the functions ``min(a, b, ...)``, ``max(a, b, ...)``, ``abs(x)``,
      ``log(x)`` (natural logarithm, ``x > 0``) and ``exp(x)``.

    Limits: at most :data:`MAX_LENGTH` characters and :data:`MAX_DEPTH` levels
    of nesting; arithmetic is in floating point, so ``**`` and ``exp`` whose
    result exceeds a float (about 1.8e308) are refused at once rather than
    computed (``9**9**9**9`` is an error, not a hang). Booleans become 0/1.

    Parameters
    ----------
    expression : str
        The expression, for example ``"u >= 5"`` or ``"11 - u"``.
    values : sequence of hashable
        The outcome values, in order.

    Returns
    -------
    numpy.ndarray
        float64, one number per value (not checked for sign or finiteness).

    Raises
    ------
    InputError
        Field ``utility``: the expression is empty, too long, not valid
        syntax, nested too deeply, or uses anything outside the grammar (an
        attribute, subscript, other name or call, lambda, comprehension,
        f-string, ...: the message names it); or its evaluation fails at some
        value (division by zero, log of a non-positive number, an overflow, text
        in arithmetic, a text result: the message names the value of ``u``).

    Examples
    --------
    >>> evaluate_utility_expression("u >= 5", [1, 4, 5, 10]).tolist()
    [0.0, 0.0, 1.0, 1.0]
    >>> evaluate_utility_expression("min(u, 3) / 3 if u in [1, 2, 3] else 0", [1, 3, 7]).tolist()
    [0.3333333333333333, 1.0, 0.0]
    >>> evaluate_utility_expression('u == "high"', ["low", "high"]).tolist()
    [0.0, 1.0]
    >>> evaluate_utility_expression("u.__class__", [1, 2])  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    fairaudit.base.errors.InputError: utility: not allowed: attribute access '.__class__'; ... (got 'u.__class__')
    >>> evaluate_utility_expression("9**9**9**9", [1])
    Traceback (most recent call last):
    ...
    fairaudit.base.errors.InputError: utility: 9 ** 387420489 is too large (at u = 1) (got '9**9**9**9')
    """
    tree = parse_expression(expression)
    evaluator = _Evaluator()
    out = np.empty(len(values), dtype=float)
    for i, (label, u) in enumerate(zip(values, _outcome_values(values), strict=True)):
        evaluator.names["u"] = u
        try:
            result = evaluator.eval(expression, previously_parsed=tree.body)
        except _Refused as exc:
            raise InputError(FIELD, f"{exc} (at u = {format_label(label)})", expression) from None
        except Exception as exc:  # defence in depth: whatever slips through is still one line
            problem = f"cannot be evaluated at u = {format_label(label)} ({type(exc).__name__}: {exc})"
            raise InputError(FIELD, problem, expression) from None
        if not isinstance(result, (int, float)):
            problem = f"gives {_show(result)}, not a number, at u = {format_label(label)}"
            raise InputError(FIELD, problem, expression)
        out[i] = float(result)
    return out
