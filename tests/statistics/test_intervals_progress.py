"""The intervals behind a filter, a map at a time: the same ends as every map at once, and a progress bar on stderr
inside ``certify(progress=True)`` only."""

from __future__ import annotations

import numpy as np
from _spec_families import write_spec
from _terminal import lines_drawn, on_terminal

import fairaudit as fa
from fairaudit.base.threshold_rule import threshold_max_many
from fairaudit.metrics.box_extremes import mixed_ratio


def test_mixed_ratio_a_map_at_a_time_equals_every_map_at_once():
    rng = np.random.default_rng(3)
    for M, A, n in [(3, 5, 7), (1, 2, 1), (2, 1, 3), (4, 6, 12)]:
        W = rng.random((M, A, n)) * (rng.random((M, A, n)) < 0.7)
        lo = rng.random(n) * 0.3
        hi = lo + rng.random(n) * (rng.random(n) < 0.8)
        steps = []
        lower, upper, fav, other = mixed_ratio(W, lo, hi, {}, progress=lambda: steps.append(1))
        assert len(steps) == 2 * M  # (each map's upper end, then each map's lower end)
        # the route before: one threshold solution over every map's pairs at once
        vals = threshold_max_many(W[:, :, None, :], W[:, None, :, :], lo, hi)[0]
        vals = np.where(~np.eye(A, dtype=bool), vals, -np.inf).reshape(M, -1)
        idx = vals.argmax(-1)
        if A >= 2:
            np.testing.assert_array_equal(upper, vals[np.arange(M), idx])
        np.testing.assert_array_equal(fav, idx // A)
        np.testing.assert_array_equal(other, idx % A)
        steps.clear()
        assert np.isnan(mixed_ratio(W, lo, hi, {}, lower_end=False, progress=lambda: steps.append(1))[0]).all()
        assert len(steps) == M


def test_certify_draws_the_intervals_bar_on_stderr_when_asked(monkeypatch, tmp_path):
    # 6 groups behind randomized response, 2 contexts, 3 decisions (a utility of the decision, not 0/1: multinomial
    # sets, so the sups over g too): (2 local maps + 1 global) x 2 ends x (L and 3 sups) = 24 steps
    spec = fa.load_spec(write_spec("counts", 1, tmp_path, groups=6))
    terminal = on_terminal(monkeypatch)
    quiet = fa.certify(spec)
    assert terminal.getvalue() == ""
    shown = fa.certify(spec, progress=True)
    drawn = lines_drawn(terminal.getvalue())
    assert drawn[0] == "intervals:   0%|          | 0/24 [00:00<?, ?step/s]"
    assert terminal.getvalue().endswith("\r")  # (cleared when the intervals are done)
    assert shown.to_dict() == quiet.to_dict()
