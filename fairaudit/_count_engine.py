"""DuckDB, the engine that counts the records of a file for :func:`fairaudit.estimate.count_file`.

One ``GROUP BY`` of the used columns over the file, out of core, on a
connection to fairaudit's own in-memory database; the small grouped table is
then given the values pandas would read (``pandas.read_parquet``'s
conversion of Arrow types, ``pandas.read_csv``'s type inference), so that
:mod:`fairaudit.estimate` counts it with the same code as records read by
pandas. Names go into SQL as quoted identifiers (:func:`sql_identifier`),
files and values as parameters, never as SQL text.

pandas, pyarrow and DuckDB are imported by the functions that use them.
"""

from __future__ import annotations

import os
import re
import tempfile
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from ._csv_format import CsvFormat, FileKind
from ._errors import InputError
from ._key_values import ROWS_SHOWN, Locate

if TYPE_CHECKING:
    import pandas as pd
    import pyarrow as pa
    import pyarrow.dataset as ds

__all__ = [
    "MEMORY_LIMIT_VARIABLE",
    "Grouped",
    "csv_group_by",
    "engine_error",
    "parquet_group_by",
    "parquet_source",
    "sql_identifier",
]

_GLOB = frozenset("*?[]{}")  # characters DuckDB may expand in a file name


def sql_identifier(name: str) -> str:
    """``name`` as a quoted SQL identifier: in double quotes, each double quote in it doubled.

    Examples
    --------
    >>> print(sql_identifier('a"b'), sql_identifier("two words"))
    "a""b" "two words"
    """
    return '"' + name.replace('"', '""') + '"'


def count_name(names: Sequence[str]) -> str:
    """A name for the count column that is none of ``names`` (DuckDB compares names ignoring case)."""
    taken = {c.lower() for c in names}
    name = "n"
    while name in taken:
        name += "_"
    return name


MEMORY_LIMIT_VARIABLE = "FAIRAUDIT_DUCKDB_MEMORY_LIMIT"
"""The environment variable that sets DuckDB's ``memory_limit`` (``4GB``, ``500MB``, ``50%``); unset, DuckDB's default
(80% of the machine's memory)."""

_DATABASE: dict[tuple[int, str | None], Any] = {}  # (process id, memory limit) -> fairaudit's own DuckDB database


def duckdb_connection() -> Any:
    """A new connection to fairaudit's own in-memory DuckDB database (not DuckDB's default one).

    The database is made once per process (a connection to a new database
    costs tens of milliseconds; one to an open database, under one); a forked
    child makes its own, and leaves its parent's alone. Close the connection
    after use. DuckDB runs a query on as many threads as there are cores, within
    the memory limit of :data:`MEMORY_LIMIT_VARIABLE` when it is set.

    Raises
    ------
    InputError
        When :data:`MEMORY_LIMIT_VARIABLE` is not a size DuckDB reads.
    """
    import duckdb

    limit = os.environ.get(MEMORY_LIMIT_VARIABLE) or None
    key = (os.getpid(), limit)
    if key not in _DATABASE:
        config: dict[str, Any] = {} if limit is None else {"memory_limit": limit}
        try:
            _DATABASE[key] = duckdb.connect(":memory:", config=config)
        except duckdb.Error as exc:
            first = (str(exc).splitlines() or [""])[0]
            raise InputError(
                MEMORY_LIMIT_VARIABLE, f"is not a memory size DuckDB reads, such as 4GB or 500MB ({first})", limit
            ) from None
    return _DATABASE[key].cursor()


