"""Issue 39, outputs: what ``--output``, ``--plot`` and ``--plot-data`` do to what is already at their path.

A device or a named pipe is written through (never replaced by a regular file), a symbolic link is followed
(its target replaced, the link kept), an existing file keeps its permission bits, and a failed write names the
flag, the path and the system's reason.
"""

from __future__ import annotations

import errno
import os
import stat
import subprocess
import sys
import textwrap
import threading

import pytest

import fairaudit
from fairaudit.base.errors import InputError
from fairaudit.base.files import write_atomic
from tests._cli import OFFICE_SPEC, run

pytestmark = pytest.mark.skipif(os.name != "posix", reason="named pipes, symbolic links and modes are POSIX")


@pytest.fixture
def spec(tmp_path):
    path = tmp_path / "spec.toml"
    path.write_text(OFFICE_SPEC)
    return path


def _report(capsys, spec):
    """The JSON report that ``certify`` prints on stdout (the bytes every output below must hold)."""
    code, out, _ = run(capsys, "certify", spec, "--format", "json")
    assert code == 0
    return out


def _read_fifo(path, into):
    with open(path, "rb") as f:  # blocks until the writer opens the pipe
        into.append(f.read())


def test_a_named_pipe_is_written_through_not_replaced(tmp_path, spec, capsys):
    expected = _report(capsys, spec)
    fifo = tmp_path / "report.fifo"
    os.mkfifo(fifo)
    got: list[bytes] = []
    reader = threading.Thread(target=_read_fifo, args=(fifo, got), daemon=True)
    reader.start()
    code, out, err = run(capsys, "certify", spec, "--format", "json", "--output", fifo)
    reader.join(timeout=30)
    assert (code, out) == (0, "")
    assert got == [expected.encode("utf-8")]
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)  # still the pipe, not a regular file
    assert err.endswith(f"report written to {fifo}\n")
    assert sorted(os.listdir(tmp_path)) == ["report.fifo", "spec.toml"]  # no temporary file left beside it


def test_a_figure_goes_through_a_named_pipe_too(tmp_path, spec, capsys):
    pytest.importorskip("matplotlib")
    fifo = tmp_path / "curve.svg"
    os.mkfifo(fifo)
    got: list[bytes] = []
    reader = threading.Thread(target=_read_fifo, args=(fifo, got), daemon=True)
    reader.start()
    code, _, _ = run(capsys, "certify", spec, "--plot", fifo, "--epsilons", "0:2:5")
    reader.join(timeout=60)
    assert code == 0
    assert got and got[0].startswith(b"<?xml") and b"</svg>" in got[0]
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)


@pytest.fixture
def null_device(tmp_path):
    """A null character device: as root, a fresh one in ``tmp_path`` (``mknod``), so that a writer that replaces
    devices breaks only its own copy, never the machine's /dev/null; otherwise /dev/null (which a user cannot
    replace)."""
    if os.geteuid() != 0:
        if not os.access(os.devnull, os.W_OK):
            pytest.skip("/dev/null is not writable here")
        return os.devnull
    path = tmp_path / "null"
    try:
        os.mknod(path, 0o666 | stat.S_IFCHR, os.stat(os.devnull).st_rdev)
    except OSError as exc:
        pytest.skip(f"cannot make a device here ({exc.strerror})")
    return str(path)


def test_a_null_device_stays_a_device(spec, capsys, null_device):
    before = os.stat(null_device)
    assert stat.S_ISCHR(before.st_mode)
    code, out, err = run(capsys, "certify", spec, "--output", null_device)
    after = os.stat(null_device)
    assert (code, out) == (0, "")
    assert err.endswith(f"report written to {null_device}\n")
    assert stat.S_ISCHR(after.st_mode) and (after.st_ino, after.st_rdev) == (before.st_ino, before.st_rdev)


