"""``fairaudit experiment`` end to end, against simulated models and a real chat-completions server on 127.0.0.1.

Independent routes: the endpoint path (HTTP, retries, parsing) must give the
same kernel, query by query, as the in-process simulated model with the same
seeds; a run killed with SIGKILL and resumed must give the same kernel as an
uninterrupted one; an audit of the per-candidate records must give L-bar =
log 15 exactly (counted by hand in the test's docstring).
"""

from __future__ import annotations

import itertools
import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from _chat_server import ChatServer
from _cli import run

from fairaudit.experiments.taskfile import PACKAGE_DELIVERY
from fairaudit.experiments.vlm.models import Query, simulated_model


def _responder(task, name):
    """A chat server's responder that answers as the named simulated model would, from the request's seed."""
    model = simulated_model(task, name)
    cells = {
        task.prompt(c, shown): (c, shown) for c in task.contexts for shown in itertools.product(task.profiles, repeat=2)
    }

    def respond(body: dict) -> str:
        content = body["messages"][-1]["content"]
        text = content if isinstance(content, str) else next(p["text"] for p in content if p["type"] == "text")
        ctx, shown = cells[text]
        return model.reply(Query("", "table", ctx, shown, 0, body["seed"])).text

    return respond


def _kernel(folder: Path) -> str:
    return (folder / "kernel.csv").read_text()


