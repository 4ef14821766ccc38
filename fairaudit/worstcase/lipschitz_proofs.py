"""The proof a certificate records for the black-box worst case over the utilities Lipschitz in the group (L_A > 0),
for ``fairaudit verify`` to check without solving: :func:`lipschitz_proof`.

The worst case is the maximum over ordered pairs (a, a') of the linear-fractional program (M_A[a]·h[a]) /
(M_A[a']·h[a']) over the polytope H of ``proofs/black_box.md`` §5: h[b, ã] in [lower, γ], |h[b, ã] − h[c, ã]| ≤
L_A d(b, c), the floors M_A[b]·h[b] ≥ τ. Each program that decides the value is solved here exactly, by Dinkelbach's
steps over exact linear programs (:class:`~fairaudit.base.exact_ratio.Polytope`), and recorded as its value λ
and the multipliers y ≥ 0 of its rows, which prove it by weak duality; the maximiser's vertex is recorded as the witness.
A pair whose screen (γ ΣM[a], or t·E[g | a'] + L_A d ΣM[a], over the least denominator) is at most the largest value
solved is not solved: ``verify`` recomputes its screen. The rows' order, which ``verify`` rebuilds, is
``proofs/verification.md`` §4b's; randomized response with one distance between groups is recorded on the symmetric
program of at most 10 variables there, at t = ``exp_up`` (ε) ≥ e^ε (the worst case is non-decreasing in e^ε).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from fractions import Fraction
from typing import Any

from fairaudit.base.exact_ratio import Polytope
from fairaudit.base.json_values import Report
from fairaudit.base.outward import exp_up, fraction_up
from fairaudit.worstcase.worst_cases import exact_number

__all__ = ["MAX_VARIABLES", "lipschitz_proof"]

MAX_VARIABLES = 36
"""The largest whole program (n groups × m released values) solved exactly for a proof; beyond it no proof is
recorded (randomized response with one distance is solved on its symmetric program, whatever its size)."""

Rows = list[list[Fraction]]


def lipschitz_proof(
    record: Mapping[str, Any],
    lower: float,
    gamma: float,
    tau: float | None,
    lipschitz: float,
    metric: Sequence[Sequence[float]] | None,
) -> Report | None:
    """The recorded proof of the worst case over the Lipschitz class behind one mechanism, as ``verify`` reads it.

    Parameters
    ----------
    record : mapping
        The mechanism as the certificate records it (``mechanism_inputs``: ``inputs``, ``outputs``, ``kind`` and
        ``matrix`` or ``epsilon``); its numbers are taken exactly.
    lower, gamma, tau, lipschitz : float
        The class (``tau`` None or NaN: no floor), as the calibration records it.
    metric : (n, n) nested sequence of float, or None
        d on the groups; None for the discrete metric.

    Returns
    -------
    dict or None
        ``programs`` (each ``group``, ``other_group``, ``bound`` λ and ``rows`` y, exact rationals as
        :func:`~fairaudit.worstcase.worst_cases.exact_number` writes them), ``group``, ``other_group`` and
        ``witness_point`` (the maximiser's vertex over the program's variables), and for randomized response ``at``,
        the e^ε of the rows; None for fewer than two groups, the identity, a program beyond :data:`MAX_VARIABLES`
        or an empty class.

    Notes
    -----
    Weak duality for linear-fractional programs: ``proofs/verification.md`` §4b; the polytope: ``proofs/black_box.md``
    §5 (Theorem 5).

    Examples
    --------
    Binary randomized response keeping 7/10 (as floats), lower = 0, γ = 1, τ = 1/2, L_A = 1/10: 58/35 to the
    floats' rounding (``proofs/black_box.md`` §5), proved on each of the two pairs, with 6 rows (2 Lipschitz rows
    per released value, a floor per group).

    >>> rr = {"inputs": ["a", "b"], "outputs": ["a", "b"], "kind": "matrix", "matrix": [[0.7, 0.3], [0.3, 0.7]]}
    >>> proof = lipschitz_proof(rr, 0.0, 1.0, 0.5, 0.1, None)
    >>> [(p["group"], float(Fraction(p["bound"])), len(p["rows"])) for p in proof["programs"]]
    [('a', 1.657142857142857, 6), ('b', 1.657142857142857, 6)]
    """
    k, n_out, kind = len(record["inputs"]), len(record["outputs"]), record["kind"]
    if k < 2 or kind == "identity":
        return None
    lo, hi, lip = Fraction(lower), Fraction(gamma), Fraction(lipschitz)
    floor = None if tau is None or math.isnan(tau) or tau == 0 else Fraction(tau)  # (None, NaN or 0: no floor)
    d = [[Fraction(int(b != c)) if metric is None else Fraction(metric[b][c]) for c in range(k)] for b in range(k)]
    distances = {d[b][c] for b in range(k) for c in range(k) if b != c}
    out: Report = {}
    if kind == "randomized_response":
        t = exp_up(record["epsilon"])
        out["at"] = "inf" if math.isinf(t) else exact_number(Fraction(t))
        if math.isinf(t):  # (the identity's rows, the limit t → ∞)
            p, q = Fraction(1), Fraction(0)
        else:
            p, q = Fraction(t) / (Fraction(t) + k - 1), 1 / (Fraction(t) + k - 1)
        rows = [[p if i == j else q for j in range(k)] for i in range(k)]
    else:
        rows = [[Fraction(v) for v in row] for row in record["matrix"]]
    if kind == "randomized_response" and len(distances) == 1:
        a_ub, b_ub, pairs = _symmetric(p, q, k, lo, hi, floor, lip * min(distances))
        screens: dict[tuple[int, int], Fraction | float] = {(0, 1): math.inf}
    elif k * n_out > MAX_VARIABLES:
        return None
    else:
        a_ub, b_ub, pairs = _full(rows, lo, hi, floor, lip, d)
        screens = {(a, b): _screen(rows, a, b, lo, hi, floor, lip * d[a][b]) for a, b in pairs}
    size = len(next(iter(pairs.values()))[0])
    polytope = Polytope([lo] * size, [hi] * size, a_ub, b_ub, size)
    if not polytope.feasible:
        return None
    best = Fraction(1)
    programs: list[Report] = []
    witness: Report | None = None
    for a, b in sorted(pairs, key=lambda pair: -screens[pair]):
        if programs and screens[(a, b)] <= best:
            break  # (and every pair after it: its screen proves it)
        result = polytope.maximize_ratio(*pairs[(a, b)], start=best if programs else None)  # (pairs alike: near)
        if result.status != "optimal":  # q·h = 0 < p·h at a vertex: unbounded
            return {**out, "programs": programs, **_point(record, a, b, result.point)}
        assert result.value is not None and result.multipliers is not None  # (optimal)
        programs.append({"group": record["inputs"][a], "other_group": record["inputs"][b],
                         "bound": _upward(result.value), "rows": [exact_number(y) for y in result.multipliers]})  # fmt: skip
        if witness is None or result.value > best:
            best, witness = result.value, _point(record, a, b, result.point)
    return {**out, "programs": programs, **(witness or {})}


def _upward(value: Fraction) -> float | str:
    """A bound as recorded: exactly (:func:`~fairaudit.worstcase.worst_cases.exact_number`), or the float above it
    where that would round it (beyond 4,000 characters): a larger bound is proved by the same multipliers."""
    written = exact_number(value)
    return fraction_up(value) if isinstance(written, float) and Fraction(written) < value else written


def _point(record: Mapping[str, Any], a: int, b: int, h: Sequence[Fraction] | None) -> Report:
    """The witness's labels and vertex."""
    labels = record["inputs"]
    return {"group": labels[a], "other_group": labels[b], "witness_point": [exact_number(v) for v in h or ()]}


