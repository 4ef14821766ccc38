"""An optional compiled pass over a decision table (numba): the numbers of :class:`~fairaudit._arrays.TableScan`.

:func:`compiled_scan` fills a :class:`~fairaudit._arrays.TableScan` in one pass over Q[x, a, u] with a kernel that
numba compiles (``pip install "fairaudit[fast]"``), on the CPUs available, instead of the numpy pass of
:meth:`~fairaudit._arrays.TableScan.chunk`. It gives the same doubles, bit for bit: every sum below adds its terms in
the numpy pass's order, every product and quotient is one IEEE operation, and maxima and minima are exact.

When it runs (else it returns False and the numpy pass runs; nothing is imported):

* :data:`ENABLED` is true, the table has at least :data:`MIN_CELLS` cells, and numba imports;
* the scan asks for everything :func:`~fairaudit.metrics.all_metrics` reads (E's ratio per context, the group
  means, the extremes per (x, u), the group law) with a utility g(u) over decisions and a population, and not E
  itself (all_metrics's results make E on first read): E is kept only where the group means need it;
* the law has no empty cell, two groups or more, and its table and the population are C-contiguous float64.

Other cases (empty cells, a utility g[x, a, u], one group) stay on the numpy pass.

Orders of summation, as in the numpy pass:

* E[g | x, a] = Σ_u Q[x, a, u] g(u) over the decisions with g(u) ≠ 0 (u = 0 alone when g = 0), in the order of
  the decisions, from the first product (a leading −0.0 adds nothing: x + (−0.0) = x for every x);
* Σ_u min_a Q[x, a, u] in the order of the decisions, from +0.0 (``numpy.add.reduce`` over axis 0);
* the group law Σ_x P(x | a) Q[x, a, u]: per chunk of contexts (the numpy pass's chunks, ``step`` long), the
  contexts one after the other from +0.0 (``einsum`` over the chunk), then the chunk sums one after the other;
* the group means Σ_x P(x | a) E[g | x, a]: all the contexts one after the other from +0.0 (the numpy pass's
  running total). The first thread adds its own contexts as it goes; the others' are added afterwards, in order,
  from their E (kept for them) and P(x, a) (:func:`_gm_tail`).

The threads take consecutive runs of whole chunks, so no result depends on their number.

How: per context, four groups at a time as one vector of four doubles (LLVM's ``<4 x double>``, written out with
numba intrinsics in :func:`_vector_operations`: numba's own vectorizer only handles innermost loops over contiguous
memory): the rows of four groups are loaded, transposed to four decisions, and combined lane by lane; the
per-context results of four contexts are finished together (:func:`_extremes`). Measured on two CPUs for 10^6
contexts x 8 groups x 4 decisions: every metric in three to four and a half reads of the table (``table.sum()``),
against some twenty-five by the numpy pass (``benchmarks/bench_law.py``). numba compiles the kernels on the first
large table (about six seconds) and caches them (about half a second to load, numba's import included).
"""

from __future__ import annotations

import functools
import os
import threading
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from concurrent.futures import ThreadPoolExecutor

    from ._arrays import TableScan

__all__ = [
    "ENABLED",
    "LOG_SPLIT",
    "MIN_CELLS",
    "THREADS",
    "available",
    "compiled_scan",
    "log_ratios",
    "runs",
    "threads",
    "use_compiled_pass",
]

ENABLED = os.environ.get("FAIRAUDIT_COMPILED", "") == "1"
"""Whether large scans go to the compiled kernel: off by default (``use_compiled_pass`` or the environment variable
``FAIRAUDIT_COMPILED=1`` turn it on). Importing numba takes about half a second and its first compilation about six
(cached afterwards): a one-shot command would lose time; a session that audits many large laws gains it back."""


def use_compiled_pass(enabled: bool = True) -> bool:
    """Send every large law's pass for all metrics to the compiled kernel (numba, ``pip install "fairaudit[fast]"``).

    The numbers are the same, bit for bit; every metric of a law of 10^6 contexts x 8 groups x 4 decisions takes
    three to five reads of the table instead of some twenty-five (``benchmarks/bench_law.py``). Worth it in a
    session that audits many large laws: numba's import costs about half a second and its first compilation about
    six seconds (cached on disk afterwards). Off by default; ``FAIRAUDIT_COMPILED=1`` turns it on too.

    Parameters
    ----------
    enabled : bool
        True to use the kernel where it applies (tables of at least :data:`MIN_CELLS` cells, complete laws, a
        utility g(u), two groups or more), False for the numpy pass everywhere.

    Returns
    -------
    bool
        Whether the kernel can run (numba imports); False means every pass stays on numpy.
    """
    global ENABLED
    ENABLED = bool(enabled)
    return available()


