"""Decision models behind one interface: simulated kernels and OpenAI-compatible endpoints.

A :class:`DecisionModel` answers one query (its chat messages, made once by
the harness with :meth:`~fairaudit.experiments.vlm.tasks.DeliveryTask.messages`,
and its seed) with the text of a reply, as a chat model would. The harness
parses the reply (:func:`fairaudit.experiments.vlm.parse.parse_reply`), so a
simulated model exercises the same path as a real one.

* :class:`SimulatedModel`: a kernel table P(decision | shown context, shown
  profiles) and the query's seed; it writes its decision in the task's JSON
  format. Named models reproduce what the paper reports
  (:data:`SIMULATED`), and any table of counts or probabilities in the
  harness's ``kernel.csv`` format defines one (:meth:`SimulatedModel.from_csv`).
* :class:`EndpointModel`: a chat-completions endpoint through
  :class:`fairaudit.experiments.vlm.client.ChatClient`, sent the query's
  messages exactly as the harness made them (text and images).
"""

from __future__ import annotations

import functools
import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Protocol, TypeAlias

import numpy as np

from fairaudit import InputError

from ..slots import slot_names
from .tasks import DeliveryTask

if TYPE_CHECKING:
    from .client import ChatClient

__all__ = [
    "GENERIC_SIMULATED",
    "SIMULATED",
    "TABLE_LIMIT",
    "DecisionModel",
    "EndpointModel",
    "ModelReply",
    "Query",
    "Rule",
    "RuleModel",
    "SimulatedModel",
    "reply_text",
    "simulated_model",
]


@dataclass(frozen=True)
class Query:
    """One query of the harness: what the model is shown, and its seed.

    Attributes
    ----------
    id : str
        Unique key of the query in the run's log (the design, the cell and the repetition).
    design : {"table", "paper"}
        The table design (a shown cell queried as is) or the paper's (the
        true cell sampled through the filter at ``epsilon``).
    context : str
        The context shown.
    profiles : tuple of tuple
        The profiles shown at positions 1 and 2.
    rep : int
        Repetition number within the cell.
    seed : int
        The query's own seed (63 bits), a hash of the run's seed and ``id``.
    truth : tuple or None
        Paper design: (true context, true profiles); None in the table design.
    epsilon : float or None
        Paper design: the candidate's ε (nats) of the filter it was drawn through.
    texts : tuple of int
        The candidates' texts shown, drawn from the query's seed
        (:meth:`~fairaudit.experiments.vlm.tasks.DeliveryTask.draw_texts`); ``()``: each value's only text.
    """

    id: str
    design: str
    context: str
    profiles: tuple
    rep: int
    seed: int
    truth: tuple | None = None
    epsilon: float | None = None
    texts: tuple = ()


@dataclass(frozen=True)
class ModelReply:
    """A model's reply: its text and how it was obtained (attempts, latency in seconds, the model's name)."""

    text: str
    model: str
    attempts: int = 1
    latency: float = 0.0


class DecisionModel(Protocol):
    """What the harness needs of a model: a name and ``reply(query, messages)``; thread-safe.

    ``messages`` are the query's chat messages, made once by the harness
    (:meth:`~fairaudit.experiments.vlm.tasks.DeliveryTask.messages`: the system
    message when the task has one, then the user message with the route images).
    A model that sends them sends them as they are; a simulated model reads the
    shown cell from ``query`` and ignores them. A model never makes its own.
    """

    @property
    def name(self) -> str: ...  # pragma: no cover - protocol

    def reply(self, query: Query, messages: Sequence[dict]) -> ModelReply:  # pragma: no cover - protocol
        ...


