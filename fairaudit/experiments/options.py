"""What an experiment runs on and how: the model source and the run options of :func:`~fairaudit.experiments.run.run_experiment`.

:class:`ModelSource` names where the decisions come from (a simulated model,
a kernel table, an OpenAI-compatible endpoint or a language model run on this
machine); :class:`RunOptions` holds everything else about the run (the
design, the samples, the privacy budgets, the seed, resuming, the bands, the
images). Both are frozen and check their own fields when made, so a bad value
is refused before anything is written.

Errors name the fields (``samples``, ``epsilons``, ``endpoint``), as the
parameters of :func:`~fairaudit.experiments.run.run_experiment` they are;
a parameter mentioned in a problem is written in backticks (```endpoint```).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from fairaudit import InputError, choice, real, whole

from .vlm.client import CONSTRAINTS

__all__ = [
    "CONSTRAINTS",
    "DEFAULT_GOALS",
    "DEFAULT_KEEPS",
    "DEFAULT_MAX_TOKENS",
    "DEFAULT_START",
    "DEFAULT_TARGETS",
    "DEFAULT_TOLERANCE",
    "PLAIN_SAMPLING",
    "ModelSource",
    "RunOptions",
]

DEFAULT_TARGETS = (0.05, 0.1, 0.25, 0.5)
"""Fairness targets (nats) at which an experiment reports the privacy budget that meets them."""

DEFAULT_KEEPS = (0.5, 0.6, 0.7, 0.8, 0.9)
"""Keep probabilities per attribute of the default ε grid (the paper varied p)."""

DEFAULT_START = "lobby_1"
"""The room the route images start from (:attr:`RunOptions.start`)."""

DEFAULT_GOALS = ("office_1", "office_2")
"""The rooms the route images go to, HR1 and HR2 (:attr:`RunOptions.goals`)."""

DEFAULT_TOLERANCE = 0.05
"""The equal-distance check's largest relative difference of the route lengths (:attr:`RunOptions.tolerance`)."""

_SOURCES = ("simulated", "kernel", "endpoint", "local_model")

DEFAULT_MAX_TOKENS = 1024
"""``max_tokens`` of an endpoint's sampled route when none is given: room for a JSON decision and its reason."""

SAMPLING_FIELDS = ("temperature", "top_p", "max_tokens", "constrain")
"""The sampling settings a run states, logs and refuses to change on resume."""


PLAIN_SAMPLING = {"temperature": 1.0, "top_k": 0, "top_p": 1.0, "min_p": 0.0}
"""Request fields that make a server sample from the model's whole softmax (``sampled_twin``): no truncation."""


