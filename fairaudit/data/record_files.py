"""DuckDB, the one engine that reads files of records: :func:`fairaudit.data.counts.count_file` and :func:`read_records`.

A file of records, delimited text (``.csv``, ``.tsv``, ``.txt``, ``.data``;
plain, gzip or zstd) or Parquet (a file or a folder of files), is a
:class:`Source`: DuckDB's ``read_csv`` or ``read_parquet`` of it, on a
connection to fairaudit's own in-memory database, and one SQL expression of
each column's values. Counting is one ``GROUP BY`` of the used columns, out of
core, whose small grouped table comes back as numpy arrays
(:meth:`Source.group_by`); reading whole is the same source as a pandas
DataFrame (:meth:`Source.read`). No other reader is tried: what DuckDB cannot
read is refused with one line saying why. Names go into SQL as quoted
identifiers (:func:`sql_identifier`), files and values as parameters, never
as SQL text.

**Labels**, the values of a key column as :func:`fairaudit.data.counts.count_file`
counts them, are the values DuckDB reads, sorted (numbers numerically, text
by code point, tuples of several columns lexicographically):

- Parquet (``.parquet``, ``.pq``, or a folder of Parquet files): the
  file's own types. Integers, floats, booleans and text (:data:`_PLAIN`) are
  labels as they are (a pandas categorical is its values); decimals are
  floats; other types (dates, timestamps, bytes) are labelled by DuckDB's
  text of them (``2020-01-01``). A null or a NaN is a missing value.
- Text (``.csv``, ``.tsv``, ``.txt``, ``.data``; plain, ``.gz`` or
  ``.zst``): every field is text (double quotes around a field holding
  the separator, a quote or a line break). A field that is empty, a
  usual missing-value marker (:data:`NA`: ``NA``, ``nan``, ``NULL``, ``None``,
  ``N/A``, ...) or one of ``csv.na_values`` is missing, after
  ``csv.skip_initial_space`` drops the spaces at its start. Each used
  column is then typed by DuckDB's casts of its distinct values:
  **integers** when every value is an integer as DuckDB writes it
  (``-12``; not ``012``, ``+12`` or ``12.0``), else **floats** when every
  value is such an integer or a float as DuckDB writes it (``2.5``,
  ``1e-05``) and no two are the same number, else **text** (:func:`_typed`). So a label
  prints as its field, or as its number (``2`` beside ``2.5``: ``2.0``),
  and two different fields are never one label: one number or boolean
  written two ways in a column (``01`` and ``1``, ``1`` and ``1.0``,
  ``true`` and ``True``) is refused, naming its rows (as two labels it
  would be two groups, or an outcome ``positive`` misses). A record
  shorter than the first is padded with missing values; a longer one is
  refused, naming its line.

pandas and DuckDB are imported by the functions that use them.
"""

from __future__ import annotations

import json
import os
import re
import tempfile
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np
import numpy.typing as npt

from fairaudit.base.errors import InputError, echo
from fairaudit.base.progress import STEP_DELAY, progress_bar
from fairaudit.data.csv_format import CsvFormat, FileKind, file_kind
from fairaudit.data.key_values import ROWS_SHOWN, Locate

if TYPE_CHECKING:
    import pandas as pd

__all__ = [
    "MEMORY_LIMIT_VARIABLE",
    "NA",
    "Grouped",
    "Source",
    "engine_error",
    "read_records",
    "source",
    "sql_identifier",
]

T = TypeVar("T")

# fmt: off
NA = (
    "", "#N/A", "#N/A N/A", "#NA", "-1.#IND", "-1.#QNAN", "-NaN", "-nan", "1.#IND", "1.#QNAN", "<NA>", "N/A", "NA",
    "NULL", "NaN", "None", "n/a", "nan", "null",
)
# fmt: on
"""The fields of a text file read as missing values (besides a format's ``na_values``): empty, and the markers of
R, pandas and spreadsheets."""

