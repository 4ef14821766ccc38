"""``fairaudit experiment --resume`` keeps the run's design and sample; ``--extend`` grows its samples (issue 39, 2).

Independent routes: a resumed run refuses every setting that changes which queries are asked or how their replies
are counted, in one line written out here by hand; an extended run's files equal, byte for byte, those of a fresh
run with the larger ``--samples`` and the same seed (each query's seed is a hash of the run's seed and its key, so
the first n repetitions of a run with N > n are the queries of a run with n); the certificate's reply counts equal
a count of the log's lines.
"""

from __future__ import annotations

import contextlib
import io
import json
import shutil
from pathlib import Path

import pytest
from _chat_server import ChatServer
from _cli import run

from fairaudit import InputError
from fairaudit.cli import main
from fairaudit.experiments.options import ModelSource, RunOptions
from fairaudit.experiments.run import run_experiment

BASE = ("--simulated", "position-biased", "--target", "0.1", "--no-progress")
"""The base run's flags, but for --samples, --keep (0.7 0.8), --out and --no-images (one target: a budget costs a scan)."""

RULE = (
    "each changes which queries are asked or how their replies are counted; resume with the logged settings, or "
    "start a new run in another folder"
)

CELLS = 3 * 2 * 2
"""package-delivery's shown cells: 3 packages x 2 profiles (complaint rate low, high) in each of 2 slots."""


def _experiment(capsys, out, *flags, samples="2"):
    keep = () if {"--keep", "--epsilon"} & set(flags) else ("--keep", "0.7", "0.8")
    return run(capsys, "experiment", "package-delivery", *BASE, *keep, "--samples", samples, "--out", out, *flags)


def _log(out: Path) -> list[dict]:
    return [json.loads(line) for line in (out / "queries.jsonl").read_text(encoding="utf-8").splitlines()]


def _answered(out: Path) -> int:
    """A hand count of the log: the distinct keys of its lines of answered queries."""
    return len({r["id"] for r in _log(out) if r["type"] == "query" and r["status"] == "ok"})


@pytest.fixture(scope="module")
def base(tmp_path_factory):
    """A complete run of 2 samples per shown cell, without route images, made once (copied by each test)."""
    out = tmp_path_factory.mktemp("base") / "run"
    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        code = main(["experiment", "package-delivery", *BASE, "--keep", "0.7", "0.8", "--samples", "2", "--out", str(out),
                     "--no-images"])  # fmt: skip
    assert code == 0, err.getvalue()
    return out


@pytest.fixture
def resumed(base, tmp_path):
    out = tmp_path / "run"
    shutil.copytree(base, out)
    return out


@pytest.mark.slow
@pytest.mark.parametrize(
    "flags, changed",
    [
        (["--samples", "1"], "--samples 2, not 1"),
        (["--samples", "3"], "--samples 2, not 3 (to add samples, give --extend)"),
        (["--seed", "9"], "--seed 0, not 9"),
        (["--design", "both"], "--design 'table', not 'both'"),
        (["--positions", "fixed"], "--positions 'balanced', not 'fixed'"),
        (["--keep", "0.6", "0.8"], "--keep [0.7, 0.8], not [0.6, 0.8]"),
        (["--keep", "0.7"], "--keep [0.7, 0.8], not [0.7]"),
        (["--epsilon", "1", "2"], "--keep [0.7, 0.8], not --epsilon [1, 2]"),
        (["--context-epsilon", "1"], "--context-epsilon none, not 1.0"),
        ([], "route images 0 per query, not 2 (--no-images)"),  # the base run sent none
    ],
    ids=[
        "fewer-samples",
        "more-samples",
        "seed",
        "design",
        "positions",
        "keep",
        "fewer-keeps",
        "epsilon",
        "context-epsilon",
        "images",
    ],  # fmt: skip
)
def test_each_changed_setting_is_refused_in_one_line(resumed, capsys, flags, changed):
    images = [] if "route images" in changed else ["--no-images"]
    samples = next((flags[i + 1] for i, f in enumerate(flags) if f == "--samples"), "2")
    flags = [f for i, f in enumerate(flags) if f != "--samples" and (i == 0 or flags[i - 1] != "--samples")]
    before = {p.name: p.read_bytes() for p in resumed.iterdir()}
    code, out, err = _experiment(capsys, resumed, "--resume", *images, *flags, samples=samples)
    assert (code, out) == (2, "")
    assert err == f"fairaudit: error: --resume: the run in {resumed} was made with other settings: {changed}: {RULE}\n"
    assert {p.name: p.read_bytes() for p in resumed.iterdir()} == before  # nothing asked, nothing written


