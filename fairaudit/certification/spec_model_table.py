"""The ``[model]`` table of a spec: its file read, its labels matched to the spec's, its decision model counted.

The table is indexed by the released values (the mechanisms' outputs). A table of whole counts that matches the
spec is counted by DuckDB and numpy, without pandas; any other table, and records, are read by DuckDB as a
DataFrame and counted by :func:`~fairaudit.data.counts.count_table` or
:func:`~fairaudit.data.counts.count_records`, which report what is wrong. Fields match the spec's labels and
``where`` values by their text (:func:`match_label`).
"""

from __future__ import annotations

from collections.abc import Hashable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from fairaudit.base.errors import InputError
from fairaudit.base.labels import format_label
from fairaudit.data.counts import CountTable, count_records, count_table
from fairaudit.data.csv_format import CsvFormat
from fairaudit.data.record_files import source
from fairaudit.laws.tables import Kernel

if TYPE_CHECKING:
    import pandas as pd

    from fairaudit.certification.spec import Spec
    from fairaudit.certification.spec_schema import ModelSpec

__all__ = [
    # reading it
    "match_label",
    "read_model",
]


def read_model(spec: Spec) -> tuple[Kernel | None, CountTable | None]:
    """The decision model P(U | X̃, Ã) of a spec's ``[model]`` (None without one), and the weighted counts.

    The table is indexed by the *released* values: the outputs of
    ``[privacy.context]`` and ``[privacy.sensitive]``.

    Returns
    -------
    kernel : Kernel or None
    weighted : CountTable or None
        For ``records`` with a ``weight_column``: their weighted counts
        (with the sums of squared weights); else None.

    Raises
    ------
    InputError
        If the file is missing, a column is unknown, a label is not in the
        spec, or a (context, group) cell has no row; the field is the spec's
        (``SPEC: model.table``).
    """
    m = spec.model.model
    if m is None:
        return None, None
    name = m.table if m.table is not None else m.records
    assert name is not None  # (SpecModel: exactly one of table and records)
    path = spec.base / name
    field = "model.table" if m.table is not None else "model.records"
    if not path.is_file():
        raise _error(spec, field, "no such file", str(path))
    counted = _counted_kernel(spec, m, path) if m.table is not None and m.probability_column is None else None
    if counted is not None:
        return counted, None
    frame = _model_frame(spec, m, path, field)
    ctx_cols = [] if spec.model.context is None else [spec.model.context.name]
    # the model sees released values: its table is indexed by the mechanisms' outputs
    contexts, groups = spec.context_mechanism.outputs, spec.sensitive_mechanism.outputs
    sens = [spec.model.sensitive.name]
    dec = spec.model.decision.name
    weighted: CountTable | None = None
    try:
        if m.records:
            table = count_records(frame, sensitive=sens, outcome=dec, context=ctx_cols, weights=m.weight_column)
            table = _relabel(table, contexts, groups, spec.decisions)
            probs_kernel = Kernel.from_counts(table.counts, contexts, groups, spec.decisions)
            weighted = table if table.squares is not None else None
        else:
            prob_col = m.probability_column
            cnt_col = m.count_column
            if prob_col is None and cnt_col is None:
                cnt_col = "count" if "count" in frame.columns else None
                prob_col = "probability" if cnt_col is None else None
                if prob_col is not None and prob_col not in frame.columns:
                    raise _error(
                        spec,
                        "model.table",
                        "needs a 'count' or 'probability' column (or set count_column)",
                        list(map(str, frame.columns)),
                    )
            column = cnt_col or prob_col
            assert column is not None  # (one of them is set above)
            table = count_table(
                frame,
                sensitive=sens,
                outcome=dec,
                context=ctx_cols,
                count=column,
                contexts=contexts,
                groups=groups,
                decisions=spec.decisions,
            )
            empty = np.argwhere(table.counts.sum(axis=-1) == 0)
            if len(empty):
                i, j = empty[0]
                raise _error(
                    spec,
                    field,
                    f"has no rows (or only zeros) for (context {format_label(contexts[i])!r}, "
                    f"group {format_label(groups[j])!r}); {len(empty)} such cells in all",
                )
            probs_kernel = (Kernel.from_counts if cnt_col else Kernel)(table.counts, contexts, groups, spec.decisions)
    except InputError as exc:
        if exc.field.startswith(spec.source):
            raise
        raise exc.under(f"{spec.source}: {field}") from None
    if probs_kernel.empty_cells:
        x, a = probs_kernel.empty_cells[0]
        raise _error(
            spec,
            field,
            f"has no rows for (context {format_label(x)!r}, group {format_label(a)!r}); "
            f"{len(probs_kernel.empty_cells)} empty cells in all",
        )
    return probs_kernel, weighted