MIN_CELLS = 1 << 20
"""Smallest table (contexts x groups x decisions) sent to the compiled kernel: below, importing numba and
starting threads cost more than the pass saves (measured: 2^20 cells take about 10 ms by numpy)."""
THREADS: int | None = None
"""Threads of the compiled pass (None: one per CPU available, at most 8). The numbers do not depend on it."""
FIRST_SHARE = 0.87
"""The first thread's share of the chunks, relative to the others' (it also adds up the group means)."""
_RUNS = [0]


def runs() -> int:
    """How many scans the compiled kernel has made in this process (tests check that it ran)."""
    return _RUNS[0]


def available() -> bool:
    """True when numba imports (the compiled kernel can run)."""
    return _compiled() is not None


def compiled_scan(scan: TableScan, step: int) -> bool:
    """Fill ``scan`` (every result asked) by the compiled kernel; False, touching nothing, where it does not apply.

    ``step`` is the length of the numpy pass's chunks of contexts: the group law is summed per chunk of that
    length, as there.
    """
    q, pop = scan.q, scan.population
    if not ENABLED or q.size < MIN_CELLS or not _wants_all(scan) or pop is None or scan.g is None:
        return False
    if not (_plain_array(q, 3) and _plain_array(pop[0], 2) and _plain_array(pop[1], 1) and scan.g.ndim == 1):
        return False
    kernels = _compiled()
    if kernels is None:
        return False
    _run(kernels, scan, step)
    _RUNS[0] += 1
    return True


LOG_SPLIT = 1 << 18
"""Arrays at least this long are cut in two for :func:`log_ratios` (one half in a thread)."""