def engine_error(exc: Exception, path: str | os.PathLike[str]) -> InputError:
    """DuckDB's failure on the file ``path`` as one line that says what it is (never a second reader's guess).

    Out of memory: DuckDB's ``memory_limit``, where it comes from and what to
    try. Anything else: DuckDB's own first line.
    """
    import duckdb

    first = (str(exc).splitlines() or [""])[0]
    if not isinstance(exc, duckdb.OutOfMemoryException):
        return InputError("DATA", f"cannot be read by DuckDB ({type(exc).__name__}: {first})", os.fspath(path))
    try:
        con = duckdb_connection()
        try:
            limit = str(con.execute("SELECT current_setting('memory_limit')").fetchone()[0])
        finally:
            con.close()
    except Exception:  # noqa: BLE001 - the limit is only named when DuckDB can still say it
        limit = "unknown"
    given = os.environ.get(MEMORY_LIMIT_VARIABLE)
    source = f"set by {MEMORY_LIMIT_VARIABLE}={given}" if given else "DuckDB's default, 80% of the memory"
    return InputError(
        "DATA",
        f"DuckDB ran out of memory counting it (memory_limit {limit}, {source}; {first}): give it more memory "
        f"({MEMORY_LIMIT_VARIABLE}, e.g. 8GB, on a machine that has it), or count a smaller file or fewer columns",
        os.fspath(path),
    )


@contextmanager
def glob_free(paths: Sequence[str]) -> Iterator[list[str]]:
    """``paths`` (absolute) as DuckDB reads them: a name with a glob character goes through a symbolic link.

    DuckDB reads ``data[1].csv`` or ``d?.parquet`` as patterns, which may match
    other files too.
    """
    if not any(_GLOB.intersection(p) for p in paths):
        yield list(paths)
        return
    with tempfile.TemporaryDirectory(prefix="fairaudit-") as tmp:
        links = []
        for i, p in enumerate(paths):
            if _GLOB.intersection(p):
                link = os.path.join(tmp, f"{i}.data")
                os.symlink(p, link)
                p = link
            links.append(p)
        yield links


# Bounded reading: Parquet pre-buffering keeps every row group's bytes read until the file is closed, so
# memory would grow with the file (apache/arrow#39808); off, with a short readahead, the peak is a few row
# groups of the column read (pandas categorical columns only, for their categories' order).
_READAHEAD = {"batch_readahead": 2, "fragment_readahead": 1}


def parquet_source(p: Path) -> tuple[pa.Schema, list[str]]:
    """The Arrow schema and the files of the Parquet file, or folder of Parquet files, ``p``.

    A folder's files are those ``pyarrow.dataset`` finds (its schema is its
    first file's); a file's schema is read from its footer alone
    (``pyarrow.parquet``, which, unlike ``pyarrow.dataset``, does not import
    pandas).
    """
    if p.is_dir():
        dataset = _parquet_dataset(p)
        return dataset.schema, list(dataset.files)
    import pyarrow.parquet as pq

    return pq.read_schema(p), [str(p)]


def _parquet_dataset(p: Path | list[str]) -> ds.Dataset:
    import pyarrow.dataset as ds

    options = ds.ParquetFragmentScanOptions(pre_buffer=False)
    return ds.dataset(p, format=ds.ParquetFileFormat(default_fragment_scan_options=options))


def _unified_dictionary(files: list[str], column: str) -> pa.Array:
    """The categories pandas.read_parquet gives a dictionary column: its batches' dictionaries unified in order."""
    import pyarrow as pa

    dataset = _parquet_dataset(files)
    dicts: list[pa.Array] = []
    for batch in dataset.to_batches(columns=[column], **_READAHEAD):
        d = batch.column(0).dictionary
        if not dicts or not d.equals(dicts[-1]):
            dicts.append(d)
    empty = pa.array([], type=pa.int32())
    chunks = pa.chunked_array(
        [pa.DictionaryArray.from_arrays(empty, d) for d in dicts],
        type=pa.dictionary(pa.int32(), dataset.schema.field(column).type.value_type),
    )
    return pa.table({column: chunks}).unify_dictionaries().column(0).chunk(0).dictionary


