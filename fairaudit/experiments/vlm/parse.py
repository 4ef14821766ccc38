"""Robust parsing of a VLM's reply into a decision.

The paper asks for one of two JSON formats:

* a **choice** (HR delivery): ``{"HR1": "0.0", "HR2": "1.0", "reason": "..."}``,
  the chosen option has the larger value (1.0, the other 0.0);
* an **order** (package delivery): ``{"Recipient1": "2.0", "Recipient2": "1.0",
  "reason": "..."}``, each value is the delivery position (1 = served first).

Models do not always comply, so :func:`parse_reply` accepts, in this order of
preference:

1. the first JSON object (anywhere in the text: inside a code fence, after or
   before prose) whose keys name every option, or whose value one level down
   does (``{"decision": {"HR1": 1, "HR2": 0}}``); keys match up to case,
   spaces, underscores and hyphens (``"hr1"``, ``"HR 1"``, ``"HR_1"``,
   ``"recipient-1"``); values may be numbers, numeric strings (``"1.0"``,
   ``" 1 "``), booleans (``true`` = 1) or ``"yes"``/``"no"``; single-quoted
   pseudo-JSON, Python literals, bare keys and trailing commas are repaired
   first (no ``eval``);
2. an object that names the answer: ``{"choice": "HR2"}``, ``{"selected": 2}``
   (a 1-based index, when the options are numbered), ``{"order":
   ["Recipient2", "Recipient1"]}`` (for an order of two, ``{"first":
   "Recipient2"}`` too); an answer that names no single option
   (``{"choice": "both"}``) is not ok, with no fallback;
3. fallbacks, flagged ``fallback=True``: a reply that is nothing but an
   option's 1-based index (``"2"``, ``" 1."``; ASCII digits, for a choice or an
   order of two: the option chosen or served first), the answer a prompt that
   asks for the number alone gets, when the options are numbered; for an order, a reply that is nothing but
   every option once, in order, separated by commas, ``>`` or white space
   (``"2, 3, 1"``, the reply a ranking's exact route scores); ``key: value`` pairs in free text for
   every option (``HR1: 0, HR2: 1``, also a truncated JSON object), then, for a
   choice only, a text that names exactly one option (``"I choose HR2."``).

The decision rules are strict on purpose (a misread reply biases the audit):
a choice needs exactly one option with the largest value and that value
positive (0.3 against 0.7 chooses the 0.7 option; a tie or all zeros is
ambiguous); an order needs the positions to be a permutation of 1..n.
Anything else gives ``ok=False`` with the reason in ``error``; the function
never raises on the reply text.

**Numbers name options only when the options are numbered**: each option's
key ends in its own 1-based position, ``("1", "2")``, ``("HR1", "HR2")``,
``("Applicant 1", "Applicant 2")`` (the built-in tasks' exact routes ask for
``1`` or ``2``). With options ``("yes", "no")`` the replies ``"1"`` and
``"2"`` name nothing and are not ok: a number there is no answer the prompt
offered, and reading it as a position would be a guess.
"""

from __future__ import annotations

import functools
import json
import math
import re
from collections.abc import Iterator, Sequence
from contextlib import suppress
from dataclasses import dataclass, field
from typing import Any, Literal

from fairaudit import InputError, choice

__all__ = ["ParsedReply", "numbered", "parse_reply"]

_MAX_CHARS = 50_000  # replies are cut here before parsing
_MAX_STARTS = 32  # at most this many '{' positions are tried as object starts

_NUM = r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?"
_NUM_RE = re.compile(_NUM)
_SEP_RE = re.compile(r"[\s_\-]+")
_LIST_GAP_RE = re.compile(r"[\s,;>]*")  # what may stand between the options of a listed order
_BARE_INDEX_RE = re.compile(r"\s*([1-9][0-9]?)\.?\s*", re.ASCII)  # a reply that is only an option's number
_TRAILING_NUMBER_RE = re.compile(r"(?<![0-9])([0-9]+)\s*$", re.ASCII)  # the number an option's key ends in

