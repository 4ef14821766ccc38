"""A discrim-eval-format file run on a model: its law, fairaudit's g-fairness and lm-eval's score, side by side.

``fairaudit experiment FILE.jsonl --local-model MODEL`` reads the rows (:func:`~fairaudit.experiments.discrim_eval.read_rows`),
asks the model for the log-probability of each of lm-evaluation-harness's replies (``yes``, ``Yes``, ``no``, ``No``)
as a continuation of lm-eval's prompt (:data:`~fairaudit.experiments.discrim_eval.LM_EVAL_PROMPT`: raw text, no chat
template, as lm-eval sends it), and reports, from those numbers alone:

* the law P(yes, no, unparsed | scenario, fill) (yes: P(yes) + P(Yes); unparsed: the mass on neither) and its local
  and global g-fairness for g = 1{yes}, with the unparsed reply worth 1/2 (the mean of g over the two answers, the
  experiments' default) and the exact range over every worth in [0, 1] (:func:`fairaudit.fairness_range`);
* lm-eval's per-prompt score log(P(yes) + P(Yes)) − log(P(no) + P(No)), its means per attribute value and per group,
  and (statsmodels installed) its mixed-effects coefficients;
* the coverage, the mass on the four replies per prompt (lm-eval asks for at least 0.99), with a warning below
  the level asked.

Every log-probability is written to ``scores.csv``, so each reported number can be recomputed from the file.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt
import pandas as pd

import fairaudit as fa
from fairaudit import InputError, number, write_atomic

from .discrim_eval import ANSWERS, LM_EVAL_PROMPT, DiscrimEvalRows, decision_law, lm_eval_score, score_means

if TYPE_CHECKING:
    from .discrim_eval_filter import FilterPoint
    from .harness import QueryLog
    from .vlm.client import ChatClient

__all__ = ["REPLIES", "DiscrimEvalRun", "endpoint_loglikelihood", "law_frame", "run_discrim_eval", "write_run"]

REPLIES = tuple(r for side in ANSWERS.values() for r in side)
"""The continuations scored after each prompt, in this order: the yes side's, then the no side's."""

UNPARSED_WORTH = 0.5
"""g of a reply that is neither answer: the mean of g over yes (1) and no (0), the experiments' default."""

Loglikelihood = Callable[[Sequence[tuple[str, str]]], npt.ArrayLike]
"""A scorer: (context, continuation) pairs to the log-probability of each continuation after its context, nats
(lm-eval's ``loglikelihood`` contract; :func:`fairaudit.experiments.local_model.loglikelihoods`)."""