def test_a_symbolic_link_is_followed_and_stays_a_link(tmp_path, spec, capsys):
    expected = _report(capsys, spec)
    (tmp_path / "reports").mkdir()
    target = tmp_path / "reports" / "2024.json"
    target.write_text("old\n")
    link = tmp_path / "latest.json"
    link.symlink_to(os.path.join("reports", "2024.json"))  # relative, as `ln -s` makes them
    code, _, _ = run(capsys, "certify", spec, "--format", "json", "--output", link)
    assert code == 0
    assert link.is_symlink() and os.readlink(link) == os.path.join("reports", "2024.json")
    assert target.read_text() == expected
    assert sorted(os.listdir(tmp_path / "reports")) == ["2024.json"]


def test_a_dangling_link_creates_its_target(tmp_path, spec, capsys):
    expected = _report(capsys, spec)
    link = tmp_path / "latest.json"
    link.symlink_to(tmp_path / "new.json")
    code, _, _ = run(capsys, "certify", spec, "--format", "json", "--output", link)
    assert code == 0 and link.is_symlink() and (tmp_path / "new.json").read_text() == expected


@pytest.mark.parametrize("mode", [0o600, 0o640, 0o444])
def test_an_existing_report_keeps_its_permissions(tmp_path, spec, capsys, mode):
    expected = _report(capsys, spec)
    out = tmp_path / "report.json"
    out.write_text("old\n")
    os.chmod(out, mode)
    code, _, _ = run(capsys, "certify", spec, "--format", "json", "--output", out)
    assert code == 0 and out.read_text() == expected
    assert stat.S_IMODE(os.stat(out).st_mode) == mode


def test_an_existing_figure_and_curve_data_keep_their_permissions(tmp_path, spec, capsys):
    pytest.importorskip("matplotlib")
    plot, data = tmp_path / "curve.png", tmp_path / "curve.csv"
    for p in (plot, data):
        p.write_text("old\n")
        os.chmod(p, 0o600)
    code, _, _ = run(capsys, "certify", spec, "--plot", plot, "--plot-data", data, "--epsilons", "0:2:5")
    assert code == 0
    assert plot.read_bytes().startswith(b"\x89PNG") and data.read_text().startswith("epsilon_nats,")
    assert [stat.S_IMODE(os.stat(p).st_mode) for p in (plot, data)] == [0o600, 0o600]


def test_a_new_report_gets_the_umask_mode(tmp_path, spec, capsys):
    old = os.umask(0o027)
    try:
        code, _, _ = run(capsys, "certify", spec, "--output", tmp_path / "new.txt")
    finally:
        os.umask(old)
    assert code == 0 and stat.S_IMODE(os.stat(tmp_path / "new.txt").st_mode) == 0o640


def test_write_atomic_follows_links_keeps_modes_and_writes_through(tmp_path):
    target = tmp_path / "t.txt"
    target.write_text("a")
    os.chmod(target, 0o604)
    link = tmp_path / "l.txt"
    link.symlink_to(target)
    write_atomic(link, b"bytes")
    write_atomic(link, lambda tmp: open(tmp, "w").write("from a callable"))
    assert target.read_text() == "from a callable" and link.is_symlink()
    assert stat.S_IMODE(os.stat(target).st_mode) == 0o604
    with pytest.raises(InputError, match=r"^--output: is a directory"):
        write_atomic(tmp_path, "x")


def test_a_failed_write_names_the_flag_the_path_and_the_reason(tmp_path, spec, capsys, monkeypatch):
    out = tmp_path / "report.json"
    out.write_text("kept\n")

    def too_large(*args, **kwargs):
        raise OSError(errno.EFBIG, os.strerror(errno.EFBIG))  # what write(2) raises: no file name

    monkeypatch.setattr(os, "fsync", too_large)
    code, stdout, err = run(capsys, "certify", spec, "--output", out)
    assert (code, stdout) == (2, "")
    assert err == f"fairaudit: error: --output: cannot be written (File too large) (got {str(out)!r})\n"
    assert out.read_text() == "kept\n" and sorted(os.listdir(tmp_path)) == ["report.json", "spec.toml"]