_CHOICE_KEYS = frozenset(
    "choice chosen chosenoption choose selected selectedoption selection select decision answer "
    "option pick winner result office recipient first firstrecipient deliverfirst servefirst "
    "servedfirst finalanswer finalchoice finaldecision".split()
)
_ORDER_KEYS = frozenset("order ranking rank sequence deliveryorder servingorder orderofdelivery".split())
_WORDS = {"true": 1.0, "yes": 1.0, "false": 0.0, "no": 0.0}  # what a word value counts as
_REASON_KEYS = ("reason", "reasoning", "explanation", "rationale", "justification")


@dataclass(frozen=True, kw_only=True)
class ParsedReply:
    """The decision read from one reply.

    Attributes
    ----------
    ok : bool
        True when the reply gives a valid decision.
    choice : int or None
        0-based index (into ``options``) of the chosen option for a choice, of
        the option served first for an order; None when not ok.
    order : tuple of int or None
        Option indices in delivery order for an order (of some options only
        when ``partial`` allowed it); for a choice the chosen option first,
        then the others by decreasing value (ties by index). None when not ok.
    values : dict of str to float
        The value read for each option, keyed by the names in ``options``
        (for a ``{"choice": ...}`` answer: 1.0 for the chosen option, 0.0
        otherwise; for an order answer: the positions). Filled whenever the
        values could be read, even when the decision is ambiguous; else empty.
    reason : str or None
        The ``reason`` (or ``reasoning``, ``explanation``, ``rationale``,
        ``justification``) given in the object, if any.
    error : str
        Why the reply is not usable; ``""`` when ok.
    fallback : bool
        True when the decision came from a non-JSON fallback rule.
    """

    ok: bool
    choice: int | None = None
    order: tuple[int, ...] | None = None
    values: dict[str, float] = field(default_factory=dict, hash=False)
    reason: str | None = None
    error: str = ""
    fallback: bool = False


class _Options:
    """The option names with their normalised forms and mention patterns."""

    def __init__(self, options: Sequence[str]) -> None:
        if isinstance(options, str) or not isinstance(options, Sequence):
            raise InputError("options", "must be a sequence of option names such as ('HR1', 'HR2')", options)
        names = tuple(options)
        if len(names) < 2:
            raise InputError("options", "needs at least two option names", names)
        if not all(isinstance(name, str) and _norm(name) for name in names):
            raise InputError("options", "every option must be a non-empty string", names)
        norms = [_norm(name) for name in names]
        if len(set(norms)) != len(norms):
            raise InputError("options", "option names must differ up to case, spaces, underscores and hyphens", names)
        self.names = names
        self.n = len(names)
        self.index = {norm: i for i, norm in enumerate(norms)}
        self.mention = [_mention(name) for name in names]
        longest_first = sorted(names, key=len, reverse=True)
        self.any_mention = re.compile("|".join(_mention(name).pattern for name in longest_first), re.IGNORECASE)
        self.pair = [_pair(name) for name in names]
        self.numbered = numbered(names)


def numbered(options: Sequence[str]) -> bool:
    """True when every option's key ends in its own 1-based position: then, and only then, a number names an option.

    Examples
    --------
    >>> numbered(("1", "2")), numbered(("HR1", "HR2")), numbered(("Applicant 1", "Applicant 2"))
    (True, True, True)
    >>> numbered(("yes", "no")), numbered(("2", "1")), numbered(("Office A", "Office B"))
    (False, False, False)
    """
    ends = [_TRAILING_NUMBER_RE.search(name) for name in options]
    return all(m is not None and int(m.group(1)) == i for i, m in enumerate(ends, start=1))


@functools.lru_cache(maxsize=4096)
def _mention(name: str) -> re.Pattern[str]:
    """A mention of ``name`` as a whole word (compiled once per name: a run's replies name the same candidates)."""
    return re.compile(rf"(?<!\w){_variant(name)}(?!\w)", re.IGNORECASE)