@pytest.mark.slow
def test_every_changed_setting_is_named_in_the_same_line(resumed, capsys):
    code, _, err = _experiment(capsys, resumed, "--resume", "--seed", "3", "--positions", "fixed", samples="1")
    assert code == 2 and err.count("\n") == 1
    assert err == (
        f"fairaudit: error: --resume: the run in {resumed} was made with other settings: --seed 0, not 3; --samples "
        f"2, not 1; --positions 'balanced', not 'fixed'; route images 0 per query, not 2 (--no-images): {RULE}\n"
    )


@pytest.mark.slow
def test_the_same_budgets_given_as_epsilons_are_the_same_filter(resumed, capsys):
    """keep 0.7 and 0.8 given again as the candidate's ε the log wrote: the same budgets (compared as the query keys
    write them, to 12 digits), so the same queries: accepted, nothing asked."""
    eps = json.loads((resumed / "queries.jsonl").read_text().splitlines()[0])["epsilons"]
    code, _, err = _experiment(capsys, resumed, "--resume", "--no-images", "--epsilon", *(repr(e) for e in eps))
    assert code == 0 and "(0 now, 0 unparsed)" in err, err


@pytest.mark.slow
def test_settings_that_do_not_change_the_result_may_change(resumed, capsys):
    """Workers, progress, the client's patience, the band's level and the targets: the same replies, counted the
    same; the kernel and the records are the run's own."""
    kernel, records = (resumed / "kernel.csv").read_bytes(), (resumed / "records.csv").read_bytes()
    flags = ["--concurrency", "3", "--timeout", "5", "--max-retries", "1", "--confidence", "0.9", "--target", "0.2"]
    code, _, err = _experiment(capsys, resumed, "--resume", "--no-images", *flags)
    assert code == 0, err
    assert f"{2 * CELLS} of {2 * CELLS} queries answered (0 now, 0 unparsed)" in err
    assert (resumed / "kernel.csv").read_bytes() == kernel and (resumed / "records.csv").read_bytes() == records
    cert = json.loads((resumed / "certificate.json").read_text())
    assert cert["confidence"] == 0.9 and {t["target"] for t in cert["budgets"]} == {0.2}


@pytest.mark.slow
@pytest.mark.parametrize("design", ["table", "both"])
def test_extend_gives_the_fresh_runs_certificate(tmp_path, capsys, design):
    """3 samples extended to 7 equal a fresh run of 7 with the same seed, file for file (the certificate but for its
    timings and the record of the extension)."""
    grown, fresh = tmp_path / "grown", tmp_path / "fresh"
    flags = ("--no-images", "--design", design, "--seed", "4")
    assert _experiment(capsys, grown, *flags, samples="3")[0] == 0
    code, _, err = _experiment(capsys, grown, *flags, "--resume", "--extend", samples="7")
    assert code == 0, err
    paper = 2 * 3 * 2 if design == "both" else 0  # the paper's design: 2 ε x 3 packages x 2 orders, per sample
    asked = (CELLS + paper) * 4
    assert f"{7 * (CELLS + paper)} of {7 * (CELLS + paper)} queries answered ({asked} now, 0 unparsed)" in err
    assert _experiment(capsys, fresh, *flags, samples="7")[0] == 0
    for name in ("kernel.csv", "candidates.csv", "records.csv", "curve.csv", "report.md"):
        if name == "report.md":  # the extension's line is the one difference
            g = (grown / name).read_text().replace("; `--samples` was extended (`--extend`) from 3 to 7", "")
            assert g == (fresh / name).read_text()
        else:
            assert (grown / name).read_bytes() == (fresh / name).read_bytes(), name
    g, f = (json.loads((d / "certificate.json").read_text()) for d in (grown, fresh))
    extended = g["run"].pop("extended")
    assert [(e["from"], e["to"]) for e in extended] == [(3, 7)]
    g["run"].pop("seconds"), f["run"].pop("seconds")
    assert g == f
    assert g["run"]["replies"] == {"used": 7 * (CELLS + paper), "logged": 7 * (CELLS + paper)}
    # the log says so, and the grown run is now a run of 7: resumed as one, and refused as one of 3
    assert [(r["from"], r["to"]) for r in _log(grown) if r["type"] == "extend"] == [(3, 7)]
    assert _experiment(capsys, grown, *flags, "--resume", samples="7")[0] == 0
    code, _, err = _experiment(capsys, grown, *flags, "--resume", samples="3")
    assert code == 2 and "other settings: --samples 7, not 3:" in err


