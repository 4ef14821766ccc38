"""Helpers for the command-line tests: run ``fairaudit`` in-process and capture its output."""

from __future__ import annotations

import json

from fairaudit.cli import main

# A two-office spec shared by the CLI tests (behind binary randomized response, keep 0.7); tests append sections.
OFFICE_SPEC = """
[sensitive]
name = "office"
values = ["HR_1", "HR_2"]
[context]
name = "document"
values = ["maternity", "holiday"]
[decision]
name = "chosen"
values = ["yes", "no"]
[privacy.sensitive]
mechanism = "randomized_response"
keep = 0.7
[utility]
kind = "indicator"
decision = "yes"
"""


def run(capsys, *argv):
    """Exit status, stdout and stderr of ``fairaudit *argv``."""
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def run_json(capsys, *argv):
    """Exit status, the parsed JSON report and stderr of ``fairaudit *argv --format json``."""
    code, out, err = run(capsys, *argv, "--format", "json")
    return code, json.loads(out), err
