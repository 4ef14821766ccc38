"""The interface of a report format: one method per kind of report dictionary."""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import ClassVar

from fairaudit.base.json_values import Report

__all__ = ["KINDS", "Format"]

#: Report kind (the subcommand) -> the :class:`Format` method that renders its dictionary.
KINDS = {
    "certify": "certificate",
    "audit": "audit",
    "calibrate": "calibration",
    "plan": "plan",
    "worst-case": "worst_case",
}


class Format(ABC):
    """A rendering of the report dictionaries (each result's ``to_dict``) as one string each.

    A format has a :attr:`name` (the value of ``--format``) and one method per
    kind of report; :meth:`render` dispatches on the kind.
    """

    name: ClassVar[str]

    @abstractmethod
    def certificate(self, d: Report) -> str:
        """The ``certify`` report of :meth:`fairaudit.certification.certificate.Certificate.to_dict`."""

    @abstractmethod
    def audit(self, d: Report) -> str:
        """The ``audit`` report of :meth:`fairaudit.statistics.record_audit.Audit.to_dict`."""

    @abstractmethod
    def calibration(self, d: Report) -> str:
        """The ``calibrate`` report of :meth:`fairaudit.worstcase.calibration_result.Calibration.to_dict`."""

    @abstractmethod
    def plan(self, d: Report) -> str:
        """The ``plan`` report of one or more :meth:`fairaudit.statistics.sample_size.SamplePlan.to_dict` (``plans`` lists each method)."""

    @abstractmethod
    def worst_case(self, d: Report) -> str:
        """The ``worst-case`` report of :meth:`fairaudit.certification.spec_worst_case.SpecWorstUtility.to_dict`."""

    def render(self, d: Report, kind: str) -> str:
        """The report of kind ``kind`` (a key of :data:`KINDS`)."""
        text: str = getattr(self, KINDS[kind])(d)
        return text
