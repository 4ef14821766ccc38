"""``fairaudit experiment``: run a delivery experiment against a model and write its report.

:func:`run_experiment` is the whole pipeline: the scene and its route images
(:mod:`fairaudit.experiments.navigation`), the model (simulated, from a kernel
table, an OpenAI-compatible endpoint, or a real language model run locally),
the queries of the table design (and of the paper's design with
``design="both"``) through the resumable log, the analysis
(:func:`fairaudit.experiments.analysis.analyse`) and the files of
:mod:`fairaudit.experiments.report`.

A local model (``local_model="smollm2"``,
:mod:`fairaudit.experiments.local_model`) takes one of two routes: without
``samples``, the exact route (its kernel from next-token probabilities, no
queries, no log); with ``samples=N``, the sampled route (N one-token replies per
cell from ``transformers serve`` on 127.0.0.1, through the same client, log and
parser as any endpoint).
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TypedDict

from .. import __version__
from .._errors import InputError
from .analysis import DEFAULT_TARGETS, ExperimentAnalysis, analyse, analyse_kernel, epsilon_from_keep
from .harness import QueryLog, RunSummary, plan_queries, run_queries
from .vlm.models import SIMULATED, DecisionModel, EndpointModel, SimulatedModel, simulated_model
from .vlm.tasks import DeliveryTask, get_task

__all__ = ["ExperimentRun", "run_experiment", "DEFAULT_KEEPS"]

DEFAULT_KEEPS = (0.5, 0.6, 0.7, 0.8, 0.9)
"""Keep probabilities per attribute of the default ε grid (the paper varied p)."""


class _Common(TypedDict):
    """The analysis options both routes pass on (typed for ``**`` unpacking)."""

    epsilons: list[float]
    positions: str
    confidence: float | None
    method: str
    context_epsilon: float | None
    targets: list[float]


@dataclass(frozen=True, eq=False)
class ExperimentRun:
    """What :func:`run_experiment` did: the query summary, the analysis (None when incomplete) and the files.

    ``summary`` is None on a local model's exact route, which asks no queries;
    ``route`` is ``"exact"`` there and ``"sampled"`` otherwise.
    """

    out: Path
    summary: RunSummary | None
    analysis: ExperimentAnalysis | None
    files: tuple
    route: str = "sampled"
    seconds: float = 0.0


def _check_sources(simulated: str | None, kernel: str | None, endpoint: str | None, local_model: str | None) -> None:
    given = [
        n
        for n, v in (
            ("--simulated", simulated),
            ("--kernel", kernel),
            ("--endpoint", endpoint),
            ("--local-model", local_model),
        )
        if v
    ]
    if len(given) > 1:
        raise InputError(
            given[1], f"give only one of --simulated, --kernel, --endpoint and --local-model (also got {given[0]})"
        )


def _model(
    task: DeliveryTask,
    simulated: str | None,
    kernel: str | None,
    endpoint: str | None,
    model: str | None,
    timeout: float,
    max_retries: int,
    concurrency: int,
) -> DecisionModel:
    if endpoint:
        if not model:
            raise InputError("--model", "is needed with --endpoint (the model name the endpoint serves)")
        from .vlm.client import ChatClient

        return EndpointModel(
            ChatClient(endpoint, model, timeout=timeout, max_retries=max_retries, max_concurrency=concurrency)
        )
    if model:
        raise InputError("--model", "goes with --endpoint", model)
    if kernel:
        return SimulatedModel.from_csv(task, kernel)
    return simulated_model(task, simulated or next(iter(SIMULATED[task.name])))


def _images(scene: str | None, images: bool) -> tuple[bytes, ...]:
    """The route images of the scene (checked for equal distances), before anything is written."""
    if not images:
        return ()
    from .navigation import delivery_scene

    s = delivery_scene(scene)
    if not s.check.equal:
        lengths = ", ".join(f"{x:.2f} m" for x in s.check.lengths)
        raise InputError(
            "--scene",
            f"the routes to the two destinations are not of equal length ({lengths}; "
            f"{s.check.max_relative_difference:.1%} apart, more than {s.check.rtol:.0%}): the paper's "
            "experiment needs equal distances",
            str(scene or "generated floor"),
        )
    return tuple(s.images)


LOCK_NAME = ".fairaudit.lock"
"""The lock file in a run's folder: held (an OS lock, ``filelock.FileLock``) while a run uses the folder."""


