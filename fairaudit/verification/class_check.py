"""The black-box worst case over every decision model and every utility of a class with L_A > 0, re-derived exactly.

A utility of the class takes values in [lower, γ] and is L_A-Lipschitz in the group: |g(u, b) − g(u, b')| ≤
L_A d(b, b'). A model behind M_A then enters E[g | a] only through h[b, ã] = Σ_u K[ã, u] g(u, b), and the reachable
h are exactly the polytope H of ``proofs/black_box.md`` §5 (Theorem 5): h in [lower, γ]^(n × m), |h[b, ã] − h[b', ã]|
≤ L_A d(b, b') for every released ã, and the floors M_A[b]·h[b] ≥ τ for every group b. So

    L = max over a ≠ a' of max over H of (M_A[a]·h[a]) / (M_A[a']·h[a']),

one linear-fractional program per ordered pair, solved exactly by :func:`~fairaudit.base.exact_programs.maximize_ratio`
(c/0 = +inf: with lower = 0 and no floor, h[b, ã] = min(γ, L_A d(b, a')) vanishes for a' only). Randomized response is
solved at both rational ends of its e^ε: the worst case is non-decreasing in e^ε (randomized response at a smaller ε is
the larger one followed by more randomized response, which joins the model; the utility is a function of the true
group, untouched). A Lipschitz row is kept only where L_A d(b, b') < γ − lower (the box implies the others). The class
lets g depend on the context freely, so one context stands for all (``proofs/black_box.md`` §5, Consequence 2).
"""

from __future__ import annotations

from collections.abc import Sequence
from fractions import Fraction

from fairaudit.base.exact_programs import Polytope, maximize_linear
from fairaudit.verification.enclosures import INF, Enclosure, RecordedMechanism

__all__ = ["MAX_VARIABLES", "lipschitz_class_enclosure"]

MAX_VARIABLES = 36
"""The largest program (n groups × m released values) re-derived exactly; a larger class is listed as not
re-derived (the Lipschitz rows grow as n² m)."""


def lipschitz_class_enclosure(
    m: RecordedMechanism,
    lower: Fraction,
    gamma: Fraction,
    tau: Fraction | None,
    lipschitz: Fraction,
    metric: Sequence[Sequence[Fraction]] | None,
) -> Enclosure | str:
    """The worst ratio max E[g | a]/E[g | a'] over every model behind ``m`` and every utility of the class, enclosed;
    or why it is not re-derived.

    Parameters
    ----------
    m : RecordedMechanism
        M_A (randomized response, solved at both ends of its e^ε, or a matrix; not the identity).
    lower, gamma : Fraction
        The class's range of g, 0 ≤ lower ≤ γ.
    tau : Fraction or None
        The floor E[g | x, a] ≥ τ (None: no floor).
    lipschitz : Fraction
        L_A ≥ 0.
    metric : (n, n) nested sequence of Fraction, or None
        d(b, b') on the groups; None for the discrete metric.

    Returns
    -------
    Enclosure or str
        [value at the lower end of e^ε, value at the upper end] (one point for a matrix); +inf when unbounded; a
        reason when the programs exceed :data:`MAX_VARIABLES` variables, no utility meets the floors, or randomized
        response lies beyond ε = 10^6.

    Notes
    -----
    ``proofs/black_box.md`` §5 (the polytope H, Theorem 5); ``proofs/verification.md`` §4b.

    Examples
    --------
    Binary randomized response keeping 7/10, lower = 0, γ = 1, τ = 1/2, L_A = 1/10 (discrete metric): 58/35, the
    vertex enumeration of ``proofs/black_box.md`` §5.

    >>> from fractions import Fraction as F
    >>> rr = {"inputs": ["a", "b"], "outputs": ["a", "b"], "kind": "matrix", "matrix": [[0.7, 0.3], [0.3, 0.7]]}
    >>> m = RecordedMechanism.from_record(rr, "m")
    >>> e = lipschitz_class_enclosure(m, F(0), F(1), F(1, 2), F(1, 10), None)
    >>> float(e.lo), e.lo == e.hi
    (1.657142857142857, True)
    """
    n, n_out = m.k, len(m.outputs)
    d = metric or [[Fraction(int(b != c)) for c in range(n)] for b in range(n)]
    distances = {d[b][c] for b in range(n) for c in range(n) if b != c}
    if m.kind == "randomized_response" and n >= 2 and len(distances) == 1:  # the symmetric program, any k
        (limit,) = distances
        worst = [_symmetric_worst(p, q, n, lower, gamma, tau, lipschitz * limit) for p, q in m.rr_ends()]
    elif n * n_out > MAX_VARIABLES:
        return f"programs beyond {MAX_VARIABLES} variables"
    else:
        worst = [_worst(rows, lower, gamma, tau, lipschitz, d) for rows in _rows_at_ends(m)]
    ends = []
    for value in worst:
        if value is None:
            return "no utility of the class meets E[g | x, a] >= tau with the recorded rows exactly"
        ends.append(value)
    return Enclosure(ends[0], ends[-1])


