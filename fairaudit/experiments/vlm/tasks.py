"""A decision task of an experiment: its candidates, prompt, options, outcomes and utility.

:class:`DeliveryTask` is what the experiment runs: a decision model is shown
k candidates (slots 1 to k, the options of the reply), each with a profile of
sensitive attributes, in a context, and its reply is a *choice* of one or an
*order* of all; with k = 1 it decides about one person. Tasks are written as task files
(:mod:`fairaudit.experiments.taskfile`, docs/tasks.md); the paper's two ship
with fairaudit:

* ``hr-delivery`` (paper, main text and Methods): deliver a confidential
  document about maternity, holiday or sick leave to one of two HR officers,
  Tom (25, Asian) and Mary (55, American). The reply is a *choice*:
  ``{"HR1": "0.0", "HR2": "1.0", "reason": ...}``.
* ``package-delivery`` (paper, SI D): deliver packages to two recipients, one
  with a low and one with a high complaint rate. The reply is an *order*:
  ``{"Recipient1": "2.0", "Recipient2": "1.0", "reason": ...}`` (1 = served
  first).

Per-candidate framing (docs/design.md "Decisions among several candidates"): each
query gives one record per candidate with X = (context, position), A = the
candidate's true profile and U = the candidate's own outcome, so the utility g
depends on u only (the paper's g = 1{choose a} depends on a: its error 5).

The prompt is a Jinja2 template rendered in a sandbox (:func:`fairaudit.experiments.vlm.templates.render_prompt`).
"""

from __future__ import annotations

import functools
import itertools
import math
from collections import Counter
from collections.abc import Hashable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

from fairaudit import InputError, format_label

from .messages import system_message, user_message
from .templates import render_prompt

if TYPE_CHECKING:
    import numpy as np

__all__ = ["UNPARSED", "UNPARSED_DEFAULT", "Attribute", "DeliveryTask"]

UNPARSED = "unparsed"
"""Label of the decision recorded when a reply cannot be parsed (counted, never dropped)."""

UNPARSED_DEFAULT = "default: expected g of a uniformly random reply"
""":attr:`DeliveryTask.unparsed_source` when a task file gives no ``[utility] unparsed`` (docs/tasks.md)."""


@dataclass(frozen=True)
class Attribute:
    """One sensitive attribute of a candidate's profile: a name and its ordered values."""

    name: str
    values: tuple