def _screen(
    rows: Rows, a: int, b: int, lower: Fraction, gamma: Fraction, floor: Fraction | None, limit: Fraction
) -> Fraction | float:
    """An upper bound on the pair's program, exactly: E[g | a] ≤ γ ΣM[a], and ≤ t E[g | a'] + L_A d ΣM[a] with
    t = max M[a]/M[a'], over the least denominator max(τ, lower ΣM[a']) (+inf where it is 0)."""
    least = max(floor or Fraction(0), lower * sum(rows[b]))
    if least == 0:
        return math.inf
    ratios = [x / y if y else math.inf for x, y in zip(rows[a], rows[b]) if x]
    t = max(ratios, default=Fraction(0))
    return min(gamma * sum(rows[a]) / least, t + limit * sum(rows[a]) / least)


Pairs = dict[tuple[int, int], tuple[list[Fraction], list[Fraction]]]


def _full(
    rows: Rows, lower: Fraction, gamma: Fraction, floor: Fraction | None, lip: Fraction, d: Rows
) -> tuple[Rows, list[Fraction], Pairs]:
    """The rows of H in ``verify``'s order (variables h[b, ã], group-major) and each ordered pair's (p, q)."""
    n, m = len(rows), len(rows[0])

    def placed(cells: dict[int, Fraction]) -> list[Fraction]:
        """A row over the n·m variables, zero but at ``cells``."""
        return [cells.get(j, Fraction(0)) for j in range(n * m)]

    def block(b: int, values: list[Fraction]) -> list[Fraction]:
        return placed(dict(zip(range(b * m, (b + 1) * m), values)))

    a_ub: Rows = []
    b_ub: list[Fraction] = []
    for b, c in itertools.combinations(range(n), 2):
        if lip * d[b][c] >= gamma - lower:
            continue  # implied by the box, not recorded
        for o, sign in itertools.product(range(m), (1, -1)):
            a_ub.append(placed({b * m + o: Fraction(sign), c * m + o: Fraction(-sign)}))
            b_ub.append(lip * d[b][c])
    if floor is not None:
        a_ub += [block(b, [-v for v in rows[b]]) for b in range(n)]
        b_ub += [-floor] * n
    return a_ub, b_ub, {(a, b): (block(a, rows[a]), block(b, rows[b])) for a, b in itertools.permutations(range(n), 2)}


