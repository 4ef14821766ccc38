"""Report formats: one module per rendering of the report dictionaries, behind one interface.

The results' report dictionaries (their ``to_dict``) are the single
intermediate; each :class:`Format` renders them as one string:
:class:`~fairaudit.reports.formats.text.TextFormat`,
:class:`~fairaudit.reports.formats.json.JsonFormat`,
:class:`~fairaudit.reports.formats.markdown.MarkdownFormat` and
:class:`~fairaudit.reports.formats.html.HtmlFormat` (one self-contained page; its
libraries, jinja2 and matplotlib, are imported only when it renders).
:data:`FORMATTERS` maps the name of each (the choices of ``--format``) to its module and class, imported
by :func:`formatter` on first use; :func:`render` turns a report dictionary into the text of a report. Each dictionary follows the JSON
contract of docs/design.md: infinite values are the string ``"inf"``, NaN is ``null``, tuple labels (product
attributes) are joined with ``" & "``.
"""

from __future__ import annotations

import functools
import importlib

from fairaudit.base.errors import InputError
from fairaudit.base.json_values import Report
from fairaudit.reports.formats.base import KINDS, Format

__all__ = ["FORMATS", "FORMATTERS", "KINDS", "Format", "formatter", "render"]

#: Format name -> its module and class, in the order the command line lists them (imported when it renders:
#: a text report loads no HTML or Markdown code).
FORMATTERS: dict[str, tuple[str, str]] = {
    "text": ("text", "TextFormat"),
    "json": ("json", "JsonFormat"),
    "markdown": ("markdown", "MarkdownFormat"),
    "html": ("html", "HtmlFormat"),
}

#: The report formats, the choices of ``--format``.
FORMATS = tuple(FORMATTERS)


@functools.cache
def formatter(name: str) -> Format:
    """The format named ``name`` (one of :data:`FORMATS`), its module imported on first use.

    Raises
    ------
    InputError
        On an unknown format (naming ``format``).

    Examples
    --------
    >>> formatter("text").name
    'text'
    """
    if name not in FORMATTERS:
        raise InputError("format", f"must be one of {', '.join(FORMATS)}", name)
    module, cls = FORMATTERS[name]
    made: Format = getattr(importlib.import_module(f"{__name__}.{module}"), cls)()
    return made


def render(data: Report, kind: str, fmt: str) -> str:
    """Render a report dictionary.

    Parameters
    ----------
    data : dict
        A result's ``to_dict()``: a :class:`~fairaudit.certification.certificate.Certificate`, an :class:`~fairaudit.statistics.record_audit.Audit`, a
        :class:`~fairaudit.worstcase.calibration_result.Calibration`, a :class:`~fairaudit.statistics.sample_size.SamplePlan` or a
        :class:`~fairaudit.certification.spec_worst_case.SpecWorstUtility`.
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
    fairaudit.base.errors.InputError: format: must be one of text, json, markdown, html (got 'pdf')
    """
    return formatter(fmt).render(data, kind)