def test_extend_grows_samples_only(resumed, capsys):
    code, _, err = _experiment(capsys, resumed, "--resume", "--extend", "--no-images", "--seed", "1", samples="4")
    assert code == 2 and err == (
        f"fairaudit: error: --resume: the run in {resumed} was made with other settings: --seed 0, not 1: {RULE}\n"
    )
    code, _, err = _experiment(capsys, resumed, "--resume", "--extend", "--no-images", samples="1")
    assert code == 2 and "other settings: --samples 2, not 1:" in err
    assert not any(r["type"] == "extend" for r in _log(resumed))
    code, _, err = _experiment(capsys, resumed, "--extend", "--no-images", samples="4")
    assert (code, err) == (2, "fairaudit: error: --extend: adds samples to a logged run: give --resume too\n")
    with pytest.raises(InputError, match=r"^extend: adds samples to a logged run: give `resume` too$"):
        RunOptions(samples=4, extend=True)
    exact = ModelSource(endpoint="http://127.0.0.1:9/v1", model="m", exact=True)  # refused before any request
    with pytest.raises(InputError, match=r"^extend: adds samples to a sampled run's log, and the exact route samp"):
        run_experiment("package-delivery", resumed.parent / "x", exact, RunOptions(resume=True, extend=True))
    assert not (resumed.parent / "x").exists()


@pytest.mark.slow
def test_the_certificate_counts_the_logged_replies(tmp_path, capsys):
    """Fresh, resumed after a crash and extended: ``run.replies`` and report.md say how many answered queries the
    certificate counts, of how many the log holds, each equal to a count of the log's lines."""
    out = tmp_path / "run"
    assert _experiment(capsys, out, "--no-images")[0] == 0

    def said(folder):
        cert = json.loads((folder / "certificate.json").read_text())
        report = (folder / "report.md").read_text()
        return cert["run"]["replies"], report

    replies, report = said(out)
    assert replies == {"used": _answered(out), "logged": _answered(out)} == {"used": 2 * CELLS, "logged": 2 * CELLS}
    assert f"Replies: the certificate counts {2 * CELLS} of the {2 * CELLS} answered queries logged" in report
    lines = (out / "queries.jsonl").read_bytes().splitlines(keepends=True)
    (out / "queries.jsonl").write_bytes(b"".join(lines[:-5]) + lines[-5][:20])  # a crash: 5 lost, one torn
    code, _, err = _experiment(capsys, out, "--resume", "--no-images")
    assert code == 0 and "(5 now" in err, err
    replies, _ = said(out)
    assert replies == {"used": _answered(out), "logged": _answered(out)} == {"used": 2 * CELLS, "logged": 2 * CELLS}
    assert _experiment(capsys, out, "--resume", "--extend", "--no-images", samples="5")[0] == 0
    replies, report = said(out)
    assert replies == {"used": _answered(out), "logged": _answered(out)} == {"used": 5 * CELLS, "logged": 5 * CELLS}
    assert "; `--samples` was extended (`--extend`) from 2 to 5." in report


@pytest.mark.slow
def test_failed_queries_are_logged_but_are_not_replies(tmp_path, capsys):
    """Through a server that fails every third request (no retries): the log holds error lines too, and the
    certificate counts the answered queries only, each once."""
    every_third = lambda n, body: ("status", 500) if n % 3 == 0 else None  # noqa: E731
    flags = ["--samples", "1", "--keep", "0.7", "--no-images", "--no-progress", "--max-retries", "0"]
    with ChatServer(fault_fn=every_third) as server:
        argv = ["experiment", "hr-delivery", "--endpoint", server.url, "--model", "m", "--out", tmp_path / "r", *flags]
        assert run(capsys, *argv)[0] == 1
        server.fault_fn = None
        code, _, err = run(capsys, *argv, "--resume")
    assert code == 0, err
    lines = [r for r in _log(tmp_path / "r") if r["type"] == "query"]
    errors = sum(r["status"] == "error" for r in lines)
    cells = 3 * 8 * 8  # hr-delivery: 3 documents x 8 profiles in each of 2 slots
    assert errors > 0 and len(lines) == cells + errors
    replies = json.loads((tmp_path / "r" / "certificate.json").read_text())["run"]["replies"]
    assert replies == {"used": _answered(tmp_path / "r"), "logged": _answered(tmp_path / "r")}
    assert replies == {"used": cells, "logged": cells}


@pytest.mark.slow
def test_the_prompt_and_the_sampling_are_settings(tmp_path, capsys):
    """An endpoint's sampled run resumed as the exact route's sampled twin (same model name) would send another
    prompt with other settings: refused, naming both."""
    flags = ["--samples", "1", "--keep", "0.7", "--no-images", "--no-progress"]
    with ChatServer(lambda body: "1") as server:
        argv = ["experiment", "package-delivery", "--endpoint", server.url, "--model", "m", "--out", tmp_path / "r"]
        assert run(capsys, *argv, *flags)[0] == 0
        n = len(server.chat_requests)
        code, _, err = run(capsys, *argv, *flags, "--resume", "--sampled-twin")
        assert len(server.chat_requests) == n
    header = _log(tmp_path / "r")[0]
    assert header["prompt"]["sent"] == "task's own" and header["sampling"]["max_tokens"] == 1024
    assert code == 2 and err.count("\n") == 1
    assert "other settings: the task's own prompt, not the exact route's; --max-tokens 1024, not 1: " in err
