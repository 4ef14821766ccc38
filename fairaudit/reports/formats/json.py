"""The JSON format: the report dictionary itself, indented."""

from __future__ import annotations

import json

from fairaudit.base.json_values import Report
from fairaudit.reports.formats.base import Format

__all__ = ["JsonFormat"]


class JsonFormat(Format):
    """``json.dumps`` of the dictionary (indent 2, UTF-8 kept, no NaN), whatever its kind."""

    name = "json"

    def dump(self, d: Report) -> str:
        """The dictionary as JSON: every kind of report alike."""
        return json.dumps(d, indent=2, ensure_ascii=False, allow_nan=False) + "\n"

    certificate = audit = calibration = plan = worst_case = dump