@dataclass(frozen=True)
class Grouped:
    """The distinct combinations of the keys in a file and their numbers of records (``weights``).

    ``plain``: the keys as numpy arrays, when each is of a plain type
    (integers, floats, booleans, text) and has no missing value: their
    values are the labels pandas would give (Python scalars by ``tolist``),
    and pandas is not needed. Otherwise ``frame``: the keys as pandas reads
    them. ``locate``: where the keys of some of these rows are in the file (a
    second query, run only for an error: :data:`fairaudit._key_values.Locate`).
    """

    weights: npt.NDArray[np.int64]
    plain: list[npt.NDArray[Any]] | None = None
    frame: pd.DataFrame | None = None
    locate: Locate | None = None


def parquet_group_by(schema: pa.Schema, files: list[str], keys: list[str]) -> Grouped:
    """The distinct combinations of ``keys`` in Parquet ``files`` as pandas reads them, with their numbers of records.

    Null and NaN keys are combinations too. Keys of plain types without a
    missing value come as numpy arrays; otherwise the grouped columns are
    cast back to the file's Arrow types and converted with the file's pandas
    metadata, as ``pandas.read_parquet`` converts them.

    Raises
    ------
    duckdb.Error, pyarrow.ArrowException, OSError
        The files cannot be read.
    """
    import pyarrow as pa

    kinds = [schema.field(c).type for c in keys]
    locate = _parquet_locate(schema, files, keys)
    if all(_is_plain(kind) for kind in kinds):
        *columns, weights = _duckdb_parquet(schema, files, keys, arrow=False)
        weights = np.asarray(weights, dtype=np.int64)
        if weights.size and all(_complete(c) for c in columns):
            plain = [np.asarray(c) for c in columns]
            return Grouped(weights, plain=plain, locate=locate(dict(zip(keys, plain))))
        arrays = [pa.array(np.ma.getdata(c), mask=np.ma.getmaskarray(c), type=k) for c, k in zip(columns, kinds)]
        table = pa.table([*arrays, pa.array(weights)], names=[*keys, count_name(keys)])
    else:
        table = _as_parquet_types(_duckdb_parquet(schema, files, keys, arrow=True), keys, schema, files)
    frame = _to_pandas(table.replace_schema_metadata(schema.metadata))
    values = {c: frame[c].to_numpy() for c in keys}
    return Grouped(frame[count_name(keys)].to_numpy(dtype=np.int64), frame=frame, locate=locate(values))


def _parquet_locate(schema: pa.Schema, files: list[str], keys: list[str]) -> Any:
    """Given the grouped keys' values, the :data:`Locate` of Parquet ``files``: rows of the file (named, for several).

    The refused values are text; a row matches when its value, as text, is
    one of them. One query, ``file_row_number`` and ``filename`` from DuckDB's
    reader, ordered by file and row.
    """

    def bind(values: dict[str, npt.NDArray[Any]]) -> Locate:
        def locate(column: str, mask: npt.NDArray[np.bool_]) -> list[tuple[str, Any]]:
            wanted = sorted({str(v) for v in np.asarray(values[column], dtype=object)[mask]})
            con = duckdb_connection()
            try:
                with glob_free([os.path.abspath(f) for f in files]) as plain:
                    name = con.read_parquet(plain, hive_partitioning=False).columns[schema.get_field_index(column)]
                    sql = (
                        f"SELECT filename, file_row_number, v FROM (SELECT filename, file_row_number, "
                        f"CAST({sql_identifier(name)} AS VARCHAR) AS v FROM read_parquet(?, hive_partitioning = false, "
                        f"file_row_number = true, filename = true)) WHERE list_contains(?, v) "
                        f"ORDER BY list_position(?, filename), file_row_number LIMIT {ROWS_SHOWN}"
                    )
                    rows = con.execute(sql, [plain, wanted, plain]).fetchall()
            finally:
                con.close()
            several = len(files) > 1
            return [(f"{r + 1} of {Path(f).name}" if several else str(r + 1), v) for f, r, v in rows]

        return locate

    return bind


def _is_plain(kind: pa.DataType) -> bool:
    import pyarrow as pa

    return (
        pa.types.is_integer(kind)
        or pa.types.is_boolean(kind)
        or pa.types.is_float32(kind)
        or pa.types.is_float64(kind)
        or pa.types.is_string(kind)
        or pa.types.is_large_string(kind)
    )


