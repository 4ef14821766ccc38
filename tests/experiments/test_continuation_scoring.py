"""Continuation scoring in process (issue 38): ``exact_kernel`` against a second route, stepping the model.

The second route scores a reply r after a prompt by a full forward pass, without any cache, padding or batch, on
prompt + r_<t for each t, and sums the log-softmax of r_t at the last position: the chain rule taken literally.
The first tests build a tiny causal language model here (random weights from a fixed seed, in float64) with a
tokenizer made in memory, so both routes agree to 1e-9 and run in seconds; the last ones check SmolLM2 (float32)
to 1e-6. All are marked ``local_model``: they need torch and transformers, and are skipped without them unless
``FAIRAUDIT_REQUIRE_LOCAL_MODEL=1``.
"""

from __future__ import annotations

import importlib.util
import math
import string
from pathlib import Path

import numpy as np
import pytest
from _model import REQUIRE_LOCAL_MODEL, need_local_model

from fairaudit.experiments import local_model as lm
from fairaudit.experiments.exact import exact_prompt, exact_prompts, prompt_replies
from fairaudit.experiments.taskfile import HR_DELIVERY, PACKAGE_DELIVERY, load_task, parse_task
from fairaudit.experiments.vlm.messages import chatml

pytestmark = pytest.mark.local_model

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "tasks"

CHAT_TEMPLATE = (
    "{% for m in messages %}<|im_start|>{{ m['role'] }}\n{{ m['content'] }}<|im_end|>\n{% endfor %}"
    "{% if add_generation_prompt %}<|im_start|>assistant\n{% endif %}"
)
WORDS = ("Office", " A", " B", ", ", "yes", "no", "ANN", "BO")  # merged tokens; the rest is one token per character


@pytest.fixture(autouse=True)
def _each_reply_alone(monkeypatch):
    """Each decision's own reply as its only variant: these tests check the chain rule reply by reply (the sums over
    the variants: test_variants.py)."""
    monkeypatch.setattr(
        lm, "prompt_variants", lambda task, answers, p: tuple((r,) for r in prompt_replies(task, answers, p))
    )


def _need_torch() -> None:
    missing = [m for m in ("torch", "transformers", "tokenizers") if importlib.util.find_spec(m) is None]
    if missing:
        why = f"needs {', '.join(missing)}: pip install -e '.[local-model]'"
        if REQUIRE_LOCAL_MODEL:
            pytest.fail(f"FAIRAUDIT_REQUIRE_LOCAL_MODEL=1 but the test {why}")
        pytest.skip(why)


def _tokenizer():
    """A character-level BPE with a few merged words and a chat template; no pre-tokenizer, no normalizer."""
    from tokenizers import Tokenizer, decoders, models
    from transformers import PreTrainedTokenizerFast

    chars = sorted(set(string.ascii_letters + string.digits + " \n.,:;?!'-()&"))
    vocab = {t: i for i, t in enumerate(["<unk>", "<pad>", "<|im_start|>", "<|im_end|>", *chars])}
    merges = []
    for w in WORDS:
        for i in range(1, len(w)):
            merges.append((w[:i], w[i]))
            vocab.setdefault(w[: i + 1], len(vocab))
    tok = Tokenizer(models.BPE(vocab=vocab, merges=merges, unk_token="<unk>"))
    tok.add_special_tokens(["<unk>", "<pad>", "<|im_start|>", "<|im_end|>"])
    tok.decoder = decoders.Fuse()
    return PreTrainedTokenizerFast(
        tokenizer_object=tok,
        unk_token="<unk>",
        pad_token="<pad>",
        eos_token="<|im_end|>",
        chat_template=CHAT_TEMPLATE,
        clean_up_tokenization_spaces=False,
    )


@pytest.fixture(scope="module")
def tiny():
    """A two-layer Llama of random weights (seed 0) in float64, around the in-memory tokenizer."""
    _need_torch()
    import torch
    from transformers import LlamaConfig, LlamaForCausalLM

    tok = _tokenizer()
    config = LlamaConfig(
        vocab_size=len(tok),
        hidden_size=32,
        intermediate_size=64,
        num_hidden_layers=2,
        num_attention_heads=4,
        num_key_value_heads=2,
        max_position_embeddings=2048,
        initializer_range=0.2,  # logits of a few units: replies of real mass, and rows far from uniform
        tie_word_embeddings=False,
        pad_token_id=tok.pad_token_id,
    )
    torch.manual_seed(0)
    model = LlamaForCausalLM(config).double().eval()
    return lm.LoadedModel("tiny", Path("."), model, tok)