def test_a_failed_figure_write_names_plot(tmp_path, spec, capsys, monkeypatch):
    pytest.importorskip("matplotlib")
    from matplotlib.figure import Figure

    def no_space(self, *args, **kwargs):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(Figure, "savefig", no_space)
    code, _, err = run(capsys, "certify", spec, "--plot", tmp_path / "c.png", "--epsilons", "0:2:5")
    path = str(tmp_path / "c.png")
    assert (code, err) == (2, f"fairaudit: error: --plot: cannot be written (No space left on device) (got {path!r})\n")


def test_file_size_limit_exits_2_with_the_flag_and_path(tmp_path, spec):
    """A real RLIMIT_FSIZE: write(2) fails with EFBIG (Python ignores SIGXFSZ); the line was ``: File too large``."""
    script = textwrap.dedent(
        f"""
        import resource, sys
        from fairaudit.cli import main
        resource.setrlimit(resource.RLIMIT_FSIZE, (200, 200))
        sys.exit(main(["certify", {str(spec)!r}, "--format", "json", "--output", "out.json"]))
        """
    )
    root = os.path.dirname(os.path.dirname(os.path.abspath(fairaudit.__file__)))
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([root, os.environ.get("PYTHONPATH", "")])}
    done = subprocess.run(
        [sys.executable, "-c", script], cwd=tmp_path, capture_output=True, text=True, env=env, timeout=120
    )
    assert done.returncode == 2, done.stderr
    assert done.stderr == "fairaudit: error: --output: cannot be written (File too large) (got 'out.json')\n"
    assert sorted(os.listdir(tmp_path)) == ["spec.toml"]  # neither the report nor a temporary file


def test_a_system_error_without_a_file_name_has_no_empty_field(capsys, monkeypatch):
    import fairaudit.cli.calibrate as calibrate

    def fails(args):
        raise OSError(errno.EFBIG, os.strerror(errno.EFBIG))

    monkeypatch.setattr(calibrate, "run", fails)
    code, _, err = run(capsys, "calibrate", "--target", "1")
    assert (code, err) == (2, "fairaudit: error: File too large\n")


# --- the counting engine's errors: no second reader, and what an out-of-memory error is ---


def _records_file(tmp_path, kind):
    import pandas as pd

    frame = pd.DataFrame({"g": [f"g{i}" for i in range(20_000)], "y": [i % 2 for i in range(20_000)]})
    path = tmp_path / f"r.{kind}"
    if kind == "csv":
        frame.to_csv(path, index=False)
    else:
        pytest.importorskip("pyarrow")
        frame.to_parquet(path)
    return path


@pytest.mark.parametrize("kind", ["csv", "parquet"])
def test_duckdb_out_of_memory_says_so_with_its_limit_and_reads_nothing_else(tmp_path, capsys, monkeypatch, kind):
    """A real out-of-memory error (memory_limit 1MB); pandas must not read the file behind it."""
    pytest.importorskip("duckdb")
    import pandas as pd

    path = _records_file(tmp_path, kind)
    monkeypatch.setenv("FAIRAUDIT_DUCKDB_MEMORY_LIMIT", "1MB")

    name = "read_csv" if kind == "csv" else "read_parquet"
    real_reader = getattr(pd, name)

    def no_second_reader(*args, **kwargs):
        if kwargs.get("nrows") in (0, 1):  # the header, read before DuckDB runs (a first step, not a fallback)
            return real_reader(*args, **kwargs)
        raise AssertionError("pandas read the whole file after DuckDB failed")

    monkeypatch.setattr(pd, name, no_second_reader)
    code, out, err = run(capsys, "audit", path, "--sensitive", "g", "--outcome", "y")
    assert (code, out) == (2, "")
    assert err.startswith(
        "fairaudit: error: DATA: DuckDB ran out of memory counting it (memory_limit 976.5 KiB, "
        "set by FAIRAUDIT_DUCKDB_MEMORY_LIMIT=1MB; Out of Memory Error: "
    )
    assert err.endswith(
        "give it more memory (FAIRAUDIT_DUCKDB_MEMORY_LIMIT, e.g. 8GB, on a machine that has it), "
        f"or count a smaller file or fewer columns (got {str(path)!r})\n"
    )
    assert "cannot be read" not in err and err.count("\n") == 1