def _complete(column: npt.NDArray[Any]) -> bool:
    """No missing value: no null (masked) nor, among floats, NaN."""
    if np.ma.is_masked(column):
        return False
    return not (column.dtype.kind == "f" and np.isnan(column).any())


def _duckdb_parquet(schema: pa.Schema, files: list[str], keys: list[str], arrow: bool) -> Any:
    """DuckDB's count of each distinct combination of ``keys`` (null and NaN keys included): keys, then the count.

    An Arrow table, or (``arrow`` False) a list of numpy arrays, masked where
    null. The columns are named by position: DuckDB renames a column whose
    name differs from another's only in case.
    """
    con = duckdb_connection()
    try:
        with glob_free([os.path.abspath(f) for f in files]) as plain:
            rel = con.read_parquet(plain, hive_partitioning=False)
            names = [rel.columns[schema.get_field_index(c)] for c in keys]
            selected = ", ".join(sql_identifier(c) for c in names)
            grouped = rel.aggregate(f"{selected}, count(*) AS {sql_identifier(count_name(rel.columns))}", selected)
            if not arrow:
                return list(grouped.fetchnumpy().values())
            to_table = getattr(grouped, "to_arrow_table", None)  # DuckDB >= 1.4; before, arrow() gives the table
            return to_table() if to_table is not None else grouped.arrow()
    finally:
        con.close()


def _as_parquet_types(grouped: pa.Table, keys: list[str], schema: pa.Schema, files: list[str]) -> pa.Table:
    """The grouped keys in the file's Arrow types, so that pandas converts them as pandas.read_parquet does.

    A dictionary (pandas categorical) column comes out of DuckDB as its
    values; it is rebuilt on the categories pandas gives it, the row groups'
    dictionaries unified in order (one more pass, over that column only).
    """
    import pyarrow as pa
    import pyarrow.compute as pc

    columns = []
    for i, c in enumerate(keys):
        kind = schema.field(c).type
        column = grouped.column(i).combine_chunks()
        if pa.types.is_dictionary(kind):
            dictionary = _unified_dictionary(files, c)
            indices = pc.index_in(column.cast(kind.value_type), value_set=dictionary)
            column = pa.DictionaryArray.from_arrays(indices, dictionary, ordered=kind.ordered)
        else:
            column = pa.nulls(len(column)) if pa.types.is_null(kind) else column.cast(kind)
        columns.append(column)
    count = count_name(keys)
    return pa.table([*columns, grouped.column(len(keys))], names=[*keys, count])


def _to_pandas(table: pa.Table) -> pd.DataFrame:
    """An Arrow table as pandas.read_parquet converts it (same dtypes, so the same labels)."""
    try:
        from pandas.io._util import arrow_table_to_pandas  # what pandas.read_parquet calls
    except ImportError:  # pragma: no cover - other pandas versions
        return table.to_pandas()
    return arrow_table_to_pandas(table)


# The CSV dialect of pandas.read_csv's defaults, every field read as text (VARCHAR); values are bound as parameters
_READ_CSV = (
    "read_csv(?, columns = ?, compression = ?, header = ?, auto_detect = false, delim = ?, quote = '\"', "
    "escape = '\"', comment = '', strict_mode = true, null_padding = false)"
)


@dataclass
class _Scan:
    """Where :func:`csv_regular` is in a file: quote parity, the record read so far, the byte before."""

    parity: int = 0
    fields: int = 1  # of the record being read
    length: int = 0  # its bytes so far
    previous: int = -1  # the byte before the block; -1 at the start of the file
    header: bool = True  # no record ended yet
    delim: int = 44  # the separator's byte (a comma)


_SCAN_BLOCK = 1 << 22  # bytes read at a time
_QUOTE, _LF, _CR = 34, 10, 13
DUCKDB_SEPARATORS = frozenset(",;\t|:")
"""The separators of the text files DuckDB counts (others go to pandas): comma, semicolon, tab, bar, colon."""