_GLOB = frozenset("*?[]{}")  # characters DuckDB may expand in a file name
_PARAMETER = re.compile(r"\$(\w+)")
# Parquet types whose values are labels as they are; DECIMAL is read as DOUBLE, any other type as its text
_PLAIN = frozenset(
    "TINYINT SMALLINT INTEGER BIGINT UTINYINT USMALLINT UINTEGER UBIGINT FLOAT DOUBLE BOOLEAN VARCHAR".split()
)
# DuckDB's reader of a text file: every field text, in the standard dialect (double quotes, doubled inside a field)
_READ_CSV = (
    "read_csv($files, columns = $columns, header = false, delim = $delim, compression = $compression, "
    "quote = '\"', escape = '\"', comment = '', auto_detect = false, strict_mode = true, null_padding = true, "
    "parallel = $parallel)"
)
# the first record: as many fields as it has, up to the columns given (strict_mode off), an empty field ''
_FIRST_RECORD = _READ_CSV.replace(
    "strict_mode = true, null_padding = true", "strict_mode = false, null_padding = true, nullstr = $unset"
)
_UNSET = "\x00fairaudit: no null string\x00"  # (DuckDB reads some field as null: one no file holds)


def sql_identifier(name: str) -> str:
    """``name`` as a quoted SQL identifier: in double quotes, each double quote in it doubled.

    Examples
    --------
    >>> print(sql_identifier('a"b'), sql_identifier("two words"))
    "a""b" "two words"
    """
    return '"' + name.replace('"', '""') + '"'


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
    try. A text file DuckDB cannot parse: the line and the reason DuckDB gives.
    Anything else: DuckDB's own first line.
    """
    import duckdb

    lines = str(exc).splitlines() or [""]
    if not isinstance(exc, duckdb.OutOfMemoryException):
        at = next((i for i, line in enumerate(lines) if "CSV Error on Line: " in line), None)
        if at is not None:  # DuckDB's reason follows the line's number and text
            reason = next((n for n in lines[at + 1 :] if n.strip() and not n.startswith("Original Line")), "")
            what = f"line {lines[at].rsplit(': ', 1)[1]}: {reason.strip()}"
        else:
            what = f"{type(exc).__name__}: {lines[0]}"
        return InputError("DATA", f"cannot be read by DuckDB ({what})", os.fspath(path))
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
        f"DuckDB ran out of memory counting it (memory_limit {limit}, {source}; {lines[0]}): give it more memory "
        f"({MEMORY_LIMIT_VARIABLE}, e.g. 8GB, on a machine that has it), or count a smaller file or fewer columns",
        os.fspath(path),
    )


@contextmanager
def interrupts_raised() -> Iterator[None]:
    """Within the block, DuckDB's answer to Ctrl-C is a :class:`KeyboardInterrupt`, as everywhere else.

    DuckDB takes the signal during a query, interrupts the query and raises
    ``RuntimeError("Query interrupted")`` in its place (DuckDB 1.x and 2.x);
    a command would end in that traceback with exit status 1, not 130.
    """
    try:
        yield
    except RuntimeError as exc:
        if str(exc) != "Query interrupted":
            raise
        raise KeyboardInterrupt from None


@contextmanager
def query_progress(con: Any, desc: str) -> Iterator[None]:
    """Within the block, DuckDB's progress through its query on ``con`` as a bar on stderr, where bars are shown.

    The bar is asked for with ``enabled=None`` (:func:`fairaudit.base.progress.progress_bar`: shown inside a
    ``progress_shown`` block, as ``fairaudit audit`` and ``filter`` open unless ``--no-progress``), after
    :data:`~fairaudit.base.progress.STEP_DELAY`. DuckDB tracks the progress (``enable_progress_bar``) without
    printing its own bar (``enable_progress_bar_print``, which writes to stdout, where the report goes); a thread
    reads ``query_progress()`` every 0.1 s, and the bar shows the furthest percentage of the block's queries.

    Parameters
    ----------
    con : duckdb.DuckDBPyConnection
        The connection the block's queries run on (its progress setting is turned on where a bar is shown).
    desc : str
        The bar's label (``"reading DATA"``).

    Yields
    ------
    None
        The bar is closed, and its reading thread joined, when the block ends, however it ends (Ctrl-C included).
    """
    import threading

    with progress_bar(100, desc, unit="%", delay=STEP_DELAY, bar_format=_PERCENT_BAR) as bar:
        if bar.disable:
            yield
            return
        con.execute("SET enable_progress_bar = true; SET enable_progress_bar_print = false")
        done = threading.Event()

        def poll() -> None:
            shown = 0
            while not done.wait(0.1):
                now = min(100, int(con.query_progress()))
                if now > shown:
                    bar.update(now - shown)
                    shown = now

        reader = threading.Thread(target=poll, name="fairaudit-duckdb-progress", daemon=True)
        reader.start()
        try:
            yield
        finally:
            done.set()
            reader.join()


_PERCENT_BAR = "{desc}: {percentage:3.0f}% |{bar}| [{elapsed}]"
"""The counting bar's line: DuckDB gives a percentage, not a count of steps, nor a rate worth showing."""


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