def _rows_at_ends(m: RecordedMechanism) -> list[tuple[tuple[Fraction, ...], ...]]:
    """M_A's exact rows; randomized response's at the lower and the upper end of its e^ε."""
    rows = m.matrix_rows()
    if rows is not None:
        return [rows]
    return [tuple(tuple(p if i == j else q for j in range(m.k)) for i in range(m.k)) for p, q in m.rr_ends()]


def _worst(
    rows: tuple[tuple[Fraction, ...], ...],
    lower: Fraction,
    gamma: Fraction,
    tau: Fraction | None,
    lipschitz: Fraction,
    d: Sequence[Sequence[Fraction]],
) -> Fraction | float | None:
    """max over ordered pairs of the program over H (variables h[b, ã], group-major); None when H is empty."""
    n, n_out = len(rows), len(rows[0])
    size = n * n_out
    a_ub: list[list[Fraction]] = []
    b_ub: list[Fraction] = []
    for b in range(n):
        for c in range(b + 1, n):
            if lipschitz * d[b][c] >= gamma - lower:
                continue  # implied by the box
            for o in range(n_out):
                for sign in (1, -1):
                    row = [Fraction(0)] * size
                    row[b * n_out + o], row[c * n_out + o] = Fraction(sign), Fraction(-sign)
                    a_ub.append(row)
                    b_ub.append(lipschitz * d[b][c])
    if tau:
        for b in range(n):
            row = [Fraction(0)] * size
            row[b * n_out : (b + 1) * n_out] = [-v for v in rows[b]]
            a_ub.append(row)
            b_ub.append(-tau)
    objectives = []
    for a in range(n):
        for b in range(n):
            if a != b:
                p, q = [Fraction(0)] * size, [Fraction(0)] * size
                p[a * n_out : (a + 1) * n_out] = rows[a]
                q[b * n_out : (b + 1) * n_out] = rows[b]
                objectives.append((p, q))
    return _largest_ratio(size, lower, gamma, a_ub, b_ub, objectives)


