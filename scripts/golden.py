"""What every documented command and every shipped example prints and writes, recorded and compared between versions.

A restructuring must not change a single printed number. This script runs, with one version of the code:

- every shell command of the documentation (``README.md`` and ``docs/**/*.md``), each page in a fresh folder, as
  ``tests/test_docs_shell.py`` runs them (the same parser, the same lists of commands that cannot run here; the
  commands of a real model, its ``SLOW`` list, are left out);
- every shipped example (``examples/``) through each command that reads it, in every ``--format``;

and records each command's standard output, standard error and exit status, and every file the commands wrote
(text as it is; other files by SHA-256). Two records are equal when they are equal byte for byte, the clock
(:data:`CLOCK`: run times, a run's seconds, latencies and timestamps) and the run folder's path aside. Benchmarks,
which print times only, are not run.

Usage::

    python scripts/golden.py --base main          # record main and this checkout, then compare (exit 1 on a change)
    python scripts/golden.py record OUT.json [--tree DIR]
    python scripts/golden.py compare OLD.json NEW.json

``--base REV`` checks REV out into a temporary git worktree and runs each version with its own code
(``PYTHONPATH``), its own documentation and its own examples; a command that only one version has is listed, not
compared. Both versions run with this checkout's ``tests/test_docs_shell.py`` (the parser and the lists).
"""

from __future__ import annotations

import argparse
import difflib
import hashlib
import json
import os
import re
import shlex
import shutil
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

import test_docs_shell as docs  # noqa: E402  (the documentation's parser and lists)

# Every shipped example through each command that reads it: (command, the examples it takes).
FORMATS = ["text", "json", "markdown", "html"]
EXAMPLE_COMMANDS = [
    *(f"fairaudit certify {{}} --format {f}" for f in FORMATS),
    "fairaudit calibrate --spec {} --target 0.1 --format json",
    "fairaudit worst-case {} --format json",
]
TASK_COMMANDS = ["fairaudit experiment {} --samples 20 --seed 1 --no-progress --no-images --out runs/{stem}"]
AUDIT_COMMANDS = [f"fairaudit audit {{}} --format {f}" for f in FORMATS]


def pages(tree: Path) -> list[docs.Page]:
    """The documentation of ``tree``, parsed, named as in the repository."""
    paths = sorted([*(tree / "docs").rglob("*.md"), tree / "README.md"])
    return [docs.parse(p, p.relative_to(tree).as_posix()) for p in paths]


def examples(tree: Path) -> docs.Page:
    """One page of commands over the examples of ``tree``: specs, task files and records."""
    page = docs.Page("examples")
    for path in sorted((tree / "examples").rglob("*")):
        rel = path.relative_to(tree).as_posix()
        if path.suffix == ".toml":
            text = path.read_text(encoding="utf-8")
            task = re.search(r"^\s*\[(task|prompt)\]", text, re.M) is not None
            for command in TASK_COMMANDS if task else EXAMPLE_COMMANDS:
                page.steps.append(docs.Command("examples", 0, command.format(rel, stem=path.stem)))
        elif path.suffix in {".csv", ".data"} and (flags := _audit_flags(tree, rel)) is not None:
            for command in AUDIT_COMMANDS:
                page.steps.append(docs.Command("examples", 0, f"{command.format(rel)} {flags}"))
    return page


def _audit_flags(tree: Path, rel: str) -> str | None:
    """The flags of the documentation's first ``fairaudit audit`` of the records file ``rel`` (its ``--format`` and
    ``--output`` aside), so that the example runs in every format with the flags a reader gives; None if none."""
    for page in pages(tree):
        for cmd in page.commands:
            words = shlex.split(cmd.text, comments=True) if "`" not in cmd.text else []
            if words[:3] == ["fairaudit", "audit", rel]:
                rest, flags = words[3:], []
                while rest:
                    word = rest.pop(0)
                    if word in {"--format", "--output", "-o"}:
                        rest = rest[1:]
                    elif not word.startswith(("--format=", "--output=")):
                        flags.append(word)
                return shlex.join(flags)
    return None


def _folder(tree: Path, tmp: Path) -> Path:
    clone = tmp / "clone"
    clone.mkdir()
    for name in docs.COPIED:
        src = tree / name
        if src.is_dir():
            shutil.copytree(src, clone / name, ignore=shutil.ignore_patterns("__pycache__", "site"))
        elif src.is_file():
            shutil.copy2(src, clone / name)
    if docs.SHARED.is_dir():
        (tmp / "shared").symlink_to(docs.SHARED, target_is_directory=True)
    return clone


def _snapshot(folder: Path) -> dict[str, str]:
    """Every file under ``folder``: its SHA-256."""
    return {
        p.relative_to(folder).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(folder.rglob("*"))
        if p.is_file() and "__pycache__" not in p.parts
    }


# What a run records of the clock, which no two runs share: a run time in a line (``in 98.0 s``), and in a run's
# JSON the seconds it took, a reply's latency and the instants a query was made and answered.
CLOCK = [
    (docs.RUN_TIME, "in <time> s"),
    (re.compile(r'"(seconds|latency)": ?-?[0-9.eE+-]+'), r'"\1": <time>'),
    (re.compile(r'"(created|time)": ?"\d{4}-\d\d-\d\dT[0-9:.]+Z?"'), r'"\1": <time>'),
]


def _normal(text: str, folder: Path) -> str:
    text = text.replace(str(folder.parent), "<run>")
    for pattern, replacement in CLOCK:
        text = pattern.sub(replacement, text)
    return text