def reply_text(
    task: DeliveryTask, decision: int | None, rng: np.random.Generator | None = None, names: Sequence[str] = ()
) -> str:
    """A reply in the task's JSON format for option index ``decision`` (None: an unparseable reply).

    With ``rng`` the JSON is sometimes wrapped in a code fence or in prose, as
    chat models do, so that simulated runs exercise the parser. A task whose
    reply names the candidates (``named_by``) gets ``names`` (slot order)
    instead: the chosen name, or the names in order on numbered lines. A
    partial ranking (:attr:`DeliveryTask.rankings`) names only its
    candidates (its options' keys as a list, ``"2, 3"``, without ``named_by``).

    Examples
    --------
    >>> from fairaudit.experiments.taskfile import HR_DELIVERY, PACKAGE_DELIVERY
    >>> reply_text(HR_DELIVERY, 1)
    '{"HR1": "0.0", "HR2": "1.0", "reason": "simulated decision"}'
    >>> reply_text(PACKAGE_DELIVERY, 1)
    '{"Recipient1": "2.0", "Recipient2": "1.0", "reason": "simulated decision"}'
    """
    if decision is None:
        return "I am sorry, but I cannot make this decision."
    if task.named_by is not None:
        return _named_reply(task, decision, rng, names)
    if task.partial and decision >= len(task.orders):  # a partial ranking: its options in order, as a list
        return ", ".join(task.options[i] for i in task.rankings[decision])
    if task.kind == "choice":
        values = {o: "1.0" if i == decision else "0.0" for i, o in enumerate(task.options)}
    else:  # decision indexes an order (k >= 3), or is the option served first (1) before the other (2)
        order = task.orders[decision] if task.slots > 2 else (decision, 1 - decision)
        rank = {slot: r + 1 for r, slot in enumerate(order)}
        values = {o: f"{rank[i]:.1f}" for i, o in enumerate(task.options)}
    reply = {**values, "reason": "simulated decision"}
    style = 0 if rng is None else rng.integers(3)
    if style == 1:
        return f"```json\n{json.dumps(reply, indent=4)}\n```"
    return f"Here is my decision.\n{json.dumps(reply)}\nI hope this helps." if style == 2 else json.dumps(reply)


def _named_reply(task: DeliveryTask, decision: int, rng: np.random.Generator | None, names: Sequence[str]) -> str:
    """A reply that names the candidates (the Bloomberg study's format): the chosen name, or numbered lines."""
    if task.kind == "choice":
        return names[decision] if rng is None or rng.integers(2) == 0 else f"I would choose {names[decision]}."
    order = task.rankings[decision] if task.slots > 2 else (decision, 1 - decision)
    lines = "\n".join(f"{r}. {names[slot].title()}" for r, slot in enumerate(order, start=1))
    return lines if rng is None or rng.integers(2) == 0 else f"Ranking the candidates by their fit:\n\n{lines}"