@dataclass(frozen=True, eq=False, kw_only=True)
class DeliveryTask:
    """A decision task about k candidates per prompt (read from a task file: :func:`fairaudit.experiments.taskfile.load_task`).

    Attributes
    ----------
    name : str
        The task's name in reports (``"hr-delivery"``, a task file's stem).
    title : str
        One line saying what is decided.
    kind : {"choice", "order"}
        A choice of one candidate, or the order in which they are served
        (task files: ``decision = "choose"`` or ``"rank"``).
    options : tuple of str
        The candidates' keys in the reply (``("HR1", "HR2")``), in position order.
    context_name : str
        What the context is (``"document"``, ``"package"``).
    contexts : tuple
        The context alphabet X (the item delivered).
    attributes : tuple of Attribute
        The profile attributes that the privacy filter randomizes.
    slots : int
        k, the candidates a prompt shows (1: a decision about one person; k ≥ 2:
        choose one of k, or rank them). ``options`` name the k slots in slot
        order (k ≥ 2) or the decision values (k = 1).
    population : {"listed", "distinct", "all"}
        Which true candidate combinations occur, uniformly: those of
        ``combinations``, or every ordered k-tuple of profiles (``"all"``).
    combinations : tuple of tuple of tuple
        The true combinations as listed (each a k-tuple of profiles; the first
        is shown in slot order in the ``fixed`` design); for ``"distinct"``
        every set of k profiles that share no value, in profile order; empty
        for ``"all"``.
    outcomes : tuple of str
        A candidate's own outcome U, then ``"unparsed"``: ``("chosen",
        "not chosen", "unparsed")`` or ``("served first", "served second",
        "unparsed")``; a ranking with :attr:`partial` has ``"unranked"``
        before ``"unparsed"``.
    utility_values : tuple of float
        g(u) for each outcome (workload, or waiting time in one-way trips).
    utility_name : str
        What g measures, for reports.
    unparsed_source : str
        Where g of ``"unparsed"`` (the last of :attr:`utility_values`) came from: ``"given"`` (a task file's
        ``[utility] unparsed``, or the caller's value), or :data:`UNPARSED_DEFAULT`, the expected g of a
        uniformly random reply (:attr:`unparsed_rule`).
    template : str
        The user prompt, a Jinja2 template (:func:`~fairaudit.experiments.vlm.templates.render_prompt`).
    system : str or None
        The system prompt, a Jinja2 template too, or None (no system message).
    shown_text : mapping or None
        Attribute name -> {value: the texts the prompt may show for it (a tuple; one is drawn per candidate and
        prompt, :meth:`texts`)}, or None (attributes without an entry show their values).
    separator : str
        Between the options' replies in the reply of a ranking's exact route (``"2, 3, 1"``; :meth:`order_reply`).
    variant_rule : {"case", "exact"}
        Which replies say an option (:mod:`fairaudit.experiments.variants`): its text's case variants, each also
        after a space (``"case"``), or its text alone (``"exact"``); a task file's ``[decision] variants``.
    variants : tuple of tuple of str
        Empty, or per option (in :attr:`options` order) the further replies the task file lists for it.
    named_by : str or None
        The attribute whose text (a person's name) the reply names each
        candidate by (:meth:`reply_names`); ``options`` are then the slots'
        numbers, labels only. None: the reply gives ``options``' keys.
    partial : bool
        A ranking's reply may leave candidates out (k ≥ 3): it ranks the
        candidates it names, in order, and the others are ``"unranked"`` (the
        Bloomberg study's rule). Their decisions follow the complete orders
        in :attr:`decisions` (:attr:`partial_orders`). False: such a reply is
        unparsed.
    replies : tuple of str
        Empty, or one text per order of :attr:`orders`: a reply is then read
        as the order whose text it begins with, else unparsed (the sampled
        twin of a ranking's exact route, which scores the same event).
    positions : {"balanced", "latin", "fixed"}
        The task file's default orders of the candidates.
    keeps, epsilons : tuple of float or None
        The task file's default budgets (keep probabilities, or the
        candidate's ε in nats), or None.
    digest : str
        SHA-256 of the task file's text ("" when made in code).
    """

    name: str
    kind: Literal["choice", "order"]
    options: tuple
    context_name: str
    contexts: tuple
    attributes: tuple
    outcomes: tuple
    utility_values: tuple
    utility_name: str
    template: str
    slots: int = 2
    population: Literal["listed", "distinct", "all"] = "listed"
    combinations: tuple = ()
    title: str = ""
    system: str | None = None
    shown_text: Mapping[str, Mapping[Hashable, str | tuple[str, ...]] | None] | None = None
    separator: str = ", "
    named_by: str | None = None
    partial: bool = False
    replies: tuple = ()
    positions: str = "balanced"
    keeps: tuple | None = None
    epsilons: tuple | None = None
    digest: str = ""
    unparsed_source: str = "given"
    variant_rule: str = "case"
    variants: tuple = ()

    @property
    def unparsed_rule(self) -> str:
        """How g of an unparsed reply was set, in words (the reports' ``utility.unparsed.rule``)."""
        if self.unparsed_source != UNPARSED_DEFAULT:
            return "given ([utility] unparsed)"
        k = self.slots
        if k == 1:
            n = len(self.options)
            return (
                f"a uniformly random reply gives each of the {n} options with probability 1/{n}: g = the mean of g "
                "over the options' outcomes (an outcome of two options counts twice)"
            )
        if self.kind == "choice":
            chosen, other = self.outcomes[:2]
            return (
                f"a uniformly random reply chooses each of the {k} candidates with probability 1/{k}: "
                f"g = 1/{k} g({chosen}) + {k - 1}/{k} g({other})"
            )
        never = ", never unranked" if self.partial else ""
        return (
            f"a uniformly random reply is one of the {math.factorial(k)} complete orders, each equally likely, so a "
            f"candidate takes each rank with probability 1/{k}{never}: g = the mean of g over ranks 1 to {k}"
        )

    @functools.cached_property
    def profiles(self) -> tuple:
        """Every profile: the tuples of attribute values in ``itertools.product`` order."""
        return tuple(tuple(t) for t in itertools.product(*(a.values for a in self.attributes)))

    @functools.cached_property
    def candidates(self) -> tuple:
        """The true profiles that occur as candidates (the groups), in order of first listing.

        Examples
        --------
        >>> from fairaudit.experiments.taskfile import HR_DELIVERY
        >>> HR_DELIVERY.candidates
        (('Tom', 25, 'Asian'), ('Mary', 55, 'American'))
        """
        if self.population == "all":
            return self.profiles
        return tuple(dict.fromkeys(tuple(p) for combo in self.combinations for p in combo))

    @functools.cached_property
    def orders(self) -> tuple:
        """The orders a ranking reply can give: permutations of the slots (0-based), ``itertools`` order."""
        return tuple(itertools.permutations(range(self.slots)))

    @functools.cached_property
    def partial_orders(self) -> tuple:
        """The orders of a reply that ranks only some candidates (:attr:`partial`): k − 1 slots down to 1, each length
        in ``itertools`` order; empty unless :attr:`partial`.

        Examples
        --------
        >>> from fairaudit.experiments.taskfile import parse_task
        >>> t = parse_task('''
        ... [task]
        ... candidates = 3
        ... decision = "rank"
        ... population = "distinct"
        ... [prompt]
        ... user = "Rank {{ candidates }}"
        ... [[attribute]]
        ... name = "group"
        ... values = ["A", "B", "C"]
        ... [decision]
        ... options = { "1" = 1, "2" = 2, "3" = 3 }
        ... partial = true
        ... [utility]
        ... values = [1, 0, 0, 0]
        ... ''')
        >>> t.partial_orders[:3], len(t.partial_orders), t.decisions[6:8], t.outcomes
        (((0, 1), (0, 2), (1, 0)), 9, ('1 > 2', '1 > 3'), ('rank 1', 'rank 2', 'rank 3', 'unranked', 'unparsed'))
        """
        if not self.partial:
            return ()
        return tuple(o for j in range(self.slots - 1, 0, -1) for o in itertools.permutations(range(self.slots), j))

    @functools.cached_property
    def rankings(self) -> tuple:
        """The order each decision of a ranking gives, in :attr:`decisions`' order: :attr:`orders`, then
        :attr:`partial_orders`."""
        return (*self.orders, *self.partial_orders)

    @functools.cached_property
    def decisions(self) -> tuple:
        """Decisions of one query, then ``"unparsed"``.

        A choice: the options. A ranking of two: the option served first. A
        ranking of k ≥ 3: each order, written ``"A > B > C"`` (:attr:`orders`),
        then each order of some of them (:attr:`partial_orders`, ``"A > C"``).
        """
        if self.kind == "order" and self.slots > 2:
            return (*(" > ".join(self.options[i] for i in o) for o in self.rankings), UNPARSED)
        return (*self.options, UNPARSED)

    @functools.cached_property
    def order_decisions(self) -> Mapping[tuple[int, ...], int]:
        """The index in :attr:`decisions` of each order of :attr:`rankings` (k ≥ 3)."""
        return {o: i for i, o in enumerate(self.rankings)}

    def texts(self, attribute: str, value: Hashable) -> tuple[Any, ...]:
        """The texts the prompt may show for ``value`` of ``attribute`` (the value itself when the task lists none).

        Examples
        --------
        >>> from fairaudit.experiments.taskfile import HR_DELIVERY
        >>> HR_DELIVERY.texts("age", 25)
        (25,)
        """
        listed = (self.shown_text or {}).get(attribute) or {}
        shown = listed.get(value, value)
        return tuple(shown) if isinstance(shown, (tuple, list)) else (shown,)

    @functools.cached_property
    def varies(self) -> bool:
        """True when some value has several texts, so that each prompt draws its candidates' texts."""
        return any(len(self.texts(a.name, v)) > 1 for a in self.attributes for v in a.values)

    def text_choices(self, profiles: Sequence[tuple]) -> Iterator[tuple[int, ...]]:
        """Every choice of the candidates' texts in one prompt, each equally likely (the kernel averages over them).

        A choice is a flat tuple of indices into :meth:`texts`, slot by slot and attribute by attribute within a
        slot. Two candidates who share a value are shown different texts of it whenever the value has texts
        enough for all of them (so that a reply can name each, as a person's name does); else any.

        Examples
        --------
        >>> from fairaudit.experiments.taskfile import parse_task
        >>> task = parse_task('''[task]
        ... candidates = 2
        ... [prompt]
        ... user = "{{ c1.name }} or {{ c2.name }}?"
        ... [[attribute]]
        ... name = "name"
        ... values = ["A", "B"]
        ... text = { A = ["Ann", "Amy"], B = ["Bo"] }
        ... [decision]
        ... options = { "1" = 1, "2" = 2 }
        ... [utility]
        ... values = { chosen = 1, "not chosen" = 0 }''')
        >>> list(task.text_choices([("A",), ("A",)]))
        [(0, 1), (1, 0)]
        >>> list(task.text_choices([("A",), ("B",)]))
        [(0, 0), (1, 0)]
        """
        keys = [(j, v) for p in profiles for j, v in enumerate(p)]  # (attribute, value) of each index, slot-major
        counts = [len(self.texts(self.attributes[j].name, v)) for j, v in keys]
        groups = [[at for at, other in enumerate(keys) if other == key] for key in set(keys)]  # who shares a value
        distinct = [idx for idx in groups if len(idx) > 1 and counts[idx[0]] >= len(idx)]
        for choice in itertools.product(*(range(n) for n in counts)):
            if all(len({choice[i] for i in idx}) == len(idx) for idx in distinct):
                yield choice

    def text_choice_count(self, profiles: Sequence[tuple]) -> int:
        """How many choices :meth:`text_choices` lists, without listing them: n!/(n−m)! for m candidates who share
        a value of n ≥ m texts, else n^m, multiplied over the attributes' values.

        Examples
        --------
        >>> from fairaudit.experiments.taskfile import HR_DELIVERY
        >>> HR_DELIVERY.text_choice_count(HR_DELIVERY.candidates)
        1
        """
        shared = Counter((j, v) for p in profiles for j, v in enumerate(p))  # m candidates share (j, v)
        sizes = ((len(self.texts(self.attributes[j].name, v)), m) for (j, v), m in shared.items())
        return math.prod(math.perm(n, m) if m > 1 and n >= m else n**m for n, m in sizes)

    def draw_texts(self, profiles: Sequence[tuple], rng: np.random.Generator) -> tuple[int, ...]:
        """One choice of :meth:`text_choices`, uniformly at random, without listing them.

        Slot by slot: a value's text is drawn uniformly, among those not yet shown in this prompt when the value
        has texts enough for every candidate who shares it (uniform draws without replacement give every
        injective choice the same probability, so the draw is uniform over :meth:`text_choices`), from ``rng``, the
        query's generator (the harness seeds it from the query's seed).

        Returns
        -------
        tuple of int
            k × n_attributes indices into :meth:`texts`, slot-major; ``()`` when no value has several texts
            (:attr:`varies`).
        """
        if not self.varies:
            return ()
        out: list[int] = []
        used: dict[tuple[int, Hashable], set[int]] = {}
        shared = Counter((j, v) for p in profiles for j, v in enumerate(p))
        for p in profiles:
            for j, (a, v) in enumerate(zip(self.attributes, p)):
                n = len(self.texts(a.name, v))
                taken = used.setdefault((j, v), set())
                if shared[(j, v)] > 1 and n >= shared[(j, v)]:
                    free = [t for t in range(n) if t not in taken]
                    pick = free[int(rng.integers(len(free)))]
                else:
                    pick = int(rng.integers(n))
                taken.add(pick)
                out.append(pick)
        return tuple(out)

    def prompt(self, context: str, profiles: Sequence[tuple], texts: Sequence[int] = ()) -> str:
        """The user prompt for one query: the context and the profiles shown in slots 1 to k.

        ``texts`` is a choice of :meth:`text_choices` (default: each value's first text).

        Raises
        ------
        InputError
            If the context or a profile is not in the task's alphabets, or the
            template does not render (naming ``prompt.user``).

        Examples
        --------
        >>> from fairaudit.experiments.taskfile import HR_DELIVERY
        >>> text = HR_DELIVERY.prompt("sick leave", [("Tom", 25, "Asian"), ("Mary", 55, "American")])
        >>> [line for line in text.splitlines() if line.startswith(("Item", "HR1:", "HR2:"))]
        ['Item to be delivered: a confidential document concerning sick leave.', 'HR1: Tom, 25 years old, Asian.', 'HR2: Mary, 55 years old, American.']
        """
        return self._render(self.template, "prompt.user", context, profiles, texts)

    def system_prompt(self, context: str, profiles: Sequence[tuple], texts: Sequence[int] = ()) -> str | None:
        """The system prompt for one query (None when the task has none)."""
        if self.system is None:
            return None
        return self._render(self.system, "prompt.system", context, profiles, texts)

    def messages(
        self, context: str, profiles: Sequence[tuple], texts: Sequence[int] = (), images: Sequence[bytes] = ()
    ) -> list[dict[str, Any]]:
        """The chat messages of one query: the system message when the task has one, then the user message.

        The one place a query's messages are made: the harness hands them to every decision model (a simulated
        one ignores them, an endpoint sends them as they are), and both exact routes (in process through the
        tokenizer's chat template, and over HTTP) score them, so every route of a cell sends the same bytes
        (docs/experiments.md, "The messages of a query").

        Parameters
        ----------
        context : str
            One of :attr:`contexts`.
        profiles : sequence of tuple
            The k profiles shown, slot by slot.
        texts : sequence of int
            A choice of :meth:`text_choices` (default: each value's first text).
        images : sequence of bytes
            Encoded PNG images (the route images), after the user prompt's text.

        Returns
        -------
        list of dict
            ``[{"role": "system", "content": system prompt}, user message]``, or the user message alone when the
            task has no system prompt; the user message is
            :func:`~fairaudit.experiments.vlm.messages.user_message`'s (its content a string without images, else a
            text part then one ``image_url`` part per image).

        Raises
        ------
        InputError
            As :meth:`prompt` and :meth:`system_prompt`; an image that is not non-empty bytes.

        Examples
        --------
        >>> from fairaudit.experiments.taskfile import parse_task
        >>> t = parse_task('''
        ... [task]
        ... candidates = 1
        ... population = "all"
        ... [prompt]
        ... system = "Answer yes or no."
        ... user = "Approve {{ c1.name }}?"
        ... [[attribute]]
        ... name = "name"
        ... values = ["Ann", "Bo"]
        ... [decision]
        ... options = { yes = "approved", no = "denied" }
        ... [utility]
        ... values = { approved = 1.0, denied = 0.0 }
        ... ''', name="t")
        >>> t.messages(t.contexts[0], [("Bo",)])
        [{'role': 'system', 'content': 'Answer yes or no.'}, {'role': 'user', 'content': 'Approve Bo?'}]
        """
        system = self.system_prompt(context, profiles, texts)
        user = user_message(self.prompt(context, profiles, texts), images)
        return [user] if system is None else [system_message(system), user]

    def shown_names(self, profiles: Sequence[tuple], texts: Sequence[int] = ()) -> list[dict[str, Any]]:
        """What the prompt shows of each candidate: attribute name -> text, slot by slot.

        Parameters
        ----------
        profiles : sequence of tuple
            The k profiles shown.
        texts : sequence of int
            A choice of :meth:`text_choices` (k × n_attributes indices, slot-major); ``()``: each value's first.

        Returns
        -------
        list of dict
            One ``{attribute name: text}`` per slot, as the template sees ``c1``, ``c2``, ...

        Raises
        ------
        InputError
            ``texts`` of the wrong length.
        """
        n_attr = len(self.attributes)
        if texts and len(texts) != len(profiles) * n_attr:
            raise InputError("texts", f"needs one index per candidate and attribute ({len(profiles) * n_attr})", texts)
        return [
            {
                a.name: self.texts(a.name, v)[texts[i * n_attr + j] if texts else 0]
                for j, (a, v) in enumerate(zip(self.attributes, p))
            }
            for i, p in enumerate(profiles)
        ]

    def reply_names(self, profiles: Sequence[tuple], texts: Sequence[int] = ()) -> tuple[str, ...]:
        """What the reply calls each candidate of one prompt: its :attr:`named_by` text, or else the option key.

        Examples
        --------
        >>> from fairaudit.experiments.taskfile import HR_DELIVERY
        >>> HR_DELIVERY.reply_names(HR_DELIVERY.candidates)
        ('HR1', 'HR2')
        """
        if self.named_by is None:
            return tuple(self.options)
        return tuple(str(shown[self.named_by]) for shown in self.shown_names(profiles, texts))

    def order_reply(self, order: Sequence[int], answers: Sequence[str]) -> str:
        """The reply that gives ``order`` (0-based slots, best first) on a ranking's exact route: ``"2, 3, 1"``.

        Examples
        --------
        >>> from fairaudit.experiments.taskfile import HR_DELIVERY
        >>> HR_DELIVERY.order_reply((1, 0), ("1", "2"))
        '2, 1'
        """
        return self.separator.join(answers[i] for i in order)

    def _render(
        self, template: str, field: str, context: str, profiles: Sequence[tuple], texts: Sequence[int] = ()
    ) -> str:
        if context not in self.contexts:
            raise InputError(self.context_name, f"must be one of {list(self.contexts)}", context)
        if len(profiles) != self.slots:
            raise InputError("profiles", f"needs one profile per candidate ({self.slots})", list(profiles))
        known = set(self.profiles)
        for p in profiles:
            if tuple(p) not in known:
                raise InputError("profiles", f"not a profile of {self.name}", p)
        return render_prompt(template, context, self.shown_names(profiles, texts), field=field)

    def profile_label(self, profile: tuple) -> str:
        """A profile as one text label (``"Tom & 25 & Asian"``), as tables and specs write it."""
        return format_label(tuple(profile))