def test_duckdb_out_of_memory_at_the_default_limit_names_it(tmp_path, capsys, monkeypatch):
    duckdb = pytest.importorskip("duckdb")
    import fairaudit.data.record_files as engine

    path = _records_file(tmp_path, "csv")
    monkeypatch.delenv("FAIRAUDIT_DUCKDB_MEMORY_LIMIT", raising=False)
    real_connection = engine.duckdb_connection
    limit = real_connection().execute("SELECT current_setting('memory_limit')").fetchone()[0]

    class Failing:
        def __init__(self):
            self.con = real_connection()

        def execute(self, sql, *args):
            if "GROUP BY" in sql:
                raise duckdb.OutOfMemoryException("Out of Memory Error: could not allocate block of size 256.0 KiB")
            return self.con.execute(sql, *args)

        def close(self):
            self.con.close()

    monkeypatch.setattr(engine, "duckdb_connection", Failing)
    code, _, err = run(capsys, "audit", path, "--sensitive", "g", "--outcome", "y")
    assert code == 2
    assert err.startswith(
        f"fairaudit: error: DATA: DuckDB ran out of memory counting it (memory_limit {limit}, DuckDB's default, "
        "80% of the memory; Out of Memory Error: could not allocate block of size 256.0 KiB): give it more memory"
    )


def test_other_duckdb_failures_are_duckdbs_own_line(tmp_path, capsys, monkeypatch):
    duckdb = pytest.importorskip("duckdb")
    import fairaudit.data.record_files as engine

    path = _records_file(tmp_path, "csv")

    class Failing:
        def execute(self, sql, *args):
            raise duckdb.IOException("IO Error: Could not read from file: Input/output error")

        def close(self):
            pass

    monkeypatch.setattr(engine, "duckdb_connection", Failing)
    code, _, err = run(capsys, "audit", path, "--sensitive", "g", "--outcome", "y")
    assert (code, err) == (
        2,
        "fairaudit: error: DATA: cannot be read by DuckDB (IOException: IO Error: Could not read from file: "
        f"Input/output error) (got {str(path)!r})\n",
    )


def test_a_memory_limit_duckdb_cannot_read_is_refused(tmp_path, capsys, monkeypatch):
    pytest.importorskip("duckdb")
    path = _records_file(tmp_path, "csv")
    monkeypatch.setenv("FAIRAUDIT_DUCKDB_MEMORY_LIMIT", "lots")
    code, _, err = run(capsys, "audit", path, "--sensitive", "g", "--outcome", "y")
    assert (code, err) == (
        2,
        "fairaudit: error: FAIRAUDIT_DUCKDB_MEMORY_LIMIT: is not a memory size DuckDB reads, such as 4GB or "
        "500MB (Parser Error: Memory must have a number (e.g. 1GB)) (got 'lots')\n",
    )


def test_a_memory_limit_that_suffices_counts_as_before(tmp_path, monkeypatch):
    pytest.importorskip("duckdb")
    from fairaudit import count_file

    path = _records_file(tmp_path, "csv")
    monkeypatch.setenv("FAIRAUDIT_DUCKDB_MEMORY_LIMIT", "2GB")
    table = count_file(path, sensitive="g", outcome="y")
    assert table.counts.sum() == 20_000 and len(table.groups) == 20_000