def _bind(sql: str, parameters: dict[str, Any]) -> dict[str, Any]:
    """The named parameters ``sql`` uses (DuckDB refuses others)."""
    return {name: parameters[name] for name in dict.fromkeys(_PARAMETER.findall(sql))}


@dataclass(frozen=True)
class Grouped:
    """The distinct combinations of the keys in a file and their numbers of records (``weights``).

    ``values``: each key's values by name, one per combination (integers,
    floats, booleans, or text with None where missing); ``missing``: where each
    key is missing (null, or NaN). ``locate``: where the keys of some of these rows
    are in the file (a second query, run only for an error:
    :data:`fairaudit.data.key_values.Locate`).
    """

    weights: npt.NDArray[np.int64]
    values: dict[str, npt.NDArray[Any]]
    missing: dict[str, npt.NDArray[np.bool_]]
    locate: Locate


@dataclass(frozen=True)
class Source:
    """A file of records as DuckDB reads it.

    ``names``: its columns, each once, in order (a text file's header may
    name one twice: ``columns`` then holds both copies). ``columns``: for each
    name, its copies as (the SQL of DuckDB's column, the SQL of its values with
    ``{}`` for that column).
    ``records``: the SQL of the records (named parameters, ``$files`` among
    them), with, for text, the column ``"row"``: the data row (from 1).
    """

    given: str
    files: tuple[str, ...]
    names: tuple[str, ...]
    columns: dict[str, list[tuple[str, str]]]
    records: str
    parameters: dict[str, Any]
    text: bool

    def _run(self, work: Callable[[Any, dict[str, Any]], T]) -> T:
        """``work(connection, parameters)`` on a new connection; DuckDB's failure as one line (:func:`engine_error`).

        A text file with a quoted line break is read again by DuckDB's serial reader (its parallel reader does
        not pad short records there).
        """
        import duckdb

        con = duckdb_connection()
        try:
            with glob_free(self.files) as files, interrupts_raised(), query_progress(con, "reading DATA"):
                parameters = {**self.parameters, "files": files}
                try:
                    return work(con, parameters)
                except duckdb.Error as exc:
                    if not (self.text and "parallel=false" in str(exc)):
                        raise
                    return work(con, {**parameters, "parallel": False})
        except duckdb.Error as exc:
            raise engine_error(exc, self.given) from None
        except OSError as exc:
            raise InputError("DATA", f"cannot be read ({exc.strerror or exc})", self.given) from None
        finally:
            con.close()

    def _check_copies(self, con: Any, parameters: dict[str, Any], names: Sequence[str]) -> None:
        """Refuse a column of ``names`` that the header names twice or more with different values."""
        for name in dict.fromkeys(names):
            copies = self.columns.get(name, [])
            if len(copies) < 2:
                continue
            first = copies[0][0]
            differ = " OR ".join(f"{first} IS DISTINCT FROM {raw}" for raw, _ in copies[1:])
            sql = f"SELECT count(*) FROM {self.records} WHERE {differ}"
            if con.execute(sql, _bind(sql, parameters)).fetchone()[0]:
                raise InputError(
                    "DATA",
                    f"names column {echo(name)} {len(copies)} times, with different values; rename all but one",
                    self.given,
                )

    def _table(
        self, con: Any, parameters: dict[str, Any], names: Sequence[str], grouped: bool, as_written: Sequence[str] = ()
    ) -> list[str]:
        """Make the temporary table ``records`` of the values of ``names`` (``k0``, ``k1``, ...), grouped (with ``n``,
        the records of each combination) or not; return the SQL of each column's labels (:func:`_typed`). The columns
        ``as_written`` of a text file are their fields' text, untyped and without missing values (an empty field is
        DuckDB's null)."""
        written = [c in as_written and self.text for c in names]
        copies = [(r, "{0}" if keep else v) for (r, v), keep in zip((self.columns[c][0] for c in names), written)]
        if grouped:  # the raw fields grouped first, then their values (few): one pass over the file
            raw = ", ".join(f"{r} AS r{j}" for j, (r, _) in enumerate(copies))
            keys = ", ".join(f"{v.format(f'r{j}')} AS k{j}" for j, (_, v) in enumerate(copies))
            inner = f"SELECT {raw}, count(*) AS n FROM {self.records} GROUP BY ALL"
            sql = f"SELECT {keys}, CAST(sum(n) AS BIGINT) AS n FROM ({inner}) GROUP BY ALL"
        else:
            sql = f"SELECT {', '.join(f'{v.format(r)} AS k{j}' for j, (r, v) in enumerate(copies))} FROM {self.records}"
        sql = f"CREATE OR REPLACE TEMP TABLE records AS {sql}"
        con.execute(sql, _bind(sql, parameters))
        keys_sql = [f"k{j}" for j in range(len(names))]
        if not self.text:
            return keys_sql
        typed = iter(_typed(con, [k for k, keep in zip(keys_sql, written) if not keep]))
        return [k if keep else next(typed) for k, keep in zip(keys_sql, written)]

    def group_by(self, keys: Sequence[str]) -> Grouped:
        """The distinct combinations of the columns ``keys`` and their numbers of records (null keys included)."""

        def work(con: Any, parameters: dict[str, Any]) -> dict[str, Any]:
            self._check_copies(con, parameters, keys)
            typed = self._table(con, parameters, keys, grouped=True)
            return con.execute(f"SELECT {', '.join(typed)}, n FROM records").fetchnumpy()

        *columns, weights = self._run(work).values()
        values, missing = {}, {}
        for key, column in zip(keys, columns):
            data, mask = np.ma.getdata(column), np.ma.getmaskarray(column).copy()
            if data.dtype.kind == "f":
                mask |= np.isnan(data)
            elif data.dtype.kind == "O":
                data = data.copy()
                data[mask] = None
            values[key], missing[key] = data, mask
        return Grouped(np.asarray(weights, dtype=np.int64), values, missing, self._locate(values))

    def read(
        self,
        columns: Sequence[str] | None = None,
        check: Sequence[str] | None = None,
        as_written: Sequence[str] = (),
    ) -> pd.DataFrame:
        """The records as a pandas DataFrame of the columns ``columns`` (default all), labelled as counted.

        Integers and booleans with a missing value are pandas' nullable ``Int64`` and ``boolean``. A column the
        header names twice is its first copy, refused when a copy differs (for the columns ``check``, default
        those read). The columns ``as_written`` of a text file are their fields' text as written (``NA`` is the
        text "NA", ``007`` is "007"; an empty field is None): what a command that rewrites the file passes through.
        """
        names = list(self.names if columns is None else columns)

        def work(con: Any, parameters: dict[str, Any]) -> pd.DataFrame:
            self._check_copies(con, parameters, names if check is None else check)
            typed = self._table(con, parameters, names, grouped=False, as_written=as_written)
            return con.execute(f"SELECT {', '.join(typed)} FROM records").df()

        frame = self._run(work)
        frame.columns = names
        return frame

    def _locate(self, values: dict[str, npt.NDArray[Any]]) -> Locate:
        """The :data:`Locate` of the grouped ``values`` of the keys: the data rows whose value, as text, is refused.

        Text: data row N is the N-th record after the header (``"row"``). Parquet: the row of the file (of a
        folder's file, named), from DuckDB's ``file_row_number`` and ``filename``.
        """

        def locate(column: str, mask: npt.NDArray[np.bool_]) -> list[tuple[str, Any]]:
            wanted = sorted({str(v) for v in np.asarray(values[column], dtype=object)[mask]})
            raw, template = self.columns[column][0]
            value = f"CAST({template.format(raw)} AS VARCHAR) AS v"
            if self.text:
                sql = f'SELECT 1 AS f, "row" AS r, {value} FROM {self.records}'
            else:
                reader = "read_parquet($files, hive_partitioning = false, file_row_number = true, filename = true)"
                sql = f"SELECT list_position($files, filename) AS f, file_row_number + 1 AS r, {value} FROM {reader}"
            sql = f"SELECT f, r, v FROM ({sql}) WHERE list_contains($wanted, v) ORDER BY f, r LIMIT {ROWS_SHOWN}"
            rows = self._run(
                lambda con, parameters: con.execute(sql, _bind(sql, {**parameters, "wanted": wanted})).fetchall()
            )
            several = len(self.files) > 1
            return [(f"{r} of {Path(self.files[f - 1]).name}" if several else str(r), v) for f, r, v in rows]

        return locate


