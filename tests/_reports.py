"""Report dictionaries for the format tests: ``fairaudit ... --format json`` written to a file and read back."""

from __future__ import annotations

import json

from fairaudit.cli import main


def report_json(tmp_path_factory, name: str, *argv) -> dict:
    """The JSON report of ``fairaudit *argv``, written to a file (no capture needed); exit status 0 or 1."""
    out = tmp_path_factory.mktemp("reports") / f"{name}.json"
    assert main([str(a) for a in argv] + ["--format", "json", "--output", str(out)]) in (0, 1)
    return json.loads(out.read_text())
