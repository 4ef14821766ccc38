"""Reports: a result's dictionary rendered as text, JSON, Markdown or HTML (:mod:`~fairaudit.reports.formats`,
:mod:`~fairaudit.reports.formats`), and the figures (:mod:`~fairaudit.reports.plots`). Imports every layer
below it; matplotlib and jinja2 only when a figure or a page is drawn.
"""
