"""The two routes that count a file's records, shared by tests/test_counts_stream.py and tests/test_count_duckdb.py.

``reference``: the pandas route, the whole file read by ``read_records`` and counted by ``count_records``.
``counted``: ``count_file`` (DuckDB). Each returns the CountTable, or the ``InputError`` it raises.
"""

from __future__ import annotations

import fairaudit.estimate as estimate
from fairaudit import InputError, count_file, count_records, read_records


def reference(path, **kw):
    """The pandas route: the whole file read by read_records and counted, or the error it raises."""
    try:
        return count_records(read_records(path), **kw)
    except InputError as exc:
        return exc


def counted(path, **kw):
    """count_file's table, or the error it raises."""
    try:
        return count_file(path, **kw)
    except InputError as exc:
        return exc


def spy_fallback(monkeypatch):
    """The paths count_file left to pandas (read_records called inside count_file), recorded as it runs."""
    calls = []
    original = estimate.read_records

    def spy(path, csv=None):
        calls.append(path)
        return original(path, csv)

    monkeypatch.setattr(estimate, "read_records", spy)
    return calls