def log_ratios(ratio: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """``numpy.log(ratio)`` of a 1-D array, into ``out`` (it may be ``ratio``), without warnings; a long array in
    two halves on two threads (elementwise: the same numbers).

    The per-context log ratios of :func:`~fairaudit.metrics.local_fairness` (a million logs take milliseconds).
    """
    result = np.empty(ratio.shape) if out is None else out

    def part(lo: int, hi: int) -> None:
        with np.errstate(divide="ignore", invalid="ignore"):
            np.log(ratio[lo:hi], out=result[lo:hi])

    n = len(ratio)
    if n < LOG_SPLIT or threads() < 2:
        part(0, n)
        return result
    future = _pool(2).submit(part, n // 2, n)
    part(0, n // 2)
    future.result()
    return result


def _wants_all(scan: TableScan) -> bool:
    """The scan asks for everything all_metrics reads (not E), on a law with no empty cell and two groups or more."""
    parts = (scan.ratio, scan.group_mean, scan.sup_ratio, scan.tv_low, scan.bottom_sum, scan.group_law)
    return scan.e is None and scan.observed is None and scan.q.shape[1] >= 2 and all(p is not None for p in parts)


def _plain_array(a: np.ndarray, ndim: int) -> bool:
    return a.ndim == ndim and a.dtype == np.float64 and a.flags.c_contiguous and a.dtype.isnative


def threads() -> int:
    """The threads of a large compiled pass: :data:`THREADS`, else one per CPU available to this process, at most 8."""
    if THREADS is not None:
        return max(1, THREADS)
    cpus = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    return max(1, min(cpus, 8))


def _threads(chunks: int) -> int:
    return min(threads(), chunks)


_POOL: list[ThreadPoolExecutor] = []
_POOL_PID = [0]
_LOCK = threading.RLock()  # the pool and the compilation are made once, by one thread


def _pool(workers: int) -> ThreadPoolExecutor:
    """A thread pool of at least ``workers`` threads, made once per process (the kernels release the GIL).

    A forked child gets a new one: its parent's threads do not run in it.
    """
    from concurrent.futures import ThreadPoolExecutor

    with _LOCK:
        if not _POOL or _POOL_PID[0] != os.getpid() or _POOL[0]._max_workers < workers:
            _POOL[:] = [ThreadPoolExecutor(workers, thread_name_prefix="fairaudit-scan")]
            _POOL_PID[0] = os.getpid()
        return _POOL[0]


def _constants(g: np.ndarray, p_group: np.ndarray, A: int, K: int) -> np.ndarray:
    """What the kernels read per quad of groups and per block of four decisions, in one array.

    Per group, padded to a multiple of four (``Ap`` entries each): P(a) (1.0 past the last group), then 1.0 where
    P(a) > 0 (P(x | a) = 0 where P(a) = 0, as :func:`~fairaudit._arrays.group_weights`), then 1.0 for a real group.
    Then per block of four decisions (8 entries each): g(u), then 1.0 where the term Q g(u) is added to E (g(u) ≠ 0,
    or u = 0 when g = 0: the numpy pass's ``terms``).
    """
    blocks, Ap = (K + 3) // 4, (A + 3) // 4 * 4
    c = np.zeros(3 * Ap + 8 * blocks + 4)
    c[:Ap] = 1.0
    c[:A] = p_group
    c[Ap : Ap + A] = p_group > 0
    c[2 * Ap : 2 * Ap + A] = 1.0
    terms = np.flatnonzero(g) if np.any(g) else np.array([0])
    u = np.arange(K)
    c[3 * Ap + 8 * (u // 4) + u % 4] = g
    c[3 * Ap + 8 * (terms // 4) + 4 + terms % 4] = 1.0
    return c


def _run(kernels: dict[str, Callable[..., Any]], scan: TableScan, step: int) -> None:
    """The pass: consecutive runs of chunks on the threads, then the group means and law added in order."""
    assert scan.population is not None and scan.g is not None and scan.ratio is not None
    assert scan.sup_ratio is not None and scan.tv_low is not None and scan.bottom_sum is not None
    assert scan.group_mean is not None and scan.group_law is not None
    assert scan.chunk_low is not None and scan.chunk_bottom is not None
    q, (joint, p_group) = scan.q, scan.population
    X, A, K = q.shape
    step = max(1, min(step, X))
    chunks = -(-X // step)
    consts = _constants(scan.g, p_group, A, K)
    Ap = (A + 3) // 4 * 4
    gm = np.zeros(Ap + 4)
    chunk_sums = np.empty((chunks, A, K))
    qf, pf = q.reshape(-1), joint.reshape(-1)
    outs = (scan.ratio, scan.sup_ratio, scan.tv_low, scan.bottom_sum)
    n_threads = _threads(chunks)
    # consecutive runs of whole chunks; the first thread also adds up the group means (about an eighth more work)
    shares = np.cumsum([0.0, FIRST_SHARE] + [1.0] * (n_threads - 1))
    bounds = [int(round(chunks * v / shares[-1])) for v in shares]
    x_tail = min(X, bounds[1] * step)  # the contexts after the first thread's: their E is kept for the group means
    ef = np.empty((X - x_tail) * A)  # (rows from x_tail)

    per_chunk = (chunk_sums, scan.chunk_low, scan.chunk_bottom)

    def part(i: int) -> None:
        kernels["_kernel"](
            qf, pf, X, A, K, consts, step, bounds[i], bounds[i + 1], ef, x_tail, *outs, gm, per_chunk, i == 0
        )

    kernels["_kernel"](qf, pf, X, A, K, consts, step, 0, 0, ef, x_tail, *outs, gm, per_chunk, True)  # compiles or loads
    if n_threads == 1:
        part(0)
    else:
        for future in [_pool(n_threads).submit(part, i) for i in range(n_threads)]:
            future.result()
    kernels["_sum_chunks"](chunk_sums, scan.group_law)
    group_mean = scan.group_mean

    def finish() -> None:  # the other threads' contexts, added to the first one's group means in order
        kernels["_gm_tail"](ef, pf, X, A, consts, x_tail, gm)
        group_mean[:] = gm[:A]

    if n_threads == 1:
        finish()
    else:  # in a thread, while the metrics read the rest (TableScan.wait)
        scan.pending = _pool(n_threads).submit(finish)


def _compiled() -> dict[str, Callable[..., Any]] | None:
    """The compiled kernels (:func:`_compile`, once, by one thread), or None without numba."""
    with _LOCK:
        return _compile()


@functools.cache
def _compile() -> dict[str, Callable[..., Any]] | None:
    """The compiled kernels, or None without numba.

    numba is imported here, on the first large scan. The kernel functions below are plain Python until then: this
    replaces them, and the vector operations they call, by numba's compiled versions (loaded from numba's cache
    after the first run: ``__pycache__`` beside this file, or the user's cache directory when that is not writable).
    """
    try:
        import numba
    except ImportError:
        return None
    names = globals()
    names.update(_vector_operations())
    jit = functools.partial(numba.njit, cache=True, nogil=True, error_model="numpy", boundscheck=False)
    for name in ("_quads", "_first_block", "_extremes", "_chunk_extremes"):  # helpers, inlined into _kernel
        names[name] = jit(inline="always")(names[name])
    return {name: jit(names[name]) for name in ("_kernel", "_gm_tail", "_sum_chunks")}


def _vector_operations() -> dict[str, Any]:
    """Operations on four float64 lanes for the kernels: a numba type whose LLVM value is ``<4 x double>``.

    numba's own vectorizer works on innermost loops over contiguous memory; here the vectors run across four
    groups (or four decisions, or four contexts) inside the loop over contexts, so they are written out. Each
    operation is one LLVM vector instruction (IEEE, lane by lane): the same doubles as the scalar ones.
    """
    from llvmlite import ir
    from numba import types
    from numba.extending import models, register_model

    class Vec4(types.Type):
        def __init__(self) -> None:
            super().__init__(name="fairaudit.Vec4")

    vec = Vec4()
    register_model(Vec4)(lambda dmm, fe_type: models.PrimitiveModel(dmm, fe_type, ir.VectorType(ir.DoubleType(), 4)))
    return {**_lane_operations(vec), **_memory_operations(vec)}


def _ir() -> Any:
    """llvmlite's IR module (imported with numba)."""
    from llvmlite import ir

    return ir


def _v4(values: list[float] | None = None) -> Any:
    """The LLVM type ``<4 x double>``, or a constant of it."""
    ir = _ir()
    t = ir.VectorType(ir.DoubleType(), 4)
    return t if values is None else ir.Constant(t, values)


def _ratio_ir(b: Any, hi: Any, lo: Any) -> Any:
    """hi / lo with 0/0 = 1 and c/0 = inf, lane by lane (:func:`~fairaudit._arrays.ratio_of_extremes`)."""
    r = b.select(b.fcmp_ordered("==", lo, _v4([0.0] * 4)), _v4([np.inf] * 4), b.fdiv(hi, lo))
    return b.select(b.fcmp_ordered("==", hi, _v4([0.0] * 4)), _v4([1.0] * 4), r)


def _lane_operations(vec: Any) -> dict[str, Any]:
    """Arithmetic, maxima and minima, selection, broadcast, one lane, and the 4 x 4 transpose."""
    ir = _ir()
    from numba import types
    from numba.extending import intrinsic

    i32 = ir.IntType(32)
    i4 = ir.VectorType(i32, 4)

    def lanewise(build: Callable[[Any, Any, Any], Any]) -> Any:
        def typer(ctx: Any, x: Any, y: Any) -> Any:
            if x != vec or y != vec:
                return None
            return vec(x, y), lambda context, builder, sig, args: build(builder, *args)

        return intrinsic(typer)

    @intrinsic
    def vsplat(ctx: Any, x: Any) -> Any:
        """(x, x, x, x)."""
        if not isinstance(x, types.Float):
            return None

        def codegen(c: Any, b: Any, sig: Any, a: Any) -> Any:
            one = b.insert_element(ir.Constant(_v4(), ir.Undefined), a[0], i32(0))
            return b.shuffle_vector(one, one, ir.Constant(i4, [0] * 4))

        return vec(x), codegen

    @intrinsic
    def vlane(ctx: Any, v: Any, i: Any) -> Any:
        """v[i]."""
        if v != vec or not isinstance(i, types.Integer):
            return None
        return types.float64(v, i), lambda c, b, sig, a: b.extract_element(a[0], a[1])

    @intrinsic
    def vsel(ctx: Any, cond: Any, x: Any, y: Any) -> Any:
        """x where the vector ``cond`` is not 0.0, else y, lane by lane."""
        if cond != vec or x != vec or y != vec:
            return None
        return vec(cond, x, y), lambda c, b, sig, a: b.select(b.fcmp_unordered("!=", a[0], _v4([0.0] * 4)), a[1], a[2])

    @intrinsic
    def vtranspose(ctx: Any, r0: Any, r1: Any, r2: Any, r3: Any) -> Any:
        """Rows to columns: the l-th result holds lane l of r0, r1, r2, r3."""
        if any(r != vec for r in (r0, r1, r2, r3)):
            return None
        ret = types.UniTuple(vec, 4)

        def codegen(c: Any, b: Any, sig: Any, a: Any) -> Any:
            i8 = ir.VectorType(i32, 8)
            low, high = (b.shuffle_vector(a[k], a[k + 1], ir.Constant(i8, list(range(8)))) for k in (0, 2))
            out = ir.Constant(c.get_value_type(ret), ir.Undefined)
            for lane in range(4):
                column = b.shuffle_vector(low, high, ir.Constant(i4, [lane + 4 * k for k in range(4)]))
                out = b.insert_value(out, column, lane)
            return out

        return ret(r0, r1, r2, r3), codegen

    return {
        "vmax": lanewise(lambda b, x, y: b.select(b.fcmp_ordered(">", x, y), x, y)),
        "vmin": lanewise(lambda b, x, y: b.select(b.fcmp_ordered("<", x, y), x, y)),
        "vadd": lanewise(lambda b, x, y: b.fadd(x, y)),
        "vsub": lanewise(lambda b, x, y: b.fsub(x, y)),
        "vmul": lanewise(lambda b, x, y: b.fmul(x, y)),
        "vdiv": lanewise(lambda b, x, y: b.fdiv(x, y)),
        "vratio": lanewise(_ratio_ir),
        "vsplat": vsplat,
        "vlane": vlane,
        "vsel": vsel,
        "vtranspose": vtranspose,
    }


def _memory_operations(vec: Any) -> dict[str, Any]:
    """Loads and stores of four lanes at a flat index of a C-contiguous float64 array (no bounds check).

    The ``_n`` forms touch only the first n lanes (masked: nothing read or written past them); the plain ones are
    used wherever the four lanes are inside the array (masked stores are slow on some CPUs).
    """
    ir = _ir()
    from numba import types
    from numba.core import cgutils
    from numba.extending import intrinsic

    i32 = ir.IntType(32)
    i4 = ir.VectorType(i32, 4)

    def address(c: Any, b: Any, arrty: Any, arr: Any, start: Any) -> Any:
        return b.bitcast(b.gep(c.make_array(arrty)(c, b, arr).data, [start]), _v4().as_pointer())

    def first_lanes(b: Any, n: Any) -> Any:  # <4 x i1>: lane < n
        n32 = b.trunc(n, i32) if n.type.width > 32 else n
        splat = b.shuffle_vector(
            b.insert_element(ir.Constant(i4, ir.Undefined), n32, i32(0)),
            ir.Constant(i4, ir.Undefined),
            ir.Constant(i4, [0] * 4),
        )
        return b.icmp_signed("<", ir.Constant(i4, [0, 1, 2, 3]), splat)

    def masked(b: Any, name: str, ret: Any, args: list[Any]) -> Any:
        fnty = ir.FunctionType(ret, [a.type for a in args])
        return b.call(cgutils.get_or_insert_function(b.module, fnty, name), args)

    def typed(arr: Any, start: Any, *rest: Any) -> bool:
        row = isinstance(arr, types.Array) and arr.dtype == types.float64 and arr.ndim == 1 and arr.layout == "C"
        return row and isinstance(start, types.Integer) and all(r == vec or isinstance(r, types.Integer) for r in rest)

    @intrinsic
    def vload(ctx: Any, arr: Any, start: Any) -> Any:
        if not typed(arr, start):
            return None
        return vec(arr, start), lambda c, b, sig, a: b.load(address(c, b, sig.args[0], a[0], a[1]), align=8)

    @intrinsic
    def vload_n(ctx: Any, arr: Any, start: Any, n: Any) -> Any:
        if not typed(arr, start, n) or n == vec:
            return None

        def codegen(c: Any, b: Any, sig: Any, a: Any) -> Any:
            args = [address(c, b, sig.args[0], a[0], a[1]), i32(8), first_lanes(b, a[2]), _v4([0.0] * 4)]
            return masked(b, "llvm.masked.load.v4f64.p0", _v4(), args)

        return vec(arr, start, n), codegen

    @intrinsic
    def vstore(ctx: Any, arr: Any, start: Any, v: Any) -> Any:
        if not typed(arr, start, v) or v != vec:
            return None

        def codegen(c: Any, b: Any, sig: Any, a: Any) -> Any:
            b.store(a[2], address(c, b, sig.args[0], a[0], a[1]), align=8)
            return c.get_dummy_value()

        return types.void(arr, start, v), codegen

    @intrinsic
    def vstore_n(ctx: Any, arr: Any, start: Any, v: Any, n: Any) -> Any:
        if not typed(arr, start, v, n) or v != vec or n == vec:
            return None

        def codegen(c: Any, b: Any, sig: Any, a: Any) -> Any:
            args = [a[2], address(c, b, sig.args[0], a[0], a[1]), i32(8), first_lanes(b, a[3])]
            masked(b, "llvm.masked.store.v4f64.p0", ir.VoidType(), args)
            return c.get_dummy_value()

        return types.void(arr, start, v, n), codegen

    return {"vload": vload, "vload_n": vload_n, "vstore": vstore, "vstore_n": vstore_n}


# --------------------------------------------------------------------------- the kernels (compiled by _compiled)
# Plain Python until _compiled() replaces them and these placeholders (the vector operations) by numba's versions.
# Layout of ``consts`` (see _constants): per group padded to a multiple of four, P(a), then 1.0 where P(a) > 0, then
# 1.0 for a real group (Ap entries each); then per block of four decisions, g(u) and 1.0 where Q g(u) is added to E.
vload: Any = None
vload_n: Any = None
vstore: Any = None
vstore_n: Any = None
vsplat: Any = None
vlane: Any = None
vsel: Any = None
vtranspose: Any = None
vmax: Any = None
vmin: Any = None
vadd: Any = None
vsub: Any = None
vmul: Any = None
vdiv: Any = None
vratio: Any = None
_NEG0 = -0.0  # x + (-0.0) = x for every x, +0.0 and -0.0 included: the start of E's sum
_INF = np.inf


def _quads(qa, qo, pa, po, x, slot, A, K, Ap, consts, first, acc, epart, gm, own_gm, e, store_e, scratch):  # type: ignore[no-untyped-def]
    """One context (its rows of Q from ``qa[qo:]``, P(x, a) from ``pa[po:]``), four groups at a time.

    Adds Q[x, a, u] P(x | a) to the chunk's group law ``acc`` ((4 blocks, Ap), decision-major), writes
    E[g | x, a] to row ``x`` of ``e`` when ``store_e`` (and adds P(x | a) E to the group means ``gm`` when
    ``own_gm``), and leaves the context's
    max and min over groups of Q[x, a, u] (per block of four decisions) and of E in ``scratch``'s ``slot``.
    Rows past the last group repeat the last one (max and min unchanged) and weigh 0; lanes past the last
    decision are never read back. The rows read past the context's end stay inside the table (see _kernel).
    ``first``: g(u) and the terms of the first block of decisions, read once per chunk (:func:`_first_block`).
    """
    blocks = (K + 3) // 4
    hi_e = vsplat(-_INF)
    lo_e = vsplat(_INF)
    for ub in range(blocks):
        u = 4 * ub
        g0, g1, g2, g3, m0, m1, m2, m3 = first if ub == 0 else _first_block(consts, 3 * Ap + 8 * ub)
        top = vload(qa, qo + u)
        bottom = top
        for a0 in range(0, A, 4):
            rest = A - a0
            o = qo + a0 * K + u
            d1 = K if rest > 1 else 0
            d2 = 2 * K if rest > 2 else d1
            d3 = 3 * K if rest > 3 else d2
            r0, r1, r2, r3 = vload(qa, o), vload(qa, o + d1), vload(qa, o + d2), vload(qa, o + d3)
            top = vmax(vmax(top, r0), vmax(vmax(r1, r2), r3))
            bottom = vmin(vmin(bottom, r0), vmin(vmin(r1, r2), r3))
            c0, c1, c2, c3 = vtranspose(r0, r1, r2, r3)  # c_l: decision u + l of the four groups
            E = vsplat(_NEG0) if ub == 0 else vload(epart, a0)
            if m0:  # the terms of E in the order of the decisions (a term with g(u) = 0 is left out)
                E = vadd(E, vmul(c0, g0))
            if m1:
                E = vadd(E, vmul(c1, g1))
            if m2:
                E = vadd(E, vmul(c2, g2))
            if m3:
                E = vadd(E, vmul(c3, g3))
            w = vsel(vload(consts, Ap + a0), vdiv(vload(pa, po + a0), vload(consts, a0)), vsplat(0.0))  # P(x | a)
            j = u * Ap + a0
            vstore(acc, j, vadd(vload(acc, j), vmul(c0, w)))
            vstore(acc, j + Ap, vadd(vload(acc, j + Ap), vmul(c1, w)))
            vstore(acc, j + 2 * Ap, vadd(vload(acc, j + 2 * Ap), vmul(c2, w)))
            vstore(acc, j + 3 * Ap, vadd(vload(acc, j + 3 * Ap), vmul(c3, w)))
            if ub < blocks - 1:
                vstore(epart, a0, E)  # E so far, for the next block of decisions
                continue
            if rest >= 4:
                if store_e:
                    vstore(e, x * A + a0, E)
                hi_e, lo_e = vmax(hi_e, E), vmin(lo_e, E)
            else:  # (scalar stores: a masked store is slow on some CPUs)
                if store_e:
                    e[x * A + a0] = vlane(E, 0)
                    if rest > 1:
                        e[x * A + a0 + 1] = vlane(E, 1)
                    if rest > 2:
                        e[x * A + a0 + 2] = vlane(E, 2)
                real = vload(consts, 2 * Ap + a0)
                hi_e, lo_e = vmax(hi_e, vsel(real, E, vsplat(-_INF))), vmin(lo_e, vsel(real, E, vsplat(_INF)))
            if own_gm:
                vstore(gm, a0, vadd(vload(gm, a0), vmul(w, E)))
        s = (slot * blocks + ub) * 8
        vstore(scratch, s, top)
        vstore(scratch, s + 4, bottom)
    s = (4 * blocks + slot) * 8
    vstore(scratch, s, hi_e)
    vstore(scratch, s + 4, lo_e)


def _first_block(consts, cg):  # type: ignore[no-untyped-def]
    """g(u) of a block of four decisions as four vectors, and whether each term is added to E."""
    g = (vsplat(consts[cg]), vsplat(consts[cg + 1]), vsplat(consts[cg + 2]), vsplat(consts[cg + 3]))
    return g + (consts[cg + 4] != 0.0, consts[cg + 5] != 0.0, consts[cg + 6] != 0.0, consts[cg + 7] != 0.0)


def _extremes(x0, n, K, scratch, ratio, sup_ratio, tv_low, bottom_sum):  # type: ignore[no-untyped-def]
    """The per-context results of contexts x0 .. x0 + n - 1 (n <= 4) from ``scratch``, the four as one vector.

    ratio: max over groups of E / min (:func:`~fairaudit._arrays.ratio_of_extremes`); sup_ratio: max over u of
    max_a Q / min_a Q; tv_low: max over u < K - 1 of max_a Q - min_a Q (0 for K = 1); bottom_sum: Σ_u min_a Q,
    from +0.0 in the order of the decisions.
    """
    blocks = (K + 3) // 4
    sr = vsplat(-_INF)
    tv = vsplat(0.0)
    bs = vsplat(0.0)
    for ub in range(blocks):
        s0, s1, s2, s3 = 8 * ub, 8 * (blocks + ub), 8 * (2 * blocks + ub), 8 * (3 * blocks + ub)
        t0, t1, t2, t3 = vtranspose(vload(scratch, s0), vload(scratch, s1), vload(scratch, s2), vload(scratch, s3))
        b0, b1, b2, b3 = vtranspose(
            vload(scratch, s0 + 4), vload(scratch, s1 + 4), vload(scratch, s2 + 4), vload(scratch, s3 + 4)
        )
        u = 4 * ub
        sr, bs = vmax(sr, vratio(t0, b0)), vadd(bs, b0)
        if u + 1 < K:
            tv, sr, bs = vmax(tv, vsub(t0, b0)), vmax(sr, vratio(t1, b1)), vadd(bs, b1)
        if u + 2 < K:
            tv, sr, bs = vmax(tv, vsub(t1, b1)), vmax(sr, vratio(t2, b2)), vadd(bs, b2)
        if u + 3 < K:
            tv, sr, bs = vmax(tv, vsub(t2, b2)), vmax(sr, vratio(t3, b3)), vadd(bs, b3)
        if u + 4 < K:
            tv = vmax(tv, vsub(t3, b3))
    s = 4 * blocks * 8
    h0, h1, h2, h3 = vtranspose(
        vload(scratch, s), vload(scratch, s + 8), vload(scratch, s + 16), vload(scratch, s + 24)
    )
    l0, l1, l2, l3 = vtranspose(
        vload(scratch, s + 4), vload(scratch, s + 12), vload(scratch, s + 20), vload(scratch, s + 28)
    )
    r = vratio(vmax(vmax(h0, h1), vmax(h2, h3)), vmin(vmin(l0, l1), vmin(l2, l3)))
    if n == 4:  # (a masked store is slow on some CPUs: only at the end of a chunk)
        vstore(ratio, x0, r)
        vstore(sup_ratio, x0, sr)
        vstore(tv_low, x0, tv)
        vstore(bottom_sum, x0, bs)
    else:
        vstore_n(ratio, x0, r, n)
        vstore_n(sup_ratio, x0, sr, n)
        vstore_n(tv_low, x0, tv, n)
        vstore_n(bottom_sum, x0, bs, n)


def _kernel(  # type: ignore[no-untyped-def]
    qf, pf, X, A, K, consts, step, c_lo, c_hi, e, e_lo, ratio, sup_ratio, tv_low, bottom_sum, gm, chunks, own_gm
):
    """Chunks c_lo .. c_hi - 1 of contexts (``step`` each): E, the per-context results, each chunk's group law.

    ``chunks`` is (group law sums, largest tv_low, smallest bottom_sum), one entry per chunk each. E[g | x, a] is
    written to row x - ``e_lo`` of ``e`` unless ``own_gm`` (the first thread adds its contexts to the group means
    as it goes; ``e`` holds the contexts from ``e_lo`` on, the others').

    Vector loads read up to three rows and three decisions past a context's end: the last contexts of the table
    are read from zero-padded copies (``tail``) so that nothing is read past it.
    """
    blocks = (K + 3) // 4
    Ap = (A + 3) // 4 * 4
    AK = A * K
    acc = np.zeros(4 * blocks * Ap)
    epart = np.zeros(Ap)
    scratch = np.zeros((4 * blocks + 4) * 8)
    tail = 1 + ((Ap - A) * K + 4 * blocks + AK - 1) // AK  # contexts whose reads could pass the end
    x_fast = max(0, X - tail)
    qs = np.zeros(tail * AK + (Ap - A) * K + 4 * blocks + 4)
    ps = np.zeros(tail * A + Ap + 4)
    if c_hi > c_lo and c_hi * step > x_fast:  # (the tail may reach back into the chunks before the last)
        qs[: (X - x_fast) * AK] = qf[x_fast * AK :]
        ps[: (X - x_fast) * A] = pf[x_fast * A :]
    first = _first_block(consts, 3 * Ap)
    store_e = not own_gm
    for ci in range(c_lo, c_hi):
        start = ci * step
        stop = min(X, start + step)
        acc[:] = 0.0
        for x in range(start, min(stop, x_fast)):
            slot = (x - start) % 4
            _quads(
                qf,
                x * AK,
                pf,
                x * A,
                x - e_lo,
                slot,
                A,
                K,
                Ap,
                consts,
                first,
                acc,
                epart,
                gm,
                own_gm,
                e,
                store_e,
                scratch,
            )
            if slot == 3 or x == stop - 1:
                _extremes(x - slot, slot + 1, K, scratch, ratio, sup_ratio, tv_low, bottom_sum)
        for x in range(max(start, x_fast), stop):
            slot = (x - start) % 4
            t = x - x_fast
            _quads(
                qs,
                t * AK,
                ps,
                t * A,
                x - e_lo,
                slot,
                A,
                K,
                Ap,
                consts,
                first,
                acc,
                epart,
                gm,
                own_gm,
                e,
                store_e,
                scratch,
            )
            if slot == 3 or x == stop - 1:
                _extremes(x - slot, slot + 1, K, scratch, ratio, sup_ratio, tv_low, bottom_sum)
        chunk_sums, chunk_low, chunk_bottom = chunks
        for a in range(A):
            for u in range(K):
                chunk_sums[ci, a, u] = acc[u * Ap + a]
        chunk_low[ci], chunk_bottom[ci] = _chunk_extremes(tv_low, bottom_sum, start, stop)


def _chunk_extremes(tv_low, bottom_sum, start, stop):  # type: ignore[no-untyped-def]
    """The largest tv_low and the smallest bottom_sum of the contexts start .. stop - 1 (four at a time)."""
    hi, lo = vsplat(tv_low[start]), vsplat(bottom_sum[start])
    x = start
    while x + 4 <= stop:
        hi, lo = vmax(hi, vload(tv_low, x)), vmin(lo, vload(bottom_sum, x))
        x += 4
    top = max(max(vlane(hi, 0), vlane(hi, 1)), max(vlane(hi, 2), vlane(hi, 3)))
    bottom = min(min(vlane(lo, 0), vlane(lo, 1)), min(vlane(lo, 2), vlane(lo, 3)))
    for y in range(x, stop):
        top, bottom = max(top, tv_low[y]), min(bottom, bottom_sum[y])
    return top, bottom


def _gm_tail(e, pf, X, A, consts, x_lo, gm):  # type: ignore[no-untyped-def]
    """Add P(x | a) E[g | x, a] of the contexts x_lo .. X - 1 to the group means ``gm``, one context after the other.

    ``e`` holds E of those contexts only, from row 0.

    Eight groups at a time, their running sums in two vectors (a chain of additions per group, no store between).
    """
    Ap = (A + 3) // 4 * 4
    for a0 in range(0, A, 8):
        n0, n1 = min(4, A - a0), min(4, max(0, A - a0 - 4))
        b1 = min(a0 + 4, Ap - 4)  # (the second quad's constants: any real quad when there is no second quad)
        s0, s1 = vload(gm, a0), vload(gm, b1)
        p0, p1 = vload(consts, a0), vload(consts, b1)
        z0, z1 = vload(consts, Ap + a0), vload(consts, Ap + b1)
        zero = vsplat(0.0)
        safe = max(x_lo, min(X, (X * A - a0 - 8) // A + 1))  # contexts whose eight lanes are inside the arrays
        for x in range(x_lo, safe):  # plain loads: lanes past the last group weigh 0
            o, oe = x * A + a0, (x - x_lo) * A + a0
            s0 = vadd(s0, vmul(vsel(z0, vdiv(vload(pf, o), p0), zero), vload(e, oe)))
            s1 = vadd(s1, vmul(vsel(z1, vdiv(vload(pf, o + 4), p1), zero), vload(e, oe + 4)))
        for x in range(safe, X):  # the last ones: masked loads, nothing read past the end
            o, oe = x * A + a0, (x - x_lo) * A + a0
            s0 = vadd(s0, vmul(vsel(z0, vdiv(vload_n(pf, o, n0), p0), zero), vload_n(e, oe, n0)))
            s1 = vadd(s1, vmul(vsel(z1, vdiv(vload_n(pf, o + 4, n1), p1), zero), vload_n(e, oe + 4, n1)))
        vstore(gm, a0, s0)
        if n1 > 0:
            vstore(gm, a0 + 4, s1)


def _sum_chunks(chunk_sums, out):  # type: ignore[no-untyped-def]
    """out = the chunk sums added one after the other, from +0.0 (the numpy pass's running total)."""
    out[:] = 0.0
    for c in range(chunk_sums.shape[0]):
        out += chunk_sums[c]
