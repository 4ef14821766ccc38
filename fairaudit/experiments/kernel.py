"""The fourth step of a run: the model asked, its kernel P(U | X̃, Ã) measured (:class:`Measured`).

On the sampled route the queries of the design go through the run's log (:mod:`fairaudit.experiments.harness`):
the answered ones are the records the analysis counts. On the exact route the kernel is the model's own
probabilities: a local model's in process (:func:`fairaudit.experiments.local_model.exact_kernel`) or an endpoint's
log-probabilities (:func:`fairaudit.experiments.endpoint.endpoint_kernel`).
"""

from __future__ import annotations

import functools
import itertools
import math
import time
from collections.abc import Callable, Iterable, Iterator
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from fairaudit import InputError, Kernel

from .harness import QueryLog, RunSummary, plan_queries, run_queries
from .slots import outcome_index, slot_names

if TYPE_CHECKING:
    from .cells import Cells
    from .endpoint import ExactKernel
    from .folder import Folder
    from .route import Route
    from .vlm.models import DecisionModel, Query
    from .vlm.tasks import DeliveryTask

__all__ = [
    "UNPARSED_WARNING",
    "Measured",
    "UnparsedMass",
    "fairaudit_version",
    "measure",
    "table_kernel",
    "true_cell_counts",
    "unparsed_mass",
]


@functools.cache
def fairaudit_version() -> str:
    """The installed fairaudit's version, recorded in every run (its log, ``certificate.json``); ``"unknown"`` when
    the code runs from a source tree that is not installed."""
    from importlib.metadata import packages_distributions, version

    names = packages_distributions().get("fairaudit", [])
    return version(names[0]) if names else "unknown"


@dataclass(frozen=True, eq=False, kw_only=True)
class Measured:
    """What the model gave: its kernel on shown cells (exact route) or the answered queries (sampled route).

    Attributes
    ----------
    model : str
        The model's name.
    task : DeliveryTask
        The task as the route asked it (a sampled twin's: the exact route's prompt).
    complete : bool
        Every query answered, every prompt scored: only then is the run analysed.
    kernel : Kernel or None
        The exact route's kernel on shown cells (no counts); None on the sampled route.
    records : tuple of dict
        The sampled route's answered queries of the plan (the log's records).
    summary : RunSummary or None
        The queries' (or requests') summary; None on a local model's exact route.
    run : dict
        What ``certificate.json``'s ``run`` says of the run: seed, design, version, task digest, prompt, filter,
        seconds, and the replies and scene and sampling (sampled route) or the scoring (exact route).
    files : tuple of Path
        The files written: the log and the route images.
    seconds : float
    """

    model: str
    task: DeliveryTask
    complete: bool
    kernel: Kernel | None = None
    records: tuple = ()
    summary: RunSummary | None = None
    run: dict
    files: tuple = ()
    seconds: float = 0.0


def measure(
    cells: Cells, route: Route, folder: Folder, *, progress: bool, log: Callable[[str], None] | None
) -> Measured:
    """Ask the model of ``route`` on ``cells``: the exact kernel, or the queries through the folder's log."""
    run = {
        "seed": cells.seed,
        "design": cells.design,
        "fairaudit": fairaudit_version(),
        "task_sha256": route.task.digest,
        "prompt": route.prompt,
        "filter": cells.asked,
    }
    if route.exact:
        return _exact(cells, route, run, progress, log)
    return _sampled(cells, route, folder, run, progress, log)


