"""Reports: a result's dictionary rendered as text, JSON, Markdown or HTML.

Each result builds its own report dictionary (its ``to_dict`` method), which
follows the JSON contract of docs/design.md (keys that other tools read);
infinite values are the string ``"inf"``, NaN is ``null``, tuple labels
(product attributes) are joined with ``" & "``. :func:`render` turns one into
the text of a report through the formats of ``fairaudit._format`` (one module
per format).
"""

from __future__ import annotations

from ._errors import InputError
from ._format import FORMATTERS
from ._json import Report

__all__ = ["FORMATS", "render"]

#: The report formats, the choices of ``--format``.
FORMATS = tuple(FORMATTERS)


def render(data: Report, kind: str, fmt: str) -> str:
    """Render a report dictionary.

    Parameters
    ----------
    data : dict
        A result's ``to_dict()``: a :class:`~fairaudit.certify.Certificate`, an :class:`~fairaudit.audit.Audit`, a
        :class:`~fairaudit.calibrate.Calibration`, a :class:`~fairaudit.plan.SamplePlan` or a
        :class:`~fairaudit.worst_case.SpecWorstUtility`.
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