def csv_regular(p: Path, n_fields: int, gzipped: bool = False, sep: str = ",") -> bool:
    """Whether every record of CSV file ``p`` has ``n_fields`` fields, its quotes around whole fields only.

    On such files DuckDB's reader and pandas' agree field by field; they
    differ elsewhere: DuckDB drops empty fields past the last column (pandas
    takes a first column as the index), trims spaces around a quoted field,
    reads a blank line before the header, or a line of spaces; pandas ends a
    record at a lone carriage return. One pass over the bytes, 4 MiB at a
    time (numpy), ``"`` toggling whether a comma or a line end is inside a
    field. ``sep`` is the separator (one of :data:`DUCKDB_SEPARATORS`).
    """
    import gzip

    scan = _Scan(delim=ord(sep))
    try:
        with gzip.open(p, "rb") if gzipped else open(p, "rb") as f:
            carry = b""
            while True:
                data = f.read(_SCAN_BLOCK)
                block = carry + data
                if not block:
                    break
                a = np.frombuffer(block, dtype=np.uint8)
                end = a.size - 1 if data else a.size  # the last byte waits for the next block (to see what follows)
                if not _scan_block(a, end, scan, n_fields):
                    return False
                carry = block[end:]
                if not data:
                    break
    except Exception:  # noqa: BLE001 - pandas reports an unreadable file
        return False
    return scan.parity == 0 and (scan.length == 0 or scan.fields == n_fields)


def _scan_block(a: npt.NDArray[np.uint8], end: int, scan: _Scan, n_fields: int) -> bool:
    """Check the bytes ``a[:end]`` (``a[end:]``, if any, follows them) and move ``scan`` past them."""
    body = a[:end]
    is_quote = body == _QUOTE
    quotes = np.flatnonzero(is_quote)
    if quotes.size and not _quotes_around_fields(a, quotes, scan):
        return False
    is_comma, is_lf, is_cr = body == scan.delim, body == _LF, body == _CR
    if quotes.size or scan.parity:  # outside a quoted field: an even number of quotes before
        outside = np.bitwise_xor.accumulate(is_quote.view(np.uint8)) == scan.parity  # quotes so far, mod 2
        is_comma &= outside
        is_lf &= outside
        is_cr &= outside
    commas = np.flatnonzero(is_comma)  # the separators outside quotes (a cumulative count would write 4 bytes each)
    lines, returns = np.flatnonzero(is_lf), np.flatnonzero(is_cr)
    if returns.size and (returns[-1] + 1 >= a.size or (a[returns + 1] != _LF).any()):
        return False  # a carriage return not followed by a line feed
    total = commas.size
    if lines.size:
        before = np.searchsorted(commas, lines)  # separators before each line end
        fields = np.diff(before, prepend=0) + 1
        fields[0] += scan.fields - 1
        lengths = np.diff(lines, prepend=-1) - 1
        lengths[0] += scan.length
        ends_cr = a[np.maximum(lines - 1, 0)] == _CR
        if not lines[0]:
            ends_cr[0] = scan.previous == _CR
        blank = lengths - ends_cr == 0
        if (scan.header and blank[0]) or not (blank | (fields == n_fields)).all():
            return False
        scan.fields, scan.length, scan.header = total - int(before[-1]) + 1, end - int(lines[-1]) - 1, False
    else:
        scan.fields, scan.length = scan.fields + total, scan.length + end
    scan.parity = (scan.parity + quotes.size) % 2
    scan.previous = int(a[end - 1]) if end else scan.previous
    return True