@dataclass(frozen=True, kw_only=True)
class ModelSource:
    """Where an experiment's decisions come from: one of four sources (default: a simulated model).

    Parameters
    ----------
    simulated : str, optional
        A named simulated model (:data:`fairaudit.experiments.vlm.models.SIMULATED`);
        the default source, with the task's first model, when nothing is given.
    kernel : str or Path, optional
        A simulated model from a kernel table (a run's ``kernel.csv``).
    endpoint : str, optional
        An OpenAI-compatible endpoint URL (API key from ``OPENAI_API_KEY``), with ``model``.
    model : str, optional
        The model's name at ``endpoint``.
    local_model : str, optional
        A real language model run on this machine, text only: a key of
        :data:`fairaudit.experiments.model_files.LOCAL_MODELS`, a transformers
        causal-LM folder or a ``.gguf`` file
        (:func:`fairaudit.experiments.model_files.model_kind`).
    exact : bool
        The exact route: the model's kernel from its first-token
        log-probabilities, one request per shown cell and no sampling
        (``endpoint``: the server must return ``logprobs``; see
        :mod:`fairaudit.experiments.vlm.logprobs`), text only. Needs
        ``endpoint`` or ``local_model``, and goes without ``samples``
        (:class:`RunOptions`). A local model takes the exact route whenever
        ``samples`` is not given, with or without ``exact``.
    sampled_twin : bool
        The sampled twin of the exact route, to check it: each reply is one
        token (``max_tokens: 1``) drawn from the whole softmax
        (:data:`PLAIN_SAMPLING`: temperature 1 and no top-k, top-p or min-p
        truncation) for the exact route's prompt
        (:func:`fairaudit.experiments.exact.exact_prompt`). Needs
        ``endpoint``; the server must accept ``top_k`` and ``min_p``
        (llama-server, vLLM; OpenAI's API refuses them).
    timeout : float
        Seconds per request (an endpoint, or a local model's server).
    max_retries : int
        Retries on 429, 5xx and timeouts.
    temperature : float, optional
        The sampled route's ``temperature`` (finite, >= 0); default 1. Every request states it.
    top_p : float, optional
        The sampled route's ``top_p``, in (0, 1]; default 1 (no nucleus truncation).
    max_tokens : int, optional
        The sampled route's ``max_tokens``, >= 1; default :data:`DEFAULT_MAX_TOKENS` (1024) for an endpoint and 1
        for a local model (its one-token replies to the exact route's prompt). ``temperature``, ``top_p`` and
        ``max_tokens`` need a sampled route of ``endpoint`` or ``local_model`` (not ``sampled_twin``, whose
        settings are fixed: :data:`PLAIN_SAMPLING`).
    constrain : {"none", "json-schema", "guided-choice", "grammar"}
        Ask the server to reply with one of the task's replies only: OpenAI's ``response_format`` with a JSON
        schema (the reply ``{"answer": ...}``), vLLM's ``guided_choice`` or llama.cpp's GBNF ``grammar``
        (:func:`fairaudit.experiments.vlm.client.constraint_body`). Needs ``endpoint`` and its sampled route
        (not ``exact`` nor ``sampled_twin``), and a task whose replies are its options' keys.

    Raises
    ------
    InputError
        When more than one source is given, ``model`` without ``endpoint`` (or the reverse),
        ``exact`` without ``endpoint`` or ``local_model``, ``sampled_twin`` without ``endpoint`` or with ``exact``,
        a sampling setting out of range or without a sampled route of a server, or ``constrain`` unknown or
        without ``endpoint``.

    Examples
    --------
    >>> ModelSource(endpoint="http://127.0.0.1:8000/v1", model="m").model
    'm'
    >>> ModelSource(simulated="fair", kernel="kernel.csv")
    Traceback (most recent call last):
    ...
    fairaudit.base.errors.InputError: kernel: give only one of `simulated`, `kernel`, `endpoint` and `local_model` (also got `simulated`)
    >>> ModelSource(endpoint="http://127.0.0.1:8000/v1", model="m", exact=True).exact
    True
    >>> ModelSource(simulated="fair", exact=True)
    Traceback (most recent call last):
    ...
    fairaudit.base.errors.InputError: exact: needs `endpoint` (with `model`) or `local_model`: the exact kernel is read from a model's token probabilities
    """

    simulated: str | None = None
    kernel: str | Path | None = None
    endpoint: str | None = None
    model: str | None = None
    local_model: str | None = None
    exact: bool = False
    sampled_twin: bool = False
    timeout: float = 60.0
    max_retries: int = 5
    temperature: float | None = None
    top_p: float | None = None
    max_tokens: int | None = None
    constrain: str = "none"
    scoring: str | None = None

    def __post_init__(self) -> None:
        given = [name for name in _SOURCES if getattr(self, name)]
        if len(given) > 1:
            listed = ", ".join(f"`{n}`" for n in _SOURCES[:-1]) + f" and `{_SOURCES[-1]}`"
            raise InputError(given[1], f"give only one of {listed} (also got `{given[0]}`)")
        if self.endpoint and not self.model:
            raise InputError("model", "is needed with `endpoint` (the model name the endpoint serves)")
        if self.model and not self.endpoint:
            raise InputError("model", "goes with `endpoint`", self.model)
        for flag in ("exact", "sampled_twin"):
            if not isinstance(getattr(self, flag), bool):
                raise InputError(flag, "must be True or False", getattr(self, flag))
        if self.sampled_twin and not self.endpoint:
            raise InputError("sampled_twin", "needs `endpoint` (with `model`): it samples a server's first token")
        if self.sampled_twin and self.exact:
            raise InputError("sampled_twin", "is the sampled twin of `exact`: give one of them")
        if self.exact and not (self.endpoint or self.local_model):
            raise InputError(
                "exact",
                "needs `endpoint` (with `model`) or `local_model`: the exact kernel is read from a model's "
                "token probabilities",
            )
        self._check_sampling()
        if self.scoring is not None:
            from .exact import SCORINGS

            choice(self.scoring, "scoring", SCORINGS)
            if not (self.exact or self.local_model or self.sampled_twin):
                raise InputError(
                    "scoring",
                    "sets how the exact route scores a decision and how its sampled twins read a reply: it needs "
                    "`exact`, `local_model` or `sampled_twin` (an endpoint's sampled route parses free replies)",
                    self.scoring,
                )

    def _check_sampling(self) -> None:
        """Check the stated sampling settings and that this source samples from a server."""
        _convert(self, "temperature", real, low=0.0)
        _convert(self, "top_p", real, low=0.0, low_open=True, high=1.0, what="in (0, 1]")
        _convert(self, "max_tokens", whole, low=1)
        choice(self.constrain, "constrain", CONSTRAINTS)
        name = next((n for n in SAMPLING_FIELDS if getattr(self, n) not in (None, "none")), None)
        if name is None:
            return
        if not (self.endpoint or self.local_model):
            raise InputError(name, "sets how a server samples: it needs `endpoint` (with `model`) or `local_model`")
        if self.exact:
            raise InputError(name, "sets how a server samples, and `exact` samples nothing: run with `samples` N")
        if self.sampled_twin:
            raise InputError(
                name,
                "is fixed by `sampled_twin`, the sampled twin of `exact`: the replies it scores, drawn from the whole "
                "softmax (temperature 1, top_p 1)",
            )
        if self.constrain != "none" and not self.endpoint:
            raise InputError(
                "constrain",
                "needs `endpoint` (with `model`): a local model's server (transformers serve) enforces no constraint",
                self.constrain,
            )


