"""Benchmark: fairaudit at scale — a law with a million contexts, ten million records in Parquet, curves.

(1) Exact metrics of a big law: a :class:`~fairaudit.laws.tables.Law` with 10^6
    contexts, 8 groups and 4 decisions (Dirichlet(1) rows, seeded), utility
    g = 1{u = 1}, uniform population. Median time and peak memory of building
    the Law from the array, of L + L̄ (``local_fairness`` + ``global_fairness``)
    and of every metric (``certify.observe``), against a straightforward pandas
    groupby computing L (with its context and pair of groups) and L̄ from the
    law in long format (built before timing).
(2) Records in Parquet: 10^7 records (100 contexts, 8 string groups, 4 integer
    decisions), written in chunks with ``pyarrow.parquet.ParquetWriter``. Time
    and peak RSS of the command ``fairaudit audit FILE --sensitive group
    --context context --outcome decision --positive 1 --format json`` (a child
    process, its peak RSS reported by a bare wrapper process), against fairlearn's
    ``MetricFrame(selection_rate, ..., control_features=context)`` with and
    without reading the file into pandas.
(3) Intervals and the known-utility worst case on the 10^6-context law:
    ``fairness_intervals`` (counts drawn from the law, 20 records per cell) and
    ``worst_model`` behind 8-ary randomized response (ε = 1), each in a forked
    child with a time limit and an address-space limit of the memory then
    available, so that a step that fails or would not fit is reported, not fatal.
(4) Scaling curves: the audit command over 10^5 … 10^8 records, the exact
    metrics over 10^2 … 10^7 contexts; log-log slopes; an optional plot.

Every timed route is checked against an independent one (pandas, plain numpy
on the generator's own counts, fairlearn, the class certificate); the script
exits with status 1 when a relative difference exceeds 1e-7. Performance is
reported as ratios against peers timed in the same run, never asserted.

Usage: ``python benchmarks/bench_scale.py [--quick] [--output FILE.md] [--plot FILE.svg]
[--seed S] [--workdir DIR] [--max-records N] [--max-contexts N] [--step-timeout SECONDS]``.
"""

from __future__ import annotations

import argparse
import gc
import json
import math
import multiprocessing
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
import tracemalloc
from collections.abc import Callable
from pathlib import Path

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _bench_common import (
    AGREEMENT_TOL,
    RSS_WRAPPER,
    emit,
    fmt_diff,
    fmt_ratio,
    fmt_time,
    machine_line,  # noqa: E402
    memory_info,
    rel_diff,
    table,
)

import fairaudit  # noqa: E402
from fairaudit import IntervalOptions
from fairaudit.data.counts import CountTable  # noqa: E402
from fairaudit.laws.tables import Law, Population  # noqa: E402
from fairaudit.metrics.observed import observe  # noqa: E402

GROUPS = tuple(f"g{i}" for i in range(8))
DECISIONS = (0, 1, 2, 3)
POSITIVE = 1  # g = 1{u = 1}
EPSILON = 1.0  # randomized response of part (3)
CONFIDENCE = 0.95
MEMORY_TARGET = 3.0  # peak memory within 3x the law's table
PACKAGES = ("numpy", "pandas", "pyarrow", "fairlearn", "fairaudit")

FULL = dict(
    law_contexts=10**6,
    cert_contexts=(10**4, 10**6),
    per_cell=20,
    records=10**7,
    record_contexts=100,
    records_curve=(10**5, 10**6, 10**7, 10**8),
    contexts_curve=(10**2, 10**3, 10**4, 10**5, 10**6, 10**7),
    repeats=3,
    slow=10.0,
    chunk=5 * 10**6,
    step_timeout=1800.0,
    startup_records=1000,
)
QUICK = dict(
    law_contexts=10**3,
    cert_contexts=(10**3,),
    per_cell=20,
    records=10**4,
    record_contexts=10,
    records_curve=(10**3, 10**4),
    contexts_curve=(10**2, 10**3, 10**4),
    repeats=1,
    slow=10.0,
    chunk=4000,
    step_timeout=120.0,
    startup_records=1000,
)

_T0 = time.perf_counter()


# ----------------------------------------------------------------------------------------------------
# small helpers
# ----------------------------------------------------------------------------------------------------
def _progress(message: str) -> None:
    print(f"[bench_scale {time.perf_counter() - _T0:7.1f} s] {message}", file=sys.stderr, flush=True)


def fmt_bytes(n: float) -> str:
    """Bytes in decimal units (kB, MB, GB, TB), three significant digits."""
    if n is None or n != n:
        return "—"
    for unit, scale in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= scale:
            return f"{n / scale:.3g} {unit}"
    return f"{n:.0f} B"


def fmt_count(n: int) -> str:
    """10^k as 10^k, other counts with thousands separators."""
    k = round(math.log10(n)) if n > 0 else 0
    return f"10^{k}" if n == 10**k and k >= 3 else f"{n:,}"


def fmt_nats(x: float) -> str:
    return "inf" if x == math.inf else ("—" if x != x else f"{x:.6g}")


def _agree(values: list[float]) -> float:
    """The largest of several relative differences (NaN only when there are none)."""
    values = [v for v in values if v == v]
    return max(values) if values else math.nan


def _slope(sizes: list[float], values: list[float]) -> float:
    """Least-squares slope of log10(value) on log10(size); NaN with fewer than two points."""
    pts = [(s, v) for s, v in zip(sizes, values) if v == v and v > 0]
    if len(pts) < 2:
        return math.nan
    x, y = np.log10([p[0] for p in pts]), np.log10([p[1] for p in pts])
    return float(np.polyfit(x, y, 1)[0])


def _law_array(n: int, seed: int, tag: int = 0) -> np.ndarray:
    """A law P(U | X, A) of shape (n, 8, 4): Dirichlet(1) rows (normalised exponentials), seeded by (seed, tag, n)."""
    rng = np.random.default_rng([seed, tag, n])
    q = rng.standard_exponential((n, len(GROUPS), len(DECISIONS)))
    q /= q.sum(axis=-1, keepdims=True)
    return q


def _g_vector() -> np.ndarray:
    return np.array([1.0 if d == POSITIVE else 0.0 for d in DECISIONS])


def _ratio_max(e: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per row of ``e`` (rows × groups, NaN = excluded cell): max/min with 0/0 = 1, c/0 = inf; argmax, argmin.

    The independent numpy route of the agreement checks (rows with fewer than two cells give NaN).
    """
    present = ~np.isnan(e)
    hi = np.where(present, e, -np.inf)
    lo = np.where(present, e, np.inf)
    vmax, vmin = hi.max(axis=1), lo.min(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(vmax == 0, 1.0, np.where(vmin == 0, np.inf, vmax / vmin))
    ratio = np.where(present.sum(axis=1) >= 2, ratio, np.nan)
    return ratio, hi.argmax(axis=1), lo.argmin(axis=1)


def _array_rel_diff(a, b) -> float:
    """max over entries of |a − b| / max(|a|, |b|) (0 where both are 0); inf when the shapes differ."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if a.shape != b.shape:
        return math.inf
    if a.size == 0:
        return 0.0
    scale = np.maximum(np.abs(a), np.abs(b))
    with np.errstate(divide="ignore", invalid="ignore"):
        d = np.where(a == b, 0.0, np.abs(a - b) / scale)
    return float(np.nanmax(np.where(np.isnan(a) != np.isnan(b), np.inf, d)))


def _log(r: float) -> float:
    return math.inf if r == math.inf else (math.nan if r != r else math.log(r))


def _numpy_metrics(e: np.ndarray, weights: np.ndarray) -> tuple[float, float]:
    """L and L̄ from E[g | x, a] (NaN = empty cell) and P(x | a) weights, by plain numpy."""
    ratio, _, _ = _ratio_max(e)
    local = _log(float(np.nanmax(ratio))) if not np.all(np.isnan(ratio)) else math.nan
    eg = np.nansum(weights * np.nan_to_num(e, nan=0.0), axis=0)
    glob, _, _ = _ratio_max(eg[None, :])
    return local, _log(float(glob[0]))


# ----------------------------------------------------------------------------------------------------
# timing, memory and the guarded child process
# ----------------------------------------------------------------------------------------------------
def _measure(fn: Callable[[], object], repeats: int, slow: float):
    """Peak traced memory of one call, then the median time of ``repeats`` calls (one when a call is slow).

    The first call runs under :mod:`tracemalloc` (numpy reports its buffers to
    it), so it also serves as the warm-up; it is not timed. Returns (median
    seconds, calls timed, peak traced bytes during the call, output of the last call).
    """
    gc.collect()
    tracemalloc.start()
    try:
        t0 = time.perf_counter()
        out = fn()
        traced = time.perf_counter() - t0
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    times = []
    for _ in range(1 if traced > slow else max(1, repeats)):
        out = None
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), len(times), peak, out