def _check_log(log_path: Path, resume: bool, exact: bool) -> None:
    """Refuse a folder whose log belongs to a run this one must not touch."""
    out = log_path.parent
    if log_path.exists() and log_path.stat().st_size > 0 and not resume:
        raise InputError(
            "--out",
            "holds a run already (queries.jsonl); pass --resume to continue it, or choose another folder",
            str(out),
        )
    if exact and log_path.exists():
        raise InputError("--out", "holds a sampled run (queries.jsonl); the exact route needs another folder", str(out))


@contextmanager
def _claim(out: Path) -> Iterator[Path]:
    """Make ``out`` and hold its lock for a ``with`` block: one run per folder; a second is refused at once.

    The lock is the operating system's (``filelock.FileLock``: ``flock`` on Unix, a byte-range lock on Windows),
    so it is released when the block ends, however it ends, and by the system when the process dies (even by
    SIGKILL). The lock file stays in the folder, empty; a later run takes it again.
    """
    try:
        from filelock import FileLock, Timeout
    except ImportError:
        raise InputError(
            "--out", "one run per folder needs filelock, which is not installed: pip install 'fairaudit[experiment]'"
        ) from None
    out.mkdir(exist_ok=True)
    path = out / LOCK_NAME
    lock = FileLock(path, timeout=0)
    try:
        lock.acquire()
    except Timeout:
        raise InputError(
            "--out",
            f"is in use by another fairaudit run (lock {path}); wait for it to finish or choose another folder",
            str(out),
        ) from None
    try:
        yield path
    finally:
        lock.release()


