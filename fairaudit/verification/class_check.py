"""The black-box worst case over every decision model and every utility of a class with L_A > 0, checked from the
proof its certificate records: nothing is solved here.

A utility of the class takes values in [lower, γ] and is L_A-Lipschitz in the group: |g(u, b) − g(u, b')| ≤
L_A d(b, b'). A model behind M_A then enters E[g | a] only through h[b, ã] = Σ_u K[ã, u] g(u, b), and the reachable
h are exactly the polytope H of ``proofs/black_box.md`` §5 (Theorem 5): h in [lower, γ]^(n × m), |h[b, ã] − h[b', ã]|
≤ L_A d(b, b') for every released ã, and the floors M_A[b]·h[b] ≥ τ for every group b. So

    L = max over a ≠ a' of max over H of (M_A[a]·h[a]) / (M_A[a']·h[a']),

one linear-fractional program per ordered pair (p·h)/(q·h) over the box and the rows A h ≤ b. Certify records, for
each member of a calibration (``calibration.proofs``), a bound λ and multipliers y ≥ 0 on those rows for each pair it
solved, and a vertex h of its maximiser (``proofs/verification.md`` §4b). λ bounds a pair's program when

    max over the box of (p − λq − Aᵀy)·h + y·b ≤ 0

(weak duality: y·(b − A h) ≥ 0 on H, so p·h ≤ λ q·h there), the box's maximum taken coordinate-wise (γ where the
coefficient is positive, lower elsewhere). A pair without a recorded program is bounded by its screen, computed
here: E[g | a] ≤ γ ΣM[a], and ≤ t E[g | a'] + L_A d ΣM[a] (t = max M[a]/M[a']), each over the least denominator
max(τ, lower ΣM[a']). The rows are rebuilt here in
a fixed order: for the groups b < c (row-major) whose L_A d(b, c) < γ − lower (the box implies the others), for each
released value, h[b] − h[c] ≤ L_A d then h[c] − h[b] ≤ L_A d; then, with τ, −M_A[b]·h[b] ≤ −τ for each group b. The
variables are h[b, ã], group-major. Randomized response with one distance between groups has one program, the
symmetric one of :func:`_symmetric` (its rows in the order built there). Behind randomized response the bounds are
checked at the e^ε the proof records (``at``, at least the upper end of e^ε here: the worst case is non-decreasing in e^ε, randomized response at a
smaller ε being the larger one followed by more randomized response, which joins the model), its witness at the lower
end, moved toward γ where it misses a floor there. The class lets g depend on the context freely, so one context
stands for all (``proofs/black_box.md`` §5, Consequence 2).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

from fairaudit.verification.enclosures import INF, Enclosure, RecordedMechanism, exact, rr_matrix

__all__ = ["lipschitz_class_enclosure"]

Rows = Sequence[Sequence[Fraction]]  # a mechanism's rows, or a metric
Box = tuple[Fraction, Fraction, Fraction | None]  # the class's lower, γ and τ

UNPROVEN = Enclosure(Fraction(1), INF)
"""What a proof that does not check proves: nothing beyond L ≥ 0, so every certified number on it fails."""

WHERE = "calibration.proofs"


def lipschitz_class_enclosure(
    m: RecordedMechanism,
    lower: Fraction,
    gamma: Fraction,
    tau: Fraction | None,
    lipschitz: Fraction,
    metric: Rows | None,
    proof: Mapping[str, Any] | None,
) -> Enclosure | str:
    """The worst ratio max E[g | a]/E[g | a'] over every model behind ``m`` and every utility of the class, enclosed
    from its recorded proof; or why it is not.

    Parameters
    ----------
    m : RecordedMechanism
        M_A (randomized response, or a matrix; not the identity).
    lower, gamma : Fraction
        The class's range of g, 0 ≤ lower ≤ γ.
    tau : Fraction or None
        The floor E[g | x, a] ≥ τ (None: no floor).
    lipschitz : Fraction
        L_A ≥ 0.
    metric : (n, n) nested sequence of Fraction, or None
        d(b, b') on the groups; None for the discrete metric.
    proof : mapping or None
        The member's recorded proof: ``programs`` (each ``group``, ``other_group``, ``bound`` λ and ``rows`` y, in
        the order of this module's docstring), ``group``, ``other_group`` and ``witness_point`` (the maximiser's h,
        over the program's variables), and for randomized response ``at``, the e^ε of the bound.

    Returns
    -------
    Enclosure or str
        [the witness's ratio at the lower end of e^ε, the largest bound] (+inf where a pair has neither a proof nor
        a floor); [1, +inf] (:data:`UNPROVEN`) when a piece of the proof does not check; a reason when none is
        recorded.

    Raises
    ------
    CertificateError
        Where a recorded number is not one.

    Notes
    -----
    ``proofs/black_box.md`` §5 (the polytope H, Theorem 5); ``proofs/verification.md`` §4b.

    Examples
    --------
    Binary randomized response keeping 7/10, lower = 0, γ = 1, τ = 1/2, L_A = 1/10 (discrete metric; as floats):
    58/35 to the floats' rounding, the vertex enumeration of ``proofs/black_box.md`` §5. Both pairs' bounds check,
    and the witness attains the larger.

    >>> from fractions import Fraction as F
    >>> from fairaudit.worstcase.lipschitz_proofs import lipschitz_proof  # (certify's side, for the example)
    >>> rr = {"inputs": ["a", "b"], "outputs": ["a", "b"], "kind": "matrix", "matrix": [[0.7, 0.3], [0.3, 0.7]]}
    >>> proof = lipschitz_proof(rr, 0.0, 1.0, 0.5, 0.1, None)
    >>> m = RecordedMechanism.from_record(rr, "m")
    >>> e = lipschitz_class_enclosure(m, F(0), F(1), F(1, 2), F(0.1), None, proof)
    >>> float(e.lo), e.lo == e.hi
    (1.657142857142857, True)
    >>> proof["programs"][0]["bound"] = 1.65  # a bound below the maximum does not check
    >>> lipschitz_class_enclosure(m, F(0), F(1), F(1, 2), F(0.1), None, proof) == UNPROVEN
    True
    """
    if not proof:
        return "the certificate records no proof for the Lipschitz class"
    n = m.k
    d = metric or [[Fraction(int(b != c)) for c in range(n)] for b in range(n)]
    distances = {d[b][c] for b in range(n) for c in range(n) if b != c}
    low = high = m.matrix_rows()
    if m.kind == "randomized_response":
        at = exact(proof.get("at"), f"{WHERE}.at")
        if at < m.t().hi:
            return UNPROVEN
        low, high = rr_matrix(m.t().lo, n), rr_matrix(at, n)

    def program(rows: Rows) -> _Program:
        if m.kind == "randomized_response" and len(distances) == 1:
            return _symmetric(rows[0][0], rows[0][1], n, (lower, gamma, tau), lipschitz * min(distances))
        return _full(rows, (lower, gamma, tau), lipschitz, d)

    upper = program(high)  # type: ignore[arg-type]
    bounds = dict(upper.screens)
    for record in proof.get("programs") or []:
        pair = _pair(record, m.inputs)
        bound = exact(record.get("bound"), f"{WHERE}.bound")
        if not upper.bounds(pair, bound, [exact(v, f"{WHERE}.rows") for v in record.get("rows") or []]):
            return UNPROVEN
        bounds[pair] = bound
    largest = max([Fraction(1)] + [bounds.get(pair, INF) for pair in upper.pairs])
    h = [exact(v, f"{WHERE}.witness_point") for v in proof.get("witness_point") or []]
    seen = program(low).witness(_pair(proof, m.inputs), h)  # type: ignore[arg-type]
    return UNPROVEN if seen is None or seen > largest else Enclosure(seen, largest)


def _pair(record: Mapping[str, Any], labels: Sequence[Any]) -> tuple[int, int]:
    """The positions of a record's ``group`` and ``other_group`` among the groups; (−1, −1) where not among them."""
    a, b = record.get("group"), record.get("other_group")
    return (labels.index(a), labels.index(b)) if a in labels and b in labels else (-1, -1)


def _dot(weights: Mapping[Any, Fraction], h: Mapping[Any, Fraction]) -> Fraction:
    return sum((w * h[cell] for cell, w in weights.items() if w), Fraction(0))


@dataclass(frozen=True)
class _Program:
    """The programs over one polytope: the box [lower, γ] on the variables ``cells`` (``box``: lower, γ, τ), the rows
    w·h ≤ c (sparse, in the order of the module's docstring; the last ``floors`` of them the floors −M[b]·h ≤ −τ),
    each ordered pair's numerator and denominator (p, q), and the pairs' screens."""

    box: Box
    cells: list[Any]
    rows: list[tuple[dict[Any, Fraction], Fraction]]
    floors: int
    pairs: dict[tuple[int, int], tuple[dict[Any, Fraction], dict[Any, Fraction]]]
    screens: dict[tuple[int, int], Fraction | float]

    def bounds(self, pair: tuple[int, int], bound: Any, y: list[Any]) -> bool:
        """Whether the multipliers y ≥ 0 prove p·h ≤ ``bound``·q·h for the pair: max over the box of
        (p − λq − Aᵀy)·h + y·b ≤ 0, the box's maximum coordinate by coordinate."""
        if pair not in self.pairs or not isinstance(bound, Fraction) or len(y) != len(self.rows):
            return False
        if any(not isinstance(v, Fraction) or v < 0 for v in y):
            return False
        (p, q), (lower, gamma, _) = self.pairs[pair], self.box
        c = {cell: p.get(cell, 0) - bound * q.get(cell, 0) for cell in self.cells}
        total = Fraction(0)
        for (weights, limit), v in zip(self.rows, y):
            total += v * limit
            for cell, w in weights.items():
                c[cell] -= v * w
        return total + sum(x * (gamma if x > 0 else lower) for x in c.values()) <= 0

    def witness(self, pair: tuple[int, int], point: list[Any]) -> Fraction | float | None:
        """The witness's ratio (at least 1; +inf where its denominator is 0 below a positive numerator), or None
        where it is not in the polytope. Where it misses a floor M[b]·h ≥ τ it is first moved to (1 − δ) h + δγ, δ
        the least that meets every floor: the box is kept and the Lipschitz differences shrink."""
        if pair not in self.pairs or len(point) != len(self.cells) or not all(isinstance(v, Fraction) for v in point):
            return None
        (lower, gamma, tau), h, delta = self.box, dict(zip(self.cells, point)), Fraction(0)
        for weights, _ in self.rows[len(self.rows) - self.floors :]:  # M[b]·h = s, moving from s toward γ ΣM[b]
            s, top = -_dot(weights, h), -gamma * sum(weights.values())
            if s < tau < top:  # type: ignore[operator]
                delta = max(delta, (tau - s) / (top - s))  # type: ignore[operator]
        h = {cell: (1 - delta) * v + delta * gamma for cell, v in h.items()}
        if any(not lower <= v <= gamma for v in h.values()) or any(_dot(w, h) > c for w, c in self.rows):
            return None
        top, bottom = _dot(self.pairs[pair][0], h), _dot(self.pairs[pair][1], h)
        return max(Fraction(1), top / bottom) if bottom else INF if top > 0 else Fraction(1)


def _rows(links: list[Any], floors: list[dict[Any, Fraction]], tau: Fraction | None) -> list[Any]:
    """Each link (one, two, limit) as h[one] − h[two] ≤ limit then h[two] − h[one] ≤ limit; then, with τ, each floor
    w as −w·h ≤ −τ."""
    rows = [({one: Fraction(s), two: Fraction(-s)}, limit) for one, two, limit in links for s in (1, -1)]
    return rows + [({cell: -w for cell, w in weights.items() if w}, -tau) for weights in floors if tau]


def _full(rows: Rows, box: Box, lipschitz: Fraction, d: Rows) -> _Program:
    """The programs over H (variables h[b, ã], group-major) of every ordered pair, with their screens: E[g | a] ≤
    γ ΣM[a], and ≤ t E[g | a'] + L_A d ΣM[a] (h[a] ≤ h[a'] + L_A d, M[a] ≤ t M[a'], t = max M[a]/M[a']), over the
    least denominator max(τ, lower ΣM[a']); +inf where it is 0."""
    (lower, gamma, tau), n, n_out = box, len(rows), len(rows[0])
    links = [((b, o), (c, o), lipschitz * d[b][c]) for b in range(n) for c in range(b + 1, n) for o in range(n_out)]
    kept = [link for link in links if link[2] < gamma - lower]  # (the box implies the others)
    weights = [{(b, o): rows[b][o] for o in range(n_out)} for b in range(n)]
    pairs = {(a, b): (weights[a], weights[b]) for a in range(n) for b in range(n) if a != b}
    screens: dict[tuple[int, int], Fraction | float] = {}
    for a, b in pairs:
        least = max(tau or Fraction(0), lower * sum(rows[b]))
        t = max((x / y if y else INF for x, y in zip(rows[a], rows[b]) if x), default=Fraction(0))
        top = min(gamma * sum(rows[a]), t * least + lipschitz * d[a][b] * sum(rows[a]))
        screens[(a, b)] = top / least if least else INF
    cells = [(b, o) for b in range(n) for o in range(n_out)]
    return _Program(box, cells, _rows(kept, weights, tau), n if tau else 0, pairs, screens)


def _symmetric(p: Fraction, q: Fraction, k: int, box: Box, limit: Fraction) -> _Program:
    """:func:`_full` for k-ary randomized response (keep p, move q) and a metric with one distance d off the
    diagonal (``limit`` = L_A·d), in at most 10 variables whatever k (``proofs/verification.md`` §4b).

    Every ordered pair is alike (a permutation of the groups, applied to the released values too, maps one program onto
    another), so the pair (a, a') = (0, 1) stands for all. The permutations that fix a and a' map H onto itself and
    leave both E[g | a] and E[g | a'] unchanged, so the mean of a maximiser's images is a maximiser: the maximum is
    reached by an h that they fix. Such an h takes one value per class of cells: for a (and for a') its h at a, at
    a' and at each of the k − 2 others; for every other group c, its h at a, at a', at c itself and at each of the
    k − 3 others. The classes' sizes weigh the floors and the ratio; the Lipschitz rows between groups and between
    classes that meet at a released value are the rows of H that such an h must meet.
    """
    (lower, gamma, tau), others = box, k - 2  # others: released values other than a and a' (and groups)
    orbit = {"a.a": 1, "a.a'": 1, "a.o": others, "a'.a": 1, "a'.a'": 1, "a'.o": others,
             "c.a": others, "c.a'": others, "c.c": others, "c.o": others * (others - 1)}  # fmt: skip
    cells = [cell for cell, size in orbit.items() if size > 0]  # (the orbits that exist for this k)
    top = {"a.a": p, "a.a'": q, "a.o": others * q}  # E[g | a] = M_A[a]·h[a]
    bottom = {"a'.a": q, "a'.a'": p, "a'.o": others * q}  # E[g | a']
    links = [("a.a", "a'.a"), ("a.a'", "a'.a'"), ("a.o", "a'.o")]  # a and a', at a, a' and another value
    for g in ("a", "a'"):  # a (or a') and another group c: at a, at a', at c, and at a fourth value
        links += [(f"{g}.a", "c.a"), (f"{g}.a'", "c.a'"), (f"{g}.o", "c.c"), (f"{g}.o", "c.o")]
    links.append(("c.c", "c.o"))  # two other groups c, c': at c (c's own, c''s other), and at c'
    kept = [(one, two, limit) for one, two in links if {one, two} <= set(cells) and limit < gamma - lower]
    floors = [top, bottom]
    if "c.c" in cells:  # another group's floor
        floors.append({"c.a": q, "c.a'": q, "c.c": p, "c.o": (others - 1) * q})
    rows = _rows(kept, floors, tau)  # (a weight on an orbit absent for this k is 0)
    return _Program(box, cells, rows, len(floors) if tau else 0, {(0, 1): (top, bottom)}, {})