def _exact(cells: Cells, route: Route, run: dict, progress: bool, log: Callable[[str], None] | None) -> Measured:
    """The exact route: the kernel of the model's token probabilities (nothing when a request failed)."""
    from . import local_model as lm
    from .endpoint import MODEL_TEMPLATE, ExactKernel, endpoint_kernel
    from .exact import SCORINGS

    task, scoring = cells.task, route.scoring or SCORINGS[0]
    t0 = time.perf_counter()
    if route.client is None:
        model = lm.load(route.name, log=log)
        likely: list = []
        kernel = lm.exact_kernel(task, model, scoring=scoring, progress=progress, unparsed=likely)
        made = ExactKernel(kernel, None, "in-process", rendering=MODEL_TEMPLATE, unparsed=tuple(likely))
    else:
        with route.client:
            made = endpoint_kernel(task, route.client, scoring=scoring, progress=progress)
    seconds = time.perf_counter() - t0
    scored = made.record(route.scoring) | _variants_record(task, made, scoring)
    run = {**run, "seconds": round(seconds, 3), "scoring": scored}
    probabilities = made.probabilities
    return Measured(
        model=route.name,
        task=task,
        complete=probabilities is not None,
        kernel=None if probabilities is None else lm.exact_law(task, probabilities),
        summary=made.summary,
        run=run,
        seconds=seconds,
    )


def _variants_record(task: DeliveryTask, made: ExactKernel, scoring: str) -> dict:
    """``run.scoring``'s ``variants`` (the rule; each decision's reply -> its variants, where one list holds for every
    prompt) and ``coverage`` (the least and the mean mass on them over the shown cells, and the likeliest replies
    that say no option, where the route knows them); the run adds the threshold and the warning."""
    from .exact import by_sequence, decision_replies, exact_prompt
    from .variants import coverage, variants_record

    out: dict = {"variants": {"rule": task.variant_rule}}
    if by_sequence(task, scoring) and task.named_by is None:
        out["variants"]["replies"] = variants_record(task, decision_replies(task, exact_prompt(task)[1]))
    if made.probabilities is not None:
        least, mean = coverage(made.probabilities)
        out["coverage"] = {"min": least, "mean": mean, "unparsed_replies": [[t, p] for t, p in made.unparsed]}
    return out


def _sampled(
    cells: Cells, route: Route, folder: Folder, run: dict, progress: bool, log: Callable[[str], None] | None
) -> Measured:
    """The sampled route: ask the queries not yet in the log, and keep the answered ones of the plan."""
    from fairaudit import write_atomic

    out = folder.out
    files = [folder.log_path]
    for i, png in enumerate(route.images, start=1):
        write_atomic(out / f"route-{i}.png", png, field="out")
        files.append(out / f"route-{i}.png")
    with ExitStack() as stack:
        m = route.model
        if m is None:  # a local model, served for the run
            m = stack.enter_context(_served(route, out, log))
        header = {
            "task": route.task.name,
            "task_sha256": route.task.digest,
            "model": m.name,
            "fairaudit": fairaudit_version(),
            **folder.settings,
        }
        queries = _queries(cells)
        with QueryLog(folder.log_path, header, resume=folder.resume) as qlog:
            if folder.extend_from is not None:
                qlog.extend(cells.samples, folder.extend_from)
            summary = run_queries(
                route.task, m, queries, qlog, images=route.images, concurrency=route.concurrency, progress=progress
            )
            records = tuple(qlog.records[q.id] for q in queries if q.id in qlog.records)
            extensions = [{"from": e["from"], "to": e["to"], "time": e["time"]} for e in qlog.extensions]
            logged = len(qlog.records)
    run = {**run, "seconds": round(summary.seconds, 3), "replies": {"used": len(records), "logged": logged}}
    given = {"extended": extensions or None, "scene": route.scene, "sampling": route.sampling}
    run |= {k: v for k, v in given.items() if v is not None}
    return Measured(
        model=m.name,
        task=route.task,
        complete=summary.complete,
        records=records,
        summary=summary,
        run=run,
        files=tuple(files),
        seconds=summary.seconds,
    )


def _queries(cells: Cells) -> list[Query]:
    """The plan's queries: the table design's, the paper's at each ε, or the paper's alone with its baseline."""
    task, n, seed = cells.task, cells.samples, cells.seed
    if cells.design == "paper":  # the true prompts without a filter, for the baseline
        queries = plan_queries(task, "paper", n, seed, epsilons=[math.inf], positions=cells.positions)
    else:
        queries = plan_queries(task, "table", n, seed)
    if cells.design != "table":
        queries += plan_queries(
            task, "paper", n, seed, epsilons=cells.epsilons, positions=cells.positions,
            context_epsilon=cells.context_epsilon,
        )  # fmt: skip
    return queries


