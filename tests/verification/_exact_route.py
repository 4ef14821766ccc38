"""The black box solved exactly, a second route for the tests: each program of L and L̄ over the model's table
(:class:`fairaudit.verification.black_box_check.KernelSetting`) as a linear-fractional program over a polytope, solved by
the rational simplex (the tests' ``_rational_simplex``). ``fairaudit verify`` solves nothing: it bounds each
program from the proofs a certificate records; these solves fix the exact values the tests hold those bounds to.

A row's last decision is written as 1 minus the others (n_U − 1 variables in [0, 1], their sum at most 1), and one
variable s, fixed at 1, carries the constants. The ratio conventions are the tool's: c/0 = +inf for c > 0 and
0/0 = 1. ``proofs/verification.md`` §4d.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

from _rational_simplex import Polytope, maximize_linear, maximize_ratio_over_product

from fairaudit.verification import black_box_check as bb
from fairaudit.verification.black_box_check import KernelSetting, reached_rows
from fairaudit.verification.enclosures import INF, Enclosure, RecordedMechanism
from fairaudit.verification.evidence import Evidence

Number = Fraction | float


def exact_enclosures(inputs: Mapping[str, Any]) -> bb.WorstCaseEnclosures:
    """L's and L̄'s worst ratios behind the recorded inputs, solved exactly at each end of e^ε (no proof read)."""
    settings = bb._settings(inputs, Evidence())
    assert not isinstance(settings, str), settings
    ends = []
    for s, t in settings:
        local = max(kernel_local(s, (i, 0, 1)) for i in range(len(s.live))) if s.cells else kernel_local(s)
        global_ = kernel_global(t, (0, 1) if t.cells else None) if len(t.present) >= 2 else Fraction(1)
        ends.append((local, global_))
    return bb.WorstCaseEnclosures(Enclosure(ends[0][0], ends[-1][0]), Enclosure(ends[0][1], ends[-1][1]), "")


def kernel_local(s: KernelSetting, at: tuple[int, int, int] | None = None) -> Number:
    """The exact local worst case: max over tables meeting the floors of E[g | x, a]/E[g | x, a'].

    Parameters
    ----------
    s : KernelSetting
        The programs' data at one end of e^ε.
    at : (int, int, int), optional
        (index into ``s.live``, a, a'): that context and ordered pair only. Default: the maximum over every live
        context and ordered pair a ≠ a'.

    Returns
    -------
    Fraction or float
        The ratio e^L (dimensionless; L in nats is its log), exact; ``float("inf")`` when a table gives c/0 with
        c > 0. 0/0 counts as 1.

    Raises
    ------
    ValueError
        When no table meets the floors.

    Notes
    -----
    ``proofs/verification.md`` §4d.

    Examples
    --------
    The setting of :func:`kernel_settings`'s example: k = P(yes | ·) = (1, 0) gives (3/4)/((1/4)/2) = 6.

    >>> from fractions import Fraction as F
    >>> s = KernelSetting(((F(3, 4), F(1, 4)), (F(1, 4), F(3, 4))), None, [[[F(1), F(0)], [F(1, 2), F(0)]]],
    ...                   None, [0], [[F(1), F(1)]], [0, 1], False, 64)
    >>> kernel_local(s), kernel_local(s, at=(0, 1, 0))
    (Fraction(6, 1), Fraction(3, 2))
    """
    best: Number = Fraction(0)
    # with M_X the identity a context's programs depend on its utility table alone: one context per table
    contexts = (
        list({tuple(map(tuple, s.g[x])): i for i, x in reversed(list(enumerate(s.live)))}.values())
        if s.context is None
        else range(len(s.live))
    )
    cases = [(i, a, b) for i in contexts for a in range(s.k) for b in range(s.k) if a != b] if at is None else [at]
    programs: dict[int, _Polytope] = {}
    for i, a, b in cases:
        x = s.live[i]
        key = x if s.context is None else -1
        if key not in programs:
            programs[key] = _Polytope.of(s, [x] if s.context is None else s.live)
        poly = programs[key]
        top, bottom = poly.coefficients(s, {x: Fraction(1)}, a), poly.coefficients(s, {x: Fraction(1)}, b)
        best = max(best, _solve([poly], [top], [bottom]))
    return best


def kernel_global(s: KernelSetting, at: tuple[int, int] | None = None) -> Number | None:
    """The exact global worst case: max over tables meeting the floors of E[g | a]/E[g | a'].

    Contexts with the same M_X row (or, under the identity, the same utility table) and proportional P(x | a) are
    merged first; this is exact (``proofs/verification.md`` §4).

    Parameters
    ----------
    s : KernelSetting
        The programs' data at one end of e^ε.
    at : (int, int), optional
        The ordered pair (a, a') of groups present only. Default: the maximum over every ordered pair of groups
        present.

    Returns
    -------
    Fraction, float or None
        The ratio e^L̄, exact; ``float("inf")`` for c/0 with c > 0; 1 (L̄ = 0) with fewer than two groups present;
        None when a block exceeds ``s.max_variables`` variables: with M_X the identity each merged context is a
        block, solved apart (``_rational_simplex.maximize_ratio_over_product``); otherwise
        every context's rows are one block.

    Raises
    ------
    ValueError
        When no table meets the floors.

    Notes
    -----
    ``proofs/verification.md`` §4d.

    Examples
    --------
    One context, so L̄ is L: 6 (see :func:`kernel_local`).

    >>> from fractions import Fraction as F
    >>> s = KernelSetting(((F(3, 4), F(1, 4)), (F(1, 4), F(3, 4))), None, [[[F(1), F(0)], [F(1, 2), F(0)]]],
    ...                   None, [0], [[F(1), F(1)]], [0, 1], False, 64)
    >>> kernel_global(s)
    Fraction(6, 1)
    """
    if len(s.present) < 2:
        return Fraction(1)
    weights = _merged(s)
    contexts = list(weights)
    # with M_X the identity each context's rows and floors are its own: the program is over a product, a block per
    # context; otherwise one block over every context's rows
    blocks = [[x] for x in contexts] if s.context is None else [contexts]
    polytopes = [_Polytope.of(s, b) for b in blocks]
    pairs = [(a, b) for a in s.present for b in s.present if a != b] if at is None else [at]
    best: Number = Fraction(1)
    for a, b in pairs:
        tops = [poly.coefficients(s, {x: weights[x][a] for x in block}, a) for poly, block in zip(polytopes, blocks)]
        bottoms = [poly.coefficients(s, {x: weights[x][b] for x in block}, b) for poly, block in zip(polytopes, blocks)]
        best = max(best, _solve(polytopes, tops, bottoms))
    return best


def _merged(s: KernelSetting) -> dict[int, list[Fraction]]:
    """P(x | a) over the live contexts for L̄ (context → its row over the groups); with M_X the identity, the contexts
    with the same g(·, x, ·) and P(x | a) proportional over the groups present merged into the first, their weights
    summed. Exact: their rows of K enter L̄ and the floors alike, so their weighted mean (a table meeting the same
    floors) gives the same E[g | a], and it is reached by giving every merged context that mean."""
    merged: dict[tuple[Any, ...], tuple[int, list[Fraction]]] = {}
    for i, x in enumerate(s.live):
        w = s.weights[i]
        total = sum(w[a] for a in s.present)
        shape = tuple(w[a] / total for a in s.present) if total and s.context is None else (x,)
        key = (tuple(tuple(row) for row in s.g[x]), shape)
        first, sums = merged.get(key, (x, [Fraction(0)] * len(w)))
        merged[key] = (first, [a + b for a, b in zip(sums, w, strict=True)])
    return dict(merged.values())


def _linear_form(
    s: KernelSetting, blocks: Sequence[tuple[int, int]], n_free: int, weight: Mapping[int, Fraction], a: int
) -> list[Fraction]:
    """Σ_x weight[x] E[g | x, a] as a linear form in the variables K[x̃, ã, u < last] of ``blocks``, then s."""
    out = [Fraction(0)] * (len(blocks) * n_free + 1)
    for x, w in weight.items():
        if not w:
            continue
        g = s.g[x][a]
        last = g[-1]
        for i, (xr, ar) in enumerate(blocks):
            m = w * s.sensitive[a][ar] * (Fraction(int(xr == x)) if s.context is None else s.context[x][xr])
            if not m:
                continue
            for u in range(n_free):
                out[i * n_free + u] += m * (g[u] - last)
            out[-1] += m * last
    return out


@dataclass(frozen=True)
class _Polytope:
    """The tables' polytope over the rows (x̃, ã) that ``contexts`` reach, with their floors: the variables are
    K[x̃, ã, u] for u below the last decision, row by row, then s = 1."""

    blocks: list[tuple[int, int]]  # (x̃, ã)
    n_free: int  # n_U − 1 variables per row
    lower: list[Fraction]
    upper: list[Fraction]
    rows: list[list[Fraction]]
    bounds: list[Fraction]
    exact: Polytope  # phase 1 once: the pairs' programs start each from the last one's basis

    @classmethod
    def of(cls, s: KernelSetting, contexts: Sequence[int]) -> _Polytope:
        n_u = len(s.g[0][0])
        blocks = reached_rows(s, contexts)
        n = len(blocks) * (n_u - 1) + 1
        rows: list[list[Fraction]] = []
        for i in range(len(blocks) if n_u > 2 else 0):  # Σ_{u < last} K[x̃, ã, u] ≤ 1
            row = [Fraction(0)] * n
            row[i * (n_u - 1) : (i + 1) * (n_u - 1)] = [Fraction(1)] * (n_u - 1)
            rows.append(row)
        bounds = [Fraction(1)] * len(rows)
        lower, upper = [Fraction(0)] * (n - 1) + [Fraction(1)], [Fraction(1)] * n
        if s.tau:  # E[g | x, a] ≥ τ in every context of the program and for every group
            for x in contexts:
                for a in range(s.k):
                    rows.append([-v for v in _linear_form(s, blocks, n_u - 1, {x: Fraction(1)}, a)])
                    bounds.append(-s.tau)
        return cls(blocks, n_u - 1, lower, upper, rows, bounds, Polytope(lower, upper, rows, bounds, n))

    def coefficients(self, s: KernelSetting, weight: Mapping[int, Fraction], a: int) -> list[Fraction]:
        """Σ_x weight[x] E[g | x, a] as a linear form in the variables (the constants on s)."""
        return _linear_form(s, self.blocks, self.n_free, weight, a)


def _solve(polytopes: Sequence[_Polytope], p: Sequence[list[Fraction]], q: Sequence[list[Fraction]]) -> Number:
    """max (Σ_i p_i·h_i)/(Σ_i q_i·h_i) over the product of the polytopes, with c/0 = +inf and 0/0 = 1."""
    result = maximize_ratio_over_product([poly.exact for poly in polytopes], p, q)
    if result.status == "infeasible":
        raise ValueError("no decision model meets the floors")
    if result.status == "optimal":
        return result.value  # type: ignore[return-value]
    # q·h = 0 somewhere: each q_i·h_i ≥ 0 (E[g | ...] ≥ 0 on every table), so there each is 0; the ratio is +inf
    # where p·h > 0 there, and 0/0 = 1 otherwise
    top = Fraction(0)
    for poly, p_i, q_i in zip(polytopes, p, q, strict=True):
        found = maximize_linear(p_i, poly.lower, poly.upper, [*poly.rows, q_i], [*poly.bounds, Fraction(0)])
        if found.status != "optimal":  # (not reached: where q·h = 0 somewhere, each block has q_i·h_i = 0 there)
            return Fraction(1)
        top += found.value  # type: ignore[operator]
    return INF if top > 0 else Fraction(1)


# the worst case over the class Lipschitz in the group (proofs/black_box.md §5), solved exactly: verify checks the
# proof its certificate records (verification.class_check); these solves fix the values the tests hold it to

MAX_VARIABLES = 36
"""The largest whole program solved here (n groups × m released values)."""


def lipschitz_class_exact(
    m: RecordedMechanism,
    lower: Fraction,
    gamma: Fraction,
    tau: Fraction | None,
    lipschitz: Fraction,
    metric: Sequence[Sequence[Fraction]] | None,
) -> Enclosure | str:
    """The worst ratio over the class Lipschitz in the group behind ``m``, solved exactly (class_check's route
    before certificates recorded their proofs): [value at the lower end of e^ε, at the upper end]; a reason where the
    programs exceed :data:`MAX_VARIABLES` variables or the class is empty."""
    n, n_out = m.k, len(m.outputs)
    d = metric or [[Fraction(int(b != c)) for c in range(n)] for b in range(n)]
    distances = {d[b][c] for b in range(n) for c in range(n) if b != c}
    if m.kind == "randomized_response" and n >= 2 and len(distances) == 1:  # the symmetric program, any k
        (limit,) = distances
        worst = [symmetric_worst(p, q, n, lower, gamma, tau, lipschitz * limit) for p, q in m.rr_ends()]
    elif n * n_out > MAX_VARIABLES:
        return f"programs beyond {MAX_VARIABLES} variables"
    else:
        worst = [lipschitz_worst(rows, lower, gamma, tau, lipschitz, d) for rows in _rows_at_ends(m)]
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


def lipschitz_worst(
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


def symmetric_worst(
    p: Fraction, q: Fraction, k: int, lower: Fraction, gamma: Fraction, tau: Fraction | None, limit: Fraction
) -> Fraction | float | None:
    """:func:`lipschitz_worst` for k-ary randomized response (keep p, move q) and a metric with one distance d off the
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