def _vm_size() -> int:
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmSize:"):
                return int(line.split()[1]) * 1024
    except OSError:
        pass
    return 0


def _child(conn, fn, args) -> None:
    """Run ``fn(*args)`` under an address-space limit of (current size + available memory); send its dict back."""
    info = memory_info()
    if info is not None:
        soft, hard = resource.getrlimit(resource.RLIMIT_AS)
        limit = _vm_size() + info["available"]
        if hard != resource.RLIM_INFINITY:
            limit = min(limit, hard)
        try:
            resource.setrlimit(resource.RLIMIT_AS, (limit, hard))
        except (ValueError, OSError):
            pass
    try:
        result = fn(*args)
    except MemoryError as exc:
        result = {"error": f"needs more memory than available (MemoryError: {str(exc).splitlines()[0][:160]})"}
    except Exception as exc:  # report any failure of the step, do not crash the benchmark
        text = str(exc).splitlines()[0][:200] if str(exc) else ""
        result = {"error": f"failed ({type(exc).__name__}: {text})"}
    conn.send(result)
    conn.close()


def run_guarded(fn: Callable[..., dict], *args, timeout: float) -> dict:
    """``fn(*args)`` in a forked child with a time limit and a memory guard; ``{"error": why}`` when it fails.

    The child runs under RLIMIT_AS = its size + the memory available at the
    start, so an allocation that would not fit raises MemoryError there
    instead of swapping or waking the OOM killer; after ``timeout`` seconds it
    is killed. Only small dicts travel back.
    """
    sys.stdout.flush()
    sys.stderr.flush()
    ctx = multiprocessing.get_context("fork")
    receive, send = ctx.Pipe(duplex=False)
    proc = ctx.Process(target=_child, args=(send, fn, args), daemon=True)
    proc.start()
    send.close()
    result = None
    try:
        if receive.poll(timeout):
            result = receive.recv()
    except EOFError:
        result = None
    finally:
        receive.close()
    if result is None and proc.is_alive():
        proc.kill()
        proc.join()
        return {"error": f"stopped at the time limit of {timeout:g} s"}
    proc.join(30)
    if result is None:
        code = proc.exitcode
        why = f"killed by signal {-code}" if code is not None and code < 0 else f"exit status {code}"
        return {"error": f"child process died ({why}; signal 9 usually means out of memory)"}
    return result


def run_command(cmd: list[str], timeout: float) -> dict:
    """Run ``cmd`` through a tiny Python wrapper: wall time, the command's peak RSS, exit status, output.

    Linux carries a process's high-water RSS across ``exec`` (and a vfork
    child shares its parent's memory until then), so waiting for a command
    started straight from this large process would report this process's peak.
    The wrapper, a bare interpreter of about 12 MB, starts the command and
    reports ``getrusage(RUSAGE_CHILDREN).ru_maxrss`` and the time around
    ``subprocess.call``; the wrapper's own size is the floor of that RSS.
    """
    with tempfile.TemporaryDirectory(prefix="fairaudit-bench-cmd-") as tmp:
        report = Path(tmp) / "report.json"
        out_path, err_path = Path(tmp) / "stdout", Path(tmp) / "stderr"
        with open(out_path, "wb") as out, open(err_path, "wb") as err:
            proc = subprocess.Popen(
                [sys.executable, "-I", "-c", RSS_WRAPPER, str(report), *cmd],
                stdout=out,
                stderr=err,
                start_new_session=True,
            )
            try:
                proc.wait(timeout)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, 9)
                proc.wait()
                return {"returncode": -9, "stdout": "", "stderr": f"stopped at the time limit of {timeout:g} s"}
        stdout = out_path.read_text(encoding="utf-8", errors="replace")
        stderr = err_path.read_text(encoding="utf-8", errors="replace")
        if not report.is_file():
            return {"returncode": proc.returncode, "stdout": stdout, "stderr": stderr or "the wrapper failed"}
        result = json.loads(report.read_text(encoding="utf-8"))
        result.update(stdout=stdout, stderr=stderr)
        return result


# ----------------------------------------------------------------------------------------------------
# (1) and (4b): the exact metrics of a big law
# ----------------------------------------------------------------------------------------------------
def _fairness_summary(f) -> dict:
    return {"value": f.value, "context": f.context, "group": f.group, "other_group": f.other_group}


def _local_global(law: Law, g, pop: Population) -> tuple[dict, dict]:
    return (
        _fairness_summary(fairaudit.local_fairness(law, g, pop)),
        _fairness_summary(fairaudit.global_fairness(law, g, pop)),
    )


def _observe_summary(law: Law, g, pop: Population) -> dict:
    o = observe(law, g, pop)
    return {
        "local": o.local_fairness.value,
        "global": o.global_fairness.value,
        "demographic_parity": o.demographic_parity.value,
        "equalized_odds": o.equalized_odds.value,
        "sup_local": o.sup_local_fairness.value,
        "sup_global": o.sup_global_fairness.value,
    }


def _long_frame(q: np.ndarray):
    """The law in long format: one row per (context, group, decision) with its probability p (integer codes)."""
    import pandas as pd

    n, a, u = q.shape
    return pd.DataFrame(
        {
            "context": np.repeat(np.arange(n, dtype=np.int64), a * u),
            "group": np.tile(np.repeat(np.arange(a, dtype=np.int64), u), n),
            "decision": np.tile(np.arange(u, dtype=np.int64), n * a),
            "p": q.reshape(-1),
        }
    )


def pandas_route(long, g_by_decision, p_xa) -> dict:
    """L (with its context and pair) and L̄ by a straightforward pandas groupby on the long law.

    E[g | x, a] by groupby-sum of p·g(u); per context the max and min over
    groups give the largest ratio (0/0 = 1, c/0 = inf); E[g | a] weights
    E[g | x, a] by P(x | a) = P(x, a) / P(a).
    """
    v = long["p"] * long["decision"].map(g_by_decision)
    e = v.groupby([long["context"], long["group"]]).sum()  # E[g | x, a], index (context, group)
    by_context = e.groupby(level="context")
    hi, lo = by_context.max(), by_context.min()
    ratio = (hi / lo).where(hi > 0, 1.0)
    x = ratio.idxmax()
    at_x = e.xs(x, level="context")
    eg = (e * p_xa).groupby(level="group").sum() / p_xa.groupby(level="group").sum()
    return {
        "local": _log(float(ratio.max())),
        "context": int(x),
        "group": int(at_x.idxmax()),
        "other_group": int(at_x.idxmin()),
        "global": _log(float(eg.max() / eg.min())),
        "global_group": int(eg.idxmax()),
        "global_other_group": int(eg.idxmin()),
    }


def _tiny_law(seed: int) -> tuple[Law, Population]:
    law = Law(_law_array(2, seed, tag=9), range(2), GROUPS, DECISIONS)
    return law, Population.uniform(law.contexts, law.groups)


