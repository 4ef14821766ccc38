"""Reading records as they come: headerless files, separators, missing-value markers, spaces, compression, repeats.

Expected counts come from an independent route: the records are made in Python, written in the format under
test, and counted with ``collections.Counter``; ``count_file`` (and ``fairaudit audit``) must give those counts
from the file. Errors are checked word for word, in Python (parameter names) and in the CLI (flag names, exit 2).
"""

from __future__ import annotations

import bz2
import gzip
import lzma
import zipfile
from collections import Counter
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from _cli import run, run_json
from hypothesis import given, settings
from hypothesis import strategies as st

from fairaudit import InputError, audit, count_file, read_records
from fairaudit.data.csv_format import CsvFormat

# UCI Adult's layout (adult.data): no header, ", " between fields, "?" for a missing value
ADULT = [
    (39, "State-gov", "Male", "<=50K"),
    (50, "Self-emp-not-inc", "Male", "<=50K"),
    (38, "Private", "Male", ">50K"),
    (53, "?", "Female", ">50K"),
    (28, "Private", "Female", "<=50K"),
    (37, "Private", "Female", "<=50K"),
    (49, "Private", "?", "<=50K"),
    (52, "Self-emp-not-inc", "Male", ">50K"),
    (31, "Private", "Female", ">50K"),
]
ADULT_NAMES = ("age", "workclass", "sex", "income")
ADULT_FORMAT = CsvFormat(header=False, names=ADULT_NAMES, na_values=("?",), skip_initial_space=True)
ADULT_FLAGS = ["--no-header", "--names", ",".join(ADULT_NAMES), "--na-values", "?", "--skip-initial-space"]


def adult_text() -> str:
    return "".join(", ".join(map(str, row)) + "\n" for row in ADULT)


def write(path: Path, text: str) -> Path:
    """``text`` to ``path``, compressed as its last suffix says."""
    data = text.encode()
    suffix = path.suffix
    if suffix == ".gz":
        path.write_bytes(gzip.compress(data))
    elif suffix == ".bz2":
        path.write_bytes(bz2.compress(data))
    elif suffix == ".xz":
        path.write_bytes(lzma.compress(data))
    elif suffix == ".zip":
        with zipfile.ZipFile(path, "w") as z:
            z.writestr(path.stem, data)
    else:
        path.write_bytes(data)
    return path


def hand_counts(rows, group: int, outcome: int):
    """n(a, u) by Counter, rows with a "?" in the used columns left out (dropna)."""
    kept = [(r[group], r[outcome]) for r in rows if "?" not in (r[group], r[outcome])]
    groups, outcomes = sorted({a for a, _ in kept}), sorted({u for _, u in kept})
    c = Counter(kept)
    return groups, outcomes, [[[c[(a, u)] for u in outcomes] for a in groups]]


@pytest.mark.parametrize("name", ["adult.data", "adult.data.gz", "adult.csv"])
def test_uci_adult_layout_counts_as_by_hand(tmp_path, name):
    path = write(tmp_path / name, adult_text())
    t = count_file(path, sensitive="sex", outcome="income", dropna=True, csv=ADULT_FORMAT)
    groups, outcomes, counts = hand_counts(ADULT, 2, 3)
    assert (t.groups, t.decisions, t.counts.tolist()) == (tuple(groups), tuple(outcomes), counts)
    assert t.n == 8  # the record with sex "?" dropped, the one with workclass "?" kept (not a used column)


@pytest.mark.parametrize(
    "name, how",
    [
        ("adult.data.bz2", "bzip2, which DuckDB does not read: decompress it first (bunzip2 -k"),
        ("adult.data.xz", "xz, which DuckDB does not read: decompress it first (unxz -k"),
        ("adult.csv.zip", "zip, which DuckDB does not read: decompress it first (unzip"),
    ],
)
def test_compressions_duckdb_does_not_read_are_refused_saying_how_to_decompress(tmp_path, capsys, name, how):
    path = write(tmp_path / name, adult_text())
    message = f"DATA: is compressed with {how} {name}) (got {str(path)!r})"
    with pytest.raises(InputError) as err:
        count_file(path, sensitive="sex", outcome="income", csv=ADULT_FORMAT)
    assert str(err.value) == message
    with pytest.raises(InputError) as err:
        read_records(path, ADULT_FORMAT)
    assert str(err.value) == message
    code, out, err_text = run(capsys, "audit", path, *ADULT_FLAGS, "--sensitive", "sex", "--outcome", "income")
    assert (code, out, err_text) == (2, "", f"fairaudit: error: {message}\n")


