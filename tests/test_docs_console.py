"""Every ``$ fairaudit ...`` example in the docs that can run from the repository prints what the page shows.

A ```` ```console ```` block holds commands (lines that start with ``$ ``), each followed by its output. A command
runs here when it is a ``fairaudit`` command whose files ship with the project (or are in ``../shared/data``, when
present) and that writes no file; what it prints (standard output, then standard error, then the exit status where
the page shows ``echo $?``) must equal the page's text, line for line (trailing spaces aside; a line ``...`` stands for
any lines). Commands on files that a page makes elsewhere (``/tmp/...``, a run folder) are not run here; the numbers in
those pages are checked by their doctests.
"""

import re
import shlex
from pathlib import Path

import pytest

from fairaudit.cli import main

ROOT = Path(__file__).resolve().parent.parent
PAGES = sorted([*(ROOT / "docs").rglob("*.md"), ROOT / "README.md"])
BLOCK = re.compile(r"^```console\n(.*?)^```", re.S | re.M)
WRITES = {"--output", "--plot", "--plot-data", "--out"}


def _examples():
    """(page, command, shown output, whether the exit status is shown) of every command of every console block."""
    for page in PAGES:
        for block in BLOCK.findall(page.read_text(encoding="utf-8")):
            runs = []
            for line in block.splitlines():
                if line.startswith("$ "):
                    runs.append([line[2:], [], False])
                elif runs:
                    runs[-1][1].append(line)
            for i, (command, output, _) in enumerate(runs):
                if command.endswith("; echo $?"):
                    runs[i] = [command.removesuffix("; echo $?"), output, True]
                elif command == "echo $?" and i > 0:  # the status of the command before
                    runs[i - 1][1] += output
                    runs[i - 1][2] = True
            for command, output, status in runs:
                if command != "echo $?":
                    yield page, command, output, status


def _runnable(argv):
    if argv[0] != "fairaudit" or WRITES & set(argv) or any("[" in a or a.isupper() for a in argv[1:]):
        return False
    files = [a for a in argv[1:] if not a.startswith("-") and ("/" in a or a.endswith((".csv", ".toml", ".parquet")))]
    return all((ROOT / f).exists() or f.startswith("../shared/") for f in files)


EXAMPLES = [
    pytest.param(argv, output, status, id=f"{page.relative_to(ROOT)}: {' '.join(argv[1:4])}")
    for page, command, output, status in _examples()
    if any(output)
    and _runnable(argv := shlex.split(command, comments=True))  # a command with no output shown is a listing
]


def test_examples_are_found():
    ids = [p.id for p in EXAMPLES]
    assert len(ids) >= 20
    assert any("docs/examples/llm_hiring.md: certify examples/llm_hiring/gpt35.toml" in i for i in ids)
    assert any("--help" in " ".join(p.values[0]) for p in EXAMPLES)


@pytest.mark.parametrize("argv, expected, status", EXAMPLES)
def test_console_example(argv, expected, status, capsys, monkeypatch):
    monkeypatch.chdir(ROOT)
    monkeypatch.setenv("COLUMNS", "80")  # argparse wraps --help at the terminal width
    shared = [a for a in argv if a.startswith("../shared/")]
    if shared and not all((ROOT / a).exists() for a in shared):
        pytest.skip(f"the shared data is not here: {shared[0]}")
    try:
        code = main(argv[1:])
    except SystemExit as exc:  # --help
        code = exc.code
    out, err = capsys.readouterr()
    out += err + (f"{code}\n" if status else "")  # as a terminal shows them: these commands write stderr last
    got = [line.rstrip() for line in out.rstrip("\n").splitlines()]
    want = [line.rstrip() for line in "\n".join(expected).rstrip("\n").splitlines()]
    if "..." not in [w.strip() for w in want]:
        assert got == want
    else:  # a line "..." stands for any lines, as in doctest's ELLIPSIS
        pattern = "".join("(?:.*\n)*?" if w.strip() == "..." else re.escape(w) + "\n" for w in want)
        assert re.fullmatch(pattern, "".join(g + "\n" for g in got)), "\n".join(got)