def run_experiment(
    experiment: str,
    out: str | Path,
    *,
    simulated: str | None = None,
    kernel: str | None = None,
    endpoint: str | None = None,
    model: str | None = None,
    local_model: str | None = None,
    samples: int | None = None,
    epsilons: Sequence[float] | None = None,
    keeps: Sequence[float] | None = None,
    context_epsilon: float | None = None,
    design: str = "table",
    positions: str = "balanced",
    seed: int = 0,
    resume: bool = False,
    concurrency: int | None = None,
    timeout: float = 60.0,
    max_retries: int = 5,
    confidence: float | None = 0.95,
    method: str = "auto",
    scene: str | None = None,
    images: bool = True,
    progress: bool = True,
    log: Callable[[str], None] | None = None,
    targets: Sequence[float] = DEFAULT_TARGETS,
) -> ExperimentRun:
    """Run one of the paper's delivery experiments and write its report to ``out``.

    Parameters
    ----------
    experiment : {"hr-delivery", "package-delivery"}
    out : str or Path
        Folder of the run (created): the log, tables, certificate, figures, report.
    simulated, kernel, endpoint, model, local_model
        The decision model, one of: a named simulated model
        (:data:`fairaudit.experiments.vlm.models.SIMULATED`; the default is the
        task's first), a kernel table (``kernel.csv`` format), an
        OpenAI-compatible endpoint URL with the model's name (API key from
        ``OPENAI_API_KEY``), or a real language model run on this machine
        (a key of :data:`fairaudit.experiments.local_model.LOCAL_MODELS`, text
        only: no route images are made or sent).
    samples : int, optional
        Queries per shown cell (and per true cell and ε in the paper's
        design); default 20. With ``local_model``, leaving it out takes the
        exact route: the model's own kernel from its next-token
        probabilities, with no queries and no sampling error.
    epsilons : sequence of float, optional
        The candidate's privacy budgets ε (nats) to report; or give ``keeps``:
        the keep probability of every attribute (default
        :data:`DEFAULT_KEEPS`).
    context_epsilon : float, optional
        ε of randomized response on the context (document type or package).
    design : {"table", "both"}
        The table design only, or also the paper's (sampling through the
        filter at every ε) for comparison; ``"both"`` needs queries (not the
        exact route).
    positions : {"balanced", "fixed"}
        Both orders of the two candidates, or the paper's only.
    seed : int
    resume : bool
        Continue the run logged in ``out``.

        One run at a time per folder: the run holds the lock ``out/.fairaudit.lock``
        from before it writes anything until it returns, and a second run on the
        same folder is refused at once (an :class:`InputError` on ``--out``).
    concurrency : int, optional
        Queries in flight (default 4 for an endpoint, 1 otherwise).
    timeout, max_retries
        Of the endpoint client.
    confidence, method
        Simultaneous intervals (None for none; none on the exact route).
    scene : str, optional
        An S3DIS area folder for the route images; default a generated office floor.
    images : bool
        Make the route images and send them with every query.
    progress : bool
        A progress bar on stderr.
    log : callable, optional
        Called with one line per step of a local model (converting, loading,
        serving); default none.
    targets : sequence of float
        Fairness targets (nats) at which the report gives the ε that meets
        them, for this model and for any model (default
        :data:`fairaudit.experiments.analysis.DEFAULT_TARGETS`).

    Returns
    -------
    ExperimentRun

    Raises
    ------
    InputError
        On invalid options (naming the flag), a log made by another run, a
        folder in use by another run (its lock held), an unreadable kernel, a scene whose routes differ in length, or a local
        model that is not installed (naming the install command).
    """
    task = get_task(experiment)
    _check_sources(simulated, kernel, endpoint, local_model)
    if design not in ("table", "both"):
        raise InputError("--design", "must be 'table' or 'both'", design)
    if epsilons is not None and keeps is not None:
        raise InputError("--keep", "give --epsilon or --keep, not both")
    if epsilons is None:
        epsilons = [epsilon_from_keep(task, k) for k in (DEFAULT_KEEPS if keeps is None else keeps)]
    eps = [float(e) for e in epsilons]
    for e in eps:
        if not (math.isfinite(e) and e >= 0):
            raise InputError("--epsilon", "must be finite and >= 0 (nats)", e)
    for t in targets:
        if not (math.isfinite(float(t)) and float(t) >= 0):
            raise InputError("--target", "must be finite and >= 0 (nats)", t)
    exact = local_model is not None and samples is None
    if local_model is not None:
        from . import local_model as lm

        if model:
            raise InputError("--model", "goes with --endpoint", model)
        if scene is not None:
            raise InputError("--scene", f"the local model {local_model} reads text only: it takes no route images")
        if exact and design == "both":
            raise InputError("--design", "the paper's design samples through the filter: give --samples N too")
        lm.check(local_model)  # not installed: one line naming the install command, before anything is written
        images = False
        m: DecisionModel | None = None
    else:
        m = _model(task, simulated, kernel, endpoint, model, timeout, max_retries, concurrency or 4)
    n = 20 if samples is None else int(samples)
    if concurrency is None:
        concurrency = 4 if endpoint else 1
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise InputError("--out", "is a file, not a folder", str(out))
    if not out.parent.is_dir():
        raise InputError("--out", "its parent folder does not exist", str(out.parent))
    log_path = out / "queries.jsonl"
    _check_log(log_path, resume, exact)
    pngs = _images(scene, images)  # a bad scene is refused before --out is touched
    common: _Common = {
        "epsilons": eps,
        "positions": positions,
        "confidence": confidence,
        "method": method,
        "context_epsilon": context_epsilon,
        "targets": [float(t) for t in targets],
    }
    with _claim(out):  # makes --out and locks it: a second run on it is refused here, before it writes anything
        _check_log(log_path, resume, exact)  # again under the lock: another run may have ended in between
        if exact:
            assert local_model is not None
            return _run_exact(task, local_model, out, seed, progress, log, common)
        from ..report import write_atomic

        for i, png in enumerate(pngs, start=1):
            write_atomic(out / f"route-{i}.png", png, field="--out")
        with ExitStack() as stack:
            if local_model is not None:
                m = stack.enter_context(_served(local_model, out, timeout, max_retries, log))
                task = lm.answer_task(task)
            assert m is not None
            header = {
                "task": task.name,
                "model": m.name,
                "seed": int(seed),
                "fairaudit": __version__,
                "samples": n,
                "design": design,
                "positions": positions,
                "epsilons": eps,
                "context_epsilon": context_epsilon,
            }
            queries = plan_queries(task, "table", n, seed)
            if design == "both":
                queries += plan_queries(
                    task, "paper", n, seed, epsilons=eps, positions=positions, context_epsilon=context_epsilon
                )
            with QueryLog(log_path, header, resume=resume) as qlog:
                summary = run_queries(task, m, queries, qlog, images=pngs, concurrency=concurrency, progress=progress)
                records = [qlog.records[q.id] for q in queries if q.id in qlog.records]
        files = [log_path] + [out / f"route-{i}.png" for i in range(1, len(pngs) + 1)]
        if not summary.complete:
            return ExperimentRun(out, summary, None, tuple(files), seconds=summary.seconds)
        analysis = analyse(
            task,
            records,
            model=m.name,
            samples=n,
            paper_epsilons=eps if design == "both" else (),
            **common,
        )
        files += _write(
            analysis,
            out,
            {"seed": int(seed), "design": design, "fairaudit": __version__, "seconds": round(summary.seconds, 3)},
        )
        return ExperimentRun(out, summary, analysis, tuple(files), seconds=summary.seconds)