def _warm_up_law(seed: int, with_pandas: bool) -> None:
    """Every call of :func:`law_job` once on a 2-context law: imports and first-call set-up stay out of the measures."""
    import pandas as pd

    law, pop = _tiny_law(seed)
    g = fairaudit.indicator(POSITIVE, DECISIONS)
    _local_global(law, g, pop)
    _observe_summary(law, g, pop)
    if with_pandas:
        idx = pd.MultiIndex.from_product([np.arange(2), np.arange(len(GROUPS))], names=["context", "group"])
        pandas_route(
            _long_frame(law.probabilities),
            pd.Series(_g_vector(), index=np.arange(len(DECISIONS))),
            pd.Series(pop.probabilities.reshape(-1), index=idx),
        )


def law_job(n: int, seed: int, repeats: int, slow: float, with_pandas: bool) -> dict:
    """Build a Law with n contexts, time L + L̄ and every metric, and (optionally) the pandas route."""
    import pandas as pd

    _warm_up_law(seed, with_pandas)
    arr = _law_array(n, seed)
    nbytes = arr.nbytes
    t_build, k_build, p_build, law = _measure(lambda: Law(arr, range(n), GROUPS, DECISIONS), repeats, slow)
    kept = _array_rel_diff(law.probabilities, arr)
    arr = None  # free the input array
    pop = Population.uniform(law.contexts, law.groups)
    g = fairaudit.indicator(POSITIVE, DECISIONS)
    t_lg, k_lg, p_lg, (loc, glo) = _measure(lambda: _local_global(law, g, pop), repeats, slow)
    t_obs, k_obs, p_obs, obs = _measure(lambda: _observe_summary(law, g, pop), repeats, slow)
    e = law.probabilities @ _g_vector()  # numpy route
    np_local, np_global = _numpy_metrics(e, pop.context_given_group())
    out = {
        "n": n,
        "nbytes": nbytes,
        "build": (t_build, k_build, p_build),
        "lg": (t_lg, k_lg, p_lg),
        "obs": (t_obs, k_obs, p_obs),
        "local": loc,
        "global": glo,
        "observed": obs,
        "build_agreement": kept,
        "numpy_agreement": _agree(
            [
                rel_diff(loc["value"], np_local),
                rel_diff(glo["value"], np_global),
                rel_diff(obs["local"], np_local),
                rel_diff(obs["global"], np_global),
            ]
        ),
        "peak_need": nbytes + max(p_build, p_lg, p_obs),
    }
    if with_pandas:
        long = _long_frame(law.probabilities)
        g_by_decision = pd.Series(_g_vector(), index=np.arange(len(DECISIONS)))
        idx = pd.MultiIndex.from_product([np.arange(n), np.arange(len(GROUPS))], names=["context", "group"])
        p_xa = pd.Series(pop.probabilities.reshape(-1), index=idx)
        t_pd, k_pd, p_pd, res = _measure(lambda: pandas_route(long, g_by_decision, p_xa), repeats, slow)
        out["pandas"] = (t_pd, k_pd, p_pd)
        out["pandas_result"] = res
        out["long_nbytes"] = int(long.memory_usage(index=True).sum())
        same = (
            res["context"] == loc["context"]
            and GROUPS[res["group"]] == loc["group"]
            and GROUPS[res["other_group"]] == loc["other_group"]
            and GROUPS[res["global_group"]] == glo["group"]
            and GROUPS[res["global_other_group"]] == glo["other_group"]
        )
        out["pandas_same_cells"] = bool(same)
        out["pandas_agreement"] = _agree([rel_diff(loc["value"], res["local"]), rel_diff(glo["value"], res["global"])])
    return out


# ----------------------------------------------------------------------------------------------------
# (3) intervals and the worst decision model
# ----------------------------------------------------------------------------------------------------
def intervals_job(n: int, seed: int, per_cell: int, repeats: int, slow: float) -> dict:
    """fairness_intervals on counts drawn from the n-context law (``per_cell`` records per cell, multinomial)."""
    from fairaudit.statistics.intervals import fairness_intervals

    g = fairaudit.indicator(POSITIVE, DECISIONS)
    tiny, _ = _tiny_law(seed)  # warm-up: imports and first calls, unmeasured
    tiny_counts = np.random.default_rng(0).multinomial(per_cell, tiny.probabilities)
    fairness_intervals(
        CountTable(tiny_counts, tiny.contexts, GROUPS, DECISIONS, ("context",), ("group",), "decision"),
        g,
        IntervalOptions(confidence=CONFIDENCE),
    )
    arr = _law_array(n, seed)
    nbytes = arr.nbytes
    counts = np.random.default_rng([seed, 1, n]).multinomial(per_cell, arr)
    del arr
    tab = CountTable(counts, tuple(range(n)), GROUPS, DECISIONS, ("context",), ("group",), "decision")
    t, k, peak, iv = _measure(lambda: fairness_intervals(tab, g, IntervalOptions(confidence=CONFIDENCE)), repeats, slow)
    o = _observe_summary(tab.law(), g, tab.population())
    diffs, inside, names = [], True, []
    for name, interval in iv.intervals().items():
        if interval is None:
            continue
        names.append(name)
        diffs.append(rel_diff(interval.estimate, o[name]))
        inside &= bool(interval.lower <= interval.estimate <= interval.upper)
    return {
        "n": n,
        "nbytes": nbytes,
        "time": (t, k, peak + counts.nbytes),
        "method": iv.method,
        "local": (iv.local_fairness.lower, iv.local_fairness.estimate, iv.local_fairness.upper),
        "global": (iv.global_fairness.lower, iv.global_fairness.estimate, iv.global_fairness.upper),
        "agreement": _agree(diffs),
        "inside": inside,
        "compared": names,
    }


def worst_job(n: int, repeats: int, slow: float) -> dict:
    """worst_model behind 8-ary randomized response (ε = 1), identity on n contexts, against black_box_bound."""
    from fairaudit.laws.closed_forms import randomized_response
    from fairaudit.worstcase.black_box import black_box_bound
    from fairaudit.worstcase.known_utility import worst_model

    mech = randomized_response(GROUPS, epsilon=EPSILON)
    g = fairaudit.indicator(POSITIVE, DECISIONS)
    worst_model(mech, g, population=Population.uniform(range(2), GROUPS))  # warm-up, unmeasured
    pop = Population.uniform(range(n), GROUPS)
    bound = black_box_bound(mech)
    t, k, peak, w = _measure(lambda: worst_model(mech, g, population=pop), repeats, slow)
    return {
        "n": n,
        "nbytes": n * len(GROUPS) * len(DECISIONS) * 8,
        "time": (t, k, peak),
        "local": w.local_fairness.value,
        "global": w.global_fairness.value,
        "bound": bound.value,
        "epsilon": mech.epsilon,
        "agreement": _agree(
            [
                rel_diff(w.local_fairness.value, bound.value),
                rel_diff(w.global_fairness.value, bound.value),
                rel_diff(bound.value, mech.epsilon),
            ]
        ),
    }