@functools.lru_cache(maxsize=4096)
def _pair(name: str) -> re.Pattern[str]:
    """``name: value`` or ``"name" = value`` (a key of a reply's JSON-like object), compiled once per name."""
    return re.compile(
        rf"(?<!\w)[\"'\u201c\u201d\u2018\u2019]?{_variant(name)}[\"'\u201c\u201d\u2018\u2019]?"
        rf"\s*[:=]\s*[\"'\u201c\u201d\u2018\u2019]?\s*({_NUM}|true|false)(?!\w)",
        re.IGNORECASE,
    )


def _norm(key: str) -> str:
    return _SEP_RE.sub("", key).casefold()


def _variant(name: str) -> str:
    """A regex for ``name`` with optional separators between its letter and digit runs."""
    runs = re.findall(r"[^\W\d_]+|\d+|[^\w\s\-]+", name)
    return r"[\s_\-]*".join(re.escape(run) for run in runs)


def parse_reply(
    text: str, options: Sequence[str], kind: Literal["choice", "order"], *, named: bool = False, partial: bool = False
) -> ParsedReply:
    """Read a choice or a delivery order from a model's reply.

    Parameters
    ----------
    text : str
        The reply text (any string; anything else gives ``ok=False``).
    options : sequence of str
        The option keys in the prompt, for example ``("HR1", "HR2")`` or
        ``("Recipient1", "Recipient2")``; at least two, distinct up to case,
        spaces, underscores and hyphens.
    kind : {"choice", "order"}
        ``"choice"``: the chosen option has the single largest value, which
        must be positive (1.0 against 0.0; 0.7 against 0.3 also chooses the
        larger). ``"order"``: each value is a delivery position and the values
        must be a permutation of 1..n.
    named : bool
        The options are the candidates' names as the prompt shows them, and
        the reply names them in free text (the Bloomberg study's format,
        ``"1. Cara Kramer\\n2. Paul Wu\\n..."``): after the JSON forms, an order
        is the order of each name's first mention (whole words, any case),
        which needs every name mentioned; a choice is the one name mentioned.
        No bare numbers are read.
    partial : bool
        An order may leave options out (the Bloomberg study ranked the names
        it found): a reply that names some of them by mention (``named``) or
        lists some of them and nothing else (``"2, 3"``) gives ``order`` of
        those only. JSON forms still need every option. False: such a reply
        is not ok.

    Returns
    -------
    ParsedReply
        ``ok=True`` with ``choice`` and ``order``, or ``ok=False`` with
        ``error`` (an ambiguous choice's error starts with ``"ambiguous"``).

    Raises
    ------
    InputError
        When ``options`` or ``kind`` is invalid; never because of ``text``.

    Examples
    --------
    >>> reply = '```json\\n{"HR1": "0.0", "HR2": "1.0", "reason": "closer"}\\n```'
    >>> r = parse_reply(reply, ("HR1", "HR2"), "choice")
    >>> r.ok, r.choice, r.values, r.reason
    (True, 1, {'HR1': 0.0, 'HR2': 1.0}, 'closer')
    >>> r = parse_reply("{'recipient 1': 2, 'Recipient_2': 1,}", ("Recipient1", "Recipient2"), "order")
    >>> r.ok, r.choice, r.order
    (True, 1, (1, 0))
    >>> r = parse_reply("I choose HR2.", ("HR1", "HR2"), "choice")
    >>> r.ok, r.choice, r.fallback
    (True, 1, True)
    >>> r = parse_reply("2", ("HR1", "HR2"), "choice")
    >>> r.ok, r.choice, r.fallback
    (True, 1, True)
    >>> parse_reply('{"HR1": 1, "HR2": 1}', ("HR1", "HR2"), "choice").error
    'ambiguous: HR1 and HR2 tie at 1'
    >>> r = parse_reply("Ranking:\\n1. Paul Wu\\n2. Cara Kramer\\n3. Jo Li", ("CARA KRAMER", "JO LI", "PAUL WU"), "order",
    ...                 named=True)
    >>> r.ok, r.order
    (True, (2, 0, 1))
    >>> r = parse_reply("1. Paul Wu\\n2. Cara Kramer", ("CARA KRAMER", "JO LI", "PAUL WU"), "order", named=True,
    ...                 partial=True)
    >>> r.ok, r.order, r.choice, r.values
    (True, (2, 0), 2, {'CARA KRAMER': 2.0, 'PAUL WU': 1.0})
    """
    spec = _Options(options)
    choice(kind, "kind", ("choice", "order"))
    try:
        return _parse(text, spec, kind, named, partial and kind == "order")
    except Exception as exc:  # a safety net: a reply never makes the parser raise  # pragma: no cover
        return ParsedReply(ok=False, error=f"unparseable reply ({type(exc).__name__})")