def run_page(tree: Path, page: docs.Page, all_pages: list[docs.Page]) -> dict[str, dict[str, object]]:
    """Run one page's commands in a fresh folder with ``tree``'s code; record what each printed and what it wrote."""
    record: dict[str, dict[str, object]] = {}
    env = {**os.environ, "COLUMNS": "80", "PYTHONPATH": str(tree), "NO_COLOR": "1"}
    steps: list[docs.Command | docs.File] = []
    for other in docs.PREPARED_BY.get(page.path, []):
        for step in next(p for p in all_pages if p.path == other).steps:
            if isinstance(step, docs.File) or step.text.startswith("python "):
                steps.append(step)
    steps += page.steps
    with tempfile.TemporaryDirectory(prefix="golden-") as tmp:
        folder = _folder(tree, Path(tmp))
        before = _snapshot(folder)
        seen: dict[str, int] = {}
        for step in steps:
            if isinstance(step, docs.File):
                (folder / step.name).write_text(step.text, encoding="utf-8")
                continue
            if page.path != "examples" and (docs._listed(docs.NOT_RUN, step) or docs._listed(docs.SLOW, step)):
                continue
            if not docs.SHARED.is_dir() and "../shared/" in step.text:
                continue
            if "benchmarks/" in step.text:  # a benchmark prints times, which no two runs share
                continue
            text = docs._aliased(step)
            done = subprocess.run(
                ["bash", "-c", docs.BASH_PRELUDE + text],
                cwd=folder,
                env=env,
                capture_output=True,
                text=True,
                timeout=1800,
            )
            seen[step.text] = seen.get(step.text, 0) + 1
            key = f"{page.path} $ {step.text}" + (f" #{seen[step.text]}" if seen[step.text] > 1 else "")
            record[key] = {
                "stdout": _normal(done.stdout, folder),
                "stderr": _normal(done.stderr, folder),
                "status": done.returncode,
            }
        for name, digest in _snapshot(folder).items():
            if before.get(name) == digest:
                continue
            path = folder / name
            try:
                content: object = _normal(path.read_text(encoding="utf-8"), folder)
            except UnicodeDecodeError:
                content = f"sha256:{digest}"
            if isinstance(content, str) and name.endswith(".jsonl"):  # a log of concurrent queries: in answer order
                content = "\n".join(sorted(content.splitlines()))
            record[f"{page.path} file {name}"] = {"content": content}
    return record


def record(tree: Path, jobs: int) -> dict[str, dict[str, object]]:
    """Everything ``tree``'s documentation and examples print and write, with ``tree``'s code."""
    parsed = pages(tree)
    todo = [*parsed, examples(tree)]
    out: dict[str, dict[str, object]] = {}
    with ThreadPoolExecutor(max_workers=jobs) as pool:
        for part in pool.map(lambda p: run_page(tree, p, parsed), todo):
            out.update(part)
    return dict(sorted(out.items()))


def compare(old: dict[str, dict[str, object]], new: dict[str, dict[str, object]], context: int = 2) -> list[str]:
    """The differences between two records, one entry per key (empty: byte-identical)."""
    problems = []
    for key in sorted(old.keys() | new.keys()):
        if key not in new or key not in old:
            problems.append(f"only in the {'old' if key in old else 'new'} version: {key}")
            continue
        for part in sorted(old[key].keys() | new[key].keys()):
            a, b = old[key].get(part), new[key].get(part)
            if a == b:
                continue
            if isinstance(a, str) and isinstance(b, str):
                diff = difflib.unified_diff(a.splitlines(), b.splitlines(), "old", "new", lineterm="", n=context)
                problems.append(f"{key} [{part}]\n" + "\n".join(diff))
            else:
                problems.append(f"{key} [{part}]: {a!r} -> {b!r}")
    return problems


def _report(problems: list[str], old: dict, new: dict) -> int:
    same = sum(1 for k in old.keys() & new.keys() if old[k] == new[k])
    changed = [p for p in problems if not p.startswith("only in")]
    for p in problems:
        print(p, end="\n\n")
    print(f"{same} identical, {len(changed)} changed, {len(problems) - len(changed)} in one version only")
    return 1 if changed else 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--base", metavar="REV", help="record REV (a git worktree) and this checkout, and compare")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="pages run at once")
    sub = parser.add_subparsers(dest="command")
    rec = sub.add_parser("record", help="record one version")
    rec.add_argument("output", type=Path)
    rec.add_argument("--tree", type=Path, default=ROOT, help="the version's checkout (default this one)")
    cmp_ = sub.add_parser("compare", help="compare two records")
    cmp_.add_argument("old", type=Path)
    cmp_.add_argument("new", type=Path)
    args = parser.parse_args(argv)
    if args.command == "record":
        tmp = args.output.with_name(args.output.name + ".part")
        tmp.write_text(json.dumps(record(args.tree.resolve(), args.jobs), indent=1) + "\n", encoding="utf-8")
        tmp.replace(args.output)
        return 0
    if args.command == "compare":
        old = json.loads(args.old.read_text(encoding="utf-8"))
        new = json.loads(args.new.read_text(encoding="utf-8"))
        return _report(compare(old, new), old, new)
    if args.base is None:
        parser.error("give --base REV, or a command (record, compare)")
    with tempfile.TemporaryDirectory(prefix="golden-base-") as tmp:
        base = Path(tmp) / "tree"
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "-q", "--detach", str(base), args.base], check=True)
        try:
            old = record(base, args.jobs)
        finally:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(base)], check=False)
    new = record(ROOT, args.jobs)
    return _report(compare(old, new), old, new)


if __name__ == "__main__":
    sys.exit(main())
