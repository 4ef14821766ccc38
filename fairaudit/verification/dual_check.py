"""A black-box program bounded from a recorded dual point, and its witness from a recorded point, exactly.

Beyond the size the rational simplex re-derives (:data:`~fairaudit.verification.black_box_check.MAX_VARIABLES`),
``fairaudit verify`` bounds a program max (Σ_j p_j·h_j)/(Σ_j q_j·h_j) over blocks h_j in [low_j, high_j]^n with
floors F_j h_j ≥ τ by weak duality, from the multipliers ν_j ≥ 0 of the floors that ``fairaudit certify`` records
(``bound_details.black_box.duals``): for every λ,

    B(λ) = Σ_j [Σ_i max(r_ji low_j, r_ji high_j) − τ Σ_r ν_jr],   r_j = p_j − λ q_j + F_jᵀ ν_j,

is at least max over the polytope of Σ_j (p_j − λ q_j)·h_j, so B(λ) ≤ 0 proves the ratio at most λ wherever the
denominator is positive, and that no point has a zero denominator under a positive numerator. :meth:`BlockProgram.dual_bound` gives
the smallest such λ, exactly. The recorded point (``witness_point``), where it lies in the polytope exactly, gives a
ratio a model attains: the lower end (:meth:`BlockProgram.vertex_ratio`). ``proofs/verification.md`` §4e.
"""

from __future__ import annotations

import operator
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

from fairaudit.base.errors import InputError
from fairaudit.base.exact_duality import ACTIVE_TOLERANCES
from fairaudit.base.exact_vertex import gauss_jordan
from fairaudit.base.json_values import label
from fairaudit.verification.enclosures import INF, exact, recorded_array

__all__ = ["SEARCH_STOP", "BlockProgram", "Evidence", "MissingDual", "without_duals"]

Number = Fraction | float
Block = Sequence[Fraction]

SEARCH_STOP = Fraction(1, 10**12)
"""Certify's pair search leaves unsolved a program whose bound is within this (relative) of the largest value found,
and returns that bound where it is larger: such a program needs no dual, its bound being the upper end."""


class MissingDual(Exception):
    """A program beyond the exact size whose bound needs a dual the certificate does not record."""


def without_duals(deferred: Sequence[Number], high: Number, what: str) -> tuple[Number, bool]:
    """The upper end once the programs left without a dual are counted: certify's search leaves unsolved a program
    whose bound is within :data:`SEARCH_STOP` of the largest value it found, and returns that bound where larger.

    Parameters
    ----------
    deferred : sequence of Fraction or float
        The bounds (ratios) of the programs beyond the exact size that no recorded dual bounds.
    high : Fraction or float
        The upper end found over the other programs.
    what : str
        The programs, for the error.

    Returns
    -------
    (Fraction or float, bool)
        The upper end, and whether a deferred bound raised it.

    Raises
    ------
    MissingDual
        ``"{what} without a recorded dual"`` when a bound exceeds ``high`` by more than :data:`SEARCH_STOP`.

    Examples
    --------
    >>> without_duals([Fraction(2) * (1 + SEARCH_STOP / 2)], Fraction(2), "programs")
    (Fraction(2000000000001, 1000000000000), True)
    """
    if any(bound * (1 - SEARCH_STOP) > high for bound in deferred):
        raise MissingDual(f"{what} without a recorded dual")
    if deferred and max(deferred) > high:
        return max(deferred), True
    return high, False