def _quotes_around_fields(a: npt.NDArray[np.uint8], quotes: npt.NDArray[np.intp], scan: _Scan) -> bool:
    """Whether each quote at ``quotes`` opens a field (or doubles a quote) or closes one (or is doubled)."""
    # what may stand before an opening quote (it starts a field, or doubles a quote) and after a closing one (it
    # ends a field, or is doubled), besides the start or the end of the file
    beside = np.zeros(256, dtype=bool)
    beside[[scan.delim, _LF, _CR, _QUOTE]] = True
    opening, closing = quotes[scan.parity :: 2], quotes[1 - scan.parity :: 2]  # they alternate
    if opening.size and opening[0] == 0:  # the byte before it is the previous block's (-1: the start of the file)
        if scan.previous >= 0 and not beside[scan.previous]:
            return False
        opening = opening[1:]
    if closing.size and closing[-1] + 1 >= a.size:  # the last byte of the file
        closing = closing[:-1]
    return bool(beside[a[opening - 1]].all() and beside[a[closing + 1]].all())


def as_read_csv(raw: Any, na_values: Sequence[str] = ()) -> pd.Series | None:
    """The values pandas.read_csv gives a column whose fields are ``raw`` (text; masked where empty).

    ``na_values``: the fields read as missing besides pandas' own (:class:`~fairaudit.estimate.CsvFormat`).

    pandas infers a column's type from its set of distinct fields, and
    whether one is missing: its own parser, with read_records' options, on
    those distinct fields alone gives each field the value, and the column
    the dtype, that it has when pandas reads the whole file. Except for an
    integer beyond int64 (pandas then tries uint64 or floats depending on
    which field comes first in the file), and 0.0 with -0.0 (the label is
    the one met first): None then.
    """
    import io

    import pandas as pd

    fields = np.ma.getdata(raw).astype(object)
    fields[np.ma.getmaskarray(raw)] = None
    codes, distinct = pd.factorize(fields)
    if any(len(v) >= 19 and _INTEGER.fullmatch(v) and not -(2**63) <= int(v) < 2**63 for v in distinct):
        return None
    lines = ["key,value", *("0," + _csv_field(v) for v in distinct)]
    if (codes < 0).any():
        lines.append("0,")  # an empty field: missing
    text = io.StringIO("\n".join(lines) + "\n")
    parsed = pd.read_csv(text, low_memory=False, na_values=list(na_values) or None)["value"]
    values = parsed.to_numpy()
    if values.dtype.kind == "f" and len(set(np.signbit(values[values == 0]))) > 1:
        return None
    return parsed.take(np.where(codes < 0, len(distinct), codes)).reset_index(drop=True)


_INTEGER = re.compile(r"\s*[+-]?[0-9]+\s*", re.ASCII)


def _csv_field(text: str) -> str:
    return '"' + text.replace('"', '""') + '"'


