"""A task's prompt templates: Jinja2 rendered in a sandbox (:func:`render_prompt`).

:meth:`fairaudit.experiments.vlm.tasks.DeliveryTask.prompt` renders a task's ``[prompt] user`` and ``system``
templates here, one candidate per slot (``{{ c1 }}``, ``{{ c2 }}``, ``{{ candidates }}``); the sandbox keeps a
template's output within its own size times the loops over the candidates.
"""

from __future__ import annotations

import functools
from collections.abc import Hashable, Mapping, Sequence
from typing import Any

from fairaudit import InputError, optional_modules

__all__ = ["PROMPT_FILTERS", "render_prompt"]


class _Candidate:
    """One candidate as the template sees it: a field per attribute; alone, its values joined by ", "."""

    def __init__(self, fields: Mapping[str, Any]) -> None:
        self._fields = dict(fields)

    def __getattr__(self, name: str) -> Any:
        try:
            return self.__dict__["_fields"][name]
        except KeyError:
            raise AttributeError(name) from None

    def __getitem__(self, name: str) -> Any:
        return self._fields[name]

    def __str__(self) -> str:
        return ", ".join(str(v) for v in self._fields.values())

    __repr__ = __str__  # inside a list, as ``{{ candidates }}`` alone renders it


class _Candidates(list[_Candidate]):
    """``{{ candidates }}``: the list of candidates; alone, each candidate's values, candidates joined by "; "."""

    def __str__(self) -> str:
        return "; ".join(str(c) for c in self)


PROMPT_FILTERS = ("capitalize", "default", "first", "join", "last", "length", "lower", "title", "trim", "upper")
"""The Jinja2 filters a prompt template may use; no other filter, no call, no arithmetic, no global function."""


@functools.cache
def _environment() -> Any:
    """A Jinja2 sandbox for prompts: text, variables, ``if``/``for`` and a few filters, nothing that can grow big.

    Calls (functions, methods, macros), arithmetic operators, the global functions
    (``range``, ``lipsum``, ...) and filters outside :data:`PROMPT_FILTERS` are
    refused, so a template's output stays within its own size times the loops
    over the candidates; the sandbox refuses attributes of Python objects; there
    is no loader, so ``include`` and ``extends`` reach no file.
    """
    optional_modules(
        "prompt", "needs jinja2, which is not installed: pip install 'fairness-certify[experiment]'", "jinja2"
    )
    from jinja2 import StrictUndefined
    from jinja2.exceptions import SecurityError
    from jinja2.sandbox import ImmutableSandboxedEnvironment

    class PromptUndefined(StrictUndefined):
        """A name the template asks for and the prompt does not have; a candidate's missing field is said so."""

        __slots__ = ()

        @property
        def _undefined_message(self) -> str:
            if (
                not self._undefined_hint  # the sandbox's own refusals keep their words
                and isinstance(self._undefined_obj, _Candidate)
                and isinstance(self._undefined_name, str)
            ):
                return f"a candidate has no field {self._undefined_name!r}"
            return str(super()._undefined_message)

    class PromptEnvironment(ImmutableSandboxedEnvironment):
        intercepted_binops = frozenset(["+", "-", "*", "/", "//", "%", "**"])
        intercepted_unops = frozenset(["+", "-"])

        def call_binop(self, context: Any, operator: str, left: Any, right: Any) -> Any:
            raise SecurityError(f"arithmetic ({operator}) is not allowed in a prompt")

        def call_unop(self, context: Any, operator: str, arg: Any) -> Any:
            raise SecurityError(f"arithmetic ({operator}) is not allowed in a prompt")

        def call(self, context: Any, obj: Any, *args: Any, **kwargs: Any) -> Any:
            raise SecurityError("calls are not allowed in a prompt (use a filter: " + ", ".join(PROMPT_FILTERS) + ")")

    env = PromptEnvironment(undefined=PromptUndefined, autoescape=False, keep_trailing_newline=True)
    env.filters = {name: env.filters[name] for name in PROMPT_FILTERS}
    env.tests = {name: env.tests[name] for name in ("defined", "undefined", "none", "number", "string", "in")}
    env.globals.clear()
    return env