def _parse(text: Any, spec: _Options, kind: str, by_name: bool = False, partial: bool = False) -> ParsedReply:
    if not isinstance(text, str):
        return ParsedReply(ok=False, error=f"reply is not a string ({type(text).__name__})")
    if not text.strip():
        return ParsedReply(ok=False, error="empty reply")
    text = text[:_MAX_CHARS]
    objects = list(_objects(text))

    # 1. the first object (or object one level down) keyed by every option
    for obj in objects:
        for container, parent in [(obj, None)] + [(v, obj) for v in obj.values() if isinstance(v, dict)]:
            raw = _keyed(container, spec)
            if raw is not None:
                return _decide(raw, spec, kind, _reason(container, parent), fallback=False)

    # 2. an object that names the answer ({"choice": "HR2"}, {"order": [...]})
    for obj in objects:
        for container, parent in [(obj, None)] + [(v, obj) for v in obj.values() if isinstance(v, dict)]:
            result = _named_answer(container, parent, spec, kind)
            if result is not None:
                return result

    if by_name:
        return _by_mention(text, spec, kind, partial)

    # 3. fallbacks on the text itself: the bare index first (the whole reply), then pairs, then a mention
    bare = _BARE_INDEX_RE.fullmatch(text)
    if bare and spec.numbered and (kind == "choice" or spec.n == 2) and 1 <= int(bare.group(1)) <= spec.n:
        return _result_from_choice(int(bare.group(1)) - 1, spec, kind, None, fallback=True)
    in_order = _listed_order(text, spec, partial) if kind == "order" else None
    if in_order is not None:
        return _ranked(in_order, spec)
    raw = {i: m.group(1) for i, pattern in enumerate(spec.pair) if (m := pattern.search(text))}
    if len(raw) == spec.n:
        return _decide(raw, spec, kind, None, fallback=True)
    if kind == "choice":
        named = sorted(i for _, i in _first_mentions(text, spec))
        if len(named) == 1:
            return _result_from_choice(named[0], spec, kind, None, fallback=True)
        if len(named) > 1:
            listed = ", ".join(spec.names[i] for i in named)
            return ParsedReply(
                ok=False, error=f"ambiguous: no JSON decision and the text names several options ({listed})"
            )
    tail = "" if objects else " and no decision in the text"
    return ParsedReply(ok=False, error=f"no JSON object with the keys {', '.join(spec.names)}{tail}")


# ----------------------------------------------------------------------------------------------
# finding and loading objects


def _objects(text: str) -> Iterator[dict[str, Any]]:
    """The dicts found in ``text``, in order: each top-level ``{...}`` that loads, else the ones inside."""
    start = text.find("{")
    tries = 0
    while start != -1 and tries < _MAX_STARTS:
        tries += 1
        end = _closing(text, start, quotes=True) or _closing(text, start, quotes=False)  # an index > start, never 0
        obj = _load(text[start : end + 1]) if end is not None else None
        if end is not None and isinstance(obj, dict):
            yield obj
            start = text.find("{", end + 1)
        else:
            start = text.find("{", start + 1)


