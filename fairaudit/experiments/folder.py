"""The third step of a run: its folder (:class:`Folder`), checked, locked, and on resume held to its log's settings.

One run at a time per folder: :func:`claim` makes the folder and holds its lock (``filelock.FileLock``) while the
run uses it. A folder that holds a log is refused unless the run resumes it, and a resumed run must have the
log's settings (:func:`check_resumed`): every setting that changes which queries are asked or how their replies are
counted.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from fairaudit import InputError, optional_modules

from .options import SAMPLING_FIELDS

__all__ = ["LOCK_NAME", "RESUME_RULE", "Folder", "check_resumed", "claim", "make_folder"]

LOCK_NAME = ".fairaudit.lock"
"""The lock file in a run's folder: held (an OS lock, ``filelock.FileLock``) while a run uses the folder."""

RESUME_RULE = (
    "each changes which queries are asked or how their replies are counted; resume with the logged settings, or "
    "start a new run in another folder"
)
"""The end of :func:`check_resumed`'s message: why, and what to do."""


@dataclass(frozen=True, eq=False, kw_only=True)
class Folder:
    """A run's folder and what the run does with its log.

    Attributes
    ----------
    out : Path
    log_path : Path
        ``queries.jsonl`` in ``out``.
    exact : bool
        The exact route: it writes no log, and a folder with one is not its.
    resume : bool
        Continue the logged run.
    settings : dict
        The settings the log's header records (the cells' and the route's; :func:`check_resumed`).
    extend : bool
        ``samples`` may grow past the log's.
    extend_from : int or None
        Resumed with ``extend``: the logged samples, which grow to ``settings["samples"]``.
    """

    out: Path
    log_path: Path
    exact: bool
    resume: bool
    settings: dict
    extend: bool = False
    extend_from: int | None = None


def make_folder(out: Path, settings: dict, *, exact: bool, resume: bool, extend: bool) -> Folder:
    """The folder ``out``, refused when it cannot be made or holds a log this run must not touch."""
    if out.exists() and not out.is_dir():
        raise InputError("out", "is a file, not a folder", str(out))
    above = next((p for p in out.parents if p.exists()), None)  # the missing folders are made by claim
    if above is not None and not above.is_dir():
        raise InputError("out", f"cannot be made: {above} is a file, not a folder", str(out))
    folder = Folder(
        out=out, log_path=out / "queries.jsonl", exact=exact, resume=resume, settings=settings, extend=extend
    )
    check_log(folder)
    return folder


def check_log(folder: Folder) -> None:
    """Refuse a folder whose log belongs to a run this one must not touch."""
    path = folder.log_path
    if path.exists() and path.stat().st_size > 0 and not folder.resume:
        raise InputError(
            "out",
            "holds a run already (queries.jsonl); pass `resume` to continue it, or choose another folder",
            str(folder.out),
        )
    if folder.exact and path.exists():
        raise InputError(
            "out", "holds a sampled run (queries.jsonl); the exact route needs another folder", str(folder.out)
        )


@contextmanager
def claim(folder: Folder) -> Iterator[Folder]:
    """Make the folder and hold its lock for a ``with`` block; give it back checked again under the lock.

    A second run on the folder is refused at once. The lock is the operating system's (``flock`` on Unix, a
    byte-range lock on Windows), released when the block ends, however it ends, and by the system when the process
    dies. Under the lock the log is checked again (another run may have ended) and, on resume, held to the run's
    settings (:func:`check_resumed`).
    """
    problem = "one run per folder needs filelock, which is not installed: pip install 'fairness-certify[experiment]'"
    filelock = optional_modules("out", problem, "filelock")[0]
    out = folder.out
    out.mkdir(parents=True, exist_ok=True)  # with its missing parents, as `mkdir -p`
    path = out / LOCK_NAME
    lock = filelock.FileLock(path, timeout=0)
    try:
        lock.acquire()
    except filelock.Timeout:
        raise InputError(
            "out",
            f"is in use by another fairaudit run (lock {path}); wait for it to finish or choose another folder",
            str(out),
        ) from None
    try:
        check_log(folder)
        yield check_resumed(folder) if folder.resume and not folder.exact else folder
    finally:
        lock.release()