@dataclass(frozen=True)
class Evidence:
    """What a certificate records to check its black box with: the floors' multipliers of each program bounded by a
    linear program, and the maximiser's point, indexed by population position.

    ``local[(x, a, b)]`` is ν over the groups for L's program at context x and pair (a, b) (per context behind a
    context mechanism other than the identity, whose L program spans every context); ``global_[(a, b)]`` is ν per
    context (the population's order) for L̄'s. ``local_point`` is (x, a, b, h) of L's maximiser, h over the released
    groups; ``global_point`` is (a, b, h) of L̄'s, h per context. For a utility that depends on the group each h over
    the released groups is the maximiser's table instead, a row over the decisions per released group; behind a
    context mechanism other than the identity both points are the table over every released context.
    """

    local: dict[tuple[int, int, int], list[Any]] = field(default_factory=dict)  # ν, or ν per context
    global_: dict[tuple[int, int], list[list[Fraction]]] = field(default_factory=dict)
    local_point: tuple[int, int, int, list[Any]] | None = None
    global_point: tuple[int, int, list[list[Any]]] | None = None
    local_theta: dict[tuple[int, int, int], Fraction] = field(default_factory=dict)  # one-floor thresholds θ
    global_theta: dict[tuple[int, int], Fraction] = field(default_factory=dict)

    @classmethod
    def from_record(cls, detail: Mapping[str, Any] | None, inputs: Mapping[str, Any]) -> Evidence:
        """Read ``bound_details.black_box`` (``detail``; None: no evidence) against the certificate's ``inputs``.

        Raises
        ------
        InputError
            Naming the field (``bound_details.black_box.duals[0].group``) whose label is not the inputs' or whose
            numbers are not finite, or whose shape is not (groups,) or (contexts, groups) (``released`` for a point).
        """
        if not detail:
            return cls()
        pop = inputs["population"]
        contexts = [label(c) for c in pop["contexts"]]
        groups = [label(g) for g in pop["groups"]]
        released = len(inputs["sensitive_mechanism"]["outputs"])
        own = inputs["context_mechanism"]["kind"] == "identity"  # (else L's program spans every context)
        where = "bound_details.black_box"
        local: dict[tuple[int, int, int], Any] = {}
        for i, d in enumerate(detail.get("duals") or []):
            name = f"{where}.duals[{i}]"
            key = (_index(d, "context", contexts, name), _index(d, "group", groups, name),
                   _index(d, "other_group", groups, name))  # fmt: skip
            floors = d.get("floors")
            if own:
                local[key] = _vector(floors, len(groups), f"{name}.floors")
            else:
                local[key] = _matrix(floors, len(contexts), len(groups), f"{name}.floors")
        glob = detail.get("global") or {}
        global_ = {}
        for i, d in enumerate(glob.get("duals") or []):
            name = f"{where}.global.duals[{i}]"
            key2 = (_index(d, "group", groups, name), _index(d, "other_group", groups, name))
            global_[key2] = _matrix(d.get("floors"), len(contexts), len(groups), f"{name}.floors")
        local_theta = _thetas(
            detail, f"{where}.screens", [("context", contexts), ("group", groups), ("other_group", groups)]
        )
        global_theta = _thetas(glob, f"{where}.global.screens", [("group", groups), ("other_group", groups)])
        # the maximiser's point (its labels are checked by verify's maximiser check, which fails a wrong one)
        local_point = None
        named = all(detail.get(k) in labels for k, labels in (("context", contexts), ("group", groups),
                                                             ("other_group", groups)))  # fmt: skip
        n_u = _decisions(inputs)
        if detail.get("witness_point") is not None and named:
            name = f"{where}.witness_point"
            h = _point(detail["witness_point"], released, n_u, name) if own else _tables(detail, name, inputs)
            local_point = (contexts.index(detail["context"]), groups.index(detail["group"]),
                           groups.index(detail["other_group"]), h)  # fmt: skip
        global_point = None
        if glob.get("witness_point") is not None and glob.get("group") in groups and glob.get("other_group") in groups:
            name = f"{where}.global.witness_point"
            if own:
                if not isinstance(glob["witness_point"], list) or len(glob["witness_point"]) != len(contexts):
                    raise InputError(name, f"must be a list of {len(contexts)} lists", glob["witness_point"])
                hs = [_point(h, released, n_u, f"{name}[{i}]") for i, h in enumerate(glob["witness_point"])]
            else:
                hs = _tables(glob, name, inputs)
            global_point = (groups.index(glob["group"]), groups.index(glob["other_group"]), hs)
        return cls(local, global_, local_point, global_point, local_theta, global_theta)