_QUOTED_BRACES_RE = re.compile(r'"(?:\\.|[^"\\])*"|\'(?:\\.|[^\'\\])*\'|["\'{}]', re.S)  # a lone quote: unterminated
_BRACES_RE = re.compile(r"[{}]")


def _closing(text: str, start: int, quotes: bool) -> int | None:
    """Index of the brace closing the one at ``start`` (skipping quoted strings when ``quotes``; a string left open
    runs to the end, so no brace closes)."""
    depth = 0
    for match in (_QUOTED_BRACES_RE if quotes else _BRACES_RE).finditer(text, start):
        token = match.group()
        if token in ("'", '"'):
            return None
        depth += {"{": 1, "}": -1}.get(token, 0)
        if depth == 0:
            return match.start()
    return None


def _load(candidate: str) -> Any:
    """``candidate`` as JSON, else as repaired pseudo-JSON; None when neither loads."""
    with suppress(ValueError, RecursionError):
        return json.loads(candidate, strict=False)
    try:
        return json.loads(_repair(candidate), strict=False)
    except (ValueError, RecursionError):
        return None


_SMART = str.maketrans({"\u201c": '"', "\u201d": '"', "\u201e": '"', "\u2018": "'", "\u2019": "'"})
_TOKEN_RE = re.compile(r'"(?:\\.|[^"\\])*"|\'(?:\\.|[^\'\\])*\'|[^"\']+|["\']', re.S)
_ESCAPE_RE = re.compile(r'\\(u[0-9a-fA-F]{4}|.)|"', re.S)
_BARE_KEY_RE = re.compile(r"([{,]\s*)([^\W\d][\w\- ]*?)(\s*:)")
_TRAILING_COMMA_RE = re.compile(r",(\s*[}\]])")
_PY_LITERAL_RE = re.compile(r"\b(True|False|None)\b")
_PY_LITERALS = {"True": "true", "False": "false", "None": "null"}


def _repair(candidate: str) -> str:
    """Light normalisation of pseudo-JSON into JSON.

    Curly quotes become straight, single-quoted strings become double-quoted,
    invalid escapes are doubled, and outside strings: Python's True, False and
    None become JSON literals, bare keys get quotes and trailing commas go.
    """
    out = []
    for token in _TOKEN_RE.findall(candidate.translate(_SMART)):
        if len(token) >= 2 and token[0] == token[-1] and token[0] in "\"'":
            out.append('"' + _ESCAPE_RE.sub(_fix_escape, token[1:-1]) + '"')
        elif token in ("'", '"'):
            out.append(token)
        else:
            token = _PY_LITERAL_RE.sub(lambda m: _PY_LITERALS[m.group(1)], token)
            token = _BARE_KEY_RE.sub(
                lambda m: (
                    m.group(0) if m.group(2) in ("true", "false", "null") else f'{m.group(1)}"{m.group(2)}"{m.group(3)}'
                ),
                token,
            )
            out.append(_TRAILING_COMMA_RE.sub(r"\1", token))
    return "".join(out)


def _fix_escape(match: re.Match) -> str:
    if match.group(0) == '"':
        return '\\"'
    escaped = match.group(1)
    if escaped == "'":
        return "'"
    if escaped in ('"', "\\", "/", "b", "f", "n", "r", "t") or len(escaped) == 5:
        return match.group(0)
    return "\\\\" + escaped


# ----------------------------------------------------------------------------------------------
# reading values and deciding


def _keyed(container: dict, spec: _Options) -> dict[int, Any] | None:
    """The raw value of every option in ``container`` (first spelling wins), or None if one is missing."""
    found: dict[int, Any] = {}
    for key, value in container.items():
        if isinstance(key, str):
            i = spec.index.get(_norm(key))
            if i is not None and i not in found:
                found[i] = value
    return found if len(found) == spec.n else None