def _stepped(loaded, task, cell) -> np.ndarray:
    """A cell's kernel row by the second route: each reply's tokens one at a time, a whole pass each, no cache."""
    import torch

    shown, answers = exact_prompt(task)
    tok = loaded.tokenizer
    row = np.zeros(len(task.decisions))
    for p in exact_prompts(task, [cell]):
        chat = shown.messages(p.context, p.profiles, p.texts)
        ids = list(tok.apply_chat_template(chat, add_generation_prompt=True, tokenize=True, return_dict=False))
        text = tok.apply_chat_template(chat, add_generation_prompt=True, tokenize=False)
        probs = []
        for reply in prompt_replies(task, answers, p):
            r = list(tok.encode(reply, add_special_tokens=False))
            assert tok.encode(text + reply, add_special_tokens=False) == ids + r  # the reply's tokens in context
            logp = 0.0
            for t in range(len(r)):
                with torch.inference_mode():
                    logits = loaded.model(torch.tensor([ids + r[:t]])).logits[0, -1]
                logp += float(torch.log_softmax(logits.double(), -1)[r[t]])
            probs.append(math.exp(logp))
        row[:-1] += p.weight * np.array(probs)
        row[-1] += p.weight * (1.0 - sum(probs))
    return row


def _index(task, cell) -> tuple[int, ...]:
    return (task.contexts.index(cell[0]), *(task.profiles.index(tuple(p)) for p in cell[1:]))


OFFICES = """
[task]
candidates = 2
decision = "choose"
population = "all"
[prompt]
system = "You deliver a confidential letter. Answer with the office only."
user = '''Letter: {{ context }}.
Office A: {{ c1.name }}.
Office B: {{ c2.name }}.
Which office gets it? Answer Office A or Office B.'''
[context]
name = "letter"
values = ["sick leave", "holiday"]
[[attribute]]
name = "name"
values = ["Tom", "Mary"]
[decision]
name = "office"
options = { "Office A" = 1, "Office B" = 2 }
[utility]
values = { chosen = 1.0, "not chosen" = 0.0 }
"""

LOAN = (EXAMPLES / "loan.toml").read_text()

RANKING = (EXAMPLES / "ranking.toml").read_text()

NAMED = """
[task]
candidates = 2
decision = "rank"
population = "distinct"
[prompt]
user = '''Rank the applicants for the {{ context }} role; write their names in order.
{% for c in candidates %}{{ c.group }}
{% endfor %}'''
[context]
name = "job"
values = ["retail"]
[[attribute]]
name = "group"
values = ["A", "B"]
text = { A = ["ANN LEE", "AMY LEE"], B = ["BO KIM", "BEATRIX KIM"] }
[decision]
name = "rank"
named_by = "group"
[utility]
values = [1.0, 0.0]
unparsed = 0.0
"""

TASKS = {
    "choice of two sharing a first token": OFFICES,
    "choice of one, yes or no": LOAN,
    "order of two": "package-delivery",
    "ranking of three": RANKING,
    "named replies of unequal lengths": NAMED,
}


def _task(source: str):
    return PACKAGE_DELIVERY if source == "package-delivery" else parse_task(source, name="t")


def _cells(task, count: int) -> list[tuple]:
    import itertools

    every = [(c, *s) for c in task.contexts for s in itertools.product(task.profiles, repeat=task.slots)]
    every = [cell for cell in every if task.population != "distinct" or len(set(cell[1:])) == task.slots]
    return every[:count]


@pytest.mark.parametrize("source", list(TASKS.values()), ids=list(TASKS))
def test_continuation_equals_stepping_the_model_token_by_token(tiny, source):
    """Every asked cell: the engine (one cached pass per prompt, the replies batched and right-padded on its cache)
    equals the stepping route to 1e-9 in log-probability; each row sums to 1 with unparsed = 1 - the rest."""
    task = _task(source)
    cells = _cells(task, 2 if task.slots > 2 else 4)  # 12 prompts at most (named: 4 per cell), in seconds
    got = lm.exact_kernel(task, tiny, cells=cells, batch_size=4)
    for cell in cells:
        row, want = got[_index(task, cell)], _stepped(tiny, task, cell)
        assert np.all(want[:-1] > 0), (cell, want)  # every reply has mass (5 tokens of an order: about 1e-14)
        np.testing.assert_allclose(np.log(row[:-1]), np.log(want[:-1]), rtol=0, atol=1e-9, err_msg=str(cell))
        assert row[-1] == pytest.approx(want[-1], abs=1e-12) and 0 < row[-1] < 1
        assert row.sum() == pytest.approx(1.0, abs=1e-12)
    assert got.sum() == pytest.approx(len(cells), abs=1e-9)  # the cells not asked stay at zero


def test_the_tiny_tokenizer_shares_first_tokens_and_writes_orders_in_several_tokens(tiny):
    """What the tests above rely on: "Office A" and "Office B" begin with the one token "Office"; an order of
    three is five tokens; names of one slot have different lengths (padding)."""
    tok = tiny.tokenizer

    def pieces(text):
        return [tok.decode([i]) for i in tok.encode(text, add_special_tokens=False)]

    assert pieces("Office A") == ["Office", " A"] and pieces("Office B") == ["Office", " B"]
    assert pieces("2, 3, 1") == ["2", ", ", "3", ", ", "1"]
    assert len(pieces("BO KIM")) != len(pieces("BEATRIX KIM")) and pieces("yes") == ["yes"]