def csv_group_by(
    p: Path, keys: list[str], kind: FileKind | None = None, fmt: CsvFormat | None = None
) -> Grouped | None:
    """The distinct combinations of ``keys`` in text file ``p`` as pandas reads them, with their numbers of records.

    ``kind`` gives the separator and compression (default: a plain CSV file),
    ``fmt`` the reading options (a header or ``names``, ``sep``, ``na_values``).
    None where the exact result is left to pandas (the caller reads the whole
    file then, as :func:`fairaudit.estimate.read_records` does), decided
    before DuckDB runs: a compression other than gzip, a separator outside
    :data:`DUCKDB_SEPARATORS`, ``skip_initial_space``, a file DuckDB might
    read differently (:func:`csv_regular`), one column (pandas skips its
    blank lines, DuckDB reads them as missing), an unknown column (pandas
    reports it), and the columns whose values depend on the order of the
    fields (:func:`as_read_csv`); and text DuckDB cannot parse in that
    dialect (its ``InvalidInputException`` or ``ConversionException``, such as
    a byte that is not UTF-8), whose error is then pandas', as
    :func:`fairaudit.estimate.read_records` gives it. When DuckDB fails for
    any other reason (out of memory, input/output, interrupted) nothing else
    reads the file: the error says why (:func:`engine_error`).

    Raises
    ------
    InputError
        DuckDB's failure (:func:`engine_error`), or the file cannot be opened.
    """
    import duckdb
    import pandas as pd

    kind = FileKind("text") if kind is None else kind
    fmt = CsvFormat() if fmt is None else fmt
    sep = fmt.sep or kind.sep
    if not p.is_file() or kind.compression not in (None, "gzip") or sep not in DUCKDB_SEPARATORS:
        return None
    if fmt.skip_initial_space:  # pandas drops spaces after a separator, before a quote too: left to it
        return None
    names = list(fmt.names or ())
    if not names:  # (then the file has a header: CsvFormat checks it)
        try:
            header = pd.read_csv(p, nrows=0, sep=sep, compression="gzip" if kind.compression else None)
        except Exception:  # noqa: BLE001 - read_records reports it
            return None
        names = [str(c) for c in header.columns]
    if len(names) < 2 or not set(keys) <= set(names) or len({c.lower() for c in names}) < len(names):
        return None
    if not csv_regular(p, len(names), kind.compression == "gzip", sep):
        return None
    selected = ", ".join(sql_identifier(c) for c in keys)
    sql = f"SELECT {selected}, count(*) AS {sql_identifier(count_name(names))} FROM {_READ_CSV} GROUP BY ALL"
    con = duckdb_connection()
    try:
        with glob_free([os.path.abspath(p)]) as (plain,):
            parameters = [plain, dict.fromkeys(names, "VARCHAR"), kind.compression or "none", fmt.header, sep]
            result = con.execute(sql, parameters).fetchnumpy()
    except (duckdb.InvalidInputException, duckdb.ConversionException):
        return None  # text DuckDB cannot parse in pandas' dialect (a Latin-1 byte): pandas, the reference, reports it
    except duckdb.Error as exc:  # out of memory, input/output, interrupted: no second reader, DuckDB's reason
        raise engine_error(exc, p) from None
    except OSError as exc:
        raise InputError("DATA", f"cannot be read ({exc.strerror or exc})", str(p)) from None
    finally:
        con.close()
    raw = list(result.values())
    values = [as_read_csv(column, fmt.na_values) for column in raw[:-1]]
    if any(v is None for v in values):
        return None
    frame = pd.DataFrame(dict(zip(keys, values)))
    parameters = [p, dict.fromkeys(names, "VARCHAR"), kind.compression or "none", fmt.header, sep]
    locate = _csv_locate(parameters, dict(zip(keys, raw)), frame)
    return Grouped(np.asarray(raw[-1], dtype=np.int64), frame=frame, locate=locate)


def _csv_locate(parameters: list[Any], raw: dict[str, Any], frame: pd.DataFrame) -> Locate:
    """The :data:`Locate` of a text file read by ``_READ_CSV`` with ``parameters``: its records in order, from 1.

    The grouped rows' fields (``raw``, as DuckDB read them) are looked for in
    the file; each row found is given the value pandas reads (``frame``).
    DuckDB keeps the file's order (``preserve_insertion_order``), so
    ``row_number() OVER ()`` numbers the records as they come, blank lines
    not counted.
    """

    def locate(column: str, mask: npt.NDArray[np.bool_]) -> list[tuple[str, Any]]:
        fields = np.ma.getdata(raw[column]).astype(object)[mask & ~np.ma.getmaskarray(raw[column])]
        read = dict(zip(fields.tolist(), frame[column].to_numpy(dtype=object)[mask & ~np.ma.getmaskarray(raw[column])]))
        name = sql_identifier(column)
        sql = (
            f"SELECT rn, v FROM (SELECT row_number() OVER () AS rn, {name} AS v FROM {_READ_CSV}) "
            f"WHERE list_contains(?, v) ORDER BY rn LIMIT {ROWS_SHOWN}"
        )
        con = duckdb_connection()
        try:
            with glob_free([os.path.abspath(parameters[0])]) as (plain,):
                rows = con.execute(sql, [plain, *parameters[1:], sorted(read)]).fetchall()
        finally:
            con.close()
        return [(str(r), read[v]) for r, v in rows]

    return locate