@pytest.mark.slow
def test_endpoint_run_equals_the_simulated_model_through_retries(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("OPENAI_API_KEY", "sk-test-secret-123")
    faults = [("status", 429, {"Retry-After": "0"}), ("status", 500), ("sleep", 1.0), ("drop",), ("status", 503)]
    with ChatServer(
        _responder(PACKAGE_DELIVERY, "low-complaint-first"), faults=faults, required_key="sk-test-secret-123"
    ) as server:
        code, out, err = run(
            capsys,
            "experiment",
            "package-delivery",
            "--endpoint",
            server.url,
            "--model",
            "vlm-x",
            "--samples",
            "6",
            "--out",
            tmp_path / "http",
            "--timeout",
            "0.5",
            "--max-retries",
            "6",
            "--concurrency",
            "3",
            "--no-progress",
            "--keep",
            "0.7",
            "0.9",
        )
        chats = server.chat_requests
    assert code == 0, err
    code2, _, err2 = run(
        capsys,
        "experiment",
        "package-delivery",
        "--simulated",
        "low-complaint-first",
        "--samples",
        "6",
        "--out",
        tmp_path / "sim",
        "--no-images",
        "--no-progress",
        "--keep",
        "0.7",
        "0.9",
    )
    assert code2 == 0, err2
    assert _kernel(tmp_path / "http") == _kernel(tmp_path / "sim")
    assert all(isinstance(c.get("seed"), int) for c in chats)
    assert {len([p for p in c["messages"][0]["content"] if p["type"] == "image_url"]) for c in chats} == {2}
    assert len(chats) >= 72 + 5
    for f in (tmp_path / "http").iterdir():
        assert "sk-test-secret-123" not in f.read_bytes().decode("utf-8", "replace"), f.name
    assert "sk-test-secret-123" not in out + err
    log = [json.loads(x) for x in (tmp_path / "http" / "queries.jsonl").read_text().splitlines()]
    assert log[0]["type"] == "header" and log[0]["model"] == "vlm-x"
    q = [r for r in log if r["type"] == "query" and r["status"] == "ok"]
    assert len({r["id"] for r in q}) == 72 and all(len(r["prompt_sha256"]) == 64 for r in q)
    assert max(r["attempts"] for r in q) >= 2


@pytest.mark.slow
@pytest.mark.skipif(sys.platform == "win32", reason="SIGKILL")
def test_killed_run_resumes_with_no_sample_lost_or_repeated(tmp_path, capsys):
    with ChatServer(
        _responder(PACKAGE_DELIVERY, "position-biased"), fault_fn=lambda n, body: ("sleep", 0.004)
    ) as server:
        out = tmp_path / "run"
        args = [
            "experiment",
            "package-delivery",
            "--endpoint",
            server.url,
            "--model",
            "m",
            "--samples",
            "40",
            "--out",
            str(out),
            "--no-images",
            "--no-progress",
            "--concurrency",
            "2",
            "--seed",
            "5",
        ]
        env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])}
        proc = subprocess.Popen(
            [sys.executable, "-m", "fairaudit.cli", *args],
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        log = out / "queries.jsonl"
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            if log.exists() and log.read_bytes().count(b"\n") > 100:
                break
            time.sleep(0.02)
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        done_before = log.read_bytes().count(b"\n") - 1
        assert 100 <= done_before < 480, "the run must be killed half-way"
        code, _, err = run(capsys, *args, "--resume")
        assert code == 0, err
    lines = [json.loads(x) for x in log.read_text().splitlines()]
    ids = [r["id"] for r in lines if r["type"] == "query" and r["status"] == "ok"]
    assert len(ids) == len(set(ids)) == 3 * 4 * 40
    assert f"{3 * 4 * 40} of {3 * 4 * 40} queries answered ({3 * 4 * 40 - done_before} now" in err
    code, _, err = run(
        capsys,
        "experiment",
        "package-delivery",
        "--simulated",
        "position-biased",
        "--samples",
        "40",
        "--out",
        tmp_path / "clean",
        "--no-images",
        "--no-progress",
        "--seed",
        "5",
    )
    assert code == 0, err
    assert _kernel(out) == _kernel(tmp_path / "clean")


@pytest.mark.slow
def test_failed_queries_exit_1_and_resume_completes(tmp_path, capsys):
    every_third = lambda n, body: ("status", 500) if n % 3 == 0 else None  # noqa: E731
    with ChatServer(_responder(PACKAGE_DELIVERY, "fair"), fault_fn=every_third) as server:
        args = [
            "experiment",
            "package-delivery",
            "--endpoint",
            server.url,
            "--model",
            "m",
            "--samples",
            "3",
            "--out",
            tmp_path / "r",
            "--no-images",
            "--no-progress",
            "--max-retries",
            "0",
        ]
        code, out, err = run(capsys, *args)
        assert code == 1 and out == ""
        assert err.startswith("fairaudit: incomplete: 24 of 36 queries answered") and "HTTP 500" in err
        assert err.count("\n") == 1 and "--resume" in err
        server.fault_fn = None
        code, out, err = run(capsys, *args, "--resume")
    assert code == 0, err
    assert "36 of 36 queries answered (12 now" in err
    assert (tmp_path / "r" / "report.md").read_text() == out


@pytest.mark.slow
def test_hr_report_certificate_and_audit_of_the_records(tmp_path, capsys):
    """prefers-mary, 2 queries per shown cell: each profile has 96 per-candidate records.

    Mary's profile shares more of Mary's attributes than any of the 7 other profiles, so against them it is always
    chosen: 7 rivals x 2 queries x 2 positions x 3 documents = 84; each of the 6 Mary-Mary queries chooses exactly one
    of its two Mary records: 6 more, 90 of 96. Tom & 25 & Asian shares none, so it is chosen only in the 6 Tom-Tom
    queries: 6 of 96. L-bar = log(90 / 6) = log 15, whatever the coins.
    """
    out = tmp_path / "hr"
    code, report, err = run(
        capsys,
        "experiment",
        "hr-delivery",
        "--samples",
        "2",
        "--out",
        out,
        "--no-images",
        "--no-progress",
        "--keep",
        "0.7",
        "--design",
        "both",
    )
    assert code == 0, err
    cert = json.loads((out / "certificate.json").read_text())
    eps = 6 * math.log(7 / 3)
    p = cert["points"][0]
    assert p["epsilon"] == pytest.approx(eps) and p["privacy"]["epsilon_profile"] == pytest.approx(eps / 2)
    assert p["privacy"]["keep_probability_per_attribute"] == {
        "name": pytest.approx(0.7),
        "age": pytest.approx(0.7),
        "race": pytest.approx(0.7),
    }
    assert p["bounds"]["black_box"] == pytest.approx(eps, abs=1e-9)  # the corollary is attained
    assert cert["baseline"]["shares"]["sick leave"]["HR1 = Tom & 25 & Asian, HR2 = Mary & 55 & American"] == {
        "HR1": 0.0,
        "HR2": 1.0,
        "unparsed": 0.0,
    }
    assert cert["queries"] == {
        "table": 384,
        "paper": 12,
        "unparsed": 0,
        "unparsed_share": 0.0,
        "table_design_needs": 384,
        "paper_design_needs_per_epsilon": 12,
    }
    assert report == (out / "report.md").read_text() and "| 5.084 | 2.542 | 0.7, 0.7, 0.7 | 5.084 |" in report
    for name in ("kernel.csv", "candidates.csv", "records.csv", "curve.csv", "baseline.png", "curve.png"):
        assert (out / name).stat().st_size > 0
    code, audit_out, err = run(
        capsys,
        "audit",
        out / "records.csv",
        "--sensitive",
        "profile",
        "--context",
        "document,position",
        "--outcome",
        "outcome",
        "--positive",
        "chosen",
        "--format",
        "json",
    )
    assert code == 0, err
    a = json.loads(audit_out)
    assert a["n"] == 2 * 384 and a["global"]["value"] == pytest.approx(math.log(15), abs=1e-12)
    assert (a["global"]["group"], a["global"]["other_group"]) == ("Mary & 55 & American", "Tom & 25 & Asian")


@pytest.mark.slow
@pytest.mark.parametrize(
    "argv, message",
    [
        (["--simulated", "oracle"], "--simulated: must be one of ['fair', 'position-biased', 'prefers-mary']"),
        (["--endpoint", "http://127.0.0.1:9/v1"], "--model: is needed with --endpoint"),
        (["--model", "gpt"], "--model: goes with --endpoint"),
        (["--kernel", "missing.csv"], "--kernel: no such file"),
        (["--endpoint", "ftp://x/v1", "--model", "m"], "--endpoint"),
        (["--scene", "no/such/area"], "no/such/area"),
    ],
)
def test_bad_options_exit_2_with_one_line(tmp_path, capsys, argv, message):
    code, out, err = run(capsys, "experiment", "hr-delivery", "--out", tmp_path / "o", "--no-progress", *argv)
    assert code == 2 and out == ""
    assert err.startswith("fairaudit: error: ") and err.count("\n") == 1 and message in err, err
    assert not (tmp_path / "o" / "queries.jsonl").exists()
    if argv[0] == "--scene":
        assert not (tmp_path / "o").exists()  # refused before --out is made


@pytest.mark.slow
def test_a_run_is_never_overwritten(tmp_path, capsys):
    args = ["experiment", "package-delivery", "--samples", "1", "--out", tmp_path / "o", "--no-images", "--no-progress"]
    assert run(capsys, *args)[0] == 0
    before = (tmp_path / "o" / "queries.jsonl").read_bytes()
    code, _, err = run(capsys, *args)
    assert code == 2 and "--out: holds a run already" in err
    assert (tmp_path / "o" / "queries.jsonl").read_bytes() == before
    code, _, err = run(
        capsys,
        "experiment",
        "package-delivery",
        "--samples",
        "1",
        "--out",
        tmp_path / "o",
        "--no-images",
        "--no-progress",
        "--resume",
        "--seed",
        "9",
    )
    assert code == 2 and "--resume: the run in" in err and "--seed 0, not 9" in err
    for bad in (["--keep", "1.5"], ["--samples", "0"], ["--epsilon", "-1"]):
        with pytest.raises(SystemExit) as exc:  # argparse's own usage errors
            run(capsys, "experiment", "package-delivery", "--out", tmp_path / "p", *bad)
        err = capsys.readouterr().err
        assert exc.value.code == 2 and err.count("\n") == 1 and bad[0] in err, bad


@pytest.mark.slow
def test_out_makes_its_missing_parent_folders(tmp_path, capsys):
    """``--out runs/pkg`` on a fresh clone (no ``runs/``): the run folder and its parents are made, as ``mkdir -p``;
    a file where a parent folder should be is refused with one line naming --out, and nothing is made."""
    args = ["experiment", "package-delivery", "--samples", "1", "--no-images", "--no-progress", "--out"]
    code, _, err = run(capsys, *args, tmp_path / "runs" / "deep" / "pkg")
    assert code == 0, err
    assert sorted(p.name for p in (tmp_path / "runs").iterdir()) == ["deep"]
    assert (tmp_path / "runs" / "deep" / "pkg" / "queries.jsonl").is_file()
    (tmp_path / "file").write_text("x")
    code, out, err = run(capsys, *args, tmp_path / "file" / "sub" / "pkg")
    assert code == 2 and out == ""
    assert (
        err
        == f"fairaudit: error: --out: cannot be made: {tmp_path / 'file'} is a file, not a folder (got '{tmp_path / 'file' / 'sub' / 'pkg'}')\n"
    )
    assert (tmp_path / "file").read_text() == "x"


@pytest.mark.slow
def test_certify_reads_the_runs_spec_and_repeats_its_certificate(tmp_path, capsys):
    """spec-eps-<e>.toml: the per-candidate matrix mechanism (2 profiles -> 4 shown pairs) over candidates.csv."""
    out = tmp_path / "pkg"
    code, _, err = run(
        capsys,
        "experiment",
        "package-delivery",
        "--samples",
        "10",
        "--out",
        out,
        "--no-images",
        "--no-progress",
        "--keep",
        "0.7",
    )
    assert code == 0, err
    exp = json.loads((out / "certificate.json").read_text())["points"][0]
    specs = sorted(out.glob("spec-eps-*.toml"))
    assert [s.name for s in specs] == ["spec-eps-1.695.toml"]
    code, cert_out, err = run(capsys, "certify", specs[0], "--format", "json")
    assert code == 0, err
    cert = json.loads(cert_out)
    assert cert["privacy"]["sensitive"]["epsilon"] == pytest.approx(2 * math.log(7 / 3), abs=1e-12)
    assert cert["bounds"]["black_box"] == pytest.approx(math.log(99 / 59), abs=1e-9) == exp["bounds"]["black_box"]
    for kind in ("local", "global"):  # the experiment adds the range over the unparsed reply's utility
        seen = {k: v for k, v in exp["observed"][kind].items() if not k.startswith("unparsed_range")}
        assert cert["observed"][kind] == seen
    assert "unfiltered" not in cert or cert["unfiltered"] is None  # the model never reads true profiles
    code, _, err = run(capsys, "certify", specs[0], "--plot", tmp_path / "c.png")  # along its [privacy.family]
    assert code == 0 and (tmp_path / "c.png").stat().st_size > 0, err
    text = specs[0].read_text()
    specs[0].write_text(text[: text.index("[privacy.family]")] + text[text.index("[model]") :])
    code, _, err = run(capsys, "certify", specs[0], "--plot", tmp_path / "d.png")  # without it: no curve
    assert code == 2 and "no curve along it" in err and err.count("\n") == 1