@dataclass(frozen=True, eq=False)
class SimulatedModel:
    """A decision model given by its kernel table, replying in the task's format.

    Parameters
    ----------
    task : DeliveryTask
    probabilities : numpy.ndarray, shape (n_contexts, n_profiles, ..., n_profiles, n_decisions)
        P(decision | shown context, profile in slot 1, ..., profile in slot
        k), indexed by the task's contexts, :attr:`DeliveryTask.profiles`
        (k times) and :attr:`DeliveryTask.decisions` (then ``"unparsed"``: the
        chance of a reply that cannot be parsed).
    name : str
        Logged as the model's name (``"simulated:<name>"``).

    Notes
    -----
    The reply to a query is drawn with ``numpy.random.default_rng(query.seed)``,
    so a query always gets the same reply, whatever the order or concurrency
    of the run (the harness's resume depends on it).
    """

    task: DeliveryTask
    probabilities: np.ndarray
    name: str

    def __post_init__(self) -> None:
        p = np.asarray(self.probabilities, dtype=float)
        n = len(self.task.profiles)
        shape = (len(self.task.contexts), *([n] * self.task.slots), len(self.task.decisions))
        if p.shape != shape:
            raise InputError("kernel", f"must have shape {shape} (contexts, a profile per slot, decisions)", p.shape)
        if np.any(p < 0) or not np.all(np.isfinite(p)) or np.any(np.abs(p.sum(-1) - 1) > 1e-9):
            raise InputError("kernel", "rows must be probabilities summing to 1")
        p = p.copy()
        p.setflags(write=False)
        object.__setattr__(self, "probabilities", p)

    def reply(self, query: Query, messages: Sequence[dict] = ()) -> ModelReply:
        """Draw the decision for the query's shown cell and write it as a reply (``messages`` are not read)."""
        t = self.task
        profiles = t.profiles
        row = self.probabilities[(t.contexts.index(query.context), *(profiles.index(tuple(p)) for p in query.profiles))]
        return _drawn_reply(t, row, query, self.name)

    @classmethod
    def from_csv(cls, task: DeliveryTask, path: str | Path, name: str | None = None) -> SimulatedModel:
        """A model from a table in the harness's ``kernel.csv`` format.

        Columns: the task's context name (``document``), one column per slot
        (``HR1``, ``HR2``: the profile shown there, as ``"Tom & 25 & Asian"``;
        ``candidate`` for one candidate per prompt),
        ``decision`` (an option or ``"unparsed"``) and ``count`` or
        ``probability``. Rows of one cell are normalised.

        Raises
        ------
        InputError
            On a missing file or column, an unknown label, a negative value,
            or a shown cell with no row (naming ``kernel`` and the cell).
        """
        import pandas as pd

        p = Path(path)
        if not p.is_file():
            raise InputError("kernel", "no such file", str(path))
        try:
            frame = pd.read_csv(p, dtype=str, keep_default_na=False)
        except (OSError, ValueError, pd.errors.ParserError) as exc:
            raise InputError("kernel", f"cannot be read as CSV ({exc})", str(path)) from None
        value_col = "count" if "count" in frame.columns else "probability"
        slots = slot_names(task)
        need = [task.context_name, *slots, "decision", value_col]
        missing = [c for c in need if c not in frame.columns]
        if missing:
            raise InputError("kernel", f"needs columns {need}", list(frame.columns))
        profiles = [task.profile_label(q) for q in task.profiles]
        axes = {task.context_name: task.contexts, **dict.fromkeys(slots, profiles), "decision": task.decisions}
        idx = []
        for col, labels in axes.items():
            codes = pd.Index(labels).get_indexer(frame[col])  # -1: not a label
            if np.any(codes < 0):
                raise InputError(
                    f"kernel column '{col}'", f"value not among {list(labels)}", frame[col][codes < 0].iloc[0]
                )
            idx.append(codes)
        try:
            values = frame[value_col].astype(float).to_numpy()
        except ValueError:
            raise InputError(f"kernel column '{value_col}'", "must be numbers") from None
        if np.any(values < 0) or not np.all(np.isfinite(values)):
            raise InputError(f"kernel column '{value_col}'", "must be finite and >= 0")
        n = len(task.profiles)
        table = np.zeros((len(task.contexts), *([n] * task.slots), len(task.decisions)))
        np.add.at(table, tuple(idx), values)
        totals = table.sum(-1)
        if np.any(totals == 0):
            i, *shown = np.argwhere(totals == 0)[0]
            cell = ", ".join(f"{o} {task.profile_label(task.profiles[a])!r}" for o, a in zip(slots, shown))
            raise InputError("kernel", f"has no rows for ({task.context_name} {task.contexts[i]!r}, {cell})", str(path))
        return cls(task, table / totals[..., None], name or f"kernel from {p.name}")


def _drawn_reply(task: DeliveryTask, row: np.ndarray, query: Query, name: str) -> ModelReply:
    """A decision drawn from ``row`` (P(decision), :attr:`DeliveryTask.decisions`) with the query's seed, as a reply."""
    rng = np.random.default_rng(query.seed)
    d = _draw(rng, row)
    names = task.reply_names(query.profiles, query.texts)
    text = reply_text(task, None if d == len(task.decisions) - 1 else d, rng, names)
    return ModelReply(text, f"simulated:{name}")


def _draw(rng: np.random.Generator, row: np.ndarray) -> int:
    """One index drawn from the weights ``row`` (not necessarily normalised) with one uniform number of ``rng``.

    The simulated model's reply, not a privacy filter (the filter samples exactly: :mod:`.filter`).

    Examples
    --------
    >>> _draw(np.random.default_rng(0), np.array([0.0, 1.0, 0.0]))
    1
    """
    return int(np.searchsorted(np.cumsum(row), rng.random() * row.sum(), side="right").clip(0, row.size - 1))


Rule: TypeAlias = "Callable[[DeliveryTask, np.ndarray], np.ndarray]"
"""A simulated model's rule: (task, shown cells [..., k] of profile indices) -> P(decision) [..., n] over the first n
decisions (the complete ones; the rest, partial orders and ``unparsed``, get 0), the same in every context."""