def test_uci_adult_layout_audits_in_one_command(tmp_path, capsys):
    path = write(tmp_path / "adult.data", adult_text())
    args = ["audit", path, *ADULT_FLAGS, "--sensitive", "sex", "--outcome", "income", "--positive", ">50K"]
    code, report, err = run_json(capsys, *args, "--dropna")
    assert code == 0, err
    # P(>50K | Female) = 2/4, P(>50K | Male) = 2/4 ... by hand: Female 53, 31 of 28, 37, 53, 31; Male 38, 52 of 4
    assert [(g["label"], g["n"]) for g in report["groups"]] == [("Female", 4), ("Male", 4)]
    assert report["global"]["ratio"] == 1.0
    # without --dropna the "?" of sex is a missing value, named with the flag to add
    code, out, err = run(capsys, *args)
    assert (code, out) == (2, "")
    assert err == "fairaudit: error: column 'sex': has 1 missing values (drop those rows: --dropna)\n"


def test_spaces_are_kept_unless_asked_and_shown_in_quotes(tmp_path, capsys):
    path = write(tmp_path / "adult.data", adult_text())
    spaced = CsvFormat(header=False, names=ADULT_NAMES, na_values=(" ?",))
    t = count_file(path, sensitive="sex", outcome="income", dropna=True, csv=spaced)
    assert t.groups == (" Female", " Male") and t.decisions == (" <=50K", " >50K")
    flags = ["--no-header", "--names", ",".join(ADULT_NAMES), "--na-values", " ?"]
    code, _, err = run(capsys, "audit", path, *flags, "--sensitive", "sex", "--outcome", "income", "--positive", ">50K")
    assert code == 2
    assert err == (
        "fairaudit: error: --positive: is not a value of the outcome column; it has ' <=50K', ' >50K' (got '>50K')\n"
    )
    code, out, err = run(capsys, "audit", path, *flags, "--dropna", "--sensitive", "sex", "--outcome", "income")
    assert code == 2
    assert err == (
        "fairaudit: error: --positive: the outcome 'income' has two values, ' <=50K' and ' >50K': say which "
        "one is positive with --positive (for example ' >50K'), or give a --utility\n"
    )


def test_two_valued_text_outcome_says_which_parameter_to_add():
    df = pd.DataFrame({"sex": ["F", "M", "F", "M"], "income": ["<=50K", ">50K", ">50K", "<=50K"]})
    with pytest.raises(InputError) as err:
        audit(df, sensitive=["sex"], outcome="income")
    assert str(err.value) == (
        "positive: the outcome 'income' has two values, '<=50K' and '>50K': say which one is positive with "
        "`positive` (for example '>50K'), or give a `utility`"
    )
    assert audit(df, sensitive=["sex"], outcome="income", positive=">50K").observed.global_fairness.ratio == 1.0


def test_tsv_is_tab_separated_and_sep_reads_other_separators(tmp_path):
    rows = [("a", 1), ("b", 0), ("a", 0), ("a", 1)]
    tsv = write(tmp_path / "r.tsv", "g\ty\n" + "".join(f"{g}\t{y}\n" for g, y in rows))
    semi = write(tmp_path / "r.txt", "g;y\n" + "".join(f"{g};{y}\n" for g, y in rows))
    for path, fmt in ((tsv, None), (semi, CsvFormat(sep=";"))):
        t = count_file(path, sensitive="g", outcome="y", csv=fmt)
        assert (t.groups, t.decisions, t.counts.tolist()) == (("a", "b"), (0, 1), [[[1, 2], [1, 0]]])


def test_names_replace_a_header(tmp_path):
    path = write(tmp_path / "r.csv", "x,y\na,1\nb,0\n")
    t = count_file(path, sensitive="group", outcome="hired", csv=CsvFormat(names=("group", "hired")))
    assert (t.groups, t.counts.tolist()) == (("a", "b"), [[[0, 1], [1, 0]]])
    path = write(tmp_path / "r.tsv", "G\tY\nx\t1\ny\t0\nx\t0\n")
    for fmt, names in ((None, ("G", "Y")), (CsvFormat(names=("g", "y")), ("g", "y"))):
        t = count_file(path, sensitive=names[0], outcome=names[1], csv=fmt)
        assert (t.groups, t.counts.tolist()) == (("x", "y"), [[[1, 1], [1, 0]]])


