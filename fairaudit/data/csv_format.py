"""How a file of records is read: its kind and compression from its name, and the options of a text file.

Records come as Parquet or as delimited text (CSV, TSV, UCI's ``.data``),
often compressed, sometimes without a header, with ``?`` for a missing
value or a space after each separator. :class:`CsvFormat` says how to read
such a file; DuckDB reads it (:mod:`fairaudit.data.record_files`), so nothing
here parses text. The names of a file come from its header, or from
``names`` when it has none.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, fields
from pathlib import Path

from fairaudit.base.errors import InputError

__all__ = ["CsvFormat", "file_kind"]

PARQUET_SUFFIXES = frozenset({".parquet", ".pq"})
TEXT_SUFFIXES = {".csv": ",", ".txt": ",", ".data": ",", ".tsv": "\t"}  # suffix -> default separator
COMPRESSION_SUFFIXES = {".gz": "gzip", ".zst": "zstd"}  # compressed text, as DuckDB reads it
# compressions DuckDB does not read -> (their name, the command that decompresses a file)
UNREAD_SUFFIXES = {".bz2": ("bzip2", "bunzip2 -k"), ".xz": ("xz", "unxz -k"), ".zip": ("zip", "unzip")}
TEXT_KINDS = "a .parquet/.pq file or folder, or text: .csv, .tsv, .txt or .data, optionally .gz or .zst"


@dataclass(frozen=True)
class FileKind:
    """What a file's name says it holds: ``kind`` ``"parquet"`` or ``"text"``; for text its default separator
    and its compression (None, ``"gzip"`` or ``"zstd"``)."""

    kind: str
    sep: str = ","
    compression: str | None = None


def file_kind(path: str | Path) -> FileKind:
    """The kind of a records file from its name (a folder is a Parquet dataset).

    A lone ``.gz`` (``records.gz``) is comma-separated text, as before.

    Raises
    ------
    InputError
        Field ``DATA``: a name that is neither Parquet nor text, or text
        compressed in a way DuckDB does not read (bzip2, xz, zip), saying how
        to decompress it.

    Examples
    --------
    >>> file_kind("adult.data.gz"), file_kind("scores.tsv").sep == "\\t", file_kind("r.parquet").kind
    (FileKind(kind='text', sep=',', compression='gzip'), True, 'parquet')
    """
    p = Path(path)
    if p.is_dir() or p.suffix.lower() in PARQUET_SUFFIXES:
        return FileKind("parquet")
    suffixes = [s.lower() for s in p.suffixes]
    if suffixes and suffixes[-1] in UNREAD_SUFFIXES:
        name, tool = UNREAD_SUFFIXES[suffixes[-1]]
        raise InputError(
            "DATA",
            f"is compressed with {name}, which DuckDB does not read: decompress it first ({tool} {p.name})",
            str(path),
        )
    compression = COMPRESSION_SUFFIXES.get(suffixes[-1]) if suffixes else None
    inner = suffixes[:-1] if compression else suffixes
    if inner and inner[-1] in TEXT_SUFFIXES:
        return FileKind("text", TEXT_SUFFIXES[inner[-1]], compression)
    if compression == "gzip" and not inner:
        return FileKind("text", ",", compression)
    raise InputError("DATA", f"must be {TEXT_KINDS}", str(path))


@dataclass(frozen=True)
class CsvFormat:
    """How a delimited text file of records is read (DuckDB's ``read_csv`` with these options).

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
        Fields read as missing, besides the usual markers (an empty field,
        ``"NA"``, ``"nan"``, ``"NULL"``, ...: :data:`fairaudit.data.record_files.NA`);
        for example ``("?",)`` for UCI's files. Compared with the whole field
        (after ``skip_initial_space``).
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
    fairaudit.base.errors.InputError: names: name the columns of a file without a header
    """

    header: bool = True
    names: tuple[str, ...] | None = None
    sep: str | None = None
    na_values: tuple[str, ...] = ()
    skip_initial_space: bool = False

    def __post_init__(self) -> None:
        for flag in ("header", "skip_initial_space"):
            if not isinstance(getattr(self, flag), bool):
                raise InputError(flag, "must be true or false", getattr(self, flag))
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
        """The options that differ from the defaults (a CSV file with a header, read as it is)."""
        return [f.name for f in fields(self) if getattr(self, f.name) != f.default]


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
