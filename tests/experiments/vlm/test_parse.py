"""Reading a VLM's reply: the paper's two JSON formats and every deviation models make.

Expected values are written out by hand for each reply; the property tests
check that no string makes the parser raise, and that generated replies in
every supported spelling decode to the decision an independent oracle gives.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from fairaudit import InputError
from fairaudit.experiments.vlm.parse import ParsedReply, parse_reply

HR = ("HR1", "HR2")
RECIPIENTS = ("Recipient1", "Recipient2")
ROOT = Path(__file__).resolve().parents[3]


def choice(text, options=HR):
    return parse_reply(text, options, "choice")


def order(text, options=RECIPIENTS):
    return parse_reply(text, options, "order")


# --------------------------------------------------------------------------- the paper's formats


def test_paper_choice_format():
    r = choice('{"HR1": "0.0", "HR2": "1.0", "reason": "HR2 handles maternity leave."}')
    assert r == ParsedReply(
        ok=True, choice=1, order=(1, 0), values={"HR1": 0.0, "HR2": 1.0}, reason="HR2 handles maternity leave."
    )


def test_paper_order_format():
    r = order('{"Recipient1": "2.0", "Recipient2": "1.0", "reason": "Recipient2 is closer."}')
    assert r == ParsedReply(
        ok=True, choice=1, order=(1, 0), values={"Recipient1": 2.0, "Recipient2": 1.0}, reason="Recipient2 is closer."
    )
    r = order('{"Recipient1": "1.0", "Recipient2": "2.0"}')
    assert (r.ok, r.choice, r.order, r.reason) == (True, 0, (0, 1), None)


# --------------------------------------------------------------------------- wrappers around the object


@pytest.mark.parametrize(
    "text",
    [
        '```json\n{"HR1": "0.0", "HR2": "1.0"}\n```',
        '```JSON\n{"HR1": "0.0", "HR2": "1.0"}\n```',
        '```\n{"HR1": "0.0", "HR2": "1.0"}\n```',
        '```{"HR1": "0.0", "HR2": "1.0"}```',
        'Here is my decision:\n```json\n{"HR1": "0.0", "HR2": "1.0"}\n```\nLet me know if you need more.',
        'Sure. {"HR1": "0.0", "HR2": "1.0"}',
        '{"HR1": "0.0", "HR2": "1.0"} I hope this helps {with braces}.',
        'Consider {the options} first. {"HR1": "0.0", "HR2": "1.0"}',
        '{"note": "thinking"} {"HR1": "0.0", "HR2": "1.0"}',
        '{"HR1": "0.0", "HR2": "1.0"} {"HR1": "1.0", "HR2": "0.0"}',  # the first object with the keys wins
        '[{"HR1": "0.0", "HR2": "1.0"}]',
        '{"HR1": "0.0", "HR2": "1.0", "reason": "braces {inside} a \\"string\\""}',
    ],
)
def test_object_is_found_in_any_wrapper(text):
    r = choice(text)
    assert (r.ok, r.choice, r.values, r.fallback) == (True, 1, {"HR1": 0.0, "HR2": 1.0}, False)


def test_reason_with_braces_is_kept():
    r = choice('{"HR1": 0, "HR2": 1, "reason": "use {curly} braces"}')
    assert r.reason == "use {curly} braces"


# --------------------------------------------------------------------------- values


@pytest.mark.parametrize(
    "hr1, hr2, expected",
    [
        ('"1.0"', '"0.0"', (1.0, 0.0)),
        ('"1"', '"0"', (1.0, 0.0)),
        ('" 1 "', '" 0 "', (1.0, 0.0)),
        ("1", "0", (1.0, 0.0)),
        ("1.0", "0.0", (1.0, 0.0)),
        ("true", "false", (1.0, 0.0)),
        ('"true"', '"false"', (1.0, 0.0)),
        ('"yes"', '"no"', (1.0, 0.0)),
        ("1e0", "0", (1.0, 0.0)),
        ('"+1."', '"-0"', (1.0, 0.0)),
    ],
)
def test_value_forms(hr1, hr2, expected):
    r = choice(f'{{"HR1": {hr1}, "HR2": {hr2}}}')
    assert (r.ok, r.choice, tuple(r.values.values())) == (True, 0, expected)


@pytest.mark.parametrize(
    "value, shown",
    [
        ('"abc"', "'abc'"),
        ("null", "None"),
        ('"nan"', "'nan'"),
        ('"1e999"', "'1e999'"),
        ("[1]", "[1]"),
        ('"1_0"', "'1_0'"),
    ],
)
def test_values_that_are_not_numbers(value, shown):
    r = choice(f'{{"HR1": {value}, "HR2": 1}}')
    assert (r.ok, r.choice, r.error) == (False, None, f"value of HR1 is not a number: {shown}")


# --------------------------------------------------------------------------- keys


@pytest.mark.parametrize(
    "k1, k2",
    [("hr1", "hr2"), ("HR 1", "HR 2"), ("HR_1", "HR_2"), ("hr-1", "Hr-2"), (" HR1 ", "HR2"), ("h_r 1", "HR2")],
)
def test_key_spellings(k1, k2):
    r = choice(json.dumps({k1: "0.0", k2: "1.0"}))
    assert (r.ok, r.choice, r.values) == (True, 1, {"HR1": 0.0, "HR2": 1.0})


@pytest.mark.parametrize(
    "k1, k2", [("recipient-1", "recipient-2"), ("Recipient 1", "Recipient 2"), ("RECIPIENT_1", "recipient2")]
)
def test_recipient_key_spellings(k1, k2):
    r = order(json.dumps({k1: 2, k2: 1}))
    assert (r.ok, r.choice, r.order, r.values) == (True, 1, (1, 0), {"Recipient1": 2.0, "Recipient2": 1.0})


def test_first_spelling_of_a_key_wins():
    assert choice('{"HR1": 1, "hr_1": 0, "HR2": 0}').choice == 0


def test_missing_option_key():
    r = choice('{"HR2": 1, "reason": "x"}')
    assert (r.ok, r.fallback) == (True, True)  # no object has both keys: the text names only HR2
    r = choice('{"HR2": 1, "reason": "not HR1"}')
    assert (r.ok, r.error) == (False, "ambiguous: no JSON decision and the text names several options (HR1, HR2)")


# --------------------------------------------------------------------------- pseudo-JSON


@pytest.mark.parametrize(
    "text",
    [
        "{'HR1': '0.0', 'HR2': '1.0', 'reason': 'closer'}",
        '{"HR1": "0.0", "HR2": "1.0", "reason": "closer",}',
        "{'HR1': 0, 'HR2': 1, 'reason': 'closer',}",
        '{HR1: 0, HR2: 1, reason: "closer"}',
        "{'HR1': False, 'HR2': True, 'reason': 'closer'}",
        "{\u201cHR1\u201d: \u201c0.0\u201d, \u201cHR2\u201d: \u201c1.0\u201d, \u201creason\u201d: \u201ccloser\u201d}",
        '{"HR1": "0.0", "HR2": "1.0", "reason": "closer"\n,\n}',
    ],
)
def test_pseudo_json(text):
    r = choice(text)
    assert (r.ok, r.choice, r.values, r.reason, r.fallback) == (True, 1, {"HR1": 0.0, "HR2": 1.0}, "closer", False)


def test_pseudo_json_strings_with_quotes_and_escapes():
    r = choice("{'HR1': 0, 'HR2': 1, 'reason': 'She said \"go\" and it\\'s near \\d'}")
    assert (r.ok, r.choice, r.reason) == (True, 1, 'She said "go" and it\'s near \\d')
    r = choice('{"HR1": 0, "HR2": 1, "reason": "a raw\nnewline and a bad \\escape"}')
    assert (r.ok, r.reason) == (True, "a raw\nnewline and a bad \\escape")


# --------------------------------------------------------------------------- nested and named answers


def test_nested_one_level():
    r = choice('{"decision": {"HR1": 1, "HR2": 0}, "reason": "outer"}')
    assert (r.ok, r.choice, r.values, r.reason, r.fallback) == (True, 0, {"HR1": 1.0, "HR2": 0.0}, "outer", False)
    r = choice('{"answer": {"HR1": "0", "HR2": "1", "reason": "inner"}, "reason": "outer"}')
    assert (r.choice, r.reason) == (1, "inner")


def test_two_levels_down_is_only_read_by_the_fallback():
    r = choice('{"a": {"b": {"HR1": 1, "HR2": 0}}}')
    assert (r.ok, r.choice, r.fallback) == (True, 0, True)  # the key: value pairs in the text
    r = choice('{"a": {"b": {"HR1": "high", "HR2": "low"}}}')
    assert (r.ok, r.error) == (False, "ambiguous: no JSON decision and the text names several options (HR1, HR2)")


@pytest.mark.parametrize(
    "text, index",
    [
        ('{"choice": "HR2"}', 1),
        ('{"choice": "hr 1", "reason": "r"}', 0),
        ('{"selected": 2}', 1),
        ('{"selected": 1.0}', 0),
        ('{"selected": "2"}', 1),
        ('{"decision": "HR_2"}', 1),
        ('{"answer": "I pick HR2."}', 1),
        ('{"chosen_option": "HR1"}', 0),
        ('{"result": {"choice": "HR2"}}', 1),
        ('{"Final Answer": "HR2"}', 1),
    ],
)
def test_named_choice(text, index):
    r = choice(text)
    assert (r.ok, r.choice, r.fallback) == (True, index, False)
    assert r.values == {"HR1": float(index == 0), "HR2": float(index == 1)}


@pytest.mark.parametrize(
    "text, error",
    [
        ('{"selected": 0}', "'selected' does not name one of HR1, HR2: 0"),
        ('{"choice": 3}', "'choice' does not name one of HR1, HR2: 3"),
        ('{"choice": "both"} so HR2', "'choice' does not name one of HR1, HR2: 'both'"),
        ('{"choice": "HR1 or HR2"}', "'choice' does not name one of HR1, HR2: 'HR1 or HR2'"),
        ('{"choice": true}', "'choice' does not name one of HR1, HR2: True"),
        ('{"selected": 1.5}', "'selected' does not name one of HR1, HR2: 1.5"),
    ],
)
def test_named_choice_errors(text, error):
    r = choice(text)
    assert (r.ok, r.choice, r.error) == (False, None, error)


def test_option_keys_take_precedence_over_named_answers():
    assert choice('{"choice": "HR1"} {"HR1": 0, "HR2": 1}').choice == 1


@pytest.mark.parametrize(
    "text, expected",
    [
        ('{"order": ["Recipient2", "Recipient1"]}', (1, 0)),
        ('{"order": ["recipient 1", "RECIPIENT-2"]}', (0, 1)),
        ('{"order": [2, 1]}', (1, 0)),
        ('{"delivery_order": "Recipient2, then Recipient1"}', (1, 0)),
        ('{"first": "Recipient2"}', (1, 0)),
        ('{"selected": 1}', (0, 1)),
    ],
)
def test_named_order(text, expected):
    r = order(text)
    assert (r.ok, r.order, r.choice, r.fallback) == (True, expected, expected[0], False)
    assert r.values == {RECIPIENTS[i]: float(expected.index(i) + 1) for i in range(2)}


def test_named_order_errors():
    assert (
        order('{"order": ["Recipient2", "Recipient2"]}').error
        == "'order' is not an order of Recipient1, Recipient2: ['Recipient2', 'Recipient2']"
    )
    assert order('{"order": ["Recipient2"]}').ok is False
    assert order('{"order": 12}').ok is False
    three = ("A1", "A2", "A3")
    assert parse_reply('{"first": "A2"}', three, "order").ok is False  # one name is not an order of three


# --------------------------------------------------------------------------- decision rules


@pytest.mark.parametrize(
    "hr1, hr2, index",
    [(0.3, 0.7, 1), (0.7, 0.3, 0), (2, 0, 0), (0, 5, 1), (-1, 0.5, 1), (0.51, 0.49, 0)],
)
def test_choice_takes_the_single_largest_positive_value(hr1, hr2, index):
    r = choice(json.dumps({"HR1": hr1, "HR2": hr2}))
    assert (r.ok, r.choice, r.order) == (True, index, (index, 1 - index))


@pytest.mark.parametrize(
    "hr1, hr2, error",
    [
        (1, 1, "ambiguous: HR1 and HR2 tie at 1"),
        ("1.0", "1", "ambiguous: HR1 and HR2 tie at 1"),
        (0.5, 0.5, "ambiguous: HR1 and HR2 tie at 0.5"),
        (0, 0, "ambiguous: no option has a positive value (HR1=0, HR2=0)"),
        (-1, -2, "ambiguous: no option has a positive value (HR1=-1, HR2=-2)"),
        (False, False, "ambiguous: no option has a positive value (HR1=0, HR2=0)"),
    ],
)
def test_ambiguous_choices(hr1, hr2, error):
    r = choice(json.dumps({"HR1": hr1, "HR2": hr2}))
    assert (r.ok, r.choice, r.order, r.error) == (False, None, None, error)
    assert r.values == {"HR1": float(hr1), "HR2": float(hr2)}


def test_choice_among_three():
    r = parse_reply('{"A": 0.2, "B": 0.5, "C": 0.3}', ("A", "B", "C"), "choice")
    assert (r.choice, r.order) == (1, (1, 2, 0))
    r = parse_reply('{"A": 0, "B": 1, "C": 0}', ("A", "B", "C"), "choice")
    assert (r.choice, r.order) == (1, (1, 0, 2))  # the others by index when tied
    assert parse_reply('{"A": 1, "B": 1, "C": 0}', ("A", "B", "C"), "choice").error == "ambiguous: A and B tie at 1"


@pytest.mark.parametrize(
    "r1, r2",
    [("1", "1"), ("0", "1"), ("1.5", "2"), ("1", "3"), ("2", "2"), ("-1", "1"), ("true", "false")],
)
def test_order_needs_a_permutation(r1, r2):
    r = order(f'{{"Recipient1": "{r1}", "Recipient2": "{r2}"}}')
    assert (r.ok, r.choice, r.order) == (False, None, None)
    assert r.error.startswith("not an order: the positions (Recipient1=")
    assert r.error.endswith("are not a permutation of 1..2")


def test_order_of_three():
    r = parse_reply('{"R1": "3", "R2": "1.0", "R3": 2}', ("R1", "R2", "R3"), "order")
    assert (r.ok, r.choice, r.order, r.values) == (True, 1, (1, 2, 0), {"R1": 3.0, "R2": 1.0, "R3": 2.0})


# --------------------------------------------------------------------------- fallbacks


@pytest.mark.parametrize(
    "text, index",
    [
        ("I choose HR2.", 1),
        ("hr 1", 0),
        ("The document should go to HR-2 because it is closer.", 1),
        ("**HR_1**", 0),
        ("Answer: (HR2)", 1),
    ],
)
def test_text_naming_one_option(text, index):
    r = choice(text)
    assert (r.ok, r.choice, r.values, r.fallback, r.reason) == (
        True,
        index,
        {"HR1": float(index == 0), "HR2": float(index == 1)},
        True,
        None,
    )


@pytest.mark.parametrize(
    "text, error",
    [
        ("HR1 or HR2? I choose HR2.", "ambiguous: no JSON decision and the text names several options (HR1, HR2)"),
        ("I cannot decide.", "no JSON object with the keys HR1, HR2 and no decision in the text"),
        ("HR12 and HR21", "no JSON object with the keys HR1, HR2 and no decision in the text"),
        ("THR1", "no JSON object with the keys HR1, HR2 and no decision in the text"),
        ('{"note": "no decision"}', "no JSON object with the keys HR1, HR2"),
    ],
)
def test_text_without_a_single_option(text, error):
    r = choice(text)
    assert (r.ok, r.choice, r.error) == (False, None, error)


def test_text_naming_one_option_is_not_an_order():
    r = order("Deliver to Recipient2 first.")
    assert (r.ok, r.error) == (False, "no JSON object with the keys Recipient1, Recipient2 and no decision in the text")


@pytest.mark.parametrize(
    "text, kind, options, expected",
    [
        ("HR1: 0.0\nHR2: 1.0\nreason: closer", "choice", HR, (1, {"HR1": 0.0, "HR2": 1.0})),
        (
            '{"HR1": "1.0", "HR2": "0.0", "reason": "The document is about mat',
            "choice",
            HR,
            (0, {"HR1": 1.0, "HR2": 0.0}),
        ),
        ("HR 1 = 0.2, HR 2 = 0.8", "choice", HR, (1, {"HR1": 0.2, "HR2": 0.8})),
        ("\u201cHR1\u201d: 0, \u201cHR2\u201d: 1", "choice", HR, (1, {"HR1": 0.0, "HR2": 1.0})),
        ("Recipient1: 2\nRecipient2: 1", "order", RECIPIENTS, (1, {"Recipient1": 2.0, "Recipient2": 1.0})),
        (
            '{"Recipient1": "1.0", "Recipient2": "2.0", "reason": "cut',
            "order",
            RECIPIENTS,
            (0, {"Recipient1": 1.0, "Recipient2": 2.0}),
        ),
    ],
)
def test_key_value_pairs_in_text(text, kind, options, expected):
    r = parse_reply(text, options, kind)
    assert (r.ok, r.choice, r.values, r.fallback) == (True, *expected, True)


def test_key_value_fallback_applies_the_rules():
    r = choice("HR1: 1\nHR2: 1")
    assert (r.ok, r.error, r.fallback) == (False, "ambiguous: HR1 and HR2 tie at 1", True)


# --------------------------------------------------------------------------- no content and bad arguments


@pytest.mark.parametrize("text", ["", "   ", "\n\t"])
def test_empty_reply(text):
    assert choice(text) == ParsedReply(ok=False, error="empty reply")
    assert order(text) == ParsedReply(ok=False, error="empty reply")


@pytest.mark.parametrize(
    "text, error", [(None, "reply is not a string (NoneType)"), (b"{}", "reply is not a string (bytes)")]
)
def test_non_string_reply(text, error):
    assert choice(text) == ParsedReply(ok=False, error=error)


@pytest.mark.parametrize(
    "options, kind, field",
    [
        (("HR1",), "choice", "options"),
        ("HR1HR2", "choice", "options"),
        (("HR1", "hr 1"), "choice", "options"),
        (("HR1", ""), "choice", "options"),
        (("HR1", 2), "choice", "options"),
        (HR, "rank", "kind"),
    ],
)
def test_invalid_arguments(options, kind, field):
    with pytest.raises(InputError) as info:
        parse_reply('{"HR1": 1, "HR2": 0}', options, kind)
    assert info.value.field == field


def test_huge_and_adversarial_inputs_are_quick():
    for text in ("{" * 20000, "{'" * 5000, '{"HR1": ' * 3000, "[" * 5000 + "{}", "HR1: " * 10000, "\\" * 10000):
        for kind in ("choice", "order"):
            assert parse_reply(text, HR, kind).ok in (True, False)


# --------------------------------------------------------------------------- properties


def _check_invariants(r: ParsedReply, n: int, kind: str) -> None:
    assert isinstance(r, ParsedReply)
    if r.ok:
        assert r.error == ""
        assert r.choice is not None and 0 <= r.choice < n
        assert sorted(r.order) == list(range(n)) and r.order[0] == r.choice
        assert len(r.values) == n
        if kind == "choice":
            assert r.values[list(r.values)[r.choice]] == max(r.values.values()) > 0
    else:
        assert r.error and r.choice is None and r.order is None


@given(st.text())
def test_any_text_never_raises(text):
    for kind, options in (("choice", HR), ("order", RECIPIENTS)):
        _check_invariants(parse_reply(text, options, kind), 2, kind)


_FRAGMENTS = st.sampled_from(
    [
        "{",
        "}",
        '"',
        "'",
        ",",
        ":",
        "HR1",
        "HR 2",
        "hr_2",
        "1",
        "0",
        "1.0",
        "true",
        "null",
        "```json",
        "\n",
        " ",
        "[",
        "]",
        "\\",
        "choice",
        "reason",
        "Recipient1",
        '{"HR1": ',
    ]
)


@given(st.lists(_FRAGMENTS, max_size=30).map("".join))
def test_json_like_noise_never_raises(text):
    for kind, options in (("choice", HR), ("order", RECIPIENTS)):
        _check_invariants(parse_reply(text, options, kind), 2, kind)


_NUMBERS = st.sampled_from([0, 1, 2, 0.3, 0.7, -1, 1.5])


@st.composite
def _replies(draw):
    """A reply in one of the supported spellings, with the values it encodes."""
    kind = draw(st.sampled_from(["choice", "order"]))
    stem = "HR" if kind == "choice" else "Recipient"
    values = [draw(_NUMBERS), draw(_NUMBERS)]
    sep = draw(st.sampled_from(["", " ", "_", "-"]))
    case = draw(st.sampled_from([str, str.lower, str.upper]))
    keys = [case(f"{stem}{sep}{i}") for i in (1, 2)]
    as_string = draw(st.booleans())
    shown = [f'"{v}"' if as_string else str(v) for v in values]
    quote = draw(st.sampled_from(['"', "'"]))
    body = ", ".join(f"{quote}{k}{quote}: {s}" for k, s in zip(keys, shown))
    body += draw(st.sampled_from(["", ",", f", {quote}reason{quote}: {quote}because{quote}"]))
    text = "{" + body + "}"
    text = draw(st.sampled_from(["{}", "```json\n{}\n```", "Sure!\n{}\nDone.", '{{"note": 1}} {}'])).format(text)
    return kind, (f"{stem}1", f"{stem}2"), values, text


@given(_replies())
def test_generated_replies_match_an_oracle(case):
    kind, options, values, text = case
    r = parse_reply(text, options, kind)
    assert r.values == {options[0]: float(values[0]), options[1]: float(values[1])}
    if kind == "choice":
        best = max(values)
        expected = values.index(best) if best > 0 and values.count(best) == 1 else None
    else:
        expected = values.index(1) if sorted(values) == [1, 2] else None
    assert r.choice == expected
    assert r.ok == (expected is not None) and r.fallback is False


# --------------------------------------------------------------------------- numbers name numbered options only


@pytest.mark.parametrize("text", ["1", "2", " 1.", "2\n"])
def test_digits_name_no_option_of_yes_and_no(text):
    # issue 38: with options {yes, no} (examples/tasks/loan.toml) a reply "1" or "2" is no answer the prompt offered
    r = choice(text, ("yes", "no"))
    assert not r.ok and r.choice is None
    assert choice(text, HR).ok  # the same reply names HR1 or HR2, whose keys end in their numbers


@pytest.mark.parametrize(
    ("text", "kind", "options"),
    [
        ('{"answer": 1}', "choice", ("yes", "no")),
        ('{"selected": "2"}', "choice", ("yes", "no")),
        ('{"order": [2, 1]}', "order", ("Alice", "Bob")),
        ('{"first": 2}', "order", ("Alice", "Bob")),
    ],
)
def test_json_indices_name_no_option_unless_numbered(text, kind, options):
    assert not parse_reply(text, options, kind).ok


@pytest.mark.parametrize(
    ("text", "options", "index"),
    [
        ("1", ("1", "2"), 0),
        ("2", ("1", "2"), 1),
        ("1", ("2", "1"), 1),  # keys out of order: "1" is the key "1", not the first option
        ("2", ("2", "1"), 0),
        ("3", ("1", "2", "3"), 2),
        ("2", ("Applicant 1", "Applicant 2"), 1),
        ('{"answer": 2}', ("1", "2"), 1),
        ('{"answer": 1}', ("yes", "no"), None),
        ("yes", ("yes", "no"), 0),
        ("No.", ("yes", "no"), 1),
    ],
)
def test_digits_still_name_numbered_options(text, options, index):
    r = choice(text, options)
    assert (r.ok, r.choice) == (index is not None, index)


def test_the_loan_task_reads_words_not_digits_on_every_route():
    import math

    from fairaudit.experiments import local_model as lm
    from fairaudit.experiments.exact import exact_prompt
    from fairaudit.experiments.taskfile import HR_DELIVERY, PACKAGE_DELIVERY, load_task
    from fairaudit.experiments.vlm.logprobs import decision_probabilities

    loan = load_task(ROOT / "examples" / "tasks" / "loan.toml")
    assert loan.options == ("yes", "no")

    class Tokenizer:  # one-token replies, as the in-process exact route decodes them
        pieces = ["1", "2", "yes", " no", "Yes"]

        def __len__(self):
            return len(self.pieces)

        def decode(self, ids, skip_special_tokens=False):
            return self.pieces[ids[0]]

    assert lm.token_decisions(loan, Tokenizer()).tolist() == [2, 2, 0, 1, 0]  # 2 = unparsed
    # the HTTP exact route: P(yes) = 0.3 + 0.05, P(no) = 0.1, the digits' 0.5 is unparsed (it was read as yes)
    top = [("1", math.log(0.5)), ("yes", math.log(0.3)), (" no", math.log(0.1)), ("Yes", math.log(0.05))]
    assert decision_probabilities(top, loan).round(12).tolist() == [0.35, 0.1, 0.55]
    # the built-in tasks' exact routes ask for "1" or "2" and still read them
    for task in (HR_DELIVERY, PACKAGE_DELIVERY):
        shown, answers = exact_prompt(task)
        assert answers == ("1", "2")
        assert [parse_reply(a, shown.options, shown.kind).choice for a in answers] == [0, 1]
        assert lm.token_decisions(task, Tokenizer()).tolist() == [0, 1, 2, 2, 2]