def test_options_sharing_their_first_token_get_different_probabilities(tiny):
    """Continuation scoring tells "Office A" from "Office B" (same first token); first-token scoring cannot: the
    token "Office" reads as neither, so both options get 0 and everything is unparsed."""
    task = _task(OFFICES)
    cells = _cells(task, 4)
    cont = lm.exact_kernel(task, tiny, cells=cells)
    first = lm.exact_kernel(task, tiny, cells=cells, scoring="first-token")
    for cell in cells:
        a, b, _ = cont[_index(task, cell)]
        assert a > 1e-6 and b > 1e-6 and abs(math.log(a / b)) > 1e-3, (cell, a, b)
        np.testing.assert_allclose(first[_index(task, cell)], [0.0, 0.0, 1.0], rtol=0, atol=1e-12)


@pytest.mark.parametrize(
    "source, tokens",
    [
        (LOAN, (["yes"], ["no"])),
        (EXAMPLES.joinpath("shortlist.toml").read_text(), (["1"], ["2"])),
        ("package-delivery", (["1"], ["2"])),
    ],
    ids=["loan", "shortlist", "package-delivery"],
)
def test_first_token_scoring_sums_the_softmax_over_the_tokens_of_each_option(tiny, source, tokens):
    """By hand from the tiny model's logits: the next-token softmax (float64) at the prompt's last position, summed
    over the tokens that read as each option (in this vocabulary, only the option's own token does)."""
    import torch

    task = _task(source)
    cells = _cells(task, 3)
    got = lm.exact_kernel(task, tiny, cells=cells, scoring="first-token")
    tok = tiny.tokenizer
    shown = exact_prompt(task)[0]
    for cell in cells:
        ids = tok.apply_chat_template(shown.messages(cell[0], cell[1:]), add_generation_prompt=True, return_dict=False)
        with torch.inference_mode():
            p = torch.softmax(tiny.model(torch.tensor([list(ids)])).logits[0, -1].double(), -1).numpy()
        want = [sum(p[tok.convert_tokens_to_ids(t)] for t in option) for option in tokens]
        want.append(1.0 - sum(want))
        np.testing.assert_allclose(got[_index(task, cell)], want, rtol=0, atol=1e-12, err_msg=str(cell))


def test_a_scoring_the_task_cannot_take_is_refused(tiny):
    from fairaudit import InputError

    with pytest.raises(InputError, match="^scoring: must be one of continuation, first-token"):
        lm.exact_kernel(_task(OFFICES), tiny, cells=_cells(_task(OFFICES), 1), scoring="first")
    with pytest.raises(InputError, match="^scoring: first-token scoring reads one token"):
        lm.exact_kernel(_task(RANKING), tiny, cells=_cells(_task(RANKING), 1), scoring="first-token")


# --------------------------------------------------------------------------- SmolLM2, float32


@pytest.fixture(scope="module")
def smollm2():
    need_local_model()
    return lm.load("smollm2")


@pytest.mark.parametrize(
    "task, cells",
    [
        (HR_DELIVERY, [("sick leave", HR_DELIVERY.profiles[0], HR_DELIVERY.profiles[-1])]),
        ("loan.toml", None),
        ("ranking.toml", None),
    ],
    ids=["hr-delivery", "loan", "ranking"],
)
def test_smollm2_continuation_equals_stepping(smollm2, task, cells):
    """SmolLM2 (float32): the engine against the stepping route on a few cells, to 1e-6 in probability."""
    task = load_task(EXAMPLES / task) if isinstance(task, str) else task
    cells = cells or _cells(task, 1)  # one cell: stepping SmolLM2 through 6 orders takes minutes
    got = lm.exact_kernel(task, smollm2, cells=cells)
    for cell in cells:
        row, want = got[_index(task, cell)], _stepped(smollm2, task, cell)
        np.testing.assert_allclose(row, want, rtol=0, atol=1e-6, err_msg=str(cell))
        assert want[:-1].max() > 1e-3  # some reply has mass worth comparing


@pytest.mark.parametrize("task", ["loan.toml", "ranking.toml"])
def test_the_text_completions_chatml_rule_is_smollm2s_own_template(smollm2, task):
    """The rule the text completions' route states (ChatML) renders a task's messages as SmolLM2's chat template
    does, so that route scores SmolLM2 on the prompt its chat routes send."""
    task = load_task(EXAMPLES / task)
    shown, _ = exact_prompt(task)
    p = exact_prompts(task)[0]
    messages = shown.messages(p.context, p.profiles, p.texts)
    assert messages[0]["role"] == "system"  # SmolLM2 adds a default system message only without one
    template = smollm2.tokenizer.apply_chat_template(messages, tokenize=False, add_generation_prompt=True)
    assert chatml(messages) == template