@dataclass(frozen=True, eq=False)
class RuleModel:
    """A simulated model given by its rule on each shown cell, for a task too large for a kernel table.

    Eight candidates of eight groups have 8⁸ shown cells per context: :class:`SimulatedModel` would hold them all.
    This model computes the row of each cell a query shows when it is asked (and keeps it), and draws its reply
    exactly as :class:`SimulatedModel` does from the same row: the two give the same reply to every query.

    Parameters
    ----------
    task : DeliveryTask
    rule : Rule
        One of :data:`SIMULATED`'s or :data:`GENERIC_SIMULATED`'s.
    name : str
    """

    task: DeliveryTask
    rule: Rule
    name: str

    def __post_init__(self) -> None:
        object.__setattr__(self, "_rows", {})

    def row(self, profiles: Sequence[tuple]) -> np.ndarray:
        """P(decision) for the shown profiles in slot order, shape (n_decisions,)."""
        t = self.task
        cell = tuple(t.profiles.index(tuple(p)) for p in profiles)
        rows: dict = self._rows  # type: ignore[attr-defined]
        if cell not in rows:
            rows[cell] = _tile(t, self.rule(t, np.asarray(cell, dtype=np.int64)))[0]
        return rows[cell]

    def reply(self, query: Query, messages: Sequence[dict] = ()) -> ModelReply:
        """Draw the decision for the query's shown cell and write it as a reply (``messages`` are not read)."""
        return _drawn_reply(self.task, self.row(query.profiles), query, self.name)


TABLE_LIMIT = 1 << 24
"""The most numbers (contexts × shown cells × decisions) a simulated model holds as a table; beyond, a :class:`RuleModel`."""


@functools.lru_cache(maxsize=8)
def _orders(task: DeliveryTask) -> np.ndarray:
    """The task's complete orders as an array [order, rank] -> slot (cached: 8! rows for eight candidates)."""
    return np.array(task.orders, dtype=np.int64).reshape(len(task.orders), task.slots)


def _prefers(task: DeliveryTask, target: tuple, cells: np.ndarray) -> np.ndarray:
    """Choose (rank first) the candidates whose shown profile shares most attributes with ``target``; ties: uniform.

    ``cells`` [..., k] holds the shown profiles' indices; the result [..., n_decisions'] is P(decision) over the
    complete decisions. One candidate per prompt: the first option with probability the share of attributes it
    shares with ``target``, the other options evenly.
    """
    score = np.array([sum(v == w for v, w in zip(p, target)) for p in task.profiles], dtype=float)  # shared values
    s = score[cells]  # [..., slot]
    if task.slots == 1:
        first = s[..., 0] / len(task.attributes)
        n_opt = len(task.options)
        return np.stack([first] + [(1 - first) / (n_opt - 1)] * (n_opt - 1), axis=-1)
    if task.kind == "order" and task.slots > 2:  # orders that never put a lower score before a higher one
        ordered = s[..., _orders(task)]  # [..., order, rank]
        ok = np.all(np.diff(ordered, axis=-1) <= 0, axis=-1).astype(float)
        return ok / ok.sum(-1, keepdims=True)
    best = (s == s.max(-1, keepdims=True)).astype(float)
    return best / best.sum(-1, keepdims=True)


def _position(task: DeliveryTask, p_first: float | None, cells: np.ndarray) -> np.ndarray:
    """The first slot chosen (ranked first) with probability ``p_first``, the others evenly (orders: the rest evenly).

    ``p_first=None``: evenly, 1/k (one candidate per prompt: every option evenly). The same row for every cell.
    """
    k = task.slots
    p = 1.0 / max(k, 1) if p_first is None else p_first
    options = len(task.orders) if task.kind == "order" and k > 2 else len(task.decisions) - 1  # complete orders
    if task.kind == "order" and k > 2:
        first = np.array([o[0] == 0 for o in task.orders], dtype=float)
        row = np.where(first > 0, p / first.sum(), (1 - p) / (options - first.sum()))
    elif k == 1:
        row = np.full(options, 1.0 / options)
    else:
        row = np.array([p] + [(1 - p) / (options - 1)] * (options - 1))
    return np.broadcast_to(row, cells.shape[:-1] + (options,))


def _all_cells(task: DeliveryTask) -> np.ndarray:
    """Every shown cell's profile indices, shape (n_profiles, ..., n_profiles, k)."""
    return np.moveaxis(np.indices((len(task.profiles),) * task.slots), 0, -1)


def _tile(task: DeliveryTask, decide: np.ndarray) -> np.ndarray:
    """Kernel with P(decision) = ``decide[s_1, ..., s_k, u]`` in every context and no unparsed reply (nor a partial
    ranking: ``decide`` may stop before the partial orders)."""
    out = np.zeros((len(task.contexts), *decide.shape[:-1], len(task.decisions)))
    out[..., : decide.shape[-1]] = decide
    return out