@contextmanager
def _served(route: Route, out: Path, log: Callable[[str], None] | None) -> Iterator[DecisionModel]:
    """The local model behind ``transformers serve`` (its output in ``out/server.log``), for a ``with`` block."""
    from . import local_model as lm
    from . import model_files
    from .vlm.client import ChatClient

    name, source, sampling = route.name, route.source, route.sampling
    assert sampling is not None  # make_route states a served model's sampling
    folder = model_files.prepare(name, log=log)
    if log:
        log(f"serving {name} on 127.0.0.1 (output in {out / 'server.log'})")
    fields = {key: sampling[key] for key in ("temperature", "top_p", "max_tokens")}
    with lm.serve(folder, log=out / "server.log") as url:
        with ChatClient(url, str(folder), timeout=source.timeout, max_retries=source.max_retries, **fields) as client:
            yield lm.ServedModel(client, name)


def table_kernel(task: DeliveryTask, records: Iterable[dict]) -> Kernel:
    """The model's kernel estimated from the table design's answered queries.

    Returns
    -------
    Kernel
        Shape (n_contexts, n_profiles^k, n_decisions) with counts: contexts are
        the shown contexts, groups the shown cells (tuples of the k profiles,
        row-major over :attr:`DeliveryTask.profiles`, slot 1 slowest),
        decisions :attr:`DeliveryTask.decisions`. Cells without any answered
        query are empty.
    """
    profiles = task.profiles
    n, k = len(profiles), task.slots
    pidx = {p: i for i, p in enumerate(profiles)}
    cidx = {c: i for i, c in enumerate(task.contexts)}
    didx = {d: i for i, d in enumerate(task.decisions)}
    rows = [
        (cidx[r["context"]], *(pidx[tuple(p)] for p in r["profiles"]), didx[r["decision"]])
        for r in records
        if r.get("design") == "table" and r.get("status") == "ok"
    ]
    counts = np.zeros((len(task.contexts), *([n] * k), len(task.decisions)))
    np.add.at(counts, tuple(np.array(rows, dtype=np.intp).reshape(-1, k + 2).T), 1.0)
    groups = list(itertools.product(profiles, repeat=k))
    return Kernel.from_counts(
        counts.reshape(len(task.contexts), n**k, -1), task.contexts, groups, task.decisions, name="kernel"
    )


