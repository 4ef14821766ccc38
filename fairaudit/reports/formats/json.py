"""The JSON format: the report dictionary itself, indented."""

from __future__ import annotations

import json

from fairaudit.base.json_values import Report
from fairaudit.reports.formats.base import Format

__all__ = ["JsonFormat"]


class JsonFormat(Format):
    """``json.dumps`` of the dictionary (indent 2, UTF-8 kept, no NaN), whatever its kind."""

    name = "json"

    def render(self, d: Report, kind: str) -> str:
        """The dictionary as JSON; ``kind`` does not change it."""
        return json.dumps(d, indent=2, ensure_ascii=False, allow_nan=False) + "\n"

    def certificate(self, d: Report) -> str:
        """The certificate as JSON."""
        return self.render(d, "certify")

    def audit(self, d: Report) -> str:
        """The audit as JSON."""
        return self.render(d, "audit")

    def calibration(self, d: Report) -> str:
        """The calibration as JSON."""
        return self.render(d, "calibrate")

    def plan(self, d: Report) -> str:
        """The plan as JSON."""
        return self.render(d, "plan")

    def worst_case(self, d: Report) -> str:
        """The worst utility as JSON."""
        return self.render(d, "worst-case")