def test_headerless_semicolon_file_with_a_missing_marker_and_a_quoted_separator(tmp_path):
    path = write(tmp_path / "r.data", 'p;a;1\np;"b;c";0\nq;a;1\nq;?;1\nq;a;?\n')
    fmt = CsvFormat(header=False, names=("ctx", "g", "y"), sep=";", na_values=("?",))
    t = count_file(path, sensitive="g", outcome="y", context="ctx", dropna=True, csv=fmt)
    assert (t.contexts, t.groups, t.decisions) == (("p", "q"), ("a", "b;c"), (0, 1))
    assert t.counts.tolist() == [[[0, 1], [1, 0]], [[0, 1], [0, 0]]]
    assert t.missing == (("g", 1.0), ("y", 1.0))
    with pytest.raises(InputError) as err:
        count_file(path, sensitive="g", outcome="y", context="ctx", csv=fmt)
    assert str(err.value) == "column 'g': has 1 missing values (drop those rows: `dropna`)"


def test_skip_initial_space_drops_spaces_before_quotes_and_in_the_header(tmp_path):
    path = write(tmp_path / "r.csv", 'g, y\na, "1"\nb,  0\n')
    t = count_file(path, sensitive="g", outcome="y", csv=CsvFormat(skip_initial_space=True))
    assert (t.groups, t.decisions, t.counts.tolist()) == (("a", "b"), (0, 1), [[[0, 1], [1, 0]]])


# ---------------------------------------------------------------- the same column named twice

COMPAS_LIKE = "id,score,race,score\n1,7,a,7\n2,3,b,3\n3,9,a,9\n"


@pytest.mark.parametrize("suffix", [".csv", ".data.gz"])
def test_a_repeated_column_with_the_same_values_is_that_column(tmp_path, suffix):
    path = write(tmp_path / f"r{suffix}", COMPAS_LIKE)
    t = count_file(path, sensitive="race", outcome="score")
    assert (t.groups, t.decisions, t.counts.tolist()) == (("a", "b"), (3, 7, 9), [[[0, 1, 1], [1, 0, 0]]])


def test_a_repeated_column_with_different_values_is_refused(tmp_path, capsys):
    path = write(tmp_path / "r.csv", "id,score,race,score\n1,7,a,7\n2,3,b,4\n")
    with pytest.raises(InputError) as err:
        count_file(path, sensitive="race", outcome="score")
    assert str(err.value) == (
        f"DATA: names column 'score' 2 times, with different values; rename all but one (got {str(path)!r})"
    )
    # a repeated column that is not used does not matter; pandas' renamed copy is not a column
    assert count_file(path, sensitive="race", outcome="id").counts.tolist() == [[[1, 0], [0, 1]]]
    with pytest.raises(InputError, match=r"^outcome: unknown column; the data has: id, score, race \(got 'score.1'\)$"):
        count_file(path, sensitive="race", outcome="score.1")
    code, out, err = run(capsys, "audit", path, "--sensitive", "race", "--outcome", "score", "--utility", "u")
    assert (code, out, err.count("\n")) == (2, "", 1)
    assert "names column 'score' 2 times" in err


# ---------------------------------------------------------------- errors


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"header": False}, "names: name the columns of a file without a header"),
        ({"names": ("a", "a")}, "names: names a column twice (got 'a')"),
        ({"names": ("a", "")}, "names: must be non-empty text (got '')"),
        ({"sep": ";;"}, "sep: must be one character, not a double quote or a line end (got ';;')"),
        ({"sep": '"'}, "sep: must be one character, not a double quote or a line end (got '\"')"),
        ({"na_values": (1,)}, "na_values: must be text (got 1)"),
        ({"header": "no"}, "header: must be true or false (got 'no')"),
    ],
)
def test_bad_formats_name_the_field(kwargs, message):
    with pytest.raises(InputError) as err:
        CsvFormat(**kwargs)
    assert str(err.value) == message