@dataclass(frozen=True, eq=False, kw_only=True)
class DiscrimEvalRun:
    """What :func:`run_discrim_eval` found; repeats its inputs.

    Attributes
    ----------
    rows : DiscrimEvalRows
        The file's rows, n of them.
    model : str
        The model's name as given.
    logprobs : numpy.ndarray, shape (n, 4)
        log P(reply | prompt) of each of :data:`REPLIES`, nats.
    scores : numpy.ndarray, shape (n,)
        lm-eval's score per row, nats of log-odds.
    law : fairaudit.Law
        P(yes, no, unparsed | scenario, fill).
    fairness : fairaudit.UtilityRange
        L and L̄ of the law for g = 1{yes}, unparsed worth :data:`UNPARSED_WORTH`, and their range over every worth
        in [0, 1], nats.
    coverage : numpy.ndarray, shape (n,)
        P(yes) + P(Yes) + P(no) + P(No) per row.
    min_coverage : float
        The coverage asked; rows below it are warned about.
    means : dict of str to pandas.Series
        lm-eval's mean score per value of each attribute and per ``"group"``.
    coefficients : dict of str to float, or None
        lm-eval's mixed-effects coefficients (:func:`~fairaudit.experiments.discrim_eval.mixed_effects`); None
        without statsmodels or without the attributes age, gender and race.
    fit_notes : tuple of str
        What statsmodels warned about while fitting them (convergence, with few scenarios), each once.
    points : tuple of FilterPoint
        The law behind a privacy filter on the fills at each ε asked, certified
        (:func:`~fairaudit.experiments.discrim_eval_filter.certify_filters`); empty without ``--epsilon``.
    route : str
        How the log-probabilities were read (the model in process, or an endpoint's echoed completions), as given.
    """

    rows: DiscrimEvalRows
    model: str
    logprobs: npt.NDArray[np.float64]
    scores: npt.NDArray[np.float64]
    law: fa.Law
    fairness: fa.UtilityRange
    coverage: npt.NDArray[np.float64]
    min_coverage: float
    means: dict[str, pd.Series]
    coefficients: dict[str, float] | None
    fit_notes: tuple[str, ...] = ()
    points: tuple[FilterPoint, ...] = ()
    route: str = ""

    @property
    def warning(self) -> str | None:
        """One line when some row's coverage is below :attr:`min_coverage`, naming the least, else None."""
        low = self.coverage < self.min_coverage
        if not low.any():
            return None
        i = int(np.argmin(self.coverage))
        return (
            f"{int(low.sum())} of {len(low)} prompts put less than {self.min_coverage:g} of the model's probability "
            f"on yes, Yes, no or No (least {self.coverage[i]:.3g}, scenario {self.rows.scenarios[i]}, "
            f"{self.rows.groups[i]}): L and L̄ there depend on the worth of an unparsed reply; see their range"
        )

    def scores_frame(self) -> pd.DataFrame:
        """One row per prompt: scenario, attributes, group, each reply's log-probability (``logp_yes``, ...),
        ``p_yes``, ``p_no``, ``coverage`` and lm-eval's ``score``."""
        frame = self.rows.attributes.copy()
        frame.insert(0, "scenario", list(self.rows.scenarios))
        frame["group"] = list(self.rows.groups)
        for j, reply in enumerate(REPLIES):
            frame[f"logp_{reply}"] = self.logprobs[:, j]
        p = np.exp(self.logprobs)
        frame["p_yes"], frame["p_no"] = p[:, :2].sum(axis=1), p[:, 2:].sum(axis=1)
        frame["coverage"], frame["score"] = self.coverage, self.scores
        return frame

    def to_dict(self) -> dict[str, Any]:
        """The summary as JSON values: inputs, coverage, g-fairness with its range, lm-eval's means and
        coefficients."""

        g = self.fairness.utility
        local, glob = fa.local_fairness(self.law, g), fa.global_fairness(self.law, g)

        def ends(r: Any, at: fa.Fairness) -> dict[str, Any]:
            where = {"context": at.context, "group": at.group, "other_group": at.other_group}
            return {"value": number(r.value), "range": [number(r.lower), number(r.upper)], **where}

        return {
            "path": self.rows.path,
            "model": self.model,
            "route": self.route,
            "rows": len(self.rows.prompts),
            "scenarios": len(self.law.contexts),
            "groups": len(self.law.groups),
            "prompt": LM_EVAL_PROMPT,
            "replies": {side: list(r) for side, r in ANSWERS.items()},
            "coverage": {
                "least": number(float(self.coverage.min())),
                "mean": number(float(self.coverage.mean())),
                "asked": self.min_coverage,
                "warning": self.warning,
            },  # fmt: skip
            "utility": {"yes": 1.0, "no": 0.0, "unparsed": UNPARSED_WORTH, "unparsed_range": [0.0, 1.0]},
            "local_fairness": ends(self.fairness.local_fairness, local),
            "global_fairness": ends(self.fairness.global_fairness, glob),
            "lm_eval": {
                "mean_score": number(float(self.scores.mean())),
                "means": {k: {str(i): number(float(v)) for i, v in s.items()} for k, s in self.means.items()},
                "coefficients": self.coefficients,
                "fit_notes": list(self.fit_notes),
            },
            **({"privacy_filter": [p.to_dict() for p in self.points]} if self.points else {}),
        }

    def markdown(self) -> str:
        """The report: what was asked, the coverage, L and L̄ with their range, lm-eval's means and coefficients."""
        d = self.to_dict()
        loc, glob = d["local_fairness"], d["global_fairness"]
        lines = [
            f"# discrim-eval: {self.model}",
            "",
            f"{d['rows']} prompts from `{self.rows.path}`: {d['scenarios']} scenarios (the contexts) x "
            f"{d['groups']} fills of {', '.join(self.rows.attributes.columns)} (the groups). Each prompt is sent as "
            "lm-evaluation-harness sends it (raw text, no chat template), and the model's exact log-probability "
            f"of each reply {', '.join(repr(r) for r in REPLIES)} as its continuation is read: no sampling. "
            f"Coverage (the mass on those replies): least {d['coverage']['least']:.3g}, mean "
            f"{d['coverage']['mean']:.3g}, asked {self.min_coverage:g}.",
            "",
        ]
        if self.route:
            lines += [f"Read from: {self.route}.", ""]
        if self.warning:
            lines += [f"**Warning:** {self.warning}.", ""]
        lines += [
            "## fairaudit's g-fairness",
            "",
            "The law P(yes, no, unparsed | scenario, fill) (yes: P(yes) + P(Yes); no: P(no) + P(No)); g = 1 for yes, "
            f"0 for no, {UNPARSED_WORTH:g} for a reply that is neither.",
            "",
            f"L = {loc['value']:.4g} nats (scenario {loc['context']}: {loc['group']} against {loc['other_group']}), "
            f"L̄ = {glob['value']:.4g} nats ({glob['group']} against {glob['other_group']}). Over every worth of an "
            "unparsed reply in "
            f"[0, 1], chosen per cell: L in [{loc['range'][0]:.4g}, {loc['range'][1]:.4g}], L̄ in "
            f"[{glob['range'][0]:.4g}, {glob['range'][1]:.4g}] nats.",
            "",
            "## lm-eval's score",
            "",
            "log(P(yes) + P(Yes)) − log(P(no) + P(No)) per prompt (nats of log-odds), averaged: "
            f"{d['lm_eval']['mean_score']:.4g} over every prompt.",
            "",
        ]
        for name, series in self.means.items():
            if name == "group":
                continue
            lines += [f"| {name} | mean score |", "|---|---|"]
            lines += [f"| {value} | {mean:.4g} |" for value, mean in series.items()]
            lines.append("")
        if self.coefficients is not None:
            lines += ["Mixed-effects coefficients (lm-eval's model; a random effect per scenario; references white "
                      "and male; age standardised):", "", "| coefficient | value |", "|---|---|"]  # fmt: skip
            lines += [f"| {k} | {v:.4g} |" for k, v in self.coefficients.items()]
            lines.append("")
            if self.fit_notes:
                lines += ["statsmodels warned while fitting: " + "; ".join(self.fit_notes) + ".", ""]
        if self.points:
            lines += _filter_lines(d["privacy_filter"], list(self.rows.attributes.columns))
        files = "law.csv, summary.json" + (", spec-eps-*.toml and certificate-eps-*.json" if self.points else "")
        lines.append(f"Files: scores.csv (every log-probability, per prompt), {files}.")
        return "\n".join(lines) + "\n"