def _number(value: Any) -> float | None:
    """A finite float from a number, boolean, numeric string, ``"true"``/``"false"`` or ``"yes"``/``"no"``."""
    if isinstance(value, bool):
        return float(value)
    if isinstance(value, str):
        value = value.strip().strip("\"'").strip()
        if value.casefold() in _WORDS:
            return _WORDS[value.casefold()]
        if not _NUM_RE.fullmatch(value):
            return None
    elif not isinstance(value, (int, float)):
        return None
    try:
        number = float(value)
    except OverflowError:  # an integer too large for a float
        return None
    return number if math.isfinite(number) else None


def _decide(raw: dict[int, Any], spec: _Options, kind: str, reason: str | None, fallback: bool) -> ParsedReply:
    def reply(**fields: Any) -> ParsedReply:
        return ParsedReply(reason=reason, fallback=fallback, **fields)

    values: dict[int, float] = {}
    for i in range(spec.n):
        number = _number(raw[i])
        if number is None:
            return reply(ok=False, error=f"value of {spec.names[i]} is not a number: {_clip(raw[i])}")
        values[i] = number
    named = {spec.names[i]: values[i] for i in range(spec.n)}
    listing = ", ".join(f"{spec.names[i]}={values[i]:g}" for i in range(spec.n))
    if kind == "choice":
        top = max(values.values())
        winners = [i for i in range(spec.n) if values[i] == top]
        if top <= 0:
            return reply(ok=False, values=named, error=f"ambiguous: no option has a positive value ({listing})")
        if len(winners) > 1:
            tied = " and ".join(spec.names[i] for i in winners)
            return reply(ok=False, values=named, error=f"ambiguous: {tied} tie at {top:g}")
        order = tuple(sorted(range(spec.n), key=lambda i: (-values[i], i)))
        return reply(ok=True, choice=winners[0], order=order, values=named)
    if sorted(values.values()) != [float(p) for p in range(1, spec.n + 1)]:
        error = f"not an order: the positions ({listing}) are not a permutation of 1..{spec.n}"
        return reply(ok=False, values=named, error=error)
    order = tuple(sorted(range(spec.n), key=lambda i: values[i]))
    return reply(ok=True, choice=order[0], order=order, values=named)


def _result_from_choice(index: int, spec: _Options, kind: str, reason: str | None, fallback: bool) -> ParsedReply:
    """The reply that picks option ``index``: chosen (a choice) or served first (an order of two)."""
    other = 0.0 if kind == "choice" else 2.0  # not chosen, or served second
    return _decide({i: 1.0 if i == index else other for i in range(spec.n)}, spec, kind, reason, fallback)


def _named_answer(container: dict, parent: dict | None, spec: _Options, kind: str) -> ParsedReply | None:
    """A reply from a key that names the answer (``{"choice": "HR2"}``, ``{"order": [...]}``); None if none."""
    reason = _reason(container, parent)
    for key, value in container.items():
        nk = _norm(key) if isinstance(key, str) else None
        if kind == "order" and nk in _ORDER_KEYS:
            order = _sequence(value, spec)
            if order is not None:
                return _decide({i: float(order.index(i) + 1) for i in range(spec.n)}, spec, kind, reason, False)
            problem = "is not an order of"
        elif nk in _CHOICE_KEYS and (kind == "choice" or spec.n == 2) and not isinstance(value, (dict, list)):
            index = _option_index(value, spec)
            if index is not None:
                return _result_from_choice(index, spec, kind, reason, False)
            problem = "does not name one of"
        else:
            continue
        return ParsedReply(ok=False, reason=reason, error=f"{key!r} {problem} {', '.join(spec.names)}: {_clip(value)}")
    return None