@contextmanager
def _served(
    name: str, out: Path, timeout: float, max_retries: int, log: Callable[[str], None] | None
) -> Iterator[DecisionModel]:
    """The local model behind ``transformers serve`` (its output in ``out/server.log``), for a ``with`` block."""
    from . import local_model as lm
    from .vlm.client import ChatClient

    folder = lm.prepare(name, log=log)
    if log:
        log(f"serving {name} on 127.0.0.1 (output in {out / 'server.log'})")
    with lm.serve(folder, log=out / "server.log") as url:
        client = ChatClient(url, str(folder), temperature=1.0, max_tokens=1, timeout=timeout, max_retries=max_retries)
        with client:
            yield lm.ServedModel(client, name)


def _run_exact(
    task: DeliveryTask,
    name: str,
    out: Path,
    seed: int,
    progress: bool,
    log: Callable[[str], None] | None,
    common: _Common,
) -> ExperimentRun:
    """The exact route of a local model: its kernel from token probabilities, analysed and written."""
    from . import local_model as lm

    t0 = time.perf_counter()
    loaded = lm.load(name, log=log)
    probabilities = lm.exact_kernel(task, loaded, progress=progress)
    analysis = analyse_kernel(task, lm.exact_law(task, probabilities), model=name, **common)
    seconds = time.perf_counter() - t0
    files = _write(
        analysis,
        out,
        {"seed": int(seed), "design": "table", "fairaudit": __version__, "seconds": round(seconds, 3)},
    )
    return ExperimentRun(out, None, analysis, tuple(files), route="exact", seconds=seconds)


def _write(analysis: ExperimentAnalysis, out: Path, run: dict) -> list:
    from ..report import write_atomic
    from .report import (
        candidate_frame,
        experiment_dict,
        experiment_markdown,
        experiment_spec,
        kernel_frame,
        plot_baseline,
        plot_experiment_curve,
        records_frame,
        write_frame,
        write_json,
    )

    data = experiment_dict(analysis, run)
    written = []
    steps: list[tuple[str, Callable[[Path], None]]] = [
        ("kernel.csv", lambda p: write_frame(p, kernel_frame(analysis))),
        ("candidates.csv", lambda p: write_frame(p, candidate_frame(analysis))),
        ("curve.csv", lambda p: analysis.curve.to_csv(p)),
        ("certificate.json", lambda p: write_json(p, data)),
        ("report.md", lambda p: write_atomic(p, experiment_markdown(data), field="--out")),
    ]
    if analysis.route == "sampled":  # records are queries: the exact route has none
        steps.insert(2, ("records.csv", lambda p: write_frame(p, records_frame(analysis))))
    for name, write in steps:
        write(out / name)
        written.append(out / name)
    for p in analysis.points:
        path = out / f"spec-eps-{p.epsilon:.4g}.toml"
        write_atomic(path, experiment_spec(analysis, p), field="--out")
        written.append(path)
    try:
        plot_baseline(analysis, out / "baseline.png")
        plot_experiment_curve(analysis, out / "curve.png")
        written += [out / "baseline.png", out / "curve.png"]
    except InputError as exc:  # matplotlib missing: the tables and report are written
        print(f"fairaudit: figures skipped: {exc}", file=sys.stderr)
    return written