def _thetas(detail: Mapping[str, Any], where: str, keys: list[tuple[str, list[Any]]]) -> dict[Any, Fraction]:
    """The recorded one-floor thresholds θ (``screens``: each program's labels and its θ, a finite number), exactly,
    by the programs' positions."""
    out = {}
    for i, d in enumerate(detail.get("screens") or []):
        name = f"{where}[{i}]"
        theta = exact(d.get("theta"), f"{name}.theta") if isinstance(d.get("theta"), (int, float)) else None
        if not isinstance(theta, Fraction):
            raise InputError(f"{name}.theta", "must be a finite number", d.get("theta"))
        out[tuple(_index(d, key, labels, name) for key, labels in keys)] = theta
    return out


def _index(record: Mapping[str, Any], key: str, labels: list[Any], name: str) -> int:
    """The position of ``record[key]`` among ``labels``."""
    value = record.get(key)
    if value not in labels:
        raise InputError(f"{name}.{key}", "is not a label of the inputs' population", value)
    return labels.index(value)


def _vector(value: Any, n: int, name: str) -> list[Fraction]:
    """A recorded list of n finite numbers, exactly."""
    if not isinstance(value, list) or len(value) != n:
        raise InputError(name, f"must be a list of {n} numbers", value)
    out = recorded_array(value, name)
    if any(not isinstance(v, Fraction) for v in out):
        raise InputError(name, "must hold finite numbers", value)
    return out


def _decisions(inputs: Mapping[str, Any]) -> int | None:
    """The number of decisions when the utility depends on the group (its witness points are tables), else None."""
    values = inputs["utility"]["values"]
    if not values or not isinstance(values[0], list):
        return None
    if all(row == table[0] for table in values for row in table):
        return None
    return len(values[0][0])


def _tables(record: Mapping[str, Any], name: str, inputs: Mapping[str, Any]) -> list[list[list[Fraction]]]:
    """A recorded table over every released context (behind a context mechanism other than the identity): shape
    (released contexts, released groups, decisions)."""
    value = record["witness_point"]
    n_x = len(inputs["context_mechanism"]["outputs"])
    values = inputs["utility"]["values"]
    n_u = len(values[0][0]) if values and isinstance(values[0], list) else len(values)
    if not isinstance(value, list) or len(value) != n_x:
        raise InputError(name, f"must be a list of {n_x} lists", value)
    return [_matrix(t, len(inputs["sensitive_mechanism"]["outputs"]), n_u, f"{name}[{i}]") for i, t in enumerate(value)]


def _point(value: Any, released: int, n_u: int | None, name: str) -> list[Any]:
    """A recorded point over the released groups: n numbers, or (``n_u`` given) a table of rows of ``n_u``."""
    return _vector(value, released, name) if n_u is None else _matrix(value, released, n_u, name)


def _matrix(value: Any, rows: int, n: int, name: str) -> list[list[Fraction]]:
    """A recorded list of ``rows`` lists of n finite numbers, exactly."""
    if not isinstance(value, list) or len(value) != rows:
        raise InputError(name, f"must be a list of {rows} lists", value)
    return [_vector(row, n, f"{name}[{i}]") for i, row in enumerate(value)]