# ----------------------------------------------------------------------------------------------------
# (2) and (4a): records in Parquet
# ----------------------------------------------------------------------------------------------------
def write_records(path: Path, n_records: int, law: np.ndarray, seed: int, chunk: int) -> np.ndarray:
    """Write ``n_records`` records drawn from ``law`` (contexts × 8 × 4) to Parquet in chunks; return their counts.

    Context and group uniform and independent, the decision drawn from the
    law's row by inverse CDF; columns ``context`` (int64), ``group`` (string
    "g0" … "g7") and ``decision`` (int64). The counts (contexts, groups,
    decisions) come from the generator itself: the independent route of the
    agreement checks.
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    n_ctx, n_grp, n_dec = law.shape
    cdf = np.cumsum(law, axis=-1)[..., :-1]
    rng = np.random.default_rng([seed, 3, n_records])
    dictionary = pa.array(list(GROUPS), type=pa.string())
    schema = pa.schema([("context", pa.int64()), ("group", pa.string()), ("decision", pa.int64())])
    counts = np.zeros(n_ctx * n_grp * n_dec, dtype=np.int64)
    tmp = path.with_name(path.name + ".part")
    with pq.ParquetWriter(tmp, schema) as writer:
        for start in range(0, n_records, chunk):
            m = min(chunk, n_records - start)
            x = rng.integers(0, n_ctx, m)
            a = rng.integers(0, n_grp, m)
            u = (rng.random(m)[:, None] > cdf[x, a]).sum(axis=1)
            counts += np.bincount((x * n_grp + a) * n_dec + u, minlength=counts.size)
            groups = pa.DictionaryArray.from_arrays(pa.array(a.astype(np.int32)), dictionary).cast(pa.string())
            writer.write_table(pa.table([pa.array(x), groups, pa.array(u.astype(np.int64))], schema=schema))
    tmp.replace(path)
    return counts.reshape(n_ctx, n_grp, n_dec)


def audit_command(path: Path) -> tuple[list[str], str]:
    """The ``fairaudit audit`` command line (the console script next to this Python, else ``python -c``)."""
    args = [
        "audit",
        str(path),
        "--sensitive",
        "group",
        "--context",
        "context",
        "--outcome",
        "decision",
        "--positive",
        str(POSITIVE),
        "--format",
        "json",
    ]
    script = Path(sys.executable).with_name("fairaudit")
    if script.is_file() and os.access(script, os.X_OK):
        return [str(script), *args], "the `fairaudit` console script"
    return [
        sys.executable,
        "-c",
        "import sys; from fairaudit.cli import main; sys.exit(main())",
        *args,
    ], "`python -c 'from fairaudit.cli import main'` (no console script found)"


def counts_metrics(counts: np.ndarray) -> tuple[float, float]:
    """L and L̄ of the empirical law of ``counts`` under the empirical population, by plain numpy."""
    n_xa = counts.sum(axis=-1).astype(float)
    k = counts[..., DECISIONS.index(POSITIVE)].astype(float)
    with np.errstate(divide="ignore", invalid="ignore"):
        e = np.where(n_xa > 0, k / n_xa, np.nan)
        w = n_xa / n_xa.sum(axis=0)
    return _numpy_metrics(e, w)


def _number(value) -> float:
    """A JSON number of the audit report ("inf" for infinity, null for NaN)."""
    return math.nan if value is None else float(value)


def time_command(cmd: list[str], n_records: int, counts: np.ndarray, repeats: int, slow: float, timeout: float) -> dict:
    """Median time and peak RSS (max over runs) of the audit command; its JSON checked against ``counts``."""
    runs = []
    for i in range(max(1, repeats)):
        r = run_command(cmd, timeout)
        if r["returncode"] != 0:
            tail = (r["stderr"].strip().splitlines() or ["(no message)"])[-1][:200]
            return {"error": f"exit status {r['returncode']}: {tail}"}
        runs.append(r)
        if r["seconds"] > slow:
            break
    data = json.loads(runs[-1]["stdout"])
    local, glob = _number(data["local"]["value"]), _number(data["global"]["value"])
    np_local, np_global = counts_metrics(counts)
    agreement = _agree([rel_diff(local, np_local), rel_diff(glob, np_global), rel_diff(float(data["n"]), n_records)])
    return {
        "seconds": statistics.median(r["seconds"] for r in runs),
        "runs": len(runs),
        "rss": max(r["rss"] for r in runs),
        "local": local,
        "global": glob,
        "n": int(data["n"]),
        "context": data["local"]["context"],
        "group": data["local"]["group"],
        "other_group": data["local"]["other_group"],
        "agreement": agreement,
    }


def count_route(path: Path):
    """The streamed Parquet counter ``fairaudit.data.counts.count_file`` (DuckDB), and its name in the report."""
    from fairaudit.data.counts import count_file

    return (
        lambda: count_file(path, sensitive=["group"], outcome="decision", context=["context"]),
        "`fairaudit.data.counts.count_file` (streamed)",
    )


def _table_vs_counts(tab: CountTable, counts: np.ndarray) -> float:
    """Largest relative difference between a CountTable and the generator's counts, matched by label."""
    try:
        ix = np.ix_(
            [int(c) for c in tab.contexts],
            [GROUPS.index(a) for a in tab.groups],
            [DECISIONS.index(int(d)) for d in tab.decisions],
        )
    except (ValueError, TypeError):
        return math.inf
    mine = np.zeros_like(counts)
    mine[ix] = tab.counts
    return _array_rel_diff(mine, counts)


# ----------------------------------------------------------------------------------------------------
# the parts of the report
# ----------------------------------------------------------------------------------------------------
def _mem_cells(peak: float, nbytes: int) -> tuple[str, str, str]:
    mult = peak / nbytes
    return fmt_bytes(peak), f"{mult:.2f}×", ("yes" if mult <= MEMORY_TARGET else "no")


def part_law(res: dict, failures: list[str]) -> str:
    """Table of part (1)."""
    if "error" in res:
        return table(
            ["step", "result", "agreement (max rel. diff)"], [["exact metrics of the big law", res["error"], "—"]]
        )
    nb = res["nbytes"]
    t_pd = res["pandas"][0] if "pandas" in res else math.nan
    loc, glo, obs = res["local"], res["global"], res["observed"]
    rows = []
    t, k, p = res["build"]
    rows.append(
        [
            "build the Law from the array",
            fmt_time(t),
            str(k),
            *_mem_cells(nb + p, nb),
            "—",
            f"table {fmt_bytes(nb)}, kept exactly",
            fmt_diff(res["build_agreement"]),
        ]
    )
    t, k, p = res["lg"]
    agree_lg = _agree([res.get("pandas_agreement", math.nan), res["numpy_agreement"]])
    rows.append(
        [
            "L + L̄ (local_fairness + global_fairness)",
            fmt_time(t),
            str(k),
            *_mem_cells(nb + p, nb),
            fmt_ratio(t_pd / t),
            f"L = {fmt_nats(loc['value'])} at context {loc['context']} ({loc['group']} vs {loc['other_group']}); "
            f"L̄ = {fmt_nats(glo['value'])} ({glo['group']} vs {glo['other_group']})",
            fmt_diff(agree_lg),
        ]
    )
    t, k, p = res["obs"]
    rows.append(
        [
            "all metrics (certify.observe: L, L̄, L_dp, L_eo, sups)",
            fmt_time(t),
            str(k),
            *_mem_cells(nb + p, nb),
            fmt_ratio(t_pd / t),
            f"L_dp = {obs['demographic_parity']:.4g}, L_eo = {obs['equalized_odds']:.4g}, "
            f"sup L = {fmt_nats(obs['sup_local'])}, sup L̄ = {fmt_nats(obs['sup_global'])}",
            fmt_diff(res["numpy_agreement"]),
        ]
    )
    if "pandas" in res:
        t, k, p = res["pandas"]
        r = res["pandas_result"]
        same = "same context and groups" if res["pandas_same_cells"] else "DIFFERENT context or groups"
        rows.append(
            [
                "baseline: pandas groupby, L + L̄",
                fmt_time(t),
                str(k),
                fmt_bytes(p + res["long_nbytes"]),
                f"{(p + res['long_nbytes']) / nb:.2f}×",
                "—",
                "1×",
                f"L = {fmt_nats(r['local'])} at context {r['context']}, L̄ = {fmt_nats(r['global'])}; {same}",
                fmt_diff(res["pandas_agreement"]),
            ]
        )
        if not res["pandas_same_cells"]:
            failures.append("(1) pandas and fairaudit disagree on the maximising context or groups")
    for name, value in (
        ("(1) Law kept", res["build_agreement"]),
        ("(1) numpy route", res["numpy_agreement"]),
        ("(1) pandas route", res.get("pandas_agreement", math.nan)),
    ):
        if value == value and not value <= AGREEMENT_TOL:
            failures.append(f"{name}: relative difference {value:.3g} > {AGREEMENT_TOL:g}")
    header = [
        "step",
        "median time",
        "repeats",
        "peak memory",
        "peak / table",
        f"within {MEMORY_TARGET:g}×",
        "pandas / fairaudit",
        "result",
        "agreement (max rel. diff)",
    ]
    return table(header, rows)


