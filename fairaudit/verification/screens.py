"""Exact upper bounds on every pair's black-box program at once, by weak duality: the pairs that cannot reach the top.

Behind a matrix on the group, :mod:`~fairaudit.verification.black_box_check` has one program per ordered pair of
groups (a, a'), k(k − 1) of them: max (p·h)/(q·h) over blocks h_x in [low_x, high_x]^n (one per context) with every
group's floors. Each lies inside its one-floor relaxation, the box with the denominator's own floor q·h ≥ t. For any
c and every h there,

    p·h − λ q·h = (p − c q)·h − (λ − c) q·h ≤ F(c) − (λ − c) t,   F(c) = Σ_i max((p_i − c q_i) low_i, (p_i − c q_i) high_i),

for λ ≥ c, so at λ = c + max(0, F(c))/t the right side is ≤ 0 and the ratio is at most λ (q·h ≥ t > 0): an upper
bound U(c) for any c, equal to the relaxation's maximum at its own threshold (``proofs/verification.md`` §4h). Floating
point picks c for each pair (the threshold rule's value, or the likelihood ratio of the cell where q·h reaches t,
whichever gives the smaller U in floats); U(c) is then computed exactly, in integers over common denominators, for
all pairs of one numerator group at once. A pair whose U is at most the largest value found needs no program: floating
point chooses which bound to try, never whether it holds.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from fractions import Fraction
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from fairaudit.base.arrays import FloatArray, IntArray
from fairaudit.base.exact_duality import on_one_denominator
from fairaudit.base.threshold_rule import threshold_max_many
from fairaudit.verification.enclosures import INF

Number = Fraction | float

__all__ = ["pair_screens"]


def pair_screens(
    rows: Sequence[Sequence[Fraction]],
    weights: Sequence[Sequence[Fraction]],
    low: Sequence[Fraction],
    high: Sequence[Fraction],
    tau: Fraction | None,
    groups: Sequence[int],
) -> dict[tuple[int, int], Number]:
    """Exact upper bounds on max (Σ_x w[x, a] M[a]·h_x)/(Σ_x w[x, b] M[b]·h_x) with Σ_x w[x, b] M[b]·h_x ≥ τ Σ_x w[x, b],
    over h_x in [low[x], high[x]]^n, for every ordered pair (a, b) of ``groups``; without τ, over the boxes alone
    (c/0 = +inf, 0/0 = 1).

    Parameters
    ----------
    rows : sequence of sequences of Fraction, shape (k, n)
        M[a]: the rows of the mechanism on the group, indexed [group, released value].
    weights : sequence of sequences of Fraction, shape (X, k)
        w[x, a] ≥ 0: P(x | a) per block (one row of ones for L at one context).
    low, high : sequences of Fraction, shape (X,)
        Each block's box, low ≤ high.
    tau : Fraction or None
        The floor, > 0; None: no floor (then U = c where F(c) ≤ 0, which rules out c/0, else +inf; max(c, 1) where
        no point has a positive denominator).
    groups : sequence of int
        The groups compared, each with Σ_x w[x, b] > 0.

    Returns
    -------
    dict
        {(a, b): U} for a ≠ b in ``groups``, each U ≥ the pair's program's maximum (of any program whose feasible set
        lies in the relaxation's: the pair's own, with every group's floors). U is a ratio (its log is in nats), a
        Fraction, or +inf where no finite bound was found.

    Raises
    ------
    IndexError
        When a group of ``groups`` is not a row of ``rows`` and ``weights``.
    ZeroDivisionError
        When a group compared has Σ_x w[x, b] = 0 with a floor (its denominator's floor is 0).

    Notes
    -----
    Weak duality on the one-floor relaxation (as ``proofs/verification.md`` §4g, in box space): §4h.

    Examples
    --------
    Binary randomized response keeping 3/4, g in [0, 1], τ = 1/2: the relaxation's maximum is (3/4 + 1/4·1/3)/(1/2),
    at h = (1, 1/3), the cell where q·h reaches 1/2 being the second.

    >>> r = [[Fraction(3, 4), Fraction(1, 4)], [Fraction(1, 4), Fraction(3, 4)]]
    >>> pair_screens(r, [[Fraction(1), Fraction(1)]], [Fraction(0)], [Fraction(1)], Fraction(1, 2), [0, 1])
    {(0, 1): Fraction(5, 3), (1, 0): Fraction(5, 3)}
    """
    k, n, blocks = len(rows), len(rows[0]), len(weights)
    (m, d_m), (w, d_w), (ends, d_box) = (
        (np.array(ints, dtype=object), d) for ints, d in map(on_one_denominator, (rows, weights, [[*low, *high]]))
    )  # (exact integers, vectorised)
    floats, fw = np.array(rows, dtype=float), np.array(weights, dtype=float)
    cell_lo = np.repeat(np.array(low, dtype=float), n)
    cell_hi = np.repeat(np.array(high, dtype=float), n)
    box = _Box(ends[0, :blocks], ends[0, blocks:], blocks, d_box * d_m)
    bottoms = (w.T[:, :, None] * m[:, None, :]).reshape(k, blocks * n)  # w[x, b] M[b, i] · d_w d_m, [b, (x, i)]
    float_bottoms = (fw.T[:, :, None] * floats[:, None, :]).reshape(k, blocks * n)
    mass = w.sum(axis=0)  # Σ_x w[x, b] · d_w
    out: dict[tuple[int, int], Number] = {}
    for a in groups:
        others = [b for b in groups if b != a]
        if not others:
            continue
        top = (w[:, a][:, None] * m[a][None, :]).reshape(blocks * n)
        float_top = (fw[:, a][:, None] * floats[a][None, :]).reshape(blocks * n)
        floor = None if tau is None else np.array([float(tau * Fraction(int(mass[b]), d_w)) for b in others])
        t = None if tau is None else [tau * int(mass[b]) for b in others]  # the floors times d_w
        raised, cell, above = _threshold(float_top, float_bottoms[others], cell_lo, cell_hi, floor)
        num, den = _thresholds(
            top, bottoms[others], np.where(raised, np.repeat(box.high, n), np.repeat(box.low, n)), cell
        )
        bounds = box.bounds(top, bottoms[others], num, den, t)
        # a prefix's ratio below the maximum by rounding leaves F(c) > 0, which the floor divides: try just above it
        retry = [r for r, u in enumerate(bounds) if math.isfinite(above[r]) and u > Fraction(num[r], den[r])]
        if retry:
            ratios = [above[r].as_integer_ratio() for r in retry]
            cn, cd = (np.array(column, dtype=object) for column in zip(*ratios))
            again = box.bounds(top, bottoms[[others[r] for r in retry]], cn, cd, t and [t[r] for r in retry])
            for r, u in zip(retry, again, strict=True):
                bounds[r] = min(bounds[r], u)
        out.update(((a, b), u) for b, u in zip(others, bounds, strict=True))
    return out


class _Box(NamedTuple):
    """Each block's box as integers over one denominator, ``scale`` = that denominator times the rows' (d_box d_m)."""

    low: np.ndarray
    high: np.ndarray
    blocks: int
    scale: int

    def bounds(
        self, top: np.ndarray, bottoms: np.ndarray, num: np.ndarray, den: np.ndarray, t: list[Fraction] | None
    ) -> list[Number]:
        """U(c) = c + max(0, F(c))/t per program (row of ``bottoms``), c = num/den, exactly; ``top`` and ``bottoms``
        are the rows times d_w d_m, ``t`` the floors times d_w. Without floors (``t`` None), c where F(c) ≤ 0
        (max(c, 1) where q·high = 0), else +inf."""
        gap = (top[None, :] * den[:, None] - num[:, None] * bottoms).reshape(len(bottoms), self.blocks, -1)
        up = np.maximum(gap, 0).sum(axis=2)  # (p − c q)·d_w d_m den summed per block where > 0, then where < 0
        f = (up * self.high + (gap.sum(axis=2) - up) * self.low).sum(axis=1)  # F(c)·d_box d_w d_m den
        if t is None:  # (F(c) ≤ 0: p·h ≤ c q·h everywhere, so no c/0; all 0/0 where no point has q·h > 0: 1)
            reach = (bottoms.reshape(len(bottoms), self.blocks, -1).sum(axis=2) * self.high).sum(axis=1)
            return [(Fraction(cn, cd) if some > 0 else max(Fraction(cn, cd), Fraction(1))) if fb <= 0 else INF
                    for fb, cn, cd, some in zip(f.tolist(), num.tolist(), den.tolist(), reach.tolist(), strict=True)]  # fmt: skip
        return [Fraction(cn, cd) + Fraction(max(fb, 0), self.scale * cd) / tb
                for fb, cn, cd, tb in zip(f.tolist(), num.tolist(), den.tolist(), t, strict=True)]  # fmt: skip


def _threshold(
    top: FloatArray, bottoms: FloatArray, low: FloatArray, high: FloatArray, floor: FloatArray | None
) -> tuple[npt.NDArray[np.bool_], IntArray, list[float]]:
    """Where to look for each program's (row of ``bottoms``) threshold c, in floating point: (the cells raised at the
    shortest maximising prefix of the threshold rule, or all False where the cell where q·h reaches the floor gives
    the smaller U in floats; that cell (the last where floats see q·high short of the floor: where q·high = t exactly,
    its ratio c gives U = p·high/t), −1 where the prefix is used; the rule's maximum widened above the floats'
    errors, inf where it is not finite). Without a floor (None), the prefix wherever the rule's maximum is finite. Any c
    gives a valid bound; these make it tight."""
    tops = np.broadcast_to(top, bottoms.shape)
    rows, n = np.arange(len(bottoms)), bottoms.shape[-1]
    with np.errstate(all="ignore"):
        value, _, order = threshold_max_many(tops, bottoms, low, high)
        span = high - low
        prefix = [
            np.take_along_axis(x * span, order, -1).cumsum(-1) + (x * low).sum(-1)[:, None] for x in (tops, bottoms)
        ]
        best = np.argmax(np.where(prefix[1] > 0, prefix[0] / prefix[1], -np.inf), axis=-1)  # the first maximum
        at = (prefix[1] < (0.0 if floor is None else floor[:, None])).sum(-1)
        cell = order[rows, np.minimum(at, n - 1)]  # (the last where floats see q·high below the floor)
        q = bottoms[rows, cell]
        marginal = np.where(q > 0, tops[rows, cell] / np.where(q > 0, q, 1.0), np.nan)
        candidates = np.stack([value, marginal])
        gap = tops[None] - candidates[:, :, None] * bottoms[None]
        bound = candidates + np.maximum(np.maximum(gap * low, gap * high).sum(-1), 0) / (
            1.0 if floor is None else floor
        )
        above = value * (1 + (4 * n + 32) * 2.0**-53)
    bound = np.where(np.isfinite(bound), bound, np.inf)
    raised = np.zeros(bottoms.shape, dtype=bool)
    np.put_along_axis(raised, order, np.arange(n) <= best[:, None], -1)
    use_value = np.isfinite(value) if floor is None else (bound[0] <= bound[1]) & np.isfinite(bound[0])
    above = np.where(use_value & np.isfinite(above), above, np.inf)
    return raised & use_value[:, None], np.where(use_value | ~np.isfinite(bound[1]), -1, cell), above.tolist()


def _thresholds(
    top: np.ndarray, bottoms: np.ndarray, point: np.ndarray, cell: IntArray
) -> tuple[np.ndarray, np.ndarray]:
    """Each program's threshold c = num/den, exactly (integer object arrays): the likelihood ratio top/bottom of its
    ``cell`` where that is ≥ 0, else the ratio (top·h)/(bottom·h) at its row of ``point`` (h), else 0."""
    num = (top[None, :] * point).sum(axis=1)
    den = (bottoms * point).sum(axis=1)
    for r, i in enumerate(cell.tolist()):
        if i >= 0 and bottoms[r, i] > 0:
            num[r], den[r] = top[i], bottoms[r, i]
        elif den[r] <= 0 or num[r] < 0:
            num[r], den[r] = 0, 1
    return num, den
