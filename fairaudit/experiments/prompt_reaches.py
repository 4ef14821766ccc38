"""Whether a task's prompt shows what it must: each attribute of each candidate, and the context (docs/tasks.md).

:func:`check_prompt_reaches` renders a few cells of the table design and refuses, in one line, a task whose prompts
do not change with an attribute or the context, naming the template line that looks like a Python-style placeholder.
"""

from __future__ import annotations

import re
from collections.abc import Hashable
from typing import Any

from fairaudit import InputError, format_label

from .vlm.tasks import DeliveryTask

__all__ = ["check_prompt_reaches"]


def check_prompt_reaches(task: DeliveryTask) -> None:
    """Refuse a task whose prompts do not show each attribute of each candidate, or the context.

    The messages of a query are its system and user messages together. For
    every context, slot i and attribute: the first shown cell of the table
    design (every slot showing the first profile) and the cell that differs
    from it only in that attribute of slot i (its second value) must render
    differently, each value written with its first text; and the first cells
    of any two contexts must render differently. That is 1 + k × n_attributes
    renders per context, never the table.

    Parameters
    ----------
    task : DeliveryTask
        Its templates (:attr:`~DeliveryTask.template`, :attr:`~DeliveryTask.system`) already render.

    Raises
    ------
    InputError
        Naming ``prompt.user`` (``prompt.system`` when the placeholder found is
        there): the first attribute and slot (or the context) that never
        reaches the prompt, the template line that looks like a Python-style
        placeholder (``{age}``, ``{c1.age}``) when there is one, and the
        Jinja2 to write instead (``{{ c1.age }}``).

    Examples
    --------
    >>> from fairaudit.experiments.taskfile import parse_task
    >>> parse_task('''
    ... [prompt]
    ... user = "Who? 1: {{ c1.name }}, {age}. 2: {{ c2.name }}, {age}."
    ... [[attribute]]
    ... name = "name"
    ... values = ["Ann", "Bo"]
    ... [[attribute]]
    ... name = "age"
    ... values = [30, 60]
    ... [decision]
    ... options = { "1" = 1, "2" = 2 }
    ... [utility]
    ... values = [1, 0]
    ... ''')
    Traceback (most recent call last):
    ...
    fairaudit.base.errors.InputError: <string>: prompt.user: the attribute 'age' of candidate 1 never reaches the prompt (nor that of candidate 2): two cells that differ only in it render the same; the line looks like a Python-style placeholder, which Jinja2 leaves as text: write {{ c1.age }} (got 'Who? 1: {{ c1.name }}, {age}. 2: {{ c2.name }}, {age}.')
    """
    base = task.profiles[0]
    cell = (base,) * task.slots

    def messages(context: Any, shown: tuple) -> tuple[str | None, str]:
        return task.system_prompt(context, shown), task.prompt(context, shown)

    first = {context: messages(context, cell) for context in task.contexts}
    missing: dict[tuple[int, int], list[Hashable]] = {}
    for j, attribute in enumerate(task.attributes):
        changed = (*base[:j], attribute.values[1], *base[j + 1 :])  # base holds every attribute's first value
        for i in range(task.slots):
            shown = (*cell[:i], changed, *cell[i + 1 :])
            same = [c for c in task.contexts if messages(c, shown) == first[c]]
            if same:
                missing[(i, j)] = same
    if missing:
        raise _not_shown(task, missing)
    seen: dict[tuple[str | None, str], Hashable] = {}
    for context, rendered in first.items():
        if rendered in seen:
            raise _context_not_shown(task, seen[rendered], context)
        seen[rendered] = context


def _not_shown(task: DeliveryTask, missing: dict[tuple[int, int], list[Hashable]]) -> InputError:
    """The error of the first (slot, attribute) whose cells render alike: which, where, and what to write."""
    (i, j), same = next(iter(missing.items()))
    name = task.attributes[j].name
    others = [f"candidate {s + 1}" for (s, a) in missing if a == j and s != i]
    more = [f"{task.attributes[a].name!r} of candidate {s + 1}" for (s, a) in missing if a != j]
    also = ""
    if others or more:
        listed = [f"that of {', '.join(others)}"] if others else []
        listed += more[:3] + ([f"{len(more) - 3} more"] if len(more) > 3 else [])
        also = f" (nor {'; '.join(listed)})"
    where = (
        "never reaches the prompt"
        if len(same) == len(task.contexts)
        else f"does not reach the prompt when the {task.context_name} is {format_label(same[0])!r}"
    )
    problem = (
        f"the attribute {name!r} of candidate {i + 1} {where}{also}: two cells that differ only in it render the same"
    )
    hint = f"{{{{ c{i + 1}.{name} }}}}" if name.isidentifier() else f'{{{{ c{i + 1}["{name}"] }}}}'
    return _unreached(problem, hint, _placeholder_line(task, (name,), i))


def _context_not_shown(task: DeliveryTask, first: Hashable, second: Hashable) -> InputError:
    """The error of two contexts whose cells render alike."""
    what = task.context_name
    problem = (
        f"the {what} never reaches the prompt: two cells that differ only in it ({format_label(first)!r} and "
        f"{format_label(second)!r}) render the same"
    )
    return _unreached(problem, "{{ context }}", _placeholder_line(task, tuple(dict.fromkeys(("context", what))), None))


def _unreached(problem: str, hint: str, found: tuple[str, str] | None) -> InputError:
    """The error of something that never reaches the prompt: the Python-style line that was meant to show it, if any."""
    if found is None:
        return InputError("prompt.user", f"{problem}; show it with {hint}")
    field, line = found
    return InputError(
        field,
        f"{problem}; the line looks like a Python-style placeholder, which Jinja2 leaves as text: write {hint}",
        line,
    )


def _placeholder_line(task: DeliveryTask, names: tuple[str, ...], slot: int | None) -> tuple[str, str] | None:
    """The first template line with a Python-style placeholder of one of ``names`` (``{age}``, ``{c1.age}``,
    ``{ c1["age"] }``), preferring one that names slot ``slot``'s ``c<slot+1>``: (its field, the line), or None."""
    owner = None if slot is None else f"c{slot + 1}"
    found = [
        (field, line.strip(), (m.group("owner") or "").lower() == owner)
        for field, template in (("prompt.user", task.template), ("prompt.system", task.system))
        for line in (template or "").splitlines()
        for m in _placeholders(names).finditer(line)
    ]
    return next(((field, line) for field, line, mine in found if mine), found[0][:2] if found else None)


def _placeholders(names: tuple[str, ...]) -> re.Pattern[str]:
    """Single braces around one of ``names``, alone or after an owner (``c1.``, ``candidate[``), not Jinja2's ``{{``."""
    name = "|".join(re.escape(n) for n in names)
    return re.compile(
        r"(?<!\{)\{\s*(?:(?P<owner>\w+)\s*(?:\.|\[\s*['\"]?)\s*)?(?:"
        + name
        + r")\s*['\"]?\s*\]?\s*(?:![rsa])?(?::[^{}]*)?\}(?!\})",
        re.IGNORECASE,
    )
