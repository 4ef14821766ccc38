"""The exact routes' prompt (:func:`~fairaudit.experiments.exact.answer_task`): the task's scene, a request for the
option's number alone, and the replies it asks for read by the harness's parser."""

from __future__ import annotations

import pytest

from fairaudit.experiments.exact import answer_task
from fairaudit.experiments.taskfile import HR_DELIVERY, PACKAGE_DELIVERY
from fairaudit.experiments.vlm.parse import parse_reply


@pytest.mark.parametrize("task", [HR_DELIVERY, PACKAGE_DELIVERY], ids=lambda t: t.name)
def test_answer_prompt_keeps_the_scene_and_asks_for_the_number(task):
    t = answer_task(task)
    c1, c2 = task.candidates
    full, short = task.prompt(task.contexts[0], (c1, c2)), t.prompt(task.contexts[0], (c1, c2))
    head = full.split("\n\nRespond by")[0]
    assert short.startswith(head) and "JSON" not in short
    assert short.endswith("\nAnswer:") and "1 to " in short and task.options[1] in short.splitlines()[-2]
    assert (t.name, t.options, t.contexts, t.profiles) == (task.name, task.options, task.contexts, task.profiles)
    for digit, index in (("1", 0), ("2", 1)):  # the one-token replies the prompt asks for
        r = parse_reply(digit, t.options, t.kind)
        assert (r.ok, r.choice, r.fallback) == (True, index, True)


@pytest.mark.parametrize(
    "text, ok",
    [
        ("1", True),
        (" 2.", True),
        ("2\n", True),
        ("3", False),
        ("0", False),
        ("12", False),
        ("１", False),
        ("1 2", False),
    ],
)
def test_bare_number_replies(text, ok):
    for options, kind in ((HR_DELIVERY.options, "choice"), (PACKAGE_DELIVERY.options, "order")):
        assert parse_reply(text, options, kind).ok is ok
