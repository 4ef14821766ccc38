"""Reports: one dictionary per result, rendered as JSON, text or Markdown.

Each result builds its own dictionary (its ``to_dict`` method); the ``*_dict``
functions here are the stable names of those. The dictionaries follow the JSON
contract of docs/design.md (keys that other tools read); infinite values are
the string ``"inf"``, NaN is ``null``, tuple labels (product attributes) are
joined with ``" & "``. :func:`render` turns one into
the text of a report through the formats of ``fairaudit._format`` (one module
per format). :func:`write_atomic` (from ``fairaudit._io``) is re-exported here.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

from ._errors import InputError
from ._format import FORMATTERS
from ._io import STALE_SECONDS, write_atomic
from ._json import Report

if TYPE_CHECKING:
    from .audit import Audit
    from .calibrate import Calibration
    from .certify import Certificate
    from .intervals import FairnessIntervals
    from .laws import Population
    from .plan import SamplePlan
    from .worst_case import SpecWorstUtility

__all__ = [
    "FORMATS",
    "STALE_SECONDS",
    "Report",
    "audit_dict",
    "calibration_dict",
    "certificate_dict",
    "intervals_dict",
    "plan_dict",
    "population_dict",
    "render",
    "worst_case_dict",
    "write_atomic",
]

#: The report formats, the choices of ``--format``.
FORMATS = tuple(FORMATTERS)


def intervals_dict(fi: FairnessIntervals) -> Report:
    """The JSON of a :class:`~fairaudit.intervals.FairnessIntervals`: :meth:`~fairaudit.intervals.FairnessIntervals.to_dict`."""
    return fi.to_dict()


def population_dict(p: Population) -> Report:
    """``population`` of a certificate or an audit: :meth:`~fairaudit.laws.Population.to_dict`."""
    return p.to_dict()


def calibration_dict(c: Calibration) -> Report:
    """The ``calibrate`` JSON of a :class:`~fairaudit.calibrate.Calibration`: :meth:`~fairaudit.calibrate.Calibration.to_dict`."""
    return c.to_dict()


def certificate_dict(cert: Certificate) -> Report:
    """The ``certify`` JSON (docs/design.md contract): :meth:`~fairaudit.certify.Certificate.to_dict`."""
    return cert.to_dict()


def audit_dict(a: Audit) -> Report:
    """The ``audit`` JSON (docs/design.md contract): :meth:`~fairaudit.audit.Audit.to_dict`."""
    return a.to_dict()


def plan_dict(plans: Sequence[SamplePlan]) -> Report:
    """The ``plan`` JSON of one or more :class:`~fairaudit.plan.SamplePlan` (same inputs, one per method).

    Keys: ``target``, ``confidence``, ``power``, ``kind``, ``groups``,
    ``contexts``, ``base_rate``, ``disparity``, ``epsilon`` (``null`` without
    a filter), ``seed``, ``max_n``, ``true_value`` (L or L̄ of the assumed law),
    ``feasible`` (every plan found an n) and ``plans``: one entry per method
    with ``method``, ``n_per_cell``, ``n_total`` (``null`` when infeasible),
    ``achieved_power``, ``expected_upper`` (median upper end, nats),
    ``datasets``, ``reason`` (``""`` when feasible). One plan's own
    dictionary is :meth:`~fairaudit.plan.SamplePlan.to_dict`.
    """
    out = plans[0].to_dict()
    out["feasible"] = all(p.feasible for p in plans)
    out["plans"] = [entry for p in plans for entry in p.to_dict()["plans"]]
    return out


def worst_case_dict(w: SpecWorstUtility) -> Report:
    """The ``worst-case`` JSON of a :class:`~fairaudit.worst_case.SpecWorstUtility`: its ``to_dict``."""
    return w.to_dict()


def render(data: Report, kind: str, fmt: str) -> str:
    """Render a report dictionary.

    Parameters
    ----------
    data : dict
        From :func:`certificate_dict`, :func:`audit_dict`, :func:`calibration_dict`, :func:`plan_dict` or
        :func:`worst_case_dict`.
    kind : {"certify", "audit", "calibrate", "plan", "worst-case"}
    fmt : {"text", "json", "markdown", "html"}
        One of :data:`FORMATS`.

    Raises
    ------
    InputError
        On an unknown format (naming ``format``).

    Examples
    --------
    >>> print(render({"epsilon": "inf"}, "calibrate", "json"), end="")
    {
      "epsilon": "inf"
    }
    >>> render({}, "audit", "pdf")
    Traceback (most recent call last):
    ...
    fairaudit._errors.InputError: format: must be one of text, json, markdown, html (got 'pdf')
    """
    formatter = FORMATTERS.get(fmt)
    if formatter is None:
        raise InputError("format", f"must be one of {', '.join(FORMATS)}", fmt)
    return formatter.render(data, kind)