def _typed(con: Any, keys: list[str]) -> list[str]:
    """The SQL of the labels of the text columns ``keys`` of the table ``records``: BIGINT, DOUBLE or VARCHAR.

    Integers when DuckDB writes every value back as it is as a BIGINT; floats when it writes each back as it is
    as a BIGINT or a DOUBLE and no two values are the same DOUBLE; else text (the module's docstring). Missing
    values do not count: a column with none but missing values is an integer column. One aggregate over the
    columns' values side by side (``UNPIVOT``, which leaves the missing values out), grouped by column.
    """
    if not keys:
        return []
    integer = "coalesce(CAST(TRY_CAST(v AS BIGINT) AS VARCHAR) = v, false)"
    real = "coalesce(CAST(TRY_CAST(v AS DOUBLE) AS VARCHAR) = v, false)"
    columns = ", ".join(keys)
    sql = (
        f"SELECT k, bool_and({integer}), bool_and({integer} OR {real}) "
        "AND count(DISTINCT v) = count(DISTINCT TRY_CAST(v AS DOUBLE)) "
        f"FROM (UNPIVOT (SELECT {columns} FROM records) ON {columns} INTO NAME k VALUE v) GROUP BY k"
    )
    flags = {k: (whole, floating) for k, whole, floating in con.execute(sql).fetchall()}
    kinds = ["BIGINT" if flags.get(k, (True,))[0] else "DOUBLE" if flags[k][1] else "VARCHAR" for k in keys]
    return [f"CAST({k} AS {kind}) AS {k}" for k, kind in zip(keys, kinds)]


