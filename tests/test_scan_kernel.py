"""The compiled pass over a law (``fairaudit._scan_kernel``, numba) gives the numpy pass's numbers, bit for bit.

Every result of :func:`~fairaudit.metrics.all_metrics` is compared between the two routes: values and ratios as
``float.hex`` (NaN as NaN), the maximising context, groups, decision and event, the notes, and the arrays
(``numpy.array_equal`` with the sign of zeros). The compiled route is forced on small tables
(``MIN_CELLS = 0``); a counter shows that it ran.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

pytest.importorskip("numba", reason="the compiled pass needs numba (pip install 'fairaudit[fast]')")

import fairaudit  # noqa: E402
from fairaudit import _scan_kernel as kernel  # noqa: E402
from fairaudit.laws import Law, Population  # noqa: E402
from fairaudit.metrics import all_metrics, expected_utility, local_fairness  # noqa: E402


@pytest.fixture(autouse=True)
def _small_tables_too(monkeypatch):
    """Send every table to the compiled kernel (it normally waits for 2^20 cells)."""
    monkeypatch.setattr(kernel, "MIN_CELLS", 0)
    monkeypatch.setattr(kernel, "ENABLED", True)


def _number(x: float) -> str:
    return "nan" if math.isnan(x) else float(x).hex()


def _same_array(a: np.ndarray | None, b: np.ndarray | None) -> bool:
    if a is None or b is None:
        return a is None and b is None
    return a.shape == b.shape and np.array_equal(a, b, equal_nan=True) and np.array_equal(np.signbit(a), np.signbit(b))


def _fields(result: object) -> dict:
    """Everything a metric result reports, numbers as hex."""
    out = {}
    for name in ("kind", "context", "group", "other_group", "event", "decision", "excluded"):
        if hasattr(result, name):
            out[name] = getattr(result, name)
    for name in ("value", "ratio"):
        if hasattr(result, name):
            out[name] = _number(getattr(result, name))
    return out


def _routes(law: Law, g: fairaudit.Utility, pop: Population | None, threads: int | None = None) -> tuple:
    """all_metrics by numpy, then by the compiled kernel (which must have run when it applies)."""
    kernel.ENABLED = False
    by_numpy = all_metrics(law, g, pop)
    kernel.ENABLED, kernel.THREADS = True, threads
    try:
        before = kernel.runs()
        compiled = all_metrics(law, g, pop)
        ran = kernel.runs() - before
    finally:
        kernel.THREADS = None
    return by_numpy, compiled, ran


def _assert_same(by_numpy: dict, compiled: dict) -> None:
    assert by_numpy.keys() == compiled.keys()
    for key in by_numpy:
        a, b = by_numpy[key], compiled[key]
        assert _fields(a) == _fields(b), key
        for name in ("expected_utility", "per_context"):
            if hasattr(a, name):
                assert _same_array(getattr(a, name), getattr(b, name)), (key, name)


def _applies(law: Law, g: fairaudit.Utility) -> bool:
    return law.complete and law.shape[1] >= 2 and g.values.ndim == 1


# --------------------------------------------------------------------------- random laws
@st.composite
def cases(draw: st.DrawFn) -> tuple[Law, fairaudit.Utility, Population | None]:
    """A law with ties, exact zeros and repeated rows, a utility over decisions, a population (or the default)."""
    X = draw(st.integers(1, 30))
    A = draw(st.sampled_from([1, 2, 2, 3, 4, 5, 7, 8, 9]))
    K = draw(st.sampled_from([1, 2, 2, 3, 4, 5, 8, 9]))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    style = draw(st.sampled_from(["exponential", "zeros", "ties", "same rows", "one-hot"]))
    if style == "ties":
        q = rng.integers(0, 3, (X, A, K)).astype(float)
    elif style == "one-hot":
        q = np.eye(K)[rng.integers(0, K, (X, A))]
    else:
        q = rng.standard_exponential((X, A, K)) * (rng.random((X, A, K)) < (0.6 if style == "zeros" else 1.0))
        if style == "same rows":
            q[:, 1:] = q[:, :1]
    q[..., 0] += q.sum(-1) == 0
    law = Law(q / q.sum(-1, keepdims=True), range(X), [f"a{i}" for i in range(A)], list(range(K)))
    g = draw(st.sampled_from(["indicator", "general", "zeros", "ones", "all zero"]))
    values = {
        "indicator": np.eye(K)[rng.integers(K)],
        "general": rng.random(K),
        "zeros": rng.random(K) * (rng.random(K) < 0.5),
        "ones": np.ones(K),
        "all zero": np.zeros(K),
    }[g]
    kind = draw(st.sampled_from(["default", "uniform", "random", "zero group", "zero context"]))
    pop = None if kind == "default" else Population.uniform(range(X), law.groups)
    if kind in ("random", "zero group", "zero context"):
        p = rng.standard_exponential((X, A)) * (rng.random((X, A)) < 0.8)
        if kind == "zero group":
            p[:, rng.integers(A)] = 0.0
        if kind == "zero context":
            p[rng.integers(X)] = 0.0
        p[0, 0] += p.sum() == 0
        pop = Population(p / p.sum(), range(X), law.groups)
    return law, fairaudit.from_table(values, list(range(K))), pop


@given(cases())
def test_both_routes_give_the_same_metrics(case):
    law, g, pop = case
    by_numpy, compiled, ran = _routes(law, g, pop)
    assert ran == _applies(law, g)
    _assert_same(by_numpy, compiled)


@given(cases(), st.integers(1, 3))
def test_the_numbers_do_not_depend_on_the_threads(case, threads):
    law, g, pop = case
    by_numpy, compiled, _ = _routes(law, g, pop, threads)
    _assert_same(by_numpy, compiled)


@pytest.mark.parametrize("threads", [1, 2, 3])
@pytest.mark.parametrize("shape", [(20_000, 2, 2), (3000, 3, 5), (2500, 8, 4), (32_769, 2, 1), (16_385, 2, 2)])
def test_many_chunks_and_threads(shape, threads):
    """Tables of several chunks of contexts: the group law and the group means are added chunk after chunk.

    (32 769 x 2 x 1 and 16 385 x 2 x 2: a last chunk of one context, the contexts read from a padded copy at the
    table's end then start in the chunk before.)
    """
    rng = np.random.default_rng(list(shape))
    X, A, K = shape
    q = rng.standard_exponential(shape) * (rng.random(shape) < 0.7)
    q[..., 0] += q.sum(-1) == 0
    law = Law(q / q.sum(-1, keepdims=True), range(X), [f"a{i}" for i in range(A)], list(range(K)))
    p = rng.standard_exponential((X, A))
    pop = Population(p / p.sum(), range(X), law.groups)
    g = fairaudit.from_table(rng.random(K) * (rng.random(K) < 0.7), list(range(K)))
    by_numpy, compiled, ran = _routes(law, g, pop, threads)
    assert ran == 1
    _assert_same(by_numpy, compiled)


# --------------------------------------------------------------------------- when it runs
def test_a_hand_checked_example_by_the_kernel():
    """Two contexts, groups a and b, decisions yes and no: every number can be checked by hand."""
    law = Law([[[0.2, 0.8], [0.6, 0.4]], [[0.5, 0.5], [0.5, 0.5]]], ["x0", "x1"], ["a", "b"], ["yes", "no"])
    pop = Population([[0.25, 0.25], [0.25, 0.25]], ["x0", "x1"], ["a", "b"])
    before = kernel.runs()
    m = all_metrics(law, fairaudit.indicator("yes", ["yes", "no"]), pop)
    assert kernel.runs() == before + 1
    assert m["local"].ratio == 0.6 / 0.2 and (m["local"].context, m["local"].group) == ("x0", "b")
    assert m["local"].expected_utility.tolist() == [[0.2, 0.6], [0.5, 0.5]]
    assert m["global"].expected_utility.tolist() == [0.5 * 0.2 + 0.5 * 0.5, 0.5 * 0.6 + 0.5 * 0.5]
    assert m["demographic_parity"].value == pytest.approx(0.2) and m["demographic_parity"].event == ("no",)
    assert m["equalized_odds"].value == pytest.approx(0.4) and m["equalized_odds"].context == "x0"
    assert m["sup_local"].ratio == 0.6 / 0.2 and m["sup_local"].decision == "yes"
    assert m["sup_global"].ratio == pytest.approx(0.55 / 0.35) and m["sup_global"].decision == "yes"


def test_other_cases_stay_on_numpy():
    """Empty cells, a utility by context and group, one group, a small table: the numpy pass, nothing compiled."""
    g = fairaudit.indicator(1, [0, 1])
    with_empty_cell = Law.from_counts([[[3, 1], [0, 0]], [[1, 1], [2, 2]]], ["x0", "x1"], ["a", "b"], [0, 1])
    one_group = Law([[[0.5, 0.5]], [[0.2, 0.8]]], ["x0", "x1"], ["a"], [0, 1])
    by_cell = fairaudit.from_table(np.full((2, 2, 2), 0.5), [0, 1], ["x0", "x1"], ["a", "b"])
    complete = Law([[[0.5, 0.5], [0.2, 0.8]]] * 2, ["x0", "x1"], ["a", "b"], [0, 1])
    before = kernel.runs()
    all_metrics(with_empty_cell, g)
    all_metrics(one_group, g)
    all_metrics(complete, by_cell)
    local_fairness(complete, g)  # (only all_metrics asks for everything)
    kernel.MIN_CELLS = 1 << 20
    all_metrics(complete, g)
    assert kernel.runs() == before


def test_the_switch_and_the_threshold():
    law = Law([[[0.5, 0.5], [0.2, 0.8]]] * 3, ["x0", "x1", "x2"], ["a", "b"], [0, 1])
    g = fairaudit.indicator(1, [0, 1])
    before = kernel.runs()
    kernel.ENABLED = False
    all_metrics(law, g)
    assert kernel.runs() == before
    kernel.ENABLED = True
    all_metrics(law, g)
    assert kernel.runs() == before + 1 and kernel.available()
    assert expected_utility(law, g).tolist() == [[0.5, 0.8]] * 3


def test_log_ratios_is_numpy_log_in_halves(monkeypatch):
    ratio = np.concatenate([np.random.default_rng(1).random(5000) * 9 + 1, [np.inf, np.nan, 1.0]])
    monkeypatch.setattr(kernel, "LOG_SPLIT", 16)
    monkeypatch.setattr(kernel, "THREADS", 2)
    assert _same_array(kernel.log_ratios(ratio), np.log(ratio))


@given(st.integers(1, 5000), st.integers(0, 2**32 - 1), st.floats(0.0, 1.2))
def test_candidates_read_only_some_chunks_and_find_the_same_contexts(n, seed, threshold):
    """TableScan.candidates (the equalized-odds bound, read chunk by chunk) equals the one pass it replaces."""
    from fairaudit._arrays import TableScan

    rng = np.random.default_rng(seed)
    scan = TableScan(np.zeros((n, 2, 2)), None, None, step=min(n, 64), extremes=True)
    scan.bottom_sum[:] = np.where(rng.random(n) < 0.05, np.nan, rng.random(n) ** 3)
    scan.tv_low[:] = rng.random(n)
    for i, start in enumerate(range(0, n, scan.step)):
        sl = slice(start, start + scan.step)
        scan.chunk_low[i], scan.chunk_bottom[i] = np.max(scan.tv_low[sl]), np.fmin.reduce(scan.bottom_sum[sl])
    valid = rng.random(n) < 0.9
    valid[0] = True  # (equalized_odds asks only when some context is valid)
    expected = np.flatnonzero(valid & (1.0 - scan.bottom_sum >= threshold))
    assert np.array_equal(scan.candidates(valid, 1.0, threshold), expected)
    assert scan.low_max(valid) == scan.tv_low[valid].max() and scan.low_max(valid | True) == scan.tv_low.max()


def test_off_by_default_and_turned_on_by_the_environment_or_the_function():
    """A one-shot command would pay numba's import: the kernel is opt-in (FAIRAUDIT_COMPILED=1, use_compiled_pass)."""
    import os
    import subprocess
    import sys

    code = "import fairaudit._scan_kernel as k; print(k.ENABLED)"
    env = {k: v for k, v in os.environ.items() if k != "FAIRAUDIT_COMPILED"}
    off = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    on = subprocess.run(
        [sys.executable, "-c", code], env={**env, "FAIRAUDIT_COMPILED": "1"}, capture_output=True, text=True, check=True
    )
    assert (off.stdout.strip(), on.stdout.strip()) == ("False", "True")
    from fairaudit.metrics import use_compiled_pass

    assert use_compiled_pass(False) is True and kernel.ENABLED is False  # (numba is here: it could run)
    assert use_compiled_pass(True) is True and kernel.ENABLED is True