@dataclass(frozen=True, kw_only=True)
class RunOptions:
    """How an experiment runs: its design, samples, privacy budgets, seed and outputs.

    Parameters
    ----------
    samples : int, optional
        Queries per shown cell (and per true cell and ε in the paper's
        design); default 20. With a local model, leaving it out takes the
        exact route: the model's own kernel from its next-token
        probabilities, with no queries and no sampling error. Not with
        :attr:`ModelSource.exact` (the run refuses both).
    epsilons : sequence of float, optional
        The candidate's privacy budgets ε (nats) to report; or give ``keeps``:
        the keep probability of every attribute. Default: the task file's
        ``[filter]`` budgets, else :data:`DEFAULT_KEEPS`.
    keeps : sequence of float, optional
    context_epsilon : float, optional
        ε of randomized response on the context (document type or package).
    design : {"table", "both", "paper"}
        The table design only; also the paper's (sampling through the
        filter at every ε) for comparison; or the paper's alone, with the
        true prompts asked without a filter for the baseline, for a task too
        large for the table design (eight candidates ranked at once:
        :mod:`fairaudit.experiments.paper_design`). ``"both"`` and ``"paper"``
        need queries (not the exact route).
    positions : {"balanced", "latin", "fixed"}, optional
        Every order of the candidates, the k cyclic shifts of the listed
        order, or the listed order only (the paper's); default the task's
        (``[task] positions`` of its file).
    targets : sequence of float
        Fairness targets (nats) at which the report gives the ε that meets
        them, for this model and for any model (default
        :data:`DEFAULT_TARGETS`).
    seed : int
    resume : bool
        Continue the run logged in the run's folder. The run's settings must be the log's: every setting that
        changes which queries are asked or how their replies are counted (docs/experiments.md, "The log, and
        resuming"); ``concurrency``, ``confidence``, ``method``, ``targets`` and the client's may change.
    extend : bool
        With ``resume``: let ``samples`` grow past the log's; the queries of the new repetitions are asked and
        appended, and the log records the extension. The first n repetitions of a run with N > n samples are
        the queries of a run with n (each query's seed is a hash of the run's seed and its key), so an extended
        run gives the certificate of a fresh run with the larger ``samples``.
    concurrency : int, optional
        Queries in flight (default 4 for an endpoint, 1 otherwise).
    confidence : float or None
        Level of the simultaneous intervals (None for none; none on the exact route).
    method : str
        Their method.
    scene : str, optional
        An S3DIS area folder for the route images; default a generated office floor.
    images : bool
        Make the route images and send them with every query (the paper's
        tasks; a task file only with ``scene``).
    start : str, optional
        The room the routes start from, a room of the scene; None for
        :data:`DEFAULT_START` (``"lobby_1"``). Only where route images are made.
    goals : sequence of str, optional
        The rooms the routes go to, one per candidate of the task (route
        ``i + 1`` to ``goals[i]``, image ``route-{i + 1}.png``), rooms of the
        scene; None for :data:`DEFAULT_GOALS` (``("office_1", "office_2")``).
        Only where route images are made.
    tolerance : float, optional
        The equal-distance check's largest relative difference of the route
        lengths, (max - min) / max, in [0, 1]; None for
        :data:`DEFAULT_TOLERANCE` (0.05). Only where route images are made.
    min_coverage : float
        On the exact route, the least mass a shown cell may put on its options' reply variants before the run warns
        (:mod:`fairaudit.experiments.variants`); default 0.99, lm-evaluation-harness's ``discrim_eval`` threshold.

    Raises
    ------
    InputError
        On an unknown design or positions, both ``epsilons`` and ``keeps``, a
        negative or infinite ε or target, ``samples`` or ``concurrency`` below 1,
        ``extend`` without ``resume``, an empty ``start`` or room of ``goals``, or a ``tolerance`` or
        ``min_coverage`` outside [0, 1].

    Examples
    --------
    >>> RunOptions(samples=5, keeps=[0.7]).keeps
    (0.7,)
    >>> RunOptions(design="kernel")
    Traceback (most recent call last):
    ...
    fairaudit.base.errors.InputError: design: must be one of table, both, paper (got 'kernel')
    >>> RunOptions(start="lobby_1", goals=["office_2", "office_1"], tolerance=0.01).goals
    ('office_2', 'office_1')
    >>> RunOptions(tolerance=5)
    Traceback (most recent call last):
    ...
    fairaudit.base.errors.InputError: tolerance: must be a relative difference in [0, 1] (got 5)
    """

    samples: int | None = None
    epsilons: Sequence[float] | None = None
    keeps: Sequence[float] | None = None
    context_epsilon: float | None = None
    design: str = "table"
    positions: str | None = None
    targets: Sequence[float] = DEFAULT_TARGETS
    seed: int = 0
    resume: bool = False
    extend: bool = False
    concurrency: int | None = None
    confidence: float | None = 0.95
    method: str = "auto"
    scene: str | None = None
    images: bool = True
    start: str | None = None
    goals: Sequence[str] | None = None
    tolerance: float | None = None
    min_coverage: float = 0.99

    def __post_init__(self) -> None:
        choice(self.design, "design", ("table", "both", "paper"))
        _convert(self, "min_coverage", real, low=0.0, high=1.0, what="a share of the mass in [0, 1]")
        if self.positions is not None:
            choice(self.positions, "positions", ("balanced", "latin", "fixed"))
        if self.epsilons is not None and self.keeps is not None:
            raise InputError("keeps", "give `epsilons` or `keeps`, not both")
        nats = "finite and >= 0 (nats)"
        if self.epsilons is not None:
            object.__setattr__(self, "epsilons", tuple(real(e, "epsilons", low=0.0, what=nats) for e in self.epsilons))
        if self.keeps is not None:
            object.__setattr__(self, "keeps", tuple(self.keeps))
        object.__setattr__(self, "targets", tuple(real(t, "targets", low=0.0, what=nats) for t in self.targets))
        _convert(self, "samples", whole, low=1)
        _convert(self, "concurrency", whole, low=1)
        if not isinstance(self.extend, bool):
            raise InputError("extend", "must be True or False", self.extend)
        if self.extend and not self.resume:
            raise InputError("extend", "adds samples to a logged run: give `resume` too")
        self._check_scene()

    def _check_scene(self) -> None:
        """Check ``start``, ``goals`` and ``tolerance`` (the rooms themselves are checked against the scene)."""
        if self.start is not None and (not isinstance(self.start, str) or not self.start.strip()):
            raise InputError("start", "must be a room name", self.start)
        if self.goals is not None:
            if isinstance(self.goals, str) or not isinstance(self.goals, Sequence) or not self.goals:
                raise InputError("goals", "must be a sequence of room names, one per candidate", self.goals)
            if not all(isinstance(g, str) and g.strip() for g in self.goals):
                raise InputError("goals", "must be room names", list(self.goals))
            object.__setattr__(self, "goals", tuple(self.goals))
        _convert(self, "tolerance", real, low=0.0, high=1.0, what="a relative difference in [0, 1]")


def _convert(options: object, name: str, check: Callable[..., Any], **limits: Any) -> None:
    """Set the field ``name`` of the frozen ``options`` to ``check(value, name, **limits)``, unless it is None."""
    value = getattr(options, name)
    if value is not None:
        object.__setattr__(options, name, check(value, name, **limits))