def part_records(rec: dict, failures: list[str]) -> str:
    """Table of part (2)."""
    header = [
        "route",
        "median time",
        "repeats",
        "peak RSS",
        "records/s",
        "time / fairaudit audit",
        "result",
        "agreement (max rel. diff)",
    ]
    cmd = rec["command"]
    n = rec["n"]
    rows = []
    if "error" in cmd:
        rows.append(
            ["`fairaudit audit FILE … --format json` (child process)", "—", "—", "—", "—", "—", cmd["error"], "—"]
        )
        t_cmd = math.nan
        failures.append(f"(2) the audit command failed: {cmd['error']}")
    else:
        t_cmd = cmd["seconds"]
        rows.append(
            [
                "`fairaudit audit FILE … --format json` (child process)",
                fmt_time(t_cmd),
                str(cmd["runs"]),
                fmt_bytes(cmd["rss"]),
                f"{n / t_cmd:,.0f}",
                "1×",
                f"n = {cmd['n']:,}; L = {fmt_nats(cmd['local'])} at context {cmd['context']} "
                f"({cmd['group']} vs {cmd['other_group']}); L̄ = {fmt_nats(cmd['global'])}",
                fmt_diff(cmd["agreement"]),
            ]
        )
    st = rec.get("startup")
    if st is not None:
        rows.append(
            [
                f"the same command on {rec['startup_records']:,} records (start-up and imports)",
                fmt_time(st["seconds"]) if "error" not in st else "—",
                str(st.get("runs", "—")),
                fmt_bytes(st.get("rss", math.nan)),
                "—",
                fmt_ratio(st.get("seconds", math.nan) / t_cmd),
                st.get("error", "fixed cost inside the command's time"),
                fmt_diff(st.get("agreement", math.nan)),
            ]
        )
    t, k = rec["api"]
    rows.append(
        [
            f"fairaudit Python API: {rec['api_route']} + observe (in process)",
            fmt_time(t),
            str(k),
            "—",
            f"{n / t:,.0f}",
            fmt_ratio(t / t_cmd),
            "counts equal to the generator's",
            fmt_diff(rec["api_agreement"]),
        ]
    )
    fl = rec["fairlearn"]
    t_read, k_read = fl["read"]
    t_mf, k_mf = fl["metricframe"]
    rows.append(
        [
            "fairlearn: read_parquet + MetricFrame(selection_rate, control_features=context)",
            fmt_time(t_read + t_mf),
            f"{k_read} + {k_mf}",
            "—",
            f"{n / (t_read + t_mf):,.0f}",
            fmt_ratio((t_read + t_mf) / t_cmd),
            f"{fl['rates']} selection rates (context, group)",
            fmt_diff(fl["agreement"]),
        ]
    )
    rows.append(
        [
            "fairlearn: MetricFrame only (DataFrame already in memory)",
            fmt_time(t_mf),
            str(k_mf),
            "—",
            f"{n / t_mf:,.0f}",
            fmt_ratio(t_mf / t_cmd),
            "the same rates",
            fmt_diff(fl["agreement"]),
        ]
    )
    for name, value in (
        ("(2) audit command vs the generator's counts", cmd.get("agreement", math.nan)),
        ("(2) start-up run vs its counts", (st or {}).get("agreement", math.nan)),
        ("(2) count route vs the generator's counts", rec["api_agreement"]),
        ("(2) fairlearn vs fairaudit's law", fl["agreement"]),
    ):
        if value == value and not value <= AGREEMENT_TOL:
            failures.append(f"{name}: relative difference {value:.3g} > {AGREEMENT_TOL:g}")
    return table(header, rows)


def part_certificates(ivs: list[dict], worsts: list[dict], bound: dict, failures: list[str]) -> str:
    """Table of part (3)."""
    rows = []
    for r, n in ivs:
        label = f"fairness_intervals(…, {CONFIDENCE:g})"
        if "error" in r:
            rows.append([label, fmt_count(n), "—", "—", "—", "—", f"did not run: {r['error']}", "—"])
            continue
        t, k, p = r["time"]
        lo, est, hi = r["local"]
        glo, gest, ghi = r["global"]
        rows.append(
            [
                label + f", {r['method']}",
                fmt_count(n),
                fmt_time(t),
                str(k),
                fmt_bytes(p),
                f"{p / r['nbytes']:.2f}×",
                f"L = {fmt_nats(est)} in [{fmt_nats(lo)}, {fmt_nats(hi)}]; L̄ = {fmt_nats(gest)} in "
                f"[{fmt_nats(glo)}, {fmt_nats(ghi)}]; estimates compared: {', '.join(r['compared'])}"
                + ("" if r["inside"] else "; an ESTIMATE OUTSIDE its interval"),
                fmt_diff(r["agreement"]),
            ]
        )
        if not r["inside"]:
            failures.append(f"(3) intervals at {n} contexts: an estimate lies outside its interval")
        if not r["agreement"] <= AGREEMENT_TOL:
            failures.append(f"(3) intervals at {n} contexts: estimates differ from observe() by {r['agreement']:.3g}")
    for r, n in worsts:
        label = f"worst_model(randomized_response(8 groups, ε = {EPSILON:g}), identity on contexts)"
        if "error" in r:
            rows.append([label, fmt_count(n), "—", "—", "—", "—", f"did not run: {r['error']}", "—"])
            continue
        t, k, p = r["time"]
        rows.append(
            [
                label,
                fmt_count(n),
                fmt_time(t),
                str(k),
                fmt_bytes(p),
                f"{p / r['nbytes']:.2f}×",
                f"local {fmt_nats(r['local'])}, global {fmt_nats(r['global'])}; black_box_bound "
                f"{fmt_nats(r['bound'])}, ε {r['epsilon']:.6g}",
                fmt_diff(r["agreement"]),
            ]
        )
        if not r["agreement"] <= AGREEMENT_TOL:
            failures.append(f"(3) worst_model at {n} contexts differs from black_box_bound by {r['agreement']:.3g}")
    rows.append(
        [
            f"black_box_bound(randomized_response(8 groups, ε = {EPSILON:g})) (class certificate, no contexts)",
            "—",
            fmt_time(bound["time"]),
            str(bound["repeats"]),
            "—",
            "—",
            f"{fmt_nats(bound['value'])} nats",
            fmt_diff(bound["agreement"]),
        ]
    )
    if not bound["agreement"] <= AGREEMENT_TOL:
        failures.append(f"(3) black_box_bound differs from ε by {bound['agreement']:.3g}")
    header = [
        "step",
        "contexts",
        "median time",
        "repeats",
        "peak memory",
        "peak / table",
        "result",
        "agreement (max rel. diff)",
    ]
    return table(header, rows)


def part_records_curve(points: list[dict], failures: list[str]) -> str:
    rows = []
    for p in points:
        n = p["n"]
        if "error" in p:
            rows.append([fmt_count(n), fmt_bytes(p.get("file", math.nan)), "—", "—", "—", "—", p["error"], "—"])
            continue
        rows.append(
            [
                fmt_count(n),
                fmt_bytes(p["file"]),
                fmt_time(p["seconds"]),
                str(p["runs"]),
                fmt_bytes(p["rss"]),
                f"{n / p['seconds']:,.0f}",
                f"L = {fmt_nats(p['local'])}, L̄ = {fmt_nats(p['global'])}",
                fmt_diff(p["agreement"]),
            ]
        )
        if not p["agreement"] <= AGREEMENT_TOL:
            failures.append(f"(4) audit command on {n} records: relative difference {p['agreement']:.3g}")
    header = [
        "records",
        "Parquet file",
        "median time",
        "repeats",
        "peak RSS",
        "records/s",
        "result",
        "agreement (max rel. diff)",
    ]
    return table(header, rows)