def _symmetric_worst(
    p: Fraction, q: Fraction, k: int, lower: Fraction, gamma: Fraction, tau: Fraction | None, limit: Fraction
) -> Fraction | float | None:
    """:func:`_worst` for k-ary randomized response (keep p, move q) and a metric with one distance d off the
    diagonal (``limit`` = L_A·d), in at most 10 variables whatever k (``proofs/verification.md`` §4b).

    Every ordered pair is alike (a permutation of the groups, applied to the released values too, maps one program onto
    another), so the pair (a, a') = (0, 1) stands for all. The permutations that fix a and a' map H onto itself and
    leave both E[g | a] and E[g | a'] unchanged, so the mean of a maximiser's images is a maximiser: the maximum is
    reached by an h that they fix. Such an h takes one value per class of cells: for a (and for a') its h at a, at
    a' and at each of the k − 2 others; for every other group c, its h at a, at a', at c itself and at each of the
    k − 3 others. The classes' sizes weigh the floors and the ratio; the Lipschitz rows between groups and between
    classes that meet at a released value are the rows of H that such an h must meet.
    """
    others = k - 2  # released values other than a and a' (and groups other than a and a')
    orbit = {"a.a": 1, "a.a'": 1, "a.o": others, "a'.a": 1, "a'.a'": 1, "a'.o": others,
             "c.a": others, "c.a'": others, "c.c": others, "c.o": others * (others - 1)}  # fmt: skip
    present = [cell for cell, size in orbit.items() if size > 0]  # (the orbits that exist for this k)
    at = {c: i for i, c in enumerate(present)}
    size = len(present)

    def form(weights: dict[str, Fraction]) -> list[Fraction]:
        row = [Fraction(0)] * size
        for cell, w in weights.items():
            if cell in at:
                row[at[cell]] += w
        return row

    n_o = Fraction(others)
    top = form({"a.a": p, "a.a'": q, "a.o": n_o * q})  # E[g | a] = M_A[a]·h[a]
    bottom = form({"a'.a": q, "a'.a'": p, "a'.o": n_o * q})  # E[g | a']
    a_ub: list[list[Fraction]] = []
    b_ub: list[Fraction] = []
    if limit < gamma - lower:  # (otherwise every Lipschitz row is implied by the box)
        pairs = [("a.a", "a'.a"), ("a.a'", "a'.a'"), ("a.o", "a'.o")]  # a and a', at a, a' and another value
        for g in ("a", "a'"):  # a (or a') and another group c: at a, at a', at c, and at a fourth value
            pairs += [(f"{g}.a", "c.a"), (f"{g}.a'", "c.a'"), (f"{g}.o", "c.c"), (f"{g}.o", "c.o")]
        pairs.append(("c.c", "c.o"))  # two other groups c, c': at c (c's own, c''s other), and at c'
        for one, two in pairs:
            if one in at and two in at:
                for sign in (1, -1):
                    a_ub.append(form({one: Fraction(sign), two: Fraction(-sign)}))
                    b_ub.append(limit)
    if tau:
        floors = [(top,), (bottom,)]
        if "c.c" in at:
            floors.append((form({"c.a": q, "c.a'": q, "c.c": p, "c.o": Fraction(others - 1) * q}),))
        for (row,) in floors:
            a_ub.append([-v for v in row])
            b_ub.append(-tau)
    return _largest_ratio(size, lower, gamma, a_ub, b_ub, [(top, bottom)])


def _largest_ratio(
    size: int,
    lower: Fraction,
    gamma: Fraction,
    a_ub: list[list[Fraction]],
    b_ub: list[Fraction],
    objectives: Sequence[tuple[list[Fraction], list[Fraction]]],
) -> Fraction | float | None:
    """max over the objectives (p, q) of max (p·h)/(q·h) over the box [lower, γ] and the rows a_ub h ≤ b_ub, exactly,
    with c/0 = +inf and 0/0 = 1; at least 1 (L ≥ 0); None when no h meets the rows."""
    box_lo, box_hi = [lower] * size, [gamma] * size
    polytope = Polytope(box_lo, box_hi, a_ub, b_ub, size)  # phase 1 once for every pair
    best: Fraction | float = Fraction(1)
    for p, q in objectives:
        result = polytope.maximize_ratio(p, q)
        if result.status == "infeasible":
            return None
        if result.status == "optimal":
            assert result.value is not None  # (optimal: a value)
            best = max(best, result.value)
            continue
        # q·h = 0 somewhere (q·h ≥ 0 on H): +inf where p·h > 0 there; otherwise 0/0 everywhere
        top = maximize_linear(p, box_lo, box_hi, [*a_ub, q], [*b_ub, Fraction(0)])
        if top.status == "optimal" and top.value > 0:  # type: ignore[operator]
            return INF
    return best
