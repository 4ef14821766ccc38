"""Every way a model says an option (issue 82): the variants, their sums on the exact routes, the coverage.

The stand-in server (tests/_chat_server.py) answers from a known law over whole replies, the same in every cell:
"yes" 0.30, "Yes" 0.20, " yes" 0.10, "No" 0.15, "no" 0.05, "maybe" 0.12, "Approve" 0.03, and "Yes" "," " approve"
0.02 (a reply that begins with "Yes"); the reply ends at once with the rest, 0.03. The kernels below are those
masses added by hand: P(yes) = 0.30 + (0.20 + 0.02) + 0.10, P(no) = 0.15 + 0.05, the rest unparsed.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from _chat_server import ChatServer
from _cli import run

from fairaudit import InputError
from fairaudit.experiments.endpoint import endpoint_kernel
from fairaudit.experiments.taskfile import parse_task
from fairaudit.experiments.variants import case_variants, decision_variants, reply_decision
from fairaudit.experiments.vlm.client import ChatClient

LOAN = (Path(__file__).resolve().parents[2] / "examples" / "tasks" / "loan.toml").read_text()
TABLE = 'options = { yes = "approved", no = "denied" }'
LISTED = (
    'options = [{ text = "yes", slot = "approved", variants = ["Yes, approve", "Approve"] }, '
    '{ text = "no", slot = "denied" }]'
)
PATHS = {
    ("yes",): 0.30,
    ("Yes",): 0.20,
    (" yes",): 0.10,
    ("No",): 0.15,
    ("no",): 0.05,
    ("maybe",): 0.12,
    ("Approve",): 0.03,
    ("Yes", ",", " approve"): 0.02,
}


def _tree(paths):
    """The next-token law after each prefix of a law over token paths {tokens: mass} (the rest of the mass ends)."""
    mass: dict[str, float] = {}
    for tokens, q in paths.items():
        for i in range(len(tokens) + 1):
            mass["".join(tokens[:i])] = mass.get("".join(tokens[:i]), 0.0) + q
    law: dict[str, list] = {}
    for tokens, q in paths.items():
        for i, token in enumerate(tokens):
            prefix = "".join(tokens[:i])
            step = (token, mass[prefix + token] / (mass[prefix] if prefix else 1.0))
            if step not in law.setdefault(prefix, []):
                law[prefix].append(step)
    return law


def _task(options=TABLE, rule=None):
    text = LOAN.replace(TABLE, options)
    if rule is not None:
        text = text.replace("[decision]\n", f'[decision]\nvariants = "{rule}"\n')
    return parse_task(text, "loan.toml", "loan")


def _kernel(task, mode="serve"):
    with ChatServer(law=lambda body: _tree(PATHS), prompt_logprobs_mode=mode) as server:
        with ChatClient(server.url, "m", max_tokens=1, top_logprobs=20, max_concurrency=4) as client:
            return endpoint_kernel(task, client)


def test_the_default_variants_are_the_case_forms_then_each_after_a_space():
    assert case_variants("yes") == ("yes", "Yes", "YES", " yes", " Yes", " YES")
    assert case_variants("Office A") == ("Office A", "office a", "OFFICE A", " Office A", " office a", " OFFICE A")
    task = _task(rule="exact")
    assert decision_variants(task, ("yes", "no")) == (("yes",), ("no",))


@pytest.mark.parametrize("mode", ["serve", "ignore"])
def test_the_kernel_is_the_sum_of_the_variants_masses(mode):
    """prompt log-probabilities (vLLM) and top log-probabilities (llama-server) alike; coverage 0.80 by hand."""
    made = _kernel(_task(), mode)
    p = made.probabilities.reshape(-1, 3)
    yes, no = 0.30 + (0.20 + 0.02) + 0.10, 0.15 + 0.05
    np.testing.assert_allclose(p, np.tile([yes, no, 1 - yes - no], (len(p), 1)), rtol=0, atol=1e-9)
    if mode == "ignore":  # the top list names the likeliest replies that say no option
        assert [t for t, _ in made.unparsed] == ["maybe", "Approve"]
        assert made.unparsed[0][1] == pytest.approx(0.12, abs=1e-12)


def test_exact_variants_count_the_options_own_texts_only():
    p = _kernel(_task(rule="exact")).probabilities.reshape(-1, 3)
    np.testing.assert_allclose(p[0], [0.30, 0.05, 0.65], rtol=0, atol=1e-9)


def test_listed_variants_add_and_a_variant_that_begins_with_another_is_not_counted_twice():
    """ "Yes, approve" begins with "Yes": P(the reply begins with "Yes") holds its 0.02 already; "Approve" adds 0.03."""
    task = _task(LISTED)
    yes_variants, _ = decision_variants(task, ("yes", "no"))
    assert "Yes, approve" not in yes_variants and "Approve" in yes_variants and " Approve" in yes_variants
    p = _kernel(task).probabilities.reshape(-1, 3)
    yes, no = 0.30 + 0.22 + 0.10 + 0.03, 0.20
    np.testing.assert_allclose(p[0], [yes, no, 1 - yes - no], rtol=0, atol=1e-9)
    exact = _task(LISTED, rule="exact")  # no "Yes" variant: "Yes, approve" is scored, 0.02
    np.testing.assert_allclose(_kernel(exact).probabilities.reshape(-1, 3)[0], [0.35, 0.05, 0.60], atol=1e-9)


def test_a_sampled_reply_is_read_by_its_variants():
    task = _task(LISTED)
    assert [reply_decision(task, r) for r in ("Yes", " YES ", "approve", "Yes, approve", "No", "maybe")] == [
        0,
        0,
        0,
        0,
        1,
        None,
    ]
    assert reply_decision(_task(LISTED, rule="exact"), "YES") is None


def test_a_variant_two_options_share_is_refused_naming_both():
    shared = LISTED.replace('"Approve"]', '"No"]')
    with pytest.raises(InputError) as err:
        _task(shared)
    assert str(err.value) == (
        "loan.toml: decision.options[0].variants: 'no' would say both 'yes' and 'no': a reply may say one option "
        "only; drop it, or set variants = \"exact\" when the options differ only in case (got 'no')"
    )
    with pytest.raises(InputError, match=r"decision.options: 'YES' would say both 'yes' and 'YES'"):
        _task('options = { yes = "approved", YES = "denied" }')
    assert _task('options = { yes = "approved", YES = "denied" }', rule="exact").options == ("yes", "YES")


def test_a_list_entry_is_checked_field_by_field():
    with pytest.raises(InputError, match=r"decision.options\[0\].variants\[1\]: string should have at least 1"):
        _task(LISTED.replace('"Approve"', '""'))
    with pytest.raises(InputError, match=r"decision.options\[1\].slot: field required"):
        _task(LISTED.replace(', slot = "denied"', ""))


@pytest.mark.parametrize(("threshold", "warned"), [(None, True), ("0.75", False)])
def test_the_coverage_is_recorded_and_warned_below_the_threshold(threshold, warned, tmp_path, capsys):
    task_path, out = tmp_path / "loan.toml", tmp_path / "run"
    task_path.write_text(LOAN)
    flags = [] if threshold is None else ["--min-coverage", threshold]
    with ChatServer(law=lambda body: _tree(PATHS), prompt_logprobs_mode="ignore") as server:
        code, _, err = run(
            capsys, "experiment", task_path, "--endpoint", server.url, "--model", "m", "--exact", "--no-progress",
            "--out", out, *flags,
        )  # fmt: skip
    assert code == 0, err
    scoring = json.loads((out / "certificate.json").read_text())["run"]["scoring"]
    assert scoring["variants"]["replies"]["yes"] == list(case_variants("yes"))
    coverage = scoring["coverage"]
    assert coverage["min"] == pytest.approx(0.82, abs=1e-9) and coverage["mean"] == pytest.approx(0.82, abs=1e-9)
    assert coverage["threshold"] == (0.99 if threshold is None else 0.75)
    lines = [line for line in err.splitlines() if "warning: coverage" in line]
    if warned:
        assert lines == [f"fairaudit: warning: {coverage['warning']}"]
        assert lines[0].startswith("fairaudit: warning: coverage 0.82 (mean 0.82) is below 0.99")
        assert "'maybe' 0.12" in lines[0]
    else:
        assert lines == [] and coverage["warning"] is None
    assert "on them (coverage) is 0.82 at least" in (out / "report.md").read_text()
