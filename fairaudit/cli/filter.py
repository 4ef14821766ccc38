"""``fairaudit filter``: one column of a CSV or Parquet file released through a privacy filter (fairaudit.PrivacyFilter).

The filter is k-ary randomized response on ``--values`` (``--epsilon`` or ``--keep``) or the spec's
``[privacy.sensitive]`` mechanism on its ``[sensitive] values`` (``--spec``): the alphabet never comes from the data,
whose values would leak through it. The file is read by DuckDB (:func:`fairaudit.data.record_files.source`), the
column released (:meth:`~fairaudit.filter.filters.PrivacyFilter.apply`, from a cryptographically secure source) and
the whole file written, by DuckDB, in the format of ``--output``'s name, atomically (into text the other columns as
written, :meth:`~fairaudit.data.record_files.Source.read`'s ``as_written``); ``--parameters`` writes the
filter's JSON (:meth:`~fairaudit.filter.filters.PrivacyFilter.to_dict`).
"""

from __future__ import annotations

import argparse
import json
import sys
from fractions import Fraction
from pathlib import Path
from typing import TYPE_CHECKING, Any

from fairaudit.base.errors import InputError
from fairaudit.base.files import write_atomic

from ._common import COMMANDS, Subparsers, add_text_format, columns, nonneg, text_format, work_done

if TYPE_CHECKING:
    import pandas as pd

    from fairaudit.filter.filters import PrivacyFilter


def add_parser(sub: Subparsers) -> None:
    """Add the ``filter`` subcommand to ``sub``."""
    f = sub.add_parser(
        "filter",
        help=COMMANDS["filter"],
        description="Releases each value of one column through k-ary randomized response (--epsilon or --keep, on "
        "--values) or a spec's [privacy.sensitive] mechanism (--spec), with exact probabilities and a "
        "cryptographically secure source of randomness, and writes the file with that column released.",
    )
    f.add_argument("data", metavar="DATA", help="the records: .csv, .tsv, .txt, .data (gzip or zstd too) or .parquet")
    f.add_argument("--column", required=True, metavar="COL", help="the column to release")
    how = f.add_mutually_exclusive_group(required=True)
    how.add_argument("--epsilon", type=nonneg, metavar="E", help="randomized response at this epsilon (nats)")
    how.add_argument(
        "--keep", metavar="P", help="randomized response keeping each value with P, exact: 0.7 or 7/10 is 7/10"
    )
    how.add_argument(
        "--spec", metavar="SPEC.toml", help="the spec's [privacy.sensitive] mechanism on its [sensitive] values"
    )
    f.add_argument(
        "--values",
        type=columns,
        metavar="V[,V...]",
        help="the column's possible values, all of them (with --epsilon or --keep); never read from the data",
    )
    f.add_argument("--output", required=True, metavar="OUT", help="the file written (.csv, .tsv or .parquet)")
    f.add_argument("--parameters", metavar="FILTER.json", help="write the filter's parameters (its JSON) there")
    f.add_argument("--no-progress", dest="progress", action="store_false", help="no bar while DuckDB reads DATA")
    add_text_format(f)
    f.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run ``fairaudit filter``; returns the exit status."""
    from fairaudit.base.progress import progress_shown
    from fairaudit.data.csv_format import file_kind
    from fairaudit.data.record_files import source

    text_output = file_kind(args.output).kind != "parquet"  # neither Parquet nor text: exit 2 before any work
    records = source(args.data, text_format(args))
    if args.column not in records.names:
        raise InputError("--column", f"is not a column of DATA (its columns: {', '.join(records.names)})", args.column)
    # into text the other columns pass through as written ("NA" stays "NA", "007" stays "007"); into Parquet they
    # are typed as fairaudit reads them, their missing values null
    others = [n for n in records.names if n != args.column] if text_output else []
    with progress_shown(args.progress):  # (DuckDB's progress through the file, after half a second)
        frame = records.read(as_written=others)  # a column the header names twice is refused where its copies differ
    column = frame[args.column]
    missing = column.isna().to_numpy()
    if missing.any():
        row = int(missing.argmax()) + 1
        raise InputError(f"DATA column {args.column!r}", f"has a missing value (data row {row}): nothing to release")
    privacy = _filter(args, column)
    try:
        released = privacy.apply(column.tolist())
    except InputError as exc:
        raise InputError(
            f"DATA column {args.column!r}", "holds a value that is not among the filter's values", exc.value
        ) from None
    frame[args.column] = _as_column(released, column)
    _write_both(args, frame, json.dumps(privacy.to_dict(), indent=2) + "\n")
    eps = "inf" if privacy.epsilon == float("inf") else f"{privacy.epsilon:.6g}"
    twice = [f"{name!r} ({len(copies)} times)" for name, copies in records.columns.items() if len(copies) > 1]
    print(
        f"released column {args.column!r} of {len(frame)} records through {privacy.name} (epsilon = {eps} nats); "
        f"written to {args.output}"
        + (f"; the header names {', '.join(twice)} with the same values: written once" if twice else ""),
        file=sys.stderr,
    )
    return 0


def _filter(args: argparse.Namespace, column: pd.Series) -> PrivacyFilter:
    """The filter of the command line: randomized response on --values, or the spec's on its values."""
    from fairaudit.filter.filters import PrivacyFilter

    if args.spec is None:
        if args.values is None:
            raise InputError("--values", "are needed with --epsilon or --keep: every value the column may hold")
        values = _typed_values(args.values, column)  # (--epsilon or --keep: argparse leaves the other None)
        return PrivacyFilter.randomized_response(values, epsilon=args.epsilon, keep=args.keep)
    if args.values is not None:
        raise InputError("--values", "come from the spec's [sensitive] values with --spec: give one of them")
    from fairaudit.certification.spec import load_spec

    spec = load_spec(args.spec)
    table = spec.model.privacy.sensitive
    if table.mechanism == "product":
        raise InputError(
            "--spec",
            "has a product mechanism, on tuples: filter each attribute's column with its own component",
            args.spec,
        )
    if table.mechanism == "randomized_response" and table.keep is not None:  # the decimal the spec wrote, exactly
        return PrivacyFilter.randomized_response(spec.groups, keep=Fraction(repr(float(table.keep))))
    return PrivacyFilter.from_mechanism(spec.sensitive_mechanism)