@dataclass(frozen=True)
class BlockProgram:
    """max (Σ_j p_j·h_j)/(Σ_j q_j·h_j) over blocks h_j in [low_j, high_j]^n with floors F_j h_j ≥ τ, in rationals: the
    black box's program as the verifier rebuilds it, to bound from a dual and to evaluate at a point.

    Attributes
    ----------
    tops, bottoms : sequence of sequence of Fraction
        p_j and q_j per block, q ≥ 0 (each block's cells).
    floors : sequence of (sequence of sequence of Fraction)
        F_j per block: its rows over the block's cells, ≥ 0.
    low, high : sequence of Fraction
        Each block's box, low ≤ high.
    tau : Fraction or None
        The floors' right-hand side (None: no floors).
    """

    tops: Sequence[Block]
    bottoms: Sequence[Block]
    floors: Sequence[Sequence[Block]]
    low: Sequence[Fraction]
    high: Sequence[Fraction]
    tau: Fraction | None

    def dual_bound(self, nus: Sequence[Block]) -> Number:
        """The smallest λ ≥ 0 with B(λ) ≤ 0 (see the module), exactly; +inf when there is none or some ν < 0.

        Parameters
        ----------
        nus : sequence of sequence of Fraction
            ν_j per block, one per row of F_j (ignored without τ).

        Returns
        -------
        Fraction or float
            An upper bound on the program's ratio (+inf when the dual proves none).

        Examples
        --------
        max (h1 + 3 h2)/(h1 + h2) over [0, 1]^2 with the floor h1 ≥ 1/2: the value is (1/2 + 3)/(3/2) = 7/3, and ν = 4/3
        on the floor certifies it; ν = 0 certifies only the box's 3.

        >>> F = Fraction
        >>> program = BlockProgram([[F(1), F(3)]], [[F(1), F(1)]], [[[F(1), F(0)]]], [F(0)], [F(1)], F(1, 2))
        >>> program.dual_bound([[F(4, 3)]]), program.dual_bound([[F(0)]]), program.dual_bound([[F(-1)]])
        (Fraction(7, 3), Fraction(3, 1), inf)
        """
        tops, bottoms, floors, low, high, tau = self.tops, self.bottoms, self.floors, self.low, self.high, self.tau
        constant = Fraction(0)
        cells: list[tuple[Fraction, Fraction, Fraction, Fraction]] = []  # (breakpoint c/q, c, q, high - low) for q > 0
        slope_after, value_after = Fraction(0), Fraction(0)  # Σ over q > 0 of q·low and c·low: B's pieces at large λ
        for j, (p, q) in enumerate(zip(tops, bottoms, strict=True)):
            c = list(p)
            if tau is not None:
                nu = nus[j]
                if any(v < 0 for v in nu):
                    return INF
                constant -= tau * sum(nu, Fraction(0))
                for v, row in zip(nu, floors[j], strict=True):
                    if v:
                        c = [ci + v * fi for ci, fi in zip(c, row, strict=True)]
            lo, hi = low[j], high[j]
            for ci, qi in zip(c, q, strict=True):
                if qi == 0:
                    constant += max(ci * lo, ci * hi)
                else:
                    cells.append((ci / qi, ci, qi, hi - lo))
                    value_after += ci * lo
                    slope_after += qi * lo
        # B(λ) = constant + Σ_{t > λ} (c − λq)·high + Σ_{t ≤ λ} (c − λq)·low: convex and piecewise linear in λ
        cells.sort(key=operator.itemgetter(0))
        # B(λ) = value − λ slope below the first breakpoint
        value = constant + value_after + sum((cell[1] * cell[3] for cell in cells), Fraction(0))
        slope = slope_after + sum((cell[2] * cell[3] for cell in cells), Fraction(0))
        start = Fraction(0)
        for t, ct, qt, wt in [*cells, (None, Fraction(0), Fraction(0), Fraction(0))]:
            end = t
            if end is None or end > start:
                at_start = value - start * slope
                if at_start <= 0:
                    return start
                if slope > 0 and (end is None or value - end * slope <= 0):
                    return value / slope
                if end is not None:
                    start = end
            if t is not None:  # past its breakpoint the cell sits at low: remove (c − λq)(high − low)
                value -= ct * wt
                slope -= qt * wt
        return INF

    def point_ratio(self, point: Sequence[Block]) -> Fraction | None:
        """(Σ_j p_j·h_j)/(Σ_j q_j·h_j) at the point h, exactly, when h lies in every block's box and meets every floor and
        the denominator is positive; None otherwise.

        Examples
        --------
        >>> F = Fraction
        >>> program = BlockProgram([[F(1), F(3)]], [[F(1), F(1)]], [[[F(1), F(0)]]], [F(0)], [F(1)], F(1, 2))
        >>> program.point_ratio([[F(1, 2), F(1)]]), program.point_ratio([[F(1, 3), F(1)]])
        (Fraction(7, 3), None)
        """
        tops, bottoms, floors, low, high, tau = self.tops, self.bottoms, self.floors, self.low, self.high, self.tau
        num, den = Fraction(0), Fraction(0)
        for j, h in enumerate(point):
            if any(not low[j] <= v <= high[j] for v in h):
                return None
            if tau is not None and any(sum(map(operator.mul, row, h), Fraction(0)) < tau for row in floors[j]):
                return None
            num += sum(map(operator.mul, tops[j], h), Fraction(0))
            den += sum(map(operator.mul, bottoms[j], h), Fraction(0))
        return num / den if den > 0 else None

    def vertex_ratio(self, point: Sequence[Block]) -> Fraction | None:
        """The largest ratio :meth:`point_ratio` gives at the point itself or at a vertex it stands for; None when none
        lies in the polytope.

        A vertex is read off the point at each of :data:`~fairaudit.base.exact_duality.ACTIVE_TOLERANCES` (relative to
        max(1, max h): an interior-point solver stops 1e-12 to 1e-8 off its vertex): a cell within it of a bound is put
        at the bound, a floor within it of τ is solved as an equality for the other cells, exactly
        (:func:`~fairaudit.base.exact_vertex.gauss_jordan`; a cell the floors leave free keeps its value). The reading is
        only a guess; a point outside the polytope is refused, never a wrong ratio (``proofs/verification.md`` §4e).

        Examples
        --------
        The point of an interior-point solver, 1e-12 inside the floor h1 ≥ 1/2, stands for the vertex (1/2, 1):

        >>> F = Fraction
        >>> program = BlockProgram([[F(1), F(3)]], [[F(1), F(1)]], [[[F(1), F(0)]]], [F(0)], [F(1)], F(1, 2))
        >>> near = [[F(0.5 - 1e-12), F(1 - 1e-12)]]
        >>> program.point_ratio(near) is None, program.vertex_ratio(near)
        (True, Fraction(7, 3))
        """
        floors, low, high, tau = self.floors, self.low, self.high, self.tau
        best = self.point_ratio(point)
        scale = max([Fraction(1)] + [abs(v) for h in point for v in h])
        for tolerance in ACTIVE_TOLERANCES:
            tol = Fraction(tolerance) * scale
            vertex = []
            for j, h in enumerate(point):
                snapped = [v if low[j] + tol < v < high[j] - tol else (low[j] if v - low[j] <= high[j] - v else high[j])
                           for v in h]  # fmt: skip
                free = [i for i, v in enumerate(h) if low[j] + tol < v < high[j] - tol]
                equations = []
                for row in floors[j] if tau is not None else []:
                    assert tau is not None  # (no floors without τ)
                    if sum(map(operator.mul, row, h), Fraction(0)) - tau <= tol * (1 + abs(tau)):
                        rhs = tau - sum((row[i] * snapped[i] for i in range(len(h)) if i not in free), Fraction(0))
                        equations.append(({i: row[i] for i in free if row[i]}, rhs, False))
                pivots = gauss_jordan(equations)
                if pivots is None:
                    break
                for c, (terms, rhs) in pivots.items():  # (the free cells keep their values)
                    snapped[c] = rhs - sum((v * snapped[cc] for cc, v in terms.items()), Fraction(0))
                vertex.append(snapped)
            else:
                found = self.point_ratio(vertex)
                if found is not None and (best is None or found > best):
                    best = found
        return best