def true_cell_counts(task: DeliveryTask, records: Iterable[dict]) -> np.ndarray:
    """Per-candidate outcome counts of decisions on true prompts shown as they are (no filter), record by record.

    The baseline of a design too large for a kernel (eight candidates: 8⁸ shown cells per context), counted
    without one: each record names its context, its k profiles in slot order and its decision, and gives each
    of its k candidates one outcome (:func:`fairaudit.experiments.slots.outcome_index`).

    Parameters
    ----------
    task : DeliveryTask
    records : iterable of dict
        ``{"context": ..., "profiles": [profile of slot 1, ..., slot k], "decision": label}`` with a label of
        :attr:`DeliveryTask.decisions` (a log's answered queries, or decisions recorded elsewhere); records with a
        ``status`` other than ``"ok"`` are skipped.

    Returns
    -------
    numpy.ndarray, shape (n_contexts, k, n_candidates, n_outcomes)
        Counts by context, slot, the candidate's true profile (:attr:`DeliveryTask.candidates`) and its outcome
        (:attr:`DeliveryTask.outcomes`).

    Raises
    ------
    InputError
        ``records`` naming a context, profile or decision the task does not have.

    Examples
    --------
    >>> from fairaudit.experiments.taskfile import HR_DELIVERY as t
    >>> c = true_cell_counts(t, [{"context": "sick leave", "profiles": t.candidates, "decision": "HR2"}])
    >>> c[t.contexts.index("sick leave")].tolist()   # slot 1 (Tom): not chosen; slot 2 (Mary): chosen
    [[[0.0, 1.0, 0.0], [0.0, 0.0, 0.0]], [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]]
    """
    cidx = {c: i for i, c in enumerate(task.contexts)}
    gidx = {tuple(g): i for i, g in enumerate(task.candidates)}
    didx = {d: i for i, d in enumerate(task.decisions)}
    rows = []
    for n, r in enumerate(records):
        if r.get("status", "ok") != "ok":
            continue
        try:
            rows.append((cidx[r["context"]], *(gidx[tuple(p)] for p in r["profiles"]), didx[r["decision"]]))
        except (KeyError, TypeError):
            raise InputError(
                f"records[{n}]", f"is not a decision of {task.name} on one of its true prompts", r
            ) from None
        if len(rows[-1]) != task.slots + 2:
            raise InputError(f"records[{n}].profiles", f"needs {task.slots} profiles", r.get("profiles"))
    out = np.zeros((len(task.contexts), task.slots, len(task.candidates), len(task.outcomes)))
    a = np.array(rows, dtype=np.int64).reshape(-1, task.slots + 2)  # (record, [context, k candidates, decision])
    slot = np.arange(task.slots)  # every record counts once per slot: indices broadcast to (record, slot)
    np.add.at(out, (a[:, :1], slot, a[:, 1:-1], outcome_index(task)[slot, a[:, -1:]]), 1.0)
    return out


UNPARSED_WARNING = 0.2
"""A shown cell whose unparsed mass exceeds this share makes the experiment warn (report.md and stderr)."""


@dataclass(frozen=True, eq=False, kw_only=True)
class UnparsedMass:
    """The shown cells whose unparsed mass exceeds a threshold: where the stated unparsed utility decides L.

    Attributes
    ----------
    threshold : float
        :data:`UNPARSED_WARNING`.
    share : float
        Share of the shown cells (context × shown profiles) whose unparsed mass exceeds ``threshold``.
    largest : float
        The largest unparsed mass of a shown cell.
    cells : tuple of (str, str, float)
        Up to five such cells, largest mass first: (context, the shown profiles by slot, mass).
    """

    threshold: float
    share: float
    largest: float
    cells: tuple

    @property
    def warning(self) -> str | None:
        """One line for report.md and stderr, or None when no cell exceeds the threshold."""
        if self.share == 0:
            return None
        named = "; ".join(f"{c} / {shown}: {m:.3g}" for c, shown, m in self.cells)
        return (
            f"{self.share:.1%} of the shown cells put more than {self.threshold:g} of their mass on unparsed replies "
            f"(largest {self.largest:.3g}; e.g. {named}): L and L̄ there depend on the utility given to an unparsed "
            "reply; see the unparsed ranges"
        )


def unparsed_mass(task: DeliveryTask, kernel: Kernel, threshold: float = UNPARSED_WARNING) -> UnparsedMass:
    """The shown cells of ``kernel`` (the table design's layout) whose unparsed mass exceeds ``threshold``."""
    mass = np.nan_to_num(kernel.probabilities[..., -1], nan=0.0)  # (n_contexts, n_shown)
    over = mass > threshold
    order = np.argsort(-mass, axis=None, kind="stable")[: min(5, int(over.sum()))]
    slots = slot_names(task)
    cells = []
    for flat in order:
        x, j = np.unravel_index(flat, mass.shape)
        shown = np.unravel_index(j, (len(task.profiles),) * task.slots)
        who = ", ".join(f"{o} = {task.profile_label(task.profiles[i])}" for o, i in zip(slots, shown))
        cells.append((str(task.contexts[x]), who, float(mass[x, j])))
    return UnparsedMass(threshold=threshold, share=float(over.mean()), largest=float(mass.max()), cells=tuple(cells))