def source(path: str | os.PathLike[str], fmt: CsvFormat | None = None) -> Source:
    """The file of records ``path`` as DuckDB reads it, with the text options ``fmt``.

    Raises
    ------
    InputError
        A missing file, a named pipe, device or socket (DuckDB opens a file
        more than once: a stream would be read in part, or block), a name
        neither Parquet nor text, a compression DuckDB
        does not read (:func:`~fairaudit.data.csv_format.file_kind`), ``fmt``
        options for Parquet, an empty text file, ``fmt.names`` not one per
        field of the first record, a folder without Parquet files, or DuckDB's
        failure to read the file's first record or schema.
    """
    p, given = Path(path), os.fspath(path)
    fmt = CsvFormat() if fmt is None else fmt
    if not p.exists():
        raise InputError("DATA", "no such file", given)
    if not (p.is_file() or p.is_dir()):
        what = "a named pipe" if p.is_fifo() else "a socket" if p.is_socket() else "a device or special file"
        instead = "DuckDB reads a file more than once; save the stream to a regular file first"
        raise InputError("DATA", f"is {what}, not a regular file: {instead}", given)
    kind = file_kind(p)
    if kind.kind == "parquet":
        if fmt.changed():
            raise InputError(fmt.changed()[0], "applies to text files, not Parquet", given)
        return _parquet_source(p, given)
    return _text_source(p, given, kind, fmt)


def read_records(path: str | Path, csv: CsvFormat | None = None) -> pd.DataFrame:
    """Read decision records from a Parquet or delimited text file (by its name), with DuckDB.

    The values are the labels :func:`~fairaudit.data.counts.count_file` counts (integers and
    booleans with a missing value as pandas' ``Int64`` and ``boolean``); the
    file, ``csv`` and the errors are as in :func:`~fairaudit.data.counts.count_file`.

    Examples
    --------
    >>> import os, tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "adult.data")
    >>> _ = open(path, "w").write("39, Male, <=50K\\n50, ?, >50K\\n")
    >>> fmt = CsvFormat(header=False, names=("age", "sex", "income"), na_values=("?",), skip_initial_space=True)
    >>> read_records(path, fmt).astype(object).values.tolist()
    [[39, 'Male', '<=50K'], [50, nan, '>50K']]
    """
    return source(path, csv).read()


