"""Helpers for the command-line tests: run ``fairaudit`` in-process and capture its output."""

from __future__ import annotations

import json

from fairaudit.cli import main


def run(capsys, *argv):
    """Exit status, stdout and stderr of ``fairaudit *argv``."""
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def run_json(capsys, *argv):
    """Exit status, the parsed JSON report and stderr of ``fairaudit *argv --format json``."""
    code, out, err = run(capsys, *argv, "--format", "json")
    return code, json.loads(out), err
