"""The paper's design alone: tasks too large for a kernel, such as eight candidates ranked at once.

The paper's design asks only the true prompts, through the filter at each ε (``RunOptions(design="paper")``), and
beside them the same prompts without a filter for the baseline; each answered query gives one record per candidate
(:func:`fairaudit.experiments.kernel.true_cell_counts`). The certificate needs M_cand only through its ε and the
black-box bound, which have closed forms when its matrix is too large to build (docs/tasks.md;
proofs/black_box.md, "With ℓ = 0 the black-box value is ε(M_A)").
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from fairaudit import (
    InputError,
    Utility,
    number,
    real,
    write_atomic,
)

from ._markdown import paper_design_markdown
from .analysis import ObservedPoint, RunAnalysis, candidate_context_mechanism, candidate_utility, observed_point
from .figures import figure_class
from .harness import paper_queries_needed
from .report import head_dict, observed_dicts, point_dict, utility_dict, write_files, write_frame, write_json
from .slots import candidate_contexts, candidate_epsilon, candidate_population
from .unparsed_bounds import BoundRange, bound_ranges_from
from .vlm.filter import TaskFilter
from .vlm.tasks import DeliveryTask

if TYPE_CHECKING:
    import pandas as pd


__all__ = [
    "DesignBounds",
    "DesignPoint",
    "PaperDesignAnalysis",
    "analyse_paper_design",
    "paper_design_bounds",
    "paper_design_dict",
    "plot_paper_design",
    "write_paper_design",
]


@dataclass(frozen=True, eq=False, kw_only=True)
class DesignBounds:
    """What holds for every decision model behind the filter at one candidate ε (nats).

    Attributes
    ----------
    epsilon : float
        The candidate's ε asked for (+inf: no filter).
    filter : TaskFilter
        Randomized response on each attribute of every profile at the share of
        ε that gives the candidate ``epsilon`` (:meth:`fairaudit.experiments.vlm.filter.TaskFilter.for_candidates`).
    corollary : float
        ε(M_cand), the corollary's bound on L.
    black_box_local, black_box_global : float
        The exact worst case of L and L̄ over every decision model.
    closed_form : bool
        True when both came from the closed forms (no matrix was built).
    """

    epsilon: float
    filter: TaskFilter
    corollary: float
    black_box_local: float
    black_box_global: float
    closed_form: bool


def paper_design_bounds(
    task: DeliveryTask,
    epsilon: float,
    positions: str = "balanced",
    *,
    tau: float | None = None,
    context_epsilon: float | None = None,
    utility: Utility | None = None,
) -> DesignBounds:
    """The corollary and black-box bounds of the candidate's filter at ``epsilon``, in closed form where they have one.

    Parameters
    ----------
    task : DeliveryTask
    epsilon : float
        The candidate's ε (nats, ≥ 0; +inf for no filter).
    positions : {"balanced", "latin", "fixed"}
    tau : float, optional
        A floor on every E[g | x, a] (the paper's τ); with it the matrix is needed.
    context_epsilon : float, optional
        ε of randomized response on the context (it leaves the closed forms unchanged: proofs/black_box.md, §1).
    utility : Utility, optional
        g of the candidate's outcome (default the task's, :func:`fairaudit.experiments.analysis.candidate_utility`);
        another one gives the bounds for it, as the range of the bounds over the unparsed reply's utility needs.

    Returns
    -------
    DesignBounds

    Raises
    ------
    InputError
        ``epsilon`` negative or NaN; ``task.candidates`` when the bounds need M_cand's matrix and it is too large
        (``utility`` when only the utility's positive smallest value, or ``tau``, makes them need it).

    Examples
    --------
    >>> from fairaudit.experiments.taskfile import HR_DELIVERY
    >>> b = paper_design_bounds(HR_DELIVERY, 3.0)
    >>> b.corollary, b.black_box_local, b.black_box_global, b.closed_form
    (3.0, 3.0, 3.0, True)
    """
    eps = real(epsilon, "epsilon", low=0.0, finite=False, what="a number of nats >= 0")
    utility = candidate_utility(task) if utility is None else utility
    filt = TaskFilter.for_candidates(task, eps, positions, context_epsilon=context_epsilon)
    closed = math.inf if math.isinf(eps) else candidate_epsilon(task, filt.epsilon_attributes, positions)
    closed_form = closed is not None and utility.lower == 0 and tau is None and positions != "fixed"
    if closed_form and closed is not None:
        corollary = local = global_ = closed
    else:
        from fairaudit import worst_model

        try:
            mech = filt.candidate_mechanism(positions)
        except InputError as exc:
            if closed is None or positions == "fixed":
                raise
            why = "a floor tau" if tau is not None else f"a utility whose smallest value is {utility.lower:g}, not 0"
            n, k = len(task.profiles), task.slots
            raise InputError(
                "utility",
                f"the black-box bound with {why} needs the candidate's mechanism, whose {n}^{k} = {n**k:,} views "
                "are too many to build; with a utility that takes the value 0 it is epsilon itself, in closed form",
            ) from exc
        mx = candidate_context_mechanism(task, context_epsilon)
        wm = worst_model(mech, utility, context_mechanism=mx, population=candidate_population(task, positions), tau=tau)
        corollary, local, global_ = mech.epsilon, wm.local_fairness.value, wm.global_fairness.value
    return DesignBounds(
        epsilon=eps,
        filter=filt,
        corollary=corollary,
        black_box_local=local,
        black_box_global=global_,
        closed_form=closed_form,
    )


@dataclass(frozen=True, eq=False, kw_only=True)
class DesignPoint(ObservedPoint):
    """The paper's design at one candidate ε: what was observed (:class:`ObservedPoint`) and what holds for any
    model.

    Attributes
    ----------
    counts : numpy.ndarray, shape (n_contexts · k, n_candidates, n_outcomes)
        Per-candidate records by context @ slot, true profile and outcome.
    bounds : DesignBounds
    bound_ranges : dict of str to BoundRange
        Each certified bound's range over every utility of the unparsed reply
        (:func:`fairaudit.experiments.unparsed_bounds.bound_ranges_from`; the lower end NaN, with the reason, when it
        needs a mechanism too large to build).
    """

    counts: np.ndarray
    bounds: DesignBounds
    bound_ranges: dict[str, BoundRange]


@dataclass(frozen=True, eq=False, kw_only=True)
class PaperDesignAnalysis(RunAnalysis):
    """A run of the paper's design alone: the baseline and each ε, with the bounds.

    Attributes
    ----------
    task : DeliveryTask
    model : str
    samples : int
        Queries per true prompt and ε.
    positions : {"balanced", "latin", "fixed"}
    population : Population
        P(context @ slot, candidate) (:func:`fairaudit.experiments.slots.candidate_population`).
    utility : Utility
    baseline : DesignPoint
        The true prompts without a filter (ε = +inf).
    points : tuple of DesignPoint
        One per requested ε, in increasing order.
    confidence : float or None
    unparsed : int
        Answered queries whose reply could not be parsed (all designs).
    context_epsilon, tau : float or None
    route : str
        ``"sampled"``.
    """

    baseline: DesignPoint
    points: tuple


def analyse_paper_design(
    task: DeliveryTask,
    records: Sequence[dict],
    *,
    model: str,
    samples: int,
    epsilons: Sequence[float],
    positions: str = "balanced",
    confidence: float | None = 0.95,
    method: str = "auto",
    tau: float | None = None,
    context_epsilon: float | None = None,
) -> PaperDesignAnalysis:
    """The per-candidate analysis of a run of the paper's design: its records at +inf (baseline) and at each ε.

    Parameters
    ----------
    task : DeliveryTask
    records : sequence of dict
        The log's answered queries: ``design = "paper"``, with ``truth``
        (context and profiles) and ``epsilon`` (``inf`` for the baseline).
    model : str
    samples : int
    epsilons : sequence of float
        The candidate's ε values (nats, finite, ≥ 0).
    positions, confidence, method, context_epsilon
        As in :func:`fairaudit.experiments.analysis.analyse`.
    tau : float, optional
        Default the utility's smallest value when it is positive, else none.

    Returns
    -------
    PaperDesignAnalysis

    Raises
    ------
    InputError
        ``paper design`` when the baseline has no answered query; a bad ε;
        the bounds' errors (:func:`paper_design_bounds`).
    """
    utility = candidate_utility(task)
    pop = candidate_population(task, positions)
    if tau is None and utility.lower > 0:
        tau = utility.lower
    eps = sorted({real(e, "epsilons", low=0.0, what="finite and >= 0 (nats)") for e in epsilons})

    def point(e: float, ctx_eps: float | None) -> DesignPoint:
        seen = observed_point(task, positions, records, e, utility, pop, confidence, method)
        bounds = paper_design_bounds(task, e, positions, tau=tau, context_epsilon=ctx_eps)
        return DesignPoint(
            **vars(seen),
            counts=np.asarray(seen.law.counts),
            bounds=bounds,
            bound_ranges=_bound_ranges(task, e, positions, tau, ctx_eps, bounds),
        )

    baseline = point(math.inf, None)
    if baseline.queries == 0:
        raise InputError("paper design", "has no answered query without a filter (the baseline); run with `resume`")
    return PaperDesignAnalysis(
        task=task,
        model=model,
        samples=samples,
        positions=positions,
        population=pop,
        utility=utility,
        baseline=baseline,
        points=tuple(point(e, context_epsilon) for e in eps),
        confidence=confidence,
        unparsed=sum(1 for r in records if r.get("status") == "ok" and r.get("decision") == "unparsed"),
        context_epsilon=context_epsilon,
        tau=tau,
    )


def _bound_ranges(
    task: DeliveryTask, eps: float, positions: str, tau: float | None, context_epsilon: float | None, b: DesignBounds
) -> dict[str, BoundRange]:
    """The bounds' ranges over the unparsed reply's utility
    (:func:`~fairaudit.experiments.unparsed_bounds.bound_ranges_from` with :func:`paper_design_bounds` for the other
    utility); a lower end that needs a mechanism too large to build is NaN, and its reason says so."""
    refused: list[str] = []

    def inside(u: Utility) -> tuple[float, float]:
        try:
            other = paper_design_bounds(task, eps, positions, tau=tau, context_epsilon=context_epsilon, utility=u)
        except InputError as exc:
            refused.append(str(exc))
            return math.nan, math.nan
        return other.black_box_local, other.black_box_global

    ranges = bound_ranges_from(b.corollary, candidate_utility(task), (b.black_box_local, b.black_box_global), inside)
    if refused:
        note = f"; the lower end is not computed ({refused[0]})"
        ranges = {k: replace(r, reason=r.reason + note) if k != "corollary" else r for k, r in ranges.items()}
    return ranges


def paper_design_dict(analysis: PaperDesignAnalysis, run: dict[str, Any] | None = None) -> dict[str, Any]:
    """The certificate JSON of a run of the paper's design alone: the keys of
    :func:`fairaudit.experiments.report.experiment_dict` where they mean the same, with ``design`` (``"paper"``) and
    per ε the bounds' ``closed_form``; no ``curve``, ``budgets`` or ``shares``, which need the kernel on every shown
    cell (docs/experiments.md, "The files").
    """
    a, t = analysis, analysis.task
    out: dict[str, Any] = head_dict(a) | {
        "design": "paper",
        "queries": {
            "baseline": a.baseline.queries,
            "paper": sum(p.queries for p in a.points),
            "unparsed": a.unparsed,
            "paper_design_needs_per_epsilon": paper_queries_needed(t, a.samples, 1, a.positions),
        },
        "utility": utility_dict(t, a.baseline.unparsed_range),
        "tau": number(a.tau),
        "confidence": number(a.confidence),
        "baseline": {"queries": a.baseline.queries, **observed_dicts(a.baseline)},
        "points": [point_dict(t, p, p.bounds, p.queries, p.bounds.closed_form) for p in a.points],
    }
    if run:
        out["run"] = run
    return out


def counts_frame(analysis: PaperDesignAnalysis) -> pd.DataFrame:
    """The per-candidate counts of every ε as a long table (``candidates.csv``).

    Columns: ``epsilon`` (the candidate's, ``inf`` for the baseline), the
    context name, ``position`` (k ≥ 2), ``profile`` (the candidate's true
    profile), ``outcome`` and ``count``; cells with no record are left out.
    """
    import pandas as pd

    t = analysis.task
    ctx = np.asarray([c.rsplit(" @ ", 1) if t.slots > 1 else (c, "") for c in candidate_contexts(t)], dtype=object)
    groups = np.asarray([t.profile_label(c) for c in t.candidates], dtype=object)
    outcomes = np.asarray(t.outcomes, dtype=object)
    frames = []
    for p in (analysis.baseline, *analysis.points):
        x, g, o = np.nonzero(p.counts)
        frame = {
            "epsilon": np.full(len(x), number(p.epsilon), dtype=object),
            t.context_name: ctx[x, 0],
            **({"position": ctx[x, 1]} if t.slots > 1 else {}),
            "profile": groups[g],
            "outcome": outcomes[o],
            "count": p.counts[x, g, o].astype(np.int64),
        }
        frames.append(pd.DataFrame(frame))
    return pd.concat(frames, ignore_index=True)


def baseline_records(analysis: PaperDesignAnalysis) -> pd.DataFrame:
    """The baseline as one record per query and candidate (``records.csv``), for ``fairaudit audit``.

    Columns: the context name, ``position`` (k ≥ 2), ``profile`` (true, as
    shown: no filter) and ``outcome``. An audit of it with ``--context
    <context>,position`` gives the certificate's baseline L and L̄.
    """
    frame = counts_frame(analysis)
    frame = frame[frame["epsilon"] == "inf"].drop(columns="epsilon")
    return frame.loc[frame.index.repeat(frame.pop("count"))].reset_index(drop=True)


def plot_paper_design(analysis: PaperDesignAnalysis, path: str | Path) -> None:
    """Observed L and L̄ at each ε with their intervals, the black-box bound and the baseline (atomic PNG or SVG).

    The x axis is the candidate's ε (nats); the baseline (no filter) is a
    dotted horizontal line on each metric, named with its value in the
    legend (only named when +inf); a +inf value at an ε is drawn as ▲ on the top edge.
    """
    from fairaudit import mark_infinite, save_figure

    fig = figure_class()(figsize=(8.0, 5.2), layout="constrained")
    ax = fig.add_subplot()
    a = analysis
    x = np.array([p.epsilon for p in a.points])
    bound = np.array([p.bounds.black_box_local for p in a.points])
    finite = [v for p in (a.baseline, *a.points) for v in _values(p) if math.isfinite(v)]
    top = 1.15 * max([*finite, *bound[np.isfinite(bound)], 1e-3])
    ax.plot(x, np.where(np.isfinite(bound), bound, np.nan), "k-", marker="s", label="black-box bound on L (any model)")
    mark_infinite(ax, x[np.isinf(bound)], "k")
    for kind, color, shift, mark in (("local", "tab:red", -0.01, "o"), ("global", "tab:blue", 0.01, "D")):
        name = "L" if kind == "local" else "L̄"
        base = getattr(a.baseline, f"{kind}_fairness").value
        if math.isfinite(base):
            ax.axhline(base, color=color, ls=":", lw=1.2, label=f"{name} without a filter (baseline): {base:.3g}")
        else:  # a legend entry without a line
            ax.plot([], [], color=color, ls=":", label=f"{name} without a filter (baseline): +∞")
        y = np.array([getattr(p, f"{kind}_fairness").value for p in a.points])
        err = _errors(a.points, kind, y)
        dx = shift * max(float(x.max()) if x.size else 1.0, 1.0)
        ax.errorbar(x + dx, np.where(np.isfinite(y), y, np.nan), yerr=err, color=color, marker=mark, ls="none",
                    capsize=3, label=f"observed {name} through the filter" + (" (interval)" if err is not None else ""))  # fmt: skip
        mark_infinite(ax, x[np.isinf(y)] + dx, color)
    ax.set_ylim(0.0, top)
    ax.set_xlim(left=0.0)
    ax.set_xlabel("privacy budget ε of a candidate (nats; all its prompt shows)")
    ax.set_ylabel("local L and global L̄ (nats)")
    ax.set_title(f"{a.task.name}: {a.model} (the paper's design, positions {a.positions})", fontsize=10)
    ax.legend(fontsize=7, loc="upper left")
    save_figure(fig, path)


def _values(p: DesignPoint) -> tuple[float, ...]:
    ends = () if p.intervals is None else (*p.intervals.local_fairness, *p.intervals.global_fairness)
    return (p.local_fairness.value, p.global_fairness.value, *ends)


def _errors(points: Sequence[DesignPoint], kind: str, y: np.ndarray) -> np.ndarray | None:
    """Error-bar lengths below and above ``y`` from the intervals (None without intervals; +inf ends capped)."""
    ivs = [p.intervals for p in points]
    if not ivs or any(v is None for v in ivs):
        return None
    iv = np.array([tuple(getattr(v, f"{kind}_fairness")) for v in ivs], dtype=np.float64)  # (point, [lower, upper])
    with np.errstate(invalid="ignore"):
        lo, hi = np.clip(y - iv[:, 0], 0, None), np.clip(iv[:, 1] - y, 0, None)
    return np.nan_to_num(np.vstack([lo, hi]), nan=0.0, posinf=0.0)


def write_paper_design(analysis: PaperDesignAnalysis, out: Path, run: dict[str, Any]) -> list[Path]:
    """Write a paper-design run's files to ``out``, each atomically: the tables, certificate, report and figure.

    ``candidates.csv`` (:func:`counts_frame`), ``records.csv``
    (:func:`baseline_records`), ``certificate.json`` (:func:`paper_design_dict`), ``report.md`` and
    ``curve.png`` (:func:`plot_paper_design`; skipped with a note on stderr when matplotlib is missing).
    """
    data = paper_design_dict(analysis, run)
    steps = (
        ("candidates.csv", lambda p: write_frame(p, counts_frame(analysis))),
        ("records.csv", lambda p: write_frame(p, baseline_records(analysis))),
        ("certificate.json", lambda p: write_json(p, data)),
        ("report.md", lambda p: write_atomic(p, paper_design_markdown(data), field="out")),
    )

    def plot() -> list[Path]:
        plot_paper_design(analysis, out / "curve.png")
        return [out / "curve.png"]

    return write_files(out, steps, plot)