def part_contexts_curve(points: list[dict], failures: list[str]) -> str:
    rows = []
    for p in points:
        n = p["n"]
        cells = n * len(GROUPS) * len(DECISIONS)
        if "error" in p:
            rows.append([fmt_count(n), fmt_bytes(cells * 8), "—", "—", "—", "—", "—", "—", "—", p["error"], "—"])
            continue
        nb = p["nbytes"]
        (tb, _, _), (tl, kl, pl), (to, ko, po) = p["build"], p["lg"], p["obs"]
        rows.append(
            [
                fmt_count(n),
                fmt_bytes(nb),
                fmt_time(tb),
                f"{fmt_time(tl)} ({kl})",
                f"{fmt_time(to)} ({ko})",
                f"{fmt_bytes(nb + pl)} ({(nb + pl) / nb:.2f}×)",
                f"{fmt_bytes(nb + po)} ({(nb + po) / nb:.2f}×)",
                f"{tl / cells * 1e9:.3g}",
                f"{to / cells * 1e9:.3g}",
                p.get("note", ""),
                fmt_diff(p["numpy_agreement"]),
            ]
        )
        if not p["numpy_agreement"] <= AGREEMENT_TOL:
            failures.append(f"(4) exact metrics at {n} contexts vs numpy: {p['numpy_agreement']:.3g}")
    header = [
        "contexts",
        "table",
        "build Law",
        "L + L̄ (repeats)",
        "all metrics (repeats)",
        "peak, L + L̄",
        "peak, all metrics",
        "ns per cell, L + L̄",
        "ns per cell, all metrics",
        "note",
        "agreement (max rel. diff)",
    ]
    return table(header, rows)


def slopes(records: list[dict], contexts: list[dict], startup: float = math.nan) -> tuple[list[str], dict]:
    """Bullet lines with the fitted log-log slopes, and the series for the plot.

    ``startup`` is the command's time on a tiny file: the curve net of it is fitted too.
    """
    rec_ok = [p for p in records if "error" not in p]
    ctx_ok = [p for p in contexts if "error" not in p]
    series = {
        "records": [p["n"] for p in rec_ok],
        "audit_time": [p["seconds"] for p in rec_ok],
        "audit_rss": [p["rss"] for p in rec_ok],
        "audit_net": [p["seconds"] - startup for p in rec_ok],
        "contexts": [p["n"] for p in ctx_ok],
        "lg_time": [p["lg"][0] for p in ctx_ok],
        "obs_time": [p["obs"][0] for p in ctx_ok],
        "build_time": [p["build"][0] for p in ctx_ok],
        "lg_peak": [p["nbytes"] + p["lg"][2] for p in ctx_ok],
        "obs_peak": [p["nbytes"] + p["obs"][2] for p in ctx_ok],
        "table": [p["nbytes"] for p in ctx_ok],
    }
    lines = []
    for label, x, y in (
        ("audit command time vs records", "records", "audit_time"),
        ("audit command time net of its start-up (the tiny-file run) vs records", "records", "audit_net"),
        ("audit command peak RSS vs records", "records", "audit_rss"),
        ("build Law time vs contexts", "contexts", "build_time"),
        ("L + L̄ time vs contexts", "contexts", "lg_time"),
        ("all metrics time vs contexts", "contexts", "obs_time"),
        ("peak memory of all metrics vs contexts", "contexts", "obs_peak"),
    ):
        xs, ys = series[x], series[y]
        whole = _slope(xs, ys)
        top = _slope(xs[-3:], ys[-3:]) if len(xs) > 3 else math.nan
        span = f"{fmt_count(xs[0])} … {fmt_count(xs[-1])}" if xs else "no size ran"
        extra = f", over the largest three sizes {top:.2f}" if top == top else ""
        lines.append(
            f"- {label}: slope {whole:.2f} over {span}{extra}."
            if whole == whole
            else f"- {label}: fewer than two sizes ran."
        )
    return lines, series


