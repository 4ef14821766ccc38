"""Report formats: one module per rendering of the report dictionaries, behind one interface.

The results' report dictionaries (their ``to_dict``) are the single
intermediate; each :class:`Format` renders them as one string:
:class:`~fairaudit._format.text.TextFormat`,
:class:`~fairaudit._format.json.JsonFormat`,
:class:`~fairaudit._format.markdown.MarkdownFormat` and
:class:`~fairaudit._format.html.HtmlFormat` (one self-contained page; its
libraries, jinja2 and matplotlib, are imported only when it renders).
:data:`FORMATTERS` maps the name of each (the choices of ``--format``) to an
instance.
"""

from __future__ import annotations

from ._base import KINDS, Format
from .html import HtmlFormat
from .json import JsonFormat
from .markdown import MarkdownFormat
from .text import TextFormat

__all__ = ["FORMATTERS", "KINDS", "Format"]

#: Format name -> format, in the order the command line lists them.
FORMATTERS: dict[str, Format] = {f.name: f for f in (TextFormat(), JsonFormat(), MarkdownFormat(), HtmlFormat())}