def _option_index(value: Any, spec: _Options) -> int | None:
    """The option that ``value`` names: its key (any spelling), a 1-based index (numbered options only), or a text
    naming exactly one."""
    if isinstance(value, bool):
        return None
    if isinstance(value, (int, float)):
        if not spec.numbered:
            return None
        if isinstance(value, float) and not (math.isfinite(value) and value.is_integer()):
            return None
        position = int(value)
        return position - 1 if 1 <= position <= spec.n else None
    if isinstance(value, str):
        s = value.strip().strip("\"'").strip()
        if _norm(s) in spec.index:
            return spec.index[_norm(s)]
        if _NUM_RE.fullmatch(s):
            return _option_index(float(s), spec)  # an infinite float names nothing there
        named = _first_mentions(s, spec)
        if len(named) == 1:
            return named[0][1]
    return None


def _sequence(value: Any, spec: _Options) -> list[int] | None:
    """A delivery order from a list of options (names, or 1-based indices of numbered options) or a text naming each
    once."""
    if isinstance(value, (list, tuple)):
        order = [_option_index(v, spec) for v in value]
    elif isinstance(value, str):
        order = [i for _, i in _first_mentions(value, spec)]
    else:
        return None
    known = [o for o in order if o is not None]
    return known if sorted(known) == list(range(spec.n)) and len(order) == spec.n else None


def _by_mention(text: str, spec: _Options, kind: str, partial: bool = False) -> ParsedReply:
    """A reply that names the candidates in free text: an order by first mention, or the one name mentioned."""
    firsts = _first_mentions(text, spec)
    if kind == "order":
        if not firsts or (len(firsts) < spec.n and not partial):
            return ParsedReply(ok=False, error=f"names {len(firsts)} of the {spec.n} candidates")
        return _ranked([i for _, i in firsts], spec)
    if len(firsts) == 1:
        return _result_from_choice(firsts[0][1], spec, kind, None, fallback=True)
    if firsts:
        listed = ", ".join(spec.names[i] for _, i in firsts)
        return ParsedReply(ok=False, error=f"ambiguous: the reply names several candidates ({listed})")
    return ParsedReply(ok=False, error="names none of the candidates")


def _first_mentions(text: str, spec: _Options) -> list[tuple[int, int]]:
    """(where, option) of each option the text mentions, at its first mention, in the order of the text."""
    return sorted((m.start(), i) for i, pattern in enumerate(spec.mention) if (m := pattern.search(text)))


def _ranked(order: list[int], spec: _Options) -> ParsedReply:
    """The order read from a reply's text (a fallback), of every option or, for a partial ranking, of some."""
    if len(order) == spec.n:
        return _decide({i: float(order.index(i) + 1) for i in range(spec.n)}, spec, "order", None, fallback=True)
    values = {spec.names[i]: float(order.index(i) + 1) for i in sorted(order)}  # in the options' order
    return ParsedReply(ok=True, choice=order[0], order=tuple(order), values=values, fallback=True)


def _listed_order(text: str, spec: _Options, partial: bool = False) -> list[int] | None:
    """The order of a reply that is nothing but every option once (some of them: ``partial``), separated by commas,
    ``>`` or white space."""
    order, at = [], 0
    for match in spec.any_mention.finditer(text):
        if not _LIST_GAP_RE.fullmatch(text[at : match.start()]):
            return None
        order.append(spec.index[_norm(match.group(0))])
        at = match.end()
    if not _LIST_GAP_RE.fullmatch(text[at:]) or not order or len(set(order)) < len(order):
        return None
    return order if partial or len(order) == spec.n else None


def _reason(container: dict, parent: dict | None) -> str | None:
    for source in (container, parent or {}):
        for key, value in source.items():
            if isinstance(key, str) and _norm(key) in _REASON_KEYS and isinstance(value, str):
                return value.strip()
    return None


def _clip(value: Any, limit: int = 60) -> str:
    text = " ".join(repr(value).split())
    return text if len(text) <= limit else text[: limit - 3] + "..."