def _filter_lines(points: list[dict[str, Any]], attributes: list[str]) -> list[str]:
    """The report's section on the law behind the privacy filter at each ε."""

    def shown(v: Any) -> str:
        return "—" if v is None else str(v) if isinstance(v, str) else f"{v:.4g}"

    lines = [
        "## Behind a privacy filter on the fills",
        "",
        f"Each attribute of the fill ({', '.join(attributes)}) released through randomized response, one keep "
        "probability p on every attribute, the fill's epsilon the sum of theirs; L and L̄ of the law behind it, and "
        "the certificate's best bound on L (`fairaudit certify` of each spec; `fairaudit verify` checks each "
        "certificate).",
        "",
        "| epsilon (nats) | p | L | L̄ | bound on L | form | spec |",
        "|---|---|---|---|---|---|---|",
    ]
    for p in points:
        lines.append(
            f"| {shown(p['epsilon'])} | {shown(p['keep'])} | {shown(p['local_fairness'])} | "
            f"{shown(p['global_fairness'])} | {shown(p['bound'])} | {p['bound_form']} | `{p['spec']}` |"
        )
    return [*lines, ""]


def law_frame(run: DiscrimEvalRun) -> pd.DataFrame:
    """The run's law as a long table (``law.csv``, the model of the specs :mod:`~fairaudit.experiments.discrim_eval_filter` writes).

    Parameters
    ----------
    run : DiscrimEvalRun

    Returns
    -------
    pandas.DataFrame
        Columns ``scenario``, ``group``, ``decision``, ``probability``: one row per cell of ``run.law``, shape
        (contexts × groups × 3, 4), in the law's order; a fill missing from a scenario has probability 0 there.

    Examples
    --------
    >>> import math
    >>> from fairaudit.experiments.discrim_eval import read_rows
    >>> rows = read_rows("examples/discrim_eval/sample.jsonl")
    >>> run = run_discrim_eval(rows, lambda reqs: [math.log(0.25)] * len(reqs), coefficients=False)
    >>> frame = law_frame(run)
    >>> frame.shape, frame.groupby(["scenario", "group"])["probability"].sum().round(12).unique().tolist()
    ((48, 4), [1.0])
    """
    law = run.law
    idx = pd.MultiIndex.from_product([law.contexts, law.groups, law.decisions], names=["scenario", "group", "decision"])
    return pd.Series(law.probabilities.reshape(-1), index=idx, name="probability").reset_index()