def _counted_kernel(spec: Spec, m: ModelSpec, path: Path) -> Kernel | None:
    """The kernel of a table of whole counts matching the spec, counted by DuckDB and numpy (without pandas).

    None wherever the table is not that plain (a missing or negative count, a field that matches no label of
    the spec, a cell twice or none, a format or file DuckDB refuses): :func:`read_model` then reads the
    table as a DataFrame and :func:`~fairaudit.data.counts.count_table` reports what is wrong. Fields match the
    spec's labels and ``where`` values by their text, as there.
    """
    count = m.count_column or "count"
    roles = [None if spec.model.context is None else spec.model.context.name]
    roles += [spec.model.sensitive.name, spec.model.decision.name]
    used = list(dict.fromkeys([*(c for c in roles if c is not None), count, *m.where]))
    try:
        records = source(path, _csv_format(m))
        grouped = records.group_by(used) if set(used) <= set(records.names) else None
    except InputError:
        return None
    if grouped is None or any(grouped.missing[c].any() for c in used) or grouped.values[count].dtype.kind != "i":
        return None
    text = {c: np.array([str(v) for v in grouped.values[c]], dtype=object) for c in used}
    keep = np.ones(len(grouped.weights), dtype=bool)
    for column, want in m.where.items():
        keep &= text[column] == str(want)
    labels = (spec.context_mechanism.outputs, spec.sensitive_mechanism.outputs, spec.decisions)
    shape = tuple(len(x) for x in labels)
    flat = np.zeros(int(keep.sum()), dtype=np.int64)
    for role, wanted, size in zip(roles, labels, shape):
        lookup = {format_label(v): i for i, v in enumerate(wanted)}
        codes = np.array([lookup.get(v, -1) for v in text[role][keep]] if role else [0] * len(flat), dtype=int)
        if (codes < 0).any():
            return None
        flat = flat * size + codes
    n = grouped.values[count][keep]
    if np.unique(flat).size < flat.size or (grouped.weights[keep] > 1).any() or (n < 0).any():
        return None
    counts = np.zeros(int(np.prod(shape)), dtype=np.int64)
    counts[flat] = n
    counts = counts.reshape(shape)
    if not bool((counts.sum(axis=-1) > 0).all()):
        return None
    return Kernel.from_counts(counts, *labels)


def _model_frame(spec: Spec, m: ModelSpec, path: Path, field: str) -> pd.DataFrame:
    """The model's file read by DuckDB (``[model.csv]``), its ``where`` filters applied."""
    try:
        fmt = _csv_format(m)
    except InputError as exc:
        raise _error(spec, f"model.csv.{exc.field}", exc.problem, exc.value) from None
    used = [spec.model.sensitive.name, spec.model.decision.name, *m.where]
    used += [spec.model.context.name] if spec.model.context is not None else []
    used += [c for c in (m.count_column, m.probability_column, m.weight_column) if c is not None]
    try:
        frame = source(path, fmt).read(check=used)
    except InputError as exc:  # a file's problem under model.records/table, a format's under model.csv
        from fairaudit.certification.spec_schema import CsvSpec

        if exc.field in CsvSpec.model_fields:
            raise _error(spec, f"model.csv.{exc.field}", exc.problem, exc.value) from None
        raise _error(spec, field, exc.problem, str(path)) from None
    for col, want in m.where.items():
        if col not in frame.columns:
            raise _error(spec, f"model.where.{col}", "is not a column of the table", col)
        frame = frame[frame[col].astype(str) == str(want)]
        if frame.empty:
            raise _error(spec, f"model.where.{col}", "selects no rows", want)
    return frame


def match_label(value: Hashable, labels: tuple) -> Hashable | None:
    """The label equal to ``value``, or whose text equals its text."""
    if value in labels:
        return value
    return next((lab for lab in labels if format_label(lab) == format_label(value)), None)


def _relabel(table: CountTable, contexts: tuple, groups: tuple, decisions: tuple) -> CountTable:
    """Re-index a CountTable from records onto the spec's label order (by text)."""

    def index(found: tuple, wanted: tuple, role: str) -> list[int]:
        pos = []
        for f in found:
            m = match_label(f, wanted)
            if m is None:
                raise InputError(role, f"value not among the spec's values {[format_label(w) for w in wanted]}", f)
            pos.append(wanted.index(m))
        return pos

    ix = index(table.contexts, contexts, "context") if contexts != ("all",) else [0]
    ia = index(table.groups, groups, "sensitive")
    iu = index(table.decisions, decisions, "decision")

    def placed(counts: Any) -> Any:
        out = np.zeros((len(contexts), len(groups), len(decisions)))
        out[np.ix_(ix, ia, iu)] = counts
        return out

    columns = (table.context_columns, table.sensitive_columns, table.outcome_column)
    squares = None if table.squares is None else placed(table.squares)
    return CountTable(
        placed(table.counts), contexts, groups, decisions, *columns, weight_column=table.weight_column, squares=squares
    )


def _csv_format(m: ModelSpec) -> CsvFormat:
    """How the model's file is read (``[model.csv]``; its errors name the option, as ``CsvFormat``'s do)."""
    if m.csv is None:
        return CsvFormat()
    return CsvFormat(**{**m.csv.model_dump(), "names": None if m.csv.names is None else tuple(m.csv.names)})


def _error(spec: Spec, field: str, problem: str, *value: object) -> InputError:
    """An error of the spec's ``field`` (``SPEC: model.table``)."""
    return InputError(f"{spec.source}: {field}", problem, *value)
