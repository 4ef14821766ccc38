"""MkDocs hook: docstrings are numpydoc, written for Sphinx; show their roles as the code they name.

``:func:`~fairaudit.estimate.count_file``` is rendered by mkdocstrings as ``:func:<code>~fairaudit...</code>``; this
hook drops the role and, as Sphinx does for a leading ``~``, keeps only the last dotted name.
"""

import re

_ROLE = re.compile(r":(?:class|func|meth|attr|mod|data|exc|obj):<code>(~?)([^<]*)</code>")


def strip_roles(html: str) -> str:
    return _ROLE.sub(lambda m: f"<code>{m.group(2).rsplit('.', 1)[-1] if m.group(1) else m.group(2)}</code>", html)


def on_page_content(html, **kwargs):
    return strip_roles(html)