def write_plot(path: str, series: dict) -> None:
    """Two log-log panels (time, memory) of the scaling curves, written atomically (.svg or .png)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from fairaudit.base.files import write_atomic

    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.4))
    for ax in (left, right):
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.grid(True, which="major", alpha=0.3)
        ax.set_xlabel("size: records (audit) or contexts (law, 8 groups × 4 decisions)")
    left.plot(series["records"], series["audit_time"], "o-", color="C0", label="fairaudit audit (records)")
    left.plot(series["contexts"], series["build_time"], "^-", color="C1", label="build Law (contexts)")
    left.plot(series["contexts"], series["lg_time"], "s-", color="C2", label="L + L̄ (contexts)")
    left.plot(series["contexts"], series["obs_time"], "d-", color="C3", label="all metrics (contexts)")
    left.set_ylabel("time (s)")
    left.set_title("time")
    left.legend(fontsize=8)
    right.plot(series["records"], series["audit_rss"], "o-", color="C0", label="audit command peak RSS (records)")
    right.plot(series["contexts"], series["lg_peak"], "s-", color="C2", label="L + L̄ peak (contexts)")
    right.plot(series["contexts"], series["obs_peak"], "d-", color="C3", label="all metrics peak (contexts)")
    right.plot(series["contexts"], series["table"], "k--", label="the law's table")
    right.plot(
        series["contexts"],
        [MEMORY_TARGET * t for t in series["table"]],
        "k:",
        label=f"{MEMORY_TARGET:g} × the table (target)",
    )
    right.set_ylabel("bytes")
    right.set_title("peak memory")
    right.legend(fontsize=8)
    fig.tight_layout()
    suffix = Path(path).suffix.lower()

    def save(tmp):
        if suffix == ".svg":
            fig.savefig(tmp, format="svg", metadata={"Date": None})
        else:
            fig.savefig(tmp, format="png", dpi=150, metadata={"Software": None})

    target = Path(path)
    (target.parent if str(target.parent) else Path(".")).mkdir(parents=True, exist_ok=True)
    try:
        write_atomic(target, save, field="--plot")
    finally:
        plt.close(fig)


# ----------------------------------------------------------------------------------------------------
# the run
# ----------------------------------------------------------------------------------------------------
def _cap(sizes, cap):
    return tuple(s for s in sizes if cap is None or s <= cap)


def run(args) -> tuple[str, list[str], dict]:
    cfg = dict(QUICK if args.quick else FULL)
    if args.step_timeout is not None:
        cfg["step_timeout"] = args.step_timeout
    seed, timeout, repeats, slow = args.seed, cfg["step_timeout"], cfg["repeats"], cfg["slow"]
    law_n = cfg["law_contexts"] if args.max_contexts is None else min(cfg["law_contexts"], args.max_contexts)
    cert_sizes = _cap(cfg["cert_contexts"], args.max_contexts) or (law_n,)
    ctx_sizes = _cap(cfg["contexts_curve"], args.max_contexts)
    n_records = cfg["records"] if args.max_records is None else min(cfg["records"], args.max_records)
    rec_sizes = _cap(cfg["records_curve"], args.max_records)
    failures: list[str] = []
    machine = machine_line(PACKAGES, memory=True)
    start = time.perf_counter()

    # (1) the big law, with the pandas baseline (a forked child, guarded)
    _progress(f"(1) exact metrics of a law with {law_n:,} contexts, and the pandas baseline")
    law_res = run_guarded(law_job, law_n, seed, repeats, slow, True, timeout=timeout)

    # (3) intervals and worst_model (forked children, guarded)
    ivs, worsts = [], []
    for n in cert_sizes:
        _progress(f"(3) fairness_intervals at {n:,} contexts")
        ivs.append((run_guarded(intervals_job, n, seed, cfg["per_cell"], repeats, slow, timeout=timeout), n))
        _progress(f"(3) worst_model at {n:,} contexts")
        worsts.append((run_guarded(worst_job, n, repeats, slow, timeout=timeout), n))
    from fairaudit.laws.closed_forms import randomized_response
    from fairaudit.worstcase.black_box import black_box_bound

    mech = randomized_response(GROUPS, epsilon=EPSILON)
    t_bb, k_bb, _, bb = _measure(lambda: black_box_bound(mech), max(repeats, 3), slow)
    bound = {"time": t_bb, "repeats": k_bb, "value": bb.value, "agreement": rel_diff(bb.value, mech.epsilon)}

    # (4b) the contexts curve (forked children, guarded; the size of (1) is reused)
    ctx_points = []
    multiple = None
    for n in ctx_sizes:
        nbytes = n * len(GROUPS) * len(DECISIONS) * 8
        info = memory_info()
        need = (multiple or 8.0) * nbytes
        if info is not None and need > 0.9 * info["available"]:
            ctx_points.append(
                {"n": n, "error": f"skipped: needs about {fmt_bytes(need)}, {fmt_bytes(info['available'])} available"}
            )
            _progress(f"(4) contexts {n:,}: skipped (needs about {fmt_bytes(need)})")
            continue
        if n == law_n and "error" not in law_res:
            point = dict(law_res, note="the run of (1)")
        else:
            _progress(f"(4) exact metrics at {n:,} contexts")
            point = run_guarded(law_job, n, seed, repeats, slow, False, timeout=timeout)
            point.setdefault("n", n)
        if "error" not in point:
            multiple = point["peak_need"] / point["nbytes"]
        ctx_points.append(point)

    # (2) records in Parquet, then (4a) the records curve
    workroot = tempfile.mkdtemp(prefix="fairaudit-bench-scale-", dir=args.workdir)
    work = Path(workroot)
    try:
        rec, rec_points = _records_parts(cfg, args, seed, n_records, rec_sizes, work, timeout, repeats, slow)
    finally:
        shutil.rmtree(workroot, ignore_errors=True)
    total = time.perf_counter() - start

    text_law = part_law(law_res, failures)
    text_rec = part_records(rec, failures)
    text_cert = part_certificates(ivs, worsts, bound, failures)
    text_rc = part_records_curve(rec_points, failures)
    text_cc = part_contexts_curve(ctx_points, failures)
    st = rec.get("startup") or {}
    slope_lines, series = slopes(rec_points, ctx_points, st.get("seconds", math.nan))
    not_run = [r["error"] for r, _ in ivs + worsts if "error" in r] + [
        p["error"] for p in rec_points + ctx_points if "error" in p
    ]
    if "error" in law_res:
        not_run.append(law_res["error"])

    fl = rec["fairlearn"]
    cmd = rec["command"]
    fl_ratio = ((fl["read"][0] + fl["metricframe"][0]) / cmd["seconds"]) if "error" not in cmd else math.nan
    fl_ratio_mf = (fl["metricframe"][0] / cmd["seconds"]) if "error" not in cmd else math.nan
    fl_ratio_api = (fl["read"][0] + fl["metricframe"][0]) / rec["api"][0]
    lines = [
        "# fairaudit at scale: a big law, records in Parquet, certificates, scaling"
        + (" (quick)" if args.quick else ""),
        "",
        machine,
        f"Seed {seed}. Times are medians of up to {repeats} calls after one untimed call under tracemalloc "
        f"(one timed call when a call takes more than {slow:g} s). Peak memory of an in-process step: the "
        "tracemalloc peak during the call (numpy reports its buffers to tracemalloc) plus the input table, also as "
        "a multiple of the law's table (n_contexts × 8 × 4 float64). Peak RSS of a command: its own maximum resident "
        "set size, reported by a bare Python wrapper that starts it (`getrusage(RUSAGE_CHILDREN)`; the wrapper's "
        f"own ~12 MB are the floor). Steps (1), (3) and (4, contexts) run in forked children with a time limit of "
        f"{timeout:g} s and an address-space limit of the memory available when they start, so a step that fails or "
        "would not fit is reported in its table instead of stopping the run. Agreement: the largest relative "
        f"difference against an independent route; the run fails above {AGREEMENT_TOL:g}.",
        "",
        f"## (1) Exact metrics of a law with {law_n:,} contexts, 8 groups, 4 decisions",
        "",
        "Dirichlet(1) rows (normalised exponentials), utility g = 1{u = 1}, uniform population. Baseline: a "
        "straightforward pandas groupby on the law in long format (columns context, group, decision, p; integer "
        "codes; built before timing): E[g | x, a] by groupby-sum of p·g(u), per context max/min over groups -> L and "
        "its context, E[g | a] with P(x | a) weights -> L̄. Its peak memory includes the long frame. Agreement: "
        "L and L̄ against pandas (and the maximising context and groups must match) and against plain numpy "
        "(E = Q @ g, max/min per row); the Law's table against the array it was built from.",
        "",
        text_law,
        "",
        f"## (2) {n_records:,} records in Parquet: the audit command against fairlearn",
        "",
        f"{rec['record_contexts']} contexts (int), 8 groups (strings g0 … g7), 4 decisions (int), uniform contexts "
        f"and groups, decisions from a Dirichlet(1) law; written in chunks of {cfg['chunk']:,} with "
        f"`pyarrow.parquet.ParquetWriter` ({fmt_bytes(rec['file'])}, written in {fmt_time(rec['write'])}). "
        f"The command is run through {rec['command_how']}: `fairaudit audit FILE --sensitive group --context "
        f"context --outcome decision --positive {POSITIVE} --format json`; its time includes the interpreter's "
        "start-up and imports (the second row measures them alone). fairlearn: "
        '`MetricFrame(metrics=selection_rate, y_true=y, y_pred=(decision == 1), sensitive_features=df["group"], '
        'control_features=df["context"])` in this process, with y = y_pred (selection_rate ignores y_true); '
        '"read" is `pandas.read_parquet` of the same file, timed separately. Agreement: the command\'s n, L and L̄ '
        "against plain numpy on the generator's own counts; the count route's table against those counts; every "
        "fairlearn selection rate by (context, group) against fairaudit's estimated P(U = 1 | x, a).",
        "",
        text_rec,
        "",
        f"fairlearn / fairaudit audit: {fmt_ratio(fl_ratio)} with reading the file, {fmt_ratio(fl_ratio_mf)} "
        f"without (target ≥ 5×: {'met' if fl_ratio >= 5 else 'not met'}); fairlearn with reading / fairaudit's "
        f"in-process Python API (no start-up): {fmt_ratio(fl_ratio_api)}.",
        "",
        "## (3) Intervals and the worst decision model on the big law",
        "",
        f"`fairness_intervals(CountTable(counts, ...), g, {CONFIDENCE:g})` with counts drawn from the law "
        f"({cfg['per_cell']} records per cell (x, a), multinomial, seeded); agreement: every interval's estimate "
        "against `observe()` on the empirical law and population (and each estimate must lie in its interval). "
        f"`worst_model(randomized_response(groups, epsilon={EPSILON:g}), g, population=uniform)`, identity on the "
        "contexts; agreement: its local and global values against `black_box_bound(mech)` (for an indicator "
        "utility both equal ε of the mechanism), and that bound against ε. Peak memory as a multiple of the law's "
        "table of the same number of contexts (the counts table has the same size).",
        "",
        text_cert,
        "",
        "## (4) Scaling curves",
        "",
        f"### The audit command over records ({rec['record_contexts']} contexts, 8 groups, 4 decisions)",
        "",
        "Same generator and command as (2), one file per size (deleted after its run). A size is skipped when its "
        "file would not fit on the disk of --workdir or the command's peak RSS, extrapolated linearly from the "
        "previous size, would exceed 90% of the memory available. Agreement as in (2).",
        "",
        text_rc,
        "",
        "### The exact metrics over contexts (8 groups, 4 decisions)",
        "",
        "Same law generator as (1). ns per cell: median time / (contexts × 8 × 4). Peak: tracemalloc peak + the "
        "table. A size is skipped when the peak, extrapolated from the previous size's multiple of the table, would "
        "exceed 90% of the memory available. Agreement: L and L̄ of both routes against plain numpy.",
        "",
        text_cc,
        "",
        "Fitted log-log slopes (1 = linear):",
        "",
        *slope_lines,
        "",
    ]
    if not_run:
        lines += [f"{len(not_run)} step(s) did not run or were skipped; each says why in its table.", ""]
    lines.append(
        f"Total benchmark time {total:.1f} s. "
        + ("Every agreement is within tolerance." if not failures else f"{len(failures)} FAILURE(S).")
    )
    return "\n".join(lines) + "\n", failures, series


def _records_parts(cfg, args, seed, n_records, rec_sizes, work: Path, timeout, repeats, slow):
    """Part (2) and the records curve (4a); files live in ``work`` and are deleted after use."""
    import pandas as pd
    from fairlearn.metrics import MetricFrame, selection_rate

    law = _law_array(cfg["record_contexts"], seed, tag=2)
    cfg = dict(cfg, startup_records=min(cfg["startup_records"], n_records))
    # (2)
    path = work / f"records-{n_records}.parquet"
    _progress(f"(2) writing {n_records:,} records to {path}")
    t0 = time.perf_counter()
    counts = write_records(path, n_records, law, seed, cfg["chunk"])
    t_write = time.perf_counter() - t0
    file_size = path.stat().st_size
    cmd, how = audit_command(path)
    _progress(f"(2) fairaudit audit on {n_records:,} records")
    command = time_command(cmd, n_records, counts, repeats, slow, timeout)
    small = work / "records-startup.parquet"
    small_counts = write_records(small, cfg["startup_records"], law, seed, cfg["chunk"])
    startup_file = small.stat().st_size
    startup = time_command(audit_command(small)[0], cfg["startup_records"], small_counts, repeats, slow, timeout)
    small.unlink()
    _progress("(2) fairaudit Python API count route")
    route, route_name = count_route(path)
    g = fairaudit.indicator(POSITIVE, DECISIONS)

    def api():
        tab = route()
        observe(tab.law(), g, tab.population())
        return tab

    t_api, k_api, _, tab = _measure(api, repeats, slow)
    api_agreement = _table_vs_counts(tab, counts)
    law_hat = tab.law()
    p1 = law_hat.probabilities[..., law_hat.decisions.index(POSITIVE)]
    ours = pd.Series(p1.reshape(-1), index=pd.MultiIndex.from_product([list(law_hat.contexts), list(law_hat.groups)]))
    del tab, law_hat
    _progress("(2) fairlearn: read_parquet")
    t_read, k_read, _, df = _measure(lambda: pd.read_parquet(path), repeats, slow)

    def metricframe():
        y = df["decision"] == POSITIVE
        return MetricFrame(
            metrics=selection_rate, y_true=y, y_pred=y, sensitive_features=df["group"], control_features=df["context"]
        )

    _progress(f"(2) fairlearn MetricFrame on {n_records:,} records (slow)")
    t0 = time.perf_counter()
    mf = metricframe()
    first = time.perf_counter() - t0
    times = [first]
    if first <= slow:
        for _ in range(max(1, repeats) - 1):
            t0 = time.perf_counter()
            mf = metricframe()
            times.append(time.perf_counter() - t0)
    by_group = mf.by_group
    theirs = pd.Series(
        np.asarray(by_group, dtype=float),
        index=pd.MultiIndex.from_tuples([(int(c), str(a)) for c, a in by_group.index]),
    )
    joined = pd.concat([ours.rename("ours"), theirs.rename("theirs")], axis=1)
    fl_agreement = (
        math.inf
        if joined.isna().any().any() or len(joined) != len(ours)
        else _array_rel_diff(joined["ours"].to_numpy(), joined["theirs"].to_numpy())
    )
    df = mf = None
    rec = {
        "n": n_records,
        "file": file_size,
        "write": t_write,
        "command": command,
        "command_how": how,
        "startup": startup,
        "startup_records": cfg["startup_records"],
        "api": (t_api, k_api),
        "api_route": route_name,
        "api_agreement": api_agreement,
        "record_contexts": cfg["record_contexts"],
        "fairlearn": {
            "read": (t_read, k_read),
            "metricframe": (statistics.median(times), len(times)),
            "agreement": fl_agreement,
            "rates": len(theirs),
        },
    }
    # (4a)
    points = []
    bytes_per_record = file_size / n_records
    previous = None  # (records, peak RSS) of the last size that ran
    for n in rec_sizes:
        if n == n_records and "error" not in command:
            points.append(dict(command, n=n, file=file_size))
            previous = (n, command["rss"])
            continue
        if n == cfg["startup_records"] and "error" not in startup:
            points.append(dict(startup, n=n, file=startup_file))
            previous = (n, startup["rss"])
            continue
        disk = shutil.disk_usage(work).free
        need_disk = bytes_per_record * n
        info = memory_info()
        need_mem = previous[1] * n / previous[0] if previous else 0.0
        if need_disk > 0.8 * disk:
            points.append(
                {
                    "n": n,
                    "error": f"skipped: the file needs about {fmt_bytes(need_disk)}, "
                    f"{fmt_bytes(disk)} free in --workdir",
                }
            )
            continue
        if info is not None and need_mem > 0.9 * info["available"]:
            points.append(
                {
                    "n": n,
                    "error": f"skipped: the command would need about {fmt_bytes(need_mem)}, "
                    f"{fmt_bytes(info['available'])} available",
                }
            )
            continue
        f = work / f"records-{n}.parquet"
        _progress(f"(4) writing {n:,} records")
        c = write_records(f, n, law, seed, cfg["chunk"])
        size = f.stat().st_size
        _progress(f"(4) fairaudit audit on {n:,} records")
        r = time_command(audit_command(f)[0], n, c, repeats, slow, timeout)
        f.unlink()
        r.update(n=n, file=size)
        points.append(r)
        if "error" not in r:
            previous = (n, r["rss"])
    path.unlink(missing_ok=True)
    return rec, points


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--quick", action="store_true", help="tiny sizes, one repeat, a few seconds (smoke test)")
    parser.add_argument("--output", metavar="FILE.md", help="also write the Markdown report here (atomically)")
    parser.add_argument("--plot", metavar="FILE", help="write the scaling curves (.svg or .png) here (atomically)")
    parser.add_argument("--seed", type=int, default=20250607, help="seed of the laws, counts and records")
    parser.add_argument(
        "--workdir",
        metavar="DIR",
        help="where the Parquet files go (a temporary folder inside it, "
        "deleted at the end; default the system's temporary folder)",
    )
    parser.add_argument("--max-records", type=int, metavar="N", help="largest number of records of (2) and (4)")
    parser.add_argument("--max-contexts", type=int, metavar="N", help="largest number of contexts of (1), (3), (4)")
    parser.add_argument(
        "--step-timeout",
        type=float,
        metavar="SECONDS",
        help="time limit of each guarded step (default 1800, quick 120)",
    )
    args = parser.parse_args(argv)
    if args.plot and Path(args.plot).suffix.lower() not in (".svg", ".png"):
        parser.error(f"--plot must end in .svg or .png: {args.plot}")
    for name in ("max_records", "max_contexts"):
        value = getattr(args, name)
        if value is not None and value < 1:
            parser.error(f"--{name.replace('_', '-')} must be at least 1: {value}")
    if args.workdir and not Path(args.workdir).is_dir():
        parser.error(f"--workdir is not a folder: {args.workdir}")
    report, failures, series = run(args)
    emit(report, args.output)
    if args.plot:
        write_plot(args.plot, series)
    for f in failures:
        print(f"FAIL: {f}", file=sys.stderr)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