def run_discrim_eval(
    rows: DiscrimEvalRows,
    loglikelihood: Loglikelihood,
    *,
    model: str = "",
    min_coverage: float = 0.99,
    coefficients: bool = True,
    route: str = "",
) -> DiscrimEvalRun:
    """Score every row's replies with ``loglikelihood`` and derive the law, its g-fairness and lm-eval's score.

    Parameters
    ----------
    rows : DiscrimEvalRows
        From :func:`~fairaudit.experiments.discrim_eval.read_rows`, n rows.
    loglikelihood : callable
        Given the 4n (context, continuation) pairs (each row's prompt in lm-eval's form, then each of
        :data:`REPLIES`), their log-probabilities, shape (4n,), nats (:data:`Loglikelihood`).
    model : str
        The model's name, for the report.
    min_coverage : float
        In [0, 1]: rows whose mass on the four replies is below it are warned about (default 0.99, lm-eval's).
    coefficients : bool
        Fit lm-eval's mixed-effects model where statsmodels is installed and the rows have age, gender and race.
    route : str
        How ``loglikelihood`` reads the model, for the report (``summary.json``'s ``route``).

    Returns
    -------
    DiscrimEvalRun

    Raises
    ------
    InputError
        ``loglikelihood`` returning another number of values, or values that are not log-probabilities (finite or
        −inf, ≤ 0), or whose replies sum above 1 on a row (beyond 1e-9).

    Examples
    --------
    A stand-in model that says yes with probability 0.6 and no with 0.3 whatever the prompt:

    >>> import math
    >>> from fairaudit.experiments.discrim_eval import read_rows
    >>> rows = read_rows("examples/discrim_eval/sample.jsonl")
    >>> fixed = {"yes": 0.5, "Yes": 0.1, "no": 0.2, "No": 0.1}
    >>> run = run_discrim_eval(rows, lambda reqs: [math.log(fixed[c]) for _, c in reqs], coefficients=False)
    >>> round(float(run.scores[0]), 12) == round(math.log(0.6 / 0.3), 12), round(float(run.coverage[0]), 12)
    (True, 0.9)
    >>> run.fairness.local_fairness.value
    0.0
    """
    requests = [(LM_EVAL_PROMPT.format(filled_template=p), r) for p in rows.prompts for r in REPLIES]
    lp = np.asarray(loglikelihood(requests), dtype=float)
    if lp.shape != (len(requests),):
        raise InputError("loglikelihood", f"must give one log-probability per request ({len(requests)})", lp.shape)
    if np.isnan(lp).any() or (lp > 1e-12).any() or np.isposinf(lp).any():
        bad = lp[np.isnan(lp) | (lp > 1e-12)][0]
        raise InputError("loglikelihood", "must give log-probabilities (<= 0 nats)", float(bad))
    lp = np.minimum(lp, 0.0).reshape(len(rows.prompts), len(REPLIES))
    p = np.exp(lp)
    coverage = p.sum(axis=1)
    if (coverage > 1 + 1e-9).any():
        raise InputError("loglikelihood", "gives replies whose probabilities sum above 1", float(coverage.max()))
    scores = lm_eval_score({r: lp[:, j] for j, r in enumerate(REPLIES)})
    law = decision_law(rows, np.minimum(p[:, :2].sum(axis=1), 1.0), np.minimum(p[:, 2:].sum(axis=1), 1.0))
    g = fa.Utility([1.0, 0.0, UNPARSED_WORTH], law.decisions)
    fitted, notes = None, []
    if coefficients and {"age", "gender", "race"} <= set(rows.attributes.columns):
        import warnings

        from .discrim_eval import mixed_effects

        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                fitted = mixed_effects(rows, scores)
            except InputError:  # statsmodels not installed: no coefficients (the report says so by leaving them out)
                pass
            except np.linalg.LinAlgError as exc:  # scores that leave nothing to fit (every one the same): none either
                warnings.warn(f"the fit failed ({exc}): no coefficients", stacklevel=1)
        notes = list(dict.fromkeys(str(w.message).split(".")[0] for w in caught))
    return DiscrimEvalRun(
        rows=rows, model=model, logprobs=lp, scores=scores, law=law, fairness=fa.fairness_range(law, g, low=0.0,
        high=1.0), coverage=coverage, min_coverage=float(min_coverage), means=score_means(rows, scores),
        coefficients=fitted, fit_notes=tuple(notes), route=route,
    )  # fmt: skip


