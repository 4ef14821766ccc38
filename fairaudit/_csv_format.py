"""How a text file of records is read: its kind and compression from its name, and the reader's options.

Records come as Parquet or as delimited text (CSV, TSV, UCI's ``.data``),
often compressed, sometimes without a header, with ``?`` for a missing
value or a space after each separator. :class:`CsvFormat` says how to read
such a file; pandas' reader (``pandas.read_csv``) does the reading, with
its own options, so nothing here parses text by hand. The names of a file
come from its header, or from ``names`` when it has none; two columns of the
same name are an error (pandas would rename the second ``x.1`` silently).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, fields
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ._errors import InputError, echo

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["CsvFormat", "file_kind"]

PARQUET_SUFFIXES = frozenset({".parquet", ".pq"})
TEXT_SUFFIXES = {".csv": ",", ".txt": ",", ".data": ",", ".tsv": "\t"}  # suffix -> default separator
# compressed text: the compression pandas infers from the last suffix, and whether DuckDB reads it too
COMPRESSION_SUFFIXES = {".gz": "gzip", ".bz2": "bz2", ".xz": "xz", ".zst": "zstd", ".zip": "zip"}
TEXT_KINDS = (
    "a .parquet/.pq file or folder, or text: .csv, .tsv, .txt or .data, optionally .gz, .bz2, .xz, .zst or .zip"
)


@dataclass(frozen=True)
class FileKind:
    """What a file's name says it holds: ``kind`` ``"parquet"`` or ``"text"``; for text its default separator
    and its compression (None, or ``"gzip"``, ``"bz2"``, ``"xz"``, ``"zstd"``, ``"zip"``)."""

    kind: str
    sep: str = ","
    compression: str | None = None


def file_kind(path: str | Path) -> FileKind:
    """The kind of a records file from its name (a folder is a Parquet dataset).

    A lone ``.gz`` (``records.gz``) is comma-separated text, as before.

    Raises
    ------
    InputError
        Field ``DATA``: a name that is neither Parquet nor text.

    Examples
    --------
    >>> file_kind("adult.data.gz"), file_kind("scores.tsv").sep == "\\t", file_kind("r.parquet").kind
    (FileKind(kind='text', sep=',', compression='gzip'), True, 'parquet')
    """
    p = Path(path)
    if p.is_dir() or p.suffix.lower() in PARQUET_SUFFIXES:
        return FileKind("parquet")
    suffixes = [s.lower() for s in p.suffixes]
    compression = COMPRESSION_SUFFIXES.get(suffixes[-1]) if suffixes else None
    inner = suffixes[:-1] if compression else suffixes
    if inner and inner[-1] in TEXT_SUFFIXES:
        return FileKind("text", TEXT_SUFFIXES[inner[-1]], compression)
    if compression == "gzip" and not inner:
        return FileKind("text", ",", compression)
    raise InputError("DATA", f"must be {TEXT_KINDS}", str(path))


@dataclass(frozen=True)
class CsvFormat:
    """How a delimited text file of records is read (``pandas.read_csv`` with these options).

    Parameters
    ----------
    header : bool
        The first line holds the column names (default). False: every line
        is a record, and ``names`` names the columns.
    names : sequence of str, optional
        The column names, one per field, distinct; required without a header.
        With a header they replace its names.
    sep : str, optional
        The separator, one character other than a quote or a line end;
        default from the file's name: a tab for ``.tsv``, else a comma.
    na_values : sequence of str
        Fields read as missing, besides pandas' own (``""``, ``"NA"``,
        ``"nan"``, ...); for example ``("?",)`` for UCI's files. Compared
        with the whole field (after ``skip_initial_space``).
    skip_initial_space : bool
        Drop the spaces that follow a separator (UCI's ``39, Male, ...``).
        Default False: a field keeps its spaces (``" Male"``), and reports
        show such a label in quotes. Trailing spaces are always kept.

    Raises
    ------
    InputError
        Naming the field: ``header`` False without ``names``, names that
        repeat or are empty, a separator that is not one character, or is a
        quote or a line end, a ``na_values`` entry that is not text.

    Examples
    --------
    >>> CsvFormat(header=False, names=("age", "sex"), na_values=("?",), skip_initial_space=True).names
    ('age', 'sex')
    >>> CsvFormat(header=False)
    Traceback (most recent call last):
    ...
    fairaudit._errors.InputError: names: name the columns of a file without a header
    """

    header: bool = True
    names: tuple[str, ...] | None = None
    sep: str | None = None
    na_values: tuple[str, ...] = ()
    skip_initial_space: bool = False

    def __post_init__(self) -> None:
        if not isinstance(self.header, bool):
            raise InputError("header", "must be true or false", self.header)
        if not isinstance(self.skip_initial_space, bool):
            raise InputError("skip_initial_space", "must be true or false", self.skip_initial_space)
        if self.names is not None:
            object.__setattr__(self, "names", distinct_names(self.names, "names"))
        elif not self.header:
            raise InputError("names", "name the columns of a file without a header")
        if self.sep is not None and (not isinstance(self.sep, str) or len(self.sep) != 1 or self.sep in '"\r\n'):
            raise InputError("sep", "must be one character, not a double quote or a line end", self.sep)
        na = tuple(self.na_values) if not isinstance(self.na_values, str) else (self.na_values,)
        for v in na:
            if not isinstance(v, str):
                raise InputError("na_values", "must be text", v)
        object.__setattr__(self, "na_values", na)

    def changed(self) -> list[str]:
        """The options that differ from the defaults (pandas' own reading of a CSV file with a header)."""
        return [f.name for f in fields(self) if getattr(self, f.name) != f.default]

    def read_csv_options(self, kind: FileKind) -> dict[str, Any]:
        """The keyword arguments of ``pandas.read_csv`` for a file of ``kind``."""
        options: dict[str, Any] = {
            "sep": self.sep or kind.sep,
            "compression": kind.compression,
            "low_memory": False,
            "skipinitialspace": self.skip_initial_space,
        }
        if self.na_values:
            options["na_values"] = list(self.na_values)
        options["header"] = 0 if self.header else None  # (0 with names: the header line is replaced, not read)
        if self.names is not None:
            options["names"] = list(self.names)
            options["index_col"] = False  # never take a first column as the index
        return options


def distinct_names(values: Iterable[object], field: str) -> tuple[str, ...]:
    """Column names as a tuple of text, each non-empty and given once (the error names the repeated one)."""
    if isinstance(values, str):
        values = [v.strip() for v in values.split(",")]
    names: list[str] = []
    for name in values:
        if not isinstance(name, str) or not name:
            raise InputError(field, "must be non-empty text", name)
        if name in names:
            raise InputError(field, "names a column twice", name)
        names.append(name)
    return tuple(names)


def check_header(p: Path, kind: FileKind, fmt: CsvFormat) -> dict[str, list[int]]:
    """The names that the header of a text file repeats, with their positions; checks ``fmt.names`` too.

    Reads the first record only (pandas, with the file's options, every field as text).

    Raises
    ------
    InputError
        ``names`` that do not give one name per field of the first record.
    """
    import pandas as pd

    options = {**fmt.read_csv_options(kind), "header": None, "names": None, "index_col": None}
    first = pd.read_csv(p, **options, nrows=1, dtype=str, keep_default_na=False)
    if fmt.names is not None:
        if len(first.columns) != len(fmt.names):
            raise InputError(
                "names", f"gives {len(fmt.names)} names for records of {len(first.columns)} fields", ",".join(fmt.names)
            )
        return {}
    header = [str(v) for v in (first.iloc[0].tolist() if len(first) else [])]
    positions: dict[str, list[int]] = {}
    for j, name in enumerate(header):
        positions.setdefault(name, []).append(j)
    return {name: js for name, js in positions.items() if len(js) > 1}


def read_text(p: Path, kind: FileKind, fmt: CsvFormat) -> pd.DataFrame:
    """Read a text file of records with pandas (``fmt.names`` checked by :func:`check_header` first)."""
    import pandas as pd

    check_header(p, kind, fmt)
    return pd.read_csv(p, **fmt.read_csv_options(kind))


def same_repeats(frame: pd.DataFrame, repeated: dict[str, list[int]], used: Iterable[str], path: object) -> None:
    """Refuse a used column that the file's header names twice or more with different values.

    pandas renames the second ``x`` to ``x.1``; when the columns hold the same
    value in every record (ProPublica's COMPAS file repeats ``decile_score``)
    either is the column, else which one is meant is unknown.

    Raises
    ------
    InputError
        Field ``DATA``, naming the column and how many times it appears.
    """
    for name in dict.fromkeys(used):
        positions = repeated.get(name, [])
        if any(not frame.iloc[:, positions[0]].equals(frame.iloc[:, j]) for j in positions[1:]):
            raise InputError(
                "DATA",
                f"names column {echo(name)} {len(positions)} times, with different values; rename all but one",
                str(path),
            )