def _typed_values(texts: list[str], column: pd.Series) -> list[Any]:
    """The --values as labels of the column's type (integers, floats, booleans or text), as DuckDB read it."""
    kind = column.dtype.kind
    try:
        if kind in "iu":
            return [int(t) for t in texts]
        if kind == "f":
            return [float(t) for t in texts]
    except ValueError:
        what = "integers" if kind in "iu" else "numbers"
        raise InputError("--values", f"must be {what}, as the column's values are", ",".join(texts)) from None
    if kind == "b":
        words = {"true": True, "false": False}
        if any(t.lower() not in words for t in texts):
            raise InputError("--values", "must be true or false, as the column's values are", ",".join(texts))
        return [words[t.lower()] for t in texts]
    return list(texts)


def _as_column(released: list[Any], column: pd.Series) -> Any:
    """The released labels as a column: of the column's own type when they all fit it."""
    import pandas as pd

    out = pd.Series(released, index=column.index, dtype=object)
    try:
        return out.astype(column.dtype)
    except (TypeError, ValueError):
        return out.infer_objects()


def _write_both(args: argparse.Namespace, frame: pd.DataFrame, parameters: str) -> None:
    """``--output`` and ``--parameters`` written together: both or neither.

    Each is written atomically (:func:`~fairaudit.base.files.write_atomic`), the output's write inside the
    parameters' (their temporary file written first, renamed last): a failure or a Ctrl-C while the records are
    written leaves neither file changed, and once they are written Ctrl-C is ignored (:func:`~fairaudit.cli.main`
    restores the handler), so that the two renames are not parted.
    """

    def output(tmp: str) -> None:
        _write(frame, tmp, args.output)
        work_done()

    def both(parameters_tmp: str) -> None:
        Path(parameters_tmp).write_text(parameters, encoding="utf-8")
        write_atomic(args.output, output, field="--output")

    if args.parameters:
        write_atomic(args.parameters, both, field="--parameters")
    else:
        write_atomic(args.output, output, field="--output")


def _write(frame: pd.DataFrame, path: str, output: str) -> None:
    """Write ``frame`` to ``path`` with DuckDB, in the format of the name ``output`` (Parquet, or delimited text)."""
    from fairaudit.data.csv_format import file_kind
    from fairaudit.data.record_files import duckdb_connection, interrupts_raised

    kind = file_kind(output)
    quoted = "'" + path.replace("'", "''") + "'"
    if kind.kind == "parquet":
        options = "FORMAT parquet"
    else:
        delimiter = "'" + kind.sep.replace("'", "''") + "'"
        options = f"FORMAT csv, HEADER true, DELIMITER {delimiter}, COMPRESSION {kind.compression or 'none'}"
    with duckdb_connection() as con, interrupts_raised():  # (the connection closed on the way out)
        con.register("released", frame)
        con.execute(f"COPY released TO {quoted} ({options})")
