"""``fairaudit experiment``: run a delivery experiment against a model and write its report.

:func:`run_experiment` is the whole pipeline: the scene and its route images
(:mod:`fairaudit.plugins.navigation`), the model (simulated, from a kernel
table, or an OpenAI-compatible endpoint), the queries of the table design
(and of the paper's design with ``design="both"``) through the resumable log,
the analysis (:func:`fairaudit.plugins.experiments.analyse`) and the files of
:mod:`fairaudit.plugins.report`.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from .. import __version__
from .._errors import InputError
from .experiments import ExperimentAnalysis, analyse, epsilon_from_keep
from .harness import QueryLog, RunSummary, plan_queries, run_queries
from .vlm.models import SIMULATED, DecisionModel, EndpointModel, SimulatedModel, simulated_model
from .vlm.tasks import DeliveryTask, get_task

__all__ = ["ExperimentRun", "run_experiment", "DEFAULT_KEEPS"]

DEFAULT_KEEPS = (0.5, 0.6, 0.7, 0.8, 0.9)
"""Keep probabilities per attribute of the default ε grid (the paper varied p)."""


@dataclass(frozen=True, eq=False)
class ExperimentRun:
    """What :func:`run_experiment` did: the query summary, the analysis (None when incomplete) and the files."""

    out: Path
    summary: RunSummary
    analysis: ExperimentAnalysis | None
    files: tuple


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
    given = [n for n, v in (("--simulated", simulated), ("--kernel", kernel), ("--endpoint", endpoint)) if v]
    if len(given) > 1:
        raise InputError(given[1], f"give only one of --simulated, --kernel and --endpoint (also got {given[0]})")
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


def run_experiment(
    experiment: str,
    out: str | Path,
    *,
    simulated: str | None = None,
    kernel: str | None = None,
    endpoint: str | None = None,
    model: str | None = None,
    samples: int = 20,
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
) -> ExperimentRun:
    """Run one of the paper's delivery experiments and write its report to ``out``.

    Parameters
    ----------
    experiment : {"hr-delivery", "package-delivery"}
    out : str or Path
        Folder of the run (created): the log, tables, certificate, figures, report.
    simulated, kernel, endpoint, model
        The decision model: a named simulated model
        (:data:`fairaudit.plugins.vlm.models.SIMULATED`; the default is the
        task's first), a kernel table (``kernel.csv`` format), or an
        OpenAI-compatible endpoint URL with the model's name (API key from
        ``OPENAI_API_KEY``).
    samples : int
        Queries per shown cell (and per true cell and ε in the paper's design).
    epsilons : sequence of float, optional
        The candidate's privacy budgets ε (nats) to report; or give ``keeps``:
        the keep probability of every attribute (default
        :data:`DEFAULT_KEEPS`).
    context_epsilon : float, optional
        ε of randomized response on the context (document type or package).
    design : {"table", "both"}
        The table design only, or also the paper's (sampling through the
        filter at every ε) for comparison.
    positions : {"balanced", "fixed"}
        Both orders of the two candidates, or the paper's only.
    seed : int
    resume : bool
        Continue the run logged in ``out``.
    concurrency : int, optional
        Queries in flight (default 4 for an endpoint, 1 otherwise).
    timeout, max_retries
        Of the endpoint client.
    confidence, method
        Simultaneous intervals (None for none).
    scene : str, optional
        An S3DIS area folder for the route images; default a generated office floor.
    images : bool
        Make the route images and send them with every query.
    progress : bool
        A progress bar on stderr.

    Returns
    -------
    ExperimentRun

    Raises
    ------
    InputError
        On invalid options (naming the flag), a log made by another run, an
        unreadable kernel, or a scene whose routes differ in length.
    """
    task = get_task(experiment)
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
    m = _model(task, simulated, kernel, endpoint, model, timeout, max_retries, concurrency or 4)
    if concurrency is None:
        concurrency = 4 if endpoint else 1
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise InputError("--out", "is a file, not a folder", str(out))
    if not out.parent.is_dir():
        raise InputError("--out", "its parent folder does not exist", str(out.parent))
    log_path = out / "queries.jsonl"
    if log_path.exists() and log_path.stat().st_size > 0 and not resume:
        raise InputError(
            "--out",
            "holds a run already (queries.jsonl); pass --resume to continue it, or choose another folder",
            str(out),
        )
    pngs = _images(scene, images)  # a bad scene is refused before --out is touched
    out.mkdir(exist_ok=True)
    from ..report import write_atomic

    for i, png in enumerate(pngs, start=1):
        write_atomic(out / f"route-{i}.png", png, field="--out")
    header = {
        "task": task.name,
        "model": m.name,
        "seed": int(seed),
        "fairaudit": __version__,
        "samples": samples,
        "design": design,
        "positions": positions,
        "epsilons": eps,
        "context_epsilon": context_epsilon,
    }
    queries = plan_queries(task, "table", samples, seed)
    if design == "both":
        queries += plan_queries(
            task, "paper", samples, seed, epsilons=eps, positions=positions, context_epsilon=context_epsilon
        )
    with QueryLog(log_path, header, resume=resume) as log:
        summary = run_queries(task, m, queries, log, images=pngs, concurrency=concurrency, progress=progress)
        records = [log.records[q.id] for q in queries if q.id in log.records]
    files = [log_path] + [out / f"route-{i}.png" for i in range(1, len(pngs) + 1)]
    if not summary.complete:
        return ExperimentRun(out, summary, None, tuple(files))
    analysis = analyse(
        task,
        records,
        model=m.name,
        samples=samples,
        epsilons=eps,
        positions=positions,
        confidence=confidence,
        method=method,
        context_epsilon=context_epsilon,
        paper_epsilons=eps if design == "both" else (),
    )
    files += _write(
        analysis,
        out,
        {"seed": int(seed), "design": design, "fairaudit": __version__, "seconds": round(summary.seconds, 3)},
    )
    return ExperimentRun(out, summary, analysis, tuple(files))


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
    for name, write in (
        ("kernel.csv", lambda p: write_frame(p, kernel_frame(analysis))),
        ("candidates.csv", lambda p: write_frame(p, candidate_frame(analysis))),
        ("records.csv", lambda p: write_frame(p, records_frame(analysis))),
        ("curve.csv", lambda p: analysis.curve.to_csv(p)),
        ("certificate.json", lambda p: write_json(p, data)),
        ("report.md", lambda p: write_atomic(p, experiment_markdown(data), field="--out")),
    ):
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