@functools.lru_cache(maxsize=64)
def _template(env: Any, template: str) -> Any:
    """``template`` compiled once in ``env`` (a run renders the same template for every query)."""
    return env.from_string(template)


def render_prompt(template: str, context: Hashable, candidates: Sequence[Mapping[str, Any]], *, field: str) -> str:
    """Render a task's Jinja2 ``template`` for one prompt, in a sandbox.

    Parameters
    ----------
    template : str
        The ``[prompt] user`` (or ``system``) template.
    context : hashable
        ``{{ context }}``.
    candidates : sequence of mapping
        Attribute name -> the text shown, one mapping per position:
        ``{{ candidates }}`` and ``{{ c1 }}``, ``{{ c2 }}``, ...
    field : str
        Named by errors (``"prompt.user"``).

    Raises
    ------
    InputError
        Naming ``field`` when the template is not valid Jinja2, names a
        variable that does not exist, or reaches outside the sandbox; naming
        ``prompt`` when Jinja2 is not installed.

    Examples
    --------
    >>> render_prompt("{{ c1.name }} or {{ c2 }}? ({{ context }})", "job", [{"name": "Ann"}, {"name": "Bo", "age": 30}],
    ...               field="prompt.user")
    'Ann or Bo, 30? (job)'
    >>> render_prompt("One of: {{ candidates }}", "job", [{"name": "Ann", "age": 41}, {"name": "Bo", "age": 30}],
    ...               field="prompt.user")
    'One of: Ann, 41; Bo, 30'
    >>> render_prompt("{{ c1.__class__ }}", "job", [{"name": "Ann"}], field="prompt.user")
    Traceback (most recent call last):
    ...
    fairaudit.base.errors.InputError: prompt.user: cannot be rendered: access to attribute '__class__' of '_Candidate' object is unsafe. (template line 1)

    A name that does not exist is named with the template's line, and the names that do are listed:

    >>> render_prompt("Who?\\n{{ c1.agee }}", "job", [{"name": "Ann", "age": 30}], field="prompt.user")
    Traceback (most recent call last):
    ...
    fairaudit.base.errors.InputError: prompt.user: cannot be rendered: a candidate has no field 'agee' (template line 2); the variables are context, candidates, c1, and a candidate's fields are name, age ({{ c1.name }})
    """
    env = _environment()  # first: without Jinja2, one line naming the install
    from jinja2 import TemplateError, TemplateSyntaxError, UndefinedError

    shown = _Candidates(_Candidate(c) for c in candidates)
    names = {f"c{i + 1}": c for i, c in enumerate(shown)}
    try:
        return str(_template(env, template).render(context=context, candidates=shown, **names))
    except (TemplateError, TypeError, ValueError, OverflowError, RecursionError) as exc:  # include/extends: TypeError
        line = exc.lineno if isinstance(exc, TemplateSyntaxError) else _template_line(exc)
        problem = f"cannot be rendered: {exc}" + ("" if line is None else f" (template line {line})")
        if isinstance(exc, UndefinedError):
            problem += "; " + _valid_names(candidates)
        raise InputError(field, problem) from None


def _template_line(exc: BaseException) -> int | None:
    """The template's line where rendering failed: Jinja2 puts it in the traceback as a frame of ``<template>``."""
    line, tb = None, exc.__traceback__
    while tb is not None:
        if tb.tb_frame.f_code.co_filename == "<template>":
            line = tb.tb_lineno
        tb = tb.tb_next
    return line


def _valid_names(candidates: Sequence[Mapping[str, Any]]) -> str:
    """What a prompt template may name: its variables and a candidate's fields."""
    k = len(candidates)
    slots = ", ".join(f"c{i}" for i in range(1, k + 1)) if k <= 4 else f"c1 to c{k}"
    fields = list(candidates[0]) if candidates else []
    example = fields[0] if fields else "name"
    shown = f"{{{{ c1.{example} }}}}" if example.isidentifier() else f'{{{{ c1["{example}"] }}}}'
    return f"the variables are context, candidates, {slots}, and a candidate's fields are {', '.join(fields)} ({shown})"
