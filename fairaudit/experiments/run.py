"""``fairaudit experiment``: run a decision task against a model and write its report.

:func:`run_experiment` is one straight pipeline, each step a function of the previous step's value
(docs/design.md, "The experiment pipeline"):

1. the task (:func:`~fairaudit.experiments.taskfile.get_task`);
2. its cells, the filter's budgets and the mechanism they certify (:func:`~fairaudit.experiments.cells.make_cells`);
3. the decision model and how it is asked: sampled or exact, local or a server, with its route images
   (:func:`~fairaudit.experiments.route.make_route`);
4. the run's folder: checked, locked, and on resume held to its log's settings (:mod:`fairaudit.experiments.folder`);
5. the kernel P(U | X̃, Ã): queries through the resumable log, or the model's token probabilities
   (:func:`~fairaudit.experiments.kernel.measure`);
6. the analysis: bounds and observed fairness at each ε, through the public functions of fairaudit
   (:mod:`fairaudit.experiments.analysis`; the paper's design alone: :mod:`fairaudit.experiments.paper_design`);
7. the report's files (:func:`~fairaudit.experiments.report.write_report`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .analysis import ExperimentAnalysis, analyse, analyse_kernel
from .cells import Cells, make_cells
from .exact import exact_prompt
from .folder import claim, make_folder
from .harness import RunSummary
from .kernel import Measured, measure
from .options import ModelSource, RunOptions
from .paper_design import PaperDesignAnalysis, analyse_paper_design, write_paper_design
from .report import write_report
from .route import make_route, scene_line, sends_images, sends_text_only
from .taskfile import get_task

__all__ = ["ExperimentRun", "ModelSource", "RunOptions", "run_experiment", "show_prompts"]


@dataclass(frozen=True, eq=False, kw_only=True)
class ExperimentRun:
    """What :func:`run_experiment` did: the query summary, the analysis (None when incomplete) and the files.

    ``route`` is ``"exact"`` on the exact route and ``"sampled"`` otherwise. ``summary`` is None on a local
    model's exact route, which asks no queries; on an endpoint's it counts the requests, one per shown cell
    (``analysis`` is None when one failed after retries: nothing is written then). ``coverage_warning``: on the
    exact route, the line naming a coverage below ``min_coverage`` (:func:`~fairaudit.experiments.variants.coverage_warning`).
    """

    out: Path
    summary: RunSummary | None
    analysis: ExperimentAnalysis | PaperDesignAnalysis | None
    files: tuple
    route: str = "sampled"
    seconds: float = 0.0
    coverage_warning: str | None = None


def run_experiment(
    experiment: str,
    out: str | Path,
    source: ModelSource | None = None,
    options: RunOptions | None = None,
    *,
    progress: bool = True,
    log: Callable[[str], None] | None = None,
) -> ExperimentRun:
    """Run one of the paper's delivery experiments and write its report to ``out``.

    Parameters
    ----------
    experiment : {"hr-delivery", "package-delivery"}
    out : str or Path
        Folder of the run (created, with its missing parent folders): the log, tables, certificate, figures,
        report.

        One run at a time per folder: the run holds the lock ``out/.fairaudit.lock``
        from before it writes anything until it returns, and a second run on the
        same folder is refused at once (an :class:`InputError` on ``out``).
    source : ModelSource, optional
        The decision model: a simulated model (the default: the task's first),
        a kernel table, an OpenAI-compatible endpoint, or a real language
        model run on this machine (text only: no route images are made or sent).
    options : RunOptions, optional
        The design, samples, privacy budgets, targets, seed, resuming,
        concurrency, bands and images (default :class:`RunOptions` ()).
    progress : bool
        A progress bar on stderr.
    log : callable, optional
        Called with one line per step of a local model (converting, loading,
        serving), and with the equal-distance check's line when route images
        are made ("route lengths 6.97 m, 6.93 m: 0.6% apart, within the
        tolerance 5%"); default none.

    Returns
    -------
    ExperimentRun

    Raises
    ------
    InputError
        On invalid options (naming the parameter), a log made by another run
        (or, resumed, with other settings: ``resume``, naming each changed
        setting with its logged and its new value: docs/experiments.md, "The
        log, and resuming"; ``samples`` may grow with ``extend``), ``extend`` on the exact route, a
        folder in use by another run (its lock held), an unreadable kernel, a
        scene whose routes differ in length by more than ``tolerance`` (naming
        ``scene``, with the lengths), an unknown room (naming ``start`` or
        ``goals`` and listing the scene's rooms), ``goals`` not one room per
        candidate, ``start``, ``goals`` or ``tolerance`` given for a run that
        sends no route images, or a local model that is not installed (naming
        the install command).

    Examples
    --------
    >>> from fairaudit.experiments.options import ModelSource, RunOptions
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     done = run_experiment(
    ...         "package-delivery",
    ...         Path(tmp) / "run",
    ...         ModelSource(simulated="fair"),
    ...         RunOptions(samples=1, keeps=[0.7], images=False, targets=[]),
    ...         progress=False,
    ...     )
    ...     done.summary.planned, done.analysis.model, (done.out / "report.md").is_file()
    (12, 'fair', True)
    """
    source = ModelSource() if source is None else source
    options = RunOptions() if options is None else options
    task = get_task(experiment)
    cells = make_cells(task, options)
    route = make_route(cells, source, options)
    settings = {**cells.settings(), **route.settings()}
    folder = make_folder(Path(out), settings, exact=route.exact, resume=options.resume, extend=options.extend)
    with claim(folder) as folder:  # makes out and locks it; resumed, the log's settings are checked under the lock
        if route.scene is not None and log is not None:
            log(scene_line(route.scene))
        measured = measure(cells, route, folder, progress=progress, log=log)
    analysis, warning, written = None, None, []  # an incomplete run is analysed and written no further
    if measured.complete:
        warning = _coverage(measured.run, options.min_coverage)
        analysis = _analyse(cells, measured)
        if isinstance(analysis, PaperDesignAnalysis):
            written = write_paper_design(analysis, folder.out, measured.run)
        else:
            written = write_report(analysis, folder.out, measured.run)
    return ExperimentRun(
        out=folder.out,
        summary=measured.summary,
        analysis=analysis,
        files=measured.files + tuple(written),
        route="exact" if route.exact else "sampled",
        seconds=measured.seconds,
        coverage_warning=warning,
    )


def _coverage(run: dict, threshold: float) -> str | None:
    """``run.scoring.coverage`` completed with ``threshold`` and its warning (None when above it, or not exact)."""
    from .variants import coverage_warning

    c = (run.get("scoring") or {}).get("coverage")
    if c is None:
        return None
    warning = coverage_warning(c["min"], c["mean"], threshold, [tuple(u) for u in c["unparsed_replies"]])
    c.update(threshold=threshold, warning=warning)
    return warning


def _analyse(cells: Cells, measured: Measured) -> ExperimentAnalysis | PaperDesignAnalysis:
    """The fifth step of a run: the analysis of what the model gave on ``cells``.

    The exact route's kernel (:func:`analyse_kernel`), the sampled route's answered queries (:func:`analyse`, with
    the paper's design beside when it ran), or the paper's design alone
    (:func:`fairaudit.experiments.paper_design.analyse_paper_design`).
    """
    common: dict[str, Any] = {
        "model": measured.model,
        "epsilons": cells.epsilons,
        "positions": cells.positions,
        "confidence": cells.confidence,
        "method": cells.method,
        "context_epsilon": cells.context_epsilon,
    }
    if measured.kernel is not None:
        return analyse_kernel(measured.task, measured.kernel, targets=cells.targets, **common)
    if cells.design == "paper":
        return analyse_paper_design(measured.task, measured.records, samples=cells.samples, **common)
    paper = cells.epsilons if cells.design == "both" else ()
    return analyse(
        measured.task, measured.records, samples=cells.samples, paper_epsilons=paper, targets=cells.targets, **common
    )


def show_prompts(
    experiment: str, count: int, source: ModelSource | None = None, options: RunOptions | None = None
) -> str:
    """The messages a run would send for the first ``count`` shown cells of the table design, as text; asks nothing.

    The cells are the table design's first, whatever ``options.design`` (:func:`~fairaudit.experiments.harness.table_queries`:
    the contexts in order; within one, the profiles of slots 1 to k in ``itertools.product`` order of
    :attr:`~fairaudit.experiments.vlm.tasks.DeliveryTask.profiles`, the last slot fastest), each at repetition 0 with
    the texts the run draws for it (``options.seed``). Each cell gives its query key, its context and each
    candidate's shown profile (with the text shown where the task writes a value otherwise), then the system message
    and the user message as ``source``'s route sends them (the exact route's prompt for ``exact``,
    ``local_model`` and ``sampled_twin``), each between marker lines, its text verbatim and then one newline; a
    line says when the route images go with the user message (only their SHA-256 goes into the log).

    Parameters
    ----------
    experiment : str
        A built-in task or a task file (:func:`~fairaudit.experiments.taskfile.get_task`).
    count : int
        How many cells, ≥ 1 (fewer when the table has fewer).
    source : ModelSource, optional
        The route whose messages are shown; no model is made, loaded or asked.
    options : RunOptions, optional
        ``seed`` (the texts drawn), ``images`` and ``scene`` (whether route images go with the messages).

    Returns
    -------
    str
        Text for a person, ending with a newline.

    Raises
    ------
    InputError
        ``count`` below 1 (naming ``show_prompts``), or the task's own errors.

    Examples
    --------
    >>> text = show_prompts("package-delivery", 2)
    >>> cell = text[text.index("== cell 2") :]
    >>> print(cell[: cell.index("\\n", cell.index("You are"))])
    == cell 2 of 12: table|documents|low|high|0
    package: documents
    candidate 1: complaint rate = low
    candidate 2: complaint rate = high
    --- no system message ---
    --- user message ---
    You are an intelligent delivery agent tasked with delivering packages to two recipients.
    >>> cell.splitlines()[-2:]
    ['--- then 2 route images (route-1.png, ...: made by the run, hashed in its log) ---', '--- end of cell 2 ---']
    >>> text.endswith("--- end of cell 2 ---\\n")
    True
    """
    import itertools

    from fairaudit import format_label, whole

    from .harness import table_queries, table_queries_needed

    whole(count, "show_prompts", low=1)
    source = ModelSource() if source is None else source
    options = RunOptions() if options is None else options
    task = get_task(experiment)
    sent = exact_prompt(task)[0] if sends_text_only(source) else task
    images = sends_images(task, source, options)
    total = table_queries_needed(task, 1)
    shown = min(int(count), total)
    order = "the profiles" if task.slots == 1 else f"the profiles of slots 1 to {task.slots}, the last slot fastest"
    lines = [
        f"{task.name}: the first {shown} of {total:,} shown cells of the table design (contexts in order; within one, "
        f"{order}), each with the messages the run sends for it; nothing is asked",
        "",
    ]
    for n, q in enumerate(itertools.islice(table_queries(task, 1, options.seed), shown), start=1):
        lines.append(f"== cell {n} of {total:,}: {q.id}")
        lines.append(f"{task.context_name}: {format_label(q.context)}")
        for i, (profile, texts) in enumerate(zip(q.profiles, task.shown_names(q.profiles, q.texts)), start=1):
            own = [(a.name, format_label(v), texts[a.name]) for a, v in zip(task.attributes, profile)]
            parts = (f"{name} = {v}" + ("" if str(text) == v else f" (shown as {text!r})") for name, v, text in own)
            lines.append(f"candidate {i}: " + ", ".join(parts))
        system = sent.system_prompt(q.context, q.profiles, q.texts)
        if system is None:
            lines.append("--- no system message ---")
        else:
            lines += ["--- system message ---", system]
        lines += ["--- user message ---", sent.prompt(q.context, q.profiles, q.texts)]
        if images:
            lines.append(
                f"--- then {task.slots} route images (route-1.png, ...: made by the run, hashed in its log) ---"
            )
        lines += [f"--- end of cell {n} ---", ""]
    return "\n".join(lines)
