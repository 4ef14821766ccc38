"""Small cells: --min-count leaves cells out (listed, never silently), --by context, and the headline's note when
the cell that drives L is smaller than what the planner needs. Expected values by hand counts and from the planner
itself (a second route: plan() called directly with the documented arguments).
"""

from __future__ import annotations

import math

import pandas as pd
import pytest
from _cli import run, run_json

import fairaudit as fa
from fairaudit import InputError

# context p: a 6/8 selected, b 2/8; context q: a 3/3, b 0/2 (a small cell that drives L = inf)
ROWS = [("p", "a", 1)] * 6 + [("p", "a", 0)] * 2 + [("p", "b", 1)] * 2 + [("p", "b", 0)] * 6
ROWS += [("q", "a", 1)] * 3 + [("q", "b", 0)] * 2
FRAME = pd.DataFrame(ROWS, columns=["x", "g", "y"])


def test_min_count_leaves_cells_out_and_lists_them():
    full = fa.audit(FRAME, sensitive=["g"], outcome="y", context=["x"])
    assert full.observed.local_fairness.value == math.inf and full.observed.local_fairness.context == "q"
    cut = fa.audit(FRAME, sensitive=["g"], outcome="y", context=["x"], records=fa.RecordOptions(min_count=3))
    assert [(c.context, c.group, c.n) for c in cut.left_out] == [("q", "b", 2.0)]
    assert cut.observed.local_fairness.value == pytest.approx(math.log(3.0), rel=1e-15)  # (6/8) / (2/8) in context p
    assert cut.table.n == 19  # the two records left out of the population too
    d = cut.to_dict()
    assert d["min_count"] == 3 and d["left_out"] == [{"context": "q", "group": "b", "n": 2.0}]
    assert "cell (context 'q', group 'b'): 2 records, fewer than min_count 3: left out" in d["excluded"]
    with pytest.raises(InputError, match="^min_count: leaves group 'a' with no records"):
        fa.audit(FRAME, sensitive=["g"], outcome="y", context=["x"], records=fa.RecordOptions(min_count=9))
    with pytest.raises(InputError, match="^min_count"):
        fa.audit(FRAME, sensitive=["g"], outcome="y", records=fa.RecordOptions(min_count=0))


def test_by_context_by_hand():
    by = fa.audit(FRAME, sensitive=["g"], outcome="y", context=["x"]).by_context
    assert by.index.name == "x"
    assert by.loc["p", "n"] == 16 and by.loc["p", "value"] == pytest.approx(math.log(3.0), rel=1e-15)
    assert (by.loc["p", "group"], by.loc["p", "other_group"]) == ("a", "b")
    assert by.loc["q", "value"] == math.inf and by.loc["q", "ratio"] == math.inf


def test_small_cell_note_matches_the_planner():
    r = fa.audit(FRAME, sensitive=["g"], outcome="y", context=["x"])
    cell = r.small_cell
    assert (cell.context, cell.group, cell.n, cell.rate) == ("q", "b", 2.0, 0.99)  # rate 3/3, clipped
    assert cell.needed == fa.plan(math.log(2), groups=2, base_rate=0.99, confidence=0.95).n_per_cell > 2
    big = pd.DataFrame(ROWS * 300, columns=["x", "g", "y"])  # 600 records in the cell: q's L is still inf
    big_cell = fa.audit(big, sensitive=["g"], outcome="y", context=["x"]).small_cell
    assert big_cell is None or big_cell.n < big_cell.needed
    non_binary = fa.audit(FRAME, sensitive=["g"], outcome="y", context=["x"], utility="2 * u")
    assert non_binary.small_cell is None  # the planner counts 0/1 decisions only


def test_cli(tmp_path, capsys):
    path = tmp_path / "r.csv"
    FRAME.to_csv(path, index=False)
    args = ["audit", path, "--sensitive", "g", "--outcome", "y", "--context", "x"]
    code, report, err = run_json(capsys, *args, "--by", "context", "--min-count", "3")
    assert code == 0, err
    assert [(r["context"], r["n"], r["group"]) for r in report["by_context"]] == [("p", 16, "a"), ("q", 3, None)]
    # the small cell is left out: L is log 3, in context p, where b's 8 records are fewer than the planner's 35 (its exact power)
    assert report["small_cell"] == {
        "context": "p",
        "group": "b",
        "n": 8.0,
        "needed": 35,
        "rate": 0.75,
        "target": math.log(2),
    }
    code, out, _ = run(capsys, *args)
    assert "note: L is driven by cell (context q, group b) of 2 records, fewer than the" in out
    code, out, _ = run(capsys, *args, "--min-count", "3", "--by", "context")
    assert "note: left out, fewer than 3 records (--min-count): 1 cell: (context q, group b): 2" in out
    assert "L by context:" in out
    code, _, err = run(capsys, *args, "--min-count", "9")
    assert (code, err) == (2, "fairaudit: error: --min-count: leaves group 'a' with no records (got 9)\n")