_ORBITS = ("a.a", "a.a'", "a.o", "a'.a", "a'.a'", "a'.o", "c.a", "c.a'", "c.c", "c.o")
"""The symmetric program's variables for the pair (a, a'), in order: the groups a, a' and another c, each at a released
value (a, a', c itself, or another one o); those absent for k = 2 or 3 are left out."""


def _symmetric(
    p: Fraction, q: Fraction, k: int, lower: Fraction, gamma: Fraction, floor: Fraction | None, limit: Fraction
) -> tuple[Rows, list[Fraction], Pairs]:
    """k-ary randomized response (keep p, move q) with one distance d between groups, ``limit`` = L_A d: the program
    of the pair (a, a') = (0, 1) over the orbits of the permutations that fix a and a' (``proofs/verification.md``
    §4b), its rows in ``verify``'s order."""
    others = k - 2
    sizes = dict(zip(_ORBITS, (1, 1, others, 1, 1, others, others, others, others, others * (others - 1))))
    present = [cell for cell in _ORBITS if sizes[cell] > 0]

    def form(weights: Mapping[str, Fraction]) -> list[Fraction]:
        return [Fraction(weights.get(cell, 0)) for cell in present]

    top = form({"a.a": p, "a.a'": q, "a.o": others * q})
    bottom = form({"a'.a": q, "a'.a'": p, "a'.o": others * q})
    a_ub: Rows = []
    b_ub: list[Fraction] = []
    if limit < gamma - lower:
        pairs = [("a.a", "a'.a"), ("a.a'", "a'.a'"), ("a.o", "a'.o")]
        for g in ("a", "a'"):
            pairs += [(f"{g}.a", "c.a"), (f"{g}.a'", "c.a'"), (f"{g}.o", "c.c"), (f"{g}.o", "c.o")]
        pairs.append(("c.c", "c.o"))
        for (one, two), sign in itertools.product(pairs, (1, -1)):
            if one in present and two in present:
                a_ub.append(form({one: Fraction(sign), two: Fraction(-sign)}))
                b_ub.append(limit)
    if floor is not None:
        floors = [top, bottom]
        if "c.c" in present:
            floors.append(form({"c.a": q, "c.a'": q, "c.c": p, "c.o": (others - 1) * q}))
        a_ub += [[-v for v in row] for row in floors]
        b_ub += [-floor] * len(floors)
    return a_ub, b_ub, {(0, 1): (top, bottom)}