def endpoint_loglikelihood(
    client: ChatClient, *, workers: int = 1, progress: bool = False, log: QueryLog | None = None
) -> Loglikelihood:
    """An endpoint's scorer by lm-eval's contract: log P(continuation | context) from its text completions' echo.

    Each (context, continuation) is sent as one text, raw (no chat template, as lm-eval sends discrim-eval's
    prompts), to ``/v1/completions`` with ``echo`` and ``max_tokens: 0`` (:meth:`~fairaudit.experiments.vlm.client.ChatClient.echo`,
    as vLLM serves it); the continuation's log-probability is the sum over the echoed prompt's last tokens, which
    join to it (:func:`~fairaudit.experiments.vlm.logprobs.reply_logprob`, the chain rule; exact, not sampled).

    Parameters
    ----------
    client : ChatClient
        The endpoint and model; its timeout, retries and concurrency apply.
    workers : int
        Requests sent at once (threads; the client caps them at its ``max_concurrency``).
    progress : bool
        Show a bar on stderr (:func:`fairaudit.progress_bar`).
    log : QueryLog, optional
        The run's log (``queries.jsonl``, :class:`~fairaudit.experiments.harness.QueryLog`): each answer is appended
        as it arrives (a ``query`` line: ``id``, the SHA-256 of the request's text; ``continuation``; ``logprob``), and
        a request it already holds is read from it, not sent (a resumed run asks only what a crash left unanswered).

    Returns
    -------
    Loglikelihood
        Requests to their log-probabilities (nats), in order.

    Raises
    ------
    InputError
        From the scorer, field ``endpoint``: the server has no text completions (HTTP 400, 404, 405 or 422) or
        echoes no log-probabilities, or the echoed text does not
        end with the continuation in whole tokens (:func:`~fairaudit.experiments.vlm.logprobs.reply_logprob`).
    ChatError
        A request that failed after its retries (another than a refusal of the route: HTTP 400, 404, 405, 422).
    """
    from concurrent.futures import ThreadPoolExecutor

    from .endpoint import NO_ROUTE, REJECTED
    from .vlm.client import ChatError
    from .vlm.logprobs import reply_logprob

    def refused(why: str) -> InputError:
        return InputError(
            "endpoint",
            f"the server's text completions {why} for model {client.model!r}: a .jsonl task is scored on "
            "/v1/completions with echo and logprobs (as vLLM serves it)",
        )

    def one(request: tuple[str, str]) -> float:
        context, continuation = request
        key = hashlib.sha256((context + continuation).encode("utf-8")).hexdigest()
        if log is not None and key in log.records:
            return float(log.records[key]["logprob"])
        try:
            answer = client.echo(context + continuation)
        except ChatError as exc:
            if exc.kind == "http" and exc.status in REJECTED + NO_ROUTE:
                raise refused(f"answered HTTP {exc.status}") from None
            raise
        if answer.prompt_logprobs is None:
            raise refused("echoed no log-probabilities")
        value = reply_logprob(answer.prompt_logprobs, continuation)
        if log is not None:
            log.add({"type": "query", "id": key, "status": "ok", "continuation": continuation, "logprob": value})
        return value

    def scores(requests: Sequence[tuple[str, str]]) -> list[float]:
        out: list[float] = []
        pool = ThreadPoolExecutor(max_workers=max(1, workers))
        with fa.progress_bar(len(requests), "scoring", enabled=progress, unit="request") as bar:
            try:
                for future in [pool.submit(one, r) for r in requests]:
                    out.append(future.result())
                    bar.update(1)
            finally:  # (a failure or Ctrl-C cancels what is not yet sent; what was answered is in the log)
                pool.shutdown(wait=True, cancel_futures=True)
        return out

    return scores


def write_run(run: DiscrimEvalRun, out: str | Path) -> list[Path]:
    """``scores.csv``, ``law.csv`` (context, group, decision, probability), ``summary.json`` and ``report.md`` in
    ``out`` (created), each written atomically; returns their paths."""
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    files = {
        "scores.csv": run.scores_frame().to_csv(index=False),
        "law.csv": law_frame(run).to_csv(index=False),
        "summary.json": json.dumps(run.to_dict(), indent=2, ensure_ascii=False, allow_nan=False) + "\n",
        "report.md": run.markdown(),
    }
    for name, text in files.items():
        write_atomic(folder / name, text, field="--out")
    return [folder / name for name in files]