def check_resumed(folder: Folder) -> Folder:
    """Refuse to resume a run with settings other than its log's, naming each (:func:`_changes`) in one line.

    Returns the folder, with ``extend_from`` set to the logged samples when ``extend`` lets them grow. A folder
    without a log passes (resuming it starts the run).
    """
    from .harness import logged_settings

    before = logged_settings(folder.log_path)
    if before is None:  # no log, or not a log (QueryLog refuses it in its own words)
        return folder
    parts = _changes(before, folder.settings, folder.extend)
    if parts:
        raise InputError(
            "resume", f"the run in {folder.out} was made with other settings: {'; '.join(parts)}: {RESUME_RULE}"
        )
    logged = before.get("samples")
    if folder.extend and isinstance(logged, int) and folder.settings["samples"] > logged:
        return dataclasses.replace(folder, extend_from=logged)
    return folder


def _shown(value: Any) -> str:
    """A setting's value in a message: text quoted, ``none`` for None, a list's numbers to 6 digits."""
    if value is None:
        return "none"
    if isinstance(value, list | tuple):
        return "[" + ", ".join(f"{v:.6g}" if isinstance(v, float) else _shown(v) for v in value) + "]"
    return repr(value)


def _filter_change(before: dict, now: dict) -> str | None:
    """The privacy filter's change in a message (as each run asked it: keep or ε), or None when the ε are the same.

    The budgets are compared as the query keys write them (12 significant digits), so ``keeps`` and ``epsilons``
    that give the same budgets are the same filter.
    """
    from .harness import eps_key

    if "epsilons" not in before:
        return None
    then = [eps_key(float(e)) for e in before["epsilons"]]
    if then == [eps_key(float(e)) for e in now["epsilons"]]:
        return None
    asked_then, asked_now = before.get("filter") or {"epsilon": before["epsilons"]}, now["filter"]
    (kind_then, values_then), (kind_now, values_now) = next(iter(asked_then.items())), next(iter(asked_now.items()))
    name = {"keep": "keeps", "epsilon": "epsilons"}
    if kind_then == kind_now:
        return f"`{name[kind_now]}` {_shown(values_then)}, not {_shown(values_now)}"
    return f"`{name[kind_then]}` {_shown(values_then)}, not `{name[kind_now]}` {_shown(values_now)}"


def _changes(before: dict, now: dict, extend: bool) -> list[str]:
    """Each setting of ``now`` that differs from the log's ``before``, as ``"`name` logged, not new"``. A setting
    the log does not record is not compared; ``samples`` may grow with ``extend``."""
    parts: list[str] = []

    def compare(name: str, then: dict, new: dict, shown: Callable[[Any], str] = _shown) -> None:
        """The setting ``name`` of ``new`` against ``then``'s, when ``then`` records it."""
        if name in then and then[name] != new.get(name):
            parts.append(f"`{name}` {shown(then[name])}, not {shown(new.get(name))}")

    compare("seed", before, now)
    then, new = before.get("samples"), now["samples"]
    if then is not None and new != then and not (extend and new > then):
        hint = " (to add samples, give `extend`)" if new > then else ""
        parts.append(f"`samples` {then}, not {new}{hint}")
    for name in ("design", "positions"):
        compare(name, before, now)
    filt = _filter_change(before, now)
    if filt is not None:
        parts.append(filt)
    compare("context_epsilon", before, now)
    if "images" in before and before["images"] != now["images"]:
        parts.append(f"route images {before['images']} per query, not {now['images']} (`images`)")
    scene_then, scene_now = before.get("scene"), now.get("scene")
    if isinstance(scene_then, dict) and scene_now is not None:
        goals = lambda v: repr(",".join(map(str, v or ())))  # noqa: E731 (as given: comma-separated)
        for name in ("start", "goals", "tolerance"):
            compare(name, scene_then, scene_now, goals if name == "goals" else _shown)
    prompt_then = before.get("prompt")
    if isinstance(prompt_then, dict) and prompt_then.get("sent") != now["prompt"]["sent"]:
        parts.append(f"the {prompt_then.get('sent')} prompt, not the {now['prompt']['sent']}")
    sampling_then, sampling_now = before.get("sampling"), now.get("sampling") or {}
    if isinstance(sampling_then, dict):
        for name in (*SAMPLING_FIELDS, "scoring"):  # the scoring says how the twins read a reply
            compare(name, sampling_then, sampling_now)
    return parts