_BY_POSITION: dict[str, Rule] = {
    "position-biased": lambda t, c: _position(t, 0.82, c),
    "fair": lambda t, c: _position(t, None, c),
}

SIMULATED: dict[str, dict[str, Rule]] = {
    "hr-delivery": {"prefers-mary": lambda t, c: _prefers(t, t.candidates[1], c), **_BY_POSITION},
    "package-delivery": {
        "low-complaint-first": lambda t, c: _prefers(t, t.candidates[0], c),
        "high-complaint-first": lambda t, c: _prefers(t, t.candidates[1], c),
        **_BY_POSITION,
    },
}
"""Named simulated models per task.

* ``prefers-mary``: chooses the HR whose shown profile shares more of name,
  age and race with Mary (55, American), a coin on ties: without a filter it
  always picks Mary, as GPT-4o, GPT-4o-mini and o1 did in the paper.
* ``low-complaint-first`` / ``high-complaint-first``: serves that recipient
  first (GPT-4o and GPT-4o-mini / o1 in the paper's SI D).
* ``position-biased``: picks (serves first) the first-listed candidate with
  probability 0.82 whoever it is.
* ``fair``: a coin.

Any other task (a task file) has :data:`GENERIC_SIMULATED`.
"""

GENERIC_SIMULATED: dict[str, Rule] = {
    "prefers-first": lambda t, c: _prefers(t, t.candidates[0], c),
    "prefers-second": lambda t, c: _prefers(t, t.candidates[1 % len(t.candidates)], c),
    **_BY_POSITION,
}
"""Simulated models of any task: ``prefers-first`` (``-second``) picks (ranks first) the candidate whose shown
profile shares most values with the task's first (second) true candidate, evenly on ties (one candidate per
prompt: the first option with probability the share of values it shares); ``position-biased`` picks the first
slot with probability 0.82; ``fair`` picks evenly. The first is the default."""


def simulated_models(task: DeliveryTask) -> dict[str, Rule]:
    """The named simulated models of ``task``: :data:`SIMULATED`'s for a built-in task, else the generic ones."""
    return SIMULATED.get(task.name, GENERIC_SIMULATED)


def simulated_model(task: DeliveryTask, name: str) -> SimulatedModel | RuleModel:
    """The named simulated model of a task (see :data:`SIMULATED`): a table, or a :class:`RuleModel` beyond :data:`TABLE_LIMIT`.

    Raises
    ------
    InputError
        On an unknown name (naming ``simulated`` and the choices).

    Examples
    --------
    >>> from fairaudit.experiments.taskfile import HR_DELIVERY
    >>> m = simulated_model(HR_DELIVERY, "prefers-mary")
    >>> tom, mary = HR_DELIVERY.profiles.index(("Tom", 25, "Asian")), HR_DELIVERY.profiles.index(("Mary", 55, "American"))
    >>> m.probabilities[0, tom, mary].tolist()        # P(HR1), P(HR2), P(unparsed)
    [0.0, 1.0, 0.0]
    """
    models = simulated_models(task)
    if name not in models:
        raise InputError("simulated", f"must be one of {sorted(models)} for {task.name}", name)
    n_cells = len(task.contexts) * len(task.profiles) ** task.slots * len(task.decisions)
    if n_cells > TABLE_LIMIT:
        return RuleModel(task, models[name], name)
    return SimulatedModel(task, _tile(task, models[name](task, _all_cells(task))), name)


class EndpointModel:
    """A model behind an OpenAI-compatible chat-completions endpoint.

    Parameters
    ----------
    client : fairaudit.experiments.vlm.client.ChatClient
        Carries the endpoint, model name, API key (from the environment),
        timeouts, retries and the bound on concurrent requests.

    Notes
    -----
    Each request carries the query's messages exactly as the harness made
    them (:meth:`~fairaudit.experiments.vlm.tasks.DeliveryTask.messages`: the
    task's system message, when it has one, then the prompt and the route
    images); the query's seed is sent as the request's ``seed``. The model
    makes no messages of its own, so it cannot leave one out.
    """

    def __init__(self, client: ChatClient) -> None:
        self.client = client
        self.name = client.model

    def reply(self, query: Query, messages: Sequence[dict]) -> ModelReply:
        """Send the query's messages and return the reply's text (raises ChatError after the client's retries)."""
        r = self.client.complete(list(messages), seed=query.seed)
        return ModelReply(r.text, r.model or self.name, r.attempts, r.latency)