def _text_source(p: Path, given: str, kind: FileKind, fmt: CsvFormat) -> Source:
    """A text file: its first record read once (its fields, or, with a header, its names), then every record."""
    parameters: dict[str, Any] = {
        "delim": fmt.sep or kind.sep,
        "compression": kind.compression or "none",
        "parallel": True,
        "na": [*NA, *fmt.na_values],
        "skip": int(fmt.header),
    }
    first = Source(given, (str(p.absolute()),), (), {}, "", parameters, True)._run(_first_record)
    if not first:
        raise InputError("DATA", "is empty", given)
    if fmt.names is not None and len(fmt.names) != len(first):
        raise InputError(
            "names", f"gives {len(fmt.names)} names for records of {len(first)} fields", ",".join(fmt.names)
        )
    names = (
        list(fmt.names) if fmt.names is not None else [f.lstrip(" ") if fmt.skip_initial_space else f for f in first]
    )
    columns: dict[str, list[tuple[str, str]]] = {}
    for j, name in enumerate(names):
        text = "ltrim({0})" if fmt.skip_initial_space else "{0}"
        value = f"CASE WHEN list_contains($na, {text}) THEN NULL ELSE {text} END"
        columns.setdefault(name, []).append((f'"c{j}"', value))
    parameters["columns"] = {f"c{j}": "VARCHAR" for j in range(len(names))}
    records = f'(SELECT * FROM (SELECT *, row_number() OVER () - $skip AS "row" FROM {_READ_CSV}) WHERE "row" > 0)'
    return Source(given, (str(p.absolute()),), tuple(columns), columns, records, parameters, True)


def _first_record(con: Any, parameters: dict[str, Any]) -> list[str]:
    """The fields of a text file's first record (blank lines skipped), each as text; [] for an empty file.

    DuckDB reads a given number of fields: up to 64, then 4 times as many while the last one read is filled.
    """
    sql = f"SELECT * FROM {_FIRST_RECORD} LIMIT 1"
    width = 64
    while True:
        columns = {f"c{j}": "VARCHAR" for j in range(width)}
        row = con.execute(sql, _bind(sql, {**parameters, "columns": columns, "unset": _UNSET})).fetchone()
        if row is None:
            return []
        if row[-1] is None:
            return [v for v in row if v is not None]
        width *= 4


def _parquet_source(p: Path, given: str) -> Source:
    """A Parquet file, or the Parquet files of a folder (its files not hidden nor named ``_...``, in name order)."""
    if p.is_dir():
        files = [str(f.absolute()) for f in sorted(p.rglob("*")) if f.is_file() and _visible(f.relative_to(p))]
        if not files:
            raise InputError("DATA", "is a folder without Parquet files", given)
    else:
        files = [str(p.absolute())]

    def schema(con: Any, parameters: dict[str, Any]) -> tuple[list[str], list[tuple[str, str]], list[str]]:
        first = {"file": parameters["files"][0]}
        elements = con.execute("SELECT name, num_children FROM parquet_schema($file)", first).fetchall()
        meta = con.execute(
            "SELECT decode(value) FROM parquet_kv_metadata($file) WHERE decode(key) = 'pandas'", first
        ).fetchall()
        sql = "DESCRIBE SELECT * FROM read_parquet($files, hive_partitioning = false)"
        described = con.execute(sql, {"files": parameters["files"]}).fetchall()
        index = json.loads(meta[0][0]).get("index_columns", []) if meta else []
        return _top_level(elements), [(str(r[0]), str(r[1])) for r in described], index

    probe = Source(given, tuple(files), (), {}, "", {}, False)
    names, described, index = probe._run(schema)
    columns: dict[str, list[tuple[str, str]]] = {}
    for name, (column, kind) in zip(names, described):
        if name in index:  # pandas' index, stored as a column: not a column of the records
            continue
        value = "{}" if kind in _PLAIN else f"CAST({{}} AS {'DOUBLE' if kind.startswith('DECIMAL') else 'VARCHAR'})"
        columns.setdefault(name, []).append((sql_identifier(column), value))
    records = "read_parquet($files, hive_partitioning = false)"
    return Source(given, tuple(files), tuple(columns), columns, records, {}, False)


def _visible(relative: Path) -> bool:
    return not any(part.startswith((".", "_")) for part in relative.parts)


def _top_level(elements: list[tuple[str, int | None]]) -> list[str]:
    """The names of a Parquet schema's top-level columns, from its elements (depth first, the root first)."""
    names, i = [], 1

    def past(i: int) -> int:  # the element after the subtree at i
        children = elements[i][1] or 0
        i += 1
        for _ in range(children):
            i = past(i)
        return i

    for _ in range(elements[0][1] or 0):
        names.append(str(elements[i][0]))
        i = past(i)
    return names
