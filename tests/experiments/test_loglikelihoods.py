"""The in-process log-likelihoods (lm-eval's ``loglikelihood`` contract) against a second route: one full forward
pass per request over lm-eval's own tokens, no cache (marker ``local_model``); and a discrim-eval file end to end."""

from __future__ import annotations

import math

import numpy as np
import pytest
from _model import need_local_model

from fairaudit import InputError


@pytest.fixture(scope="module")
def smollm2():
    need_local_model()
    from fairaudit.experiments import local_model as lm

    return lm.load("smollm2")


def _full_pass(model, context: str, continuation: str) -> float:
    """log P(continuation | context) from one uncached pass over lm-eval's tokens (``_encode_pair``), written out."""
    import torch

    tok = model.tokenizer
    spaces = len(context) - len(context.rstrip())
    if spaces:
        context, continuation = context[:-spaces], context[-spaces:] + continuation
    ctx = tok.encode(context, add_special_tokens=False)
    cont = tok.encode(context + continuation, add_special_tokens=False)[len(ctx) :]
    ids = torch.tensor([ctx + cont])
    with torch.inference_mode():
        logp = torch.log_softmax(model.model(ids).logits[0].double(), dim=-1)
    return float(sum(logp[len(ctx) - 1 + t, c] for t, c in enumerate(cont)))


@pytest.mark.local_model
def test_cached_log_likelihoods_equal_full_passes(smollm2):
    from fairaudit.experiments.local_model import loglikelihoods

    requests = [
        ("Is the sky blue? Answer:", " yes"),
        ("Is the sky blue? Answer:", " no"),
        ("Is the sky blue? Answer: ", "No, it is green"),  # the trailing space moves to the continuation
        ("The capital of France is", " Paris, of course."),
    ]
    got = loglikelihoods(smollm2, requests, batch_size=2)
    want = [_full_pass(smollm2, c, r) for c, r in requests]
    assert got.tolist() == pytest.approx(want, rel=1e-4, abs=1e-4)  # fp32 logits, cached against uncached
    assert (got < 0).all()
    with pytest.raises(InputError, match="^requests: request 0 needs a non-empty context and continuation"):
        loglikelihoods(smollm2, [("", "x")])


@pytest.mark.local_model
def test_a_discrim_eval_file_runs_end_to_end_on_the_real_model(smollm2, tmp_path):
    from fairaudit.experiments.discrim_eval import LM_EVAL_PROMPT, read_rows
    from fairaudit.experiments.discrim_eval_run import REPLIES, run_discrim_eval, write_run
    from fairaudit.experiments.local_model import loglikelihoods

    rows = read_rows("examples/discrim_eval/sample.jsonl")
    run = run_discrim_eval(rows, lambda r: loglikelihoods(smollm2, r), model="smollm2", coefficients=False)
    write_run(run, tmp_path)
    # the first prompt's four log-probabilities, by full passes
    prompt = LM_EVAL_PROMPT.format(filled_template=rows.prompts[0])
    want = [_full_pass(smollm2, prompt, r) for r in REPLIES]
    assert run.logprobs[0].tolist() == pytest.approx(want, rel=1e-4, abs=1e-4)
    assert 0 < run.coverage.min() <= run.coverage.max() <= 1
    p = np.exp(want)
    assert run.scores[0] == pytest.approx(math.log((p[0] + p[1]) / (p[2] + p[3])), abs=1e-4)


@pytest.mark.local_model
def test_prompts_padded_in_one_pass_equal_one_by_one(smollm2):
    """Prompts of unequal lengths left-padded in one pass, with replies of several tokens scored from the batch's
    cache across prompts, give the log-likelihoods of one prompt per pass to 1e-4 (float32, issue 82 item 3); the
    exact kernel likewise on a shared prefix, the pads then between the prefix and each prompt."""
    from fairaudit.experiments.local_model import exact_kernel, loglikelihoods
    from fairaudit.experiments.taskfile import HR_DELIVERY

    requests = [
        ("Is the sky blue? Answer:", " yes"),
        ("Is the sky blue? Answer:", " No, it is green"),
        ("The capital of France, a country in western Europe, is", " Paris, of course."),
        ("Two plus two is", " four"),
        ("Two plus two is", " five, said nobody"),
    ]
    alone = loglikelihoods(smollm2, requests, prompt_batch=1)
    together = loglikelihoods(smollm2, requests, prompt_batch=3, batch_size=2)
    assert together.tolist() == pytest.approx(alone.tolist(), rel=1e-4, abs=1e-4)
    assert loglikelihoods(smollm2, requests).tolist() == pytest.approx(alone.tolist(), rel=1e-4, abs=1e-4)
    assert alone[2] == pytest.approx(_full_pass(smollm2, *requests[2]), abs=1e-4)  # the route itself, uncached
    cells = [
        (c, a, b) for c in HR_DELIVERY.contexts[:1] for a in HR_DELIVERY.profiles[:2] for b in HR_DELIVERY.profiles[-2:]
    ]
    one = exact_kernel(HR_DELIVERY, smollm2, cells=cells, prompt_batch=1)
    batched = exact_kernel(HR_DELIVERY, smollm2, cells=cells)
    np.testing.assert_allclose(batched, one, rtol=0, atol=1e-4)
    assert one.sum() == pytest.approx(len(cells))  # every asked cell's row sums to 1