def test_wrong_number_of_names_and_parquet_options_are_refused(tmp_path, capsys):
    path = write(tmp_path / "adult.data", adult_text())
    with pytest.raises(InputError, match=r"^names: gives 3 names for records of 4 fields \(got 'a,b,c'\)$"):
        count_file(path, sensitive="a", outcome="b", csv=CsvFormat(header=False, names=("a", "b", "c")))
    with pytest.raises(InputError, match=r"^names: gives 2 names for records of 3 fields \(got 'g,y'\)$"):
        read_records(write(tmp_path / "r.csv", "a;1;x\nb;0;y\n"), CsvFormat(header=False, names=("g", "y"), sep=";"))
    pq = pytest.importorskip("pyarrow.parquet")
    import pyarrow as pa

    ppath = tmp_path / "r.parquet"
    pq.write_table(pa.table({"g": ["a"], "y": [1]}), ppath)
    with pytest.raises(InputError, match=r"^sep: applies to text files, not Parquet"):
        count_file(ppath, sensitive="g", outcome="y", csv=CsvFormat(sep=";"))
    code, _, err = run(capsys, "audit", ppath, "--sensitive", "g", "--outcome", "y", "--skip-initial-space")
    assert (code, err) == (
        2,
        f"fairaudit: error: --skip-initial-space: applies to text files, not Parquet (got {str(ppath)!r})\n",
    )
    code, _, err = run(capsys, "audit", path, "--no-header", "--sensitive", "g", "--outcome", "y")
    assert (code, err) == (2, "fairaudit: error: --names: name the columns of a file without a header\n")


def test_unknown_file_names_are_refused(tmp_path):
    path = write(tmp_path / "records.json", "{}")
    with pytest.raises(InputError) as err:
        read_records(path)
    assert str(err.value).startswith("DATA: must be a .parquet/.pq file or folder, or text: .csv, .tsv")


# ---------------------------------------------------------------- any format, counted as by hand

FIELD = st.sampled_from(["a", "b", "Male", "x y", "7", "-1", "?"])


@pytest.mark.slow
@settings(deadline=None, max_examples=60)
@given(
    rows=st.lists(st.tuples(FIELD, FIELD, FIELD), min_size=1, max_size=25),
    sep=st.sampled_from([",", ";", "\t", "|"]),
    spaces=st.booleans(),
    header=st.booleans(),
    suffix=st.sampled_from([".csv", ".txt", ".data.gz", ".tsv"]),
)
def test_any_format_counts_as_by_hand(tmp_path_factory, rows, sep, spaces, header, suffix):
    """Records written with a separator, spaces after it or not, a header or not; "?" missing, dropped."""
    folder = tmp_path_factory.mktemp("fmt")
    joiner = sep + (" " if spaces else "")
    text = ("c" + joiner + "g" + joiner + "y\n" if header else "") + "".join(joiner.join(r) + "\n" for r in rows)
    path = write(folder / f"r{suffix}", text)
    fmt = CsvFormat(
        header=header, names=None if header else ("c", "g", "y"), sep=sep, na_values=("?",), skip_initial_space=spaces
    )
    kept = [r for r in rows if "?" not in r]
    if not kept:
        with pytest.raises(InputError):
            count_file(path, sensitive="g", outcome="y", context="c", dropna=True, csv=fmt, mixed_outcome=True)
        return
    # "a" beside "7" in the outcome is counted as it is (mixed_outcome; refused by default: tests/data/test_key_values.py)
    t = count_file(path, sensitive="g", outcome="y", context="c", dropna=True, csv=fmt, mixed_outcome=True)
    # a column of whole numbers is integers, else text (count_file's rule): labels compared as numbers
    c = Counter(kept)
    contexts, groups, outcomes = (sorted({r[i] for r in kept}, key=_as_read) for i in range(3))
    assert [_value(v) for v in t.contexts] == [_value(v) for v in contexts]
    assert [_value(v) for v in t.groups] == [_value(v) for v in groups]
    assert [_value(v) for v in t.decisions] == [_value(v) for v in outcomes]
    want = [[[c[(x, a, u)] for u in outcomes] for a in groups] for x in contexts]
    assert t.counts.tolist() == want
    assert int(np.sum(t.counts)) == len(kept)


def _value(label) -> float | str:
    return float(label) if str(label).lstrip("-").replace(".", "", 1).isdigit() else str(label)


def _as_read(field: str):
    """Sort key of a field as count_file types it: all-integer columns sort as numbers, else as text."""
    return (0, int(field), "") if field.lstrip("-").isdigit() else (1, 0, field)
