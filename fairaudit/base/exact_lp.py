"""Linear programs solved by HiGHS's simplex and proved optimal in exact rational arithmetic from its basis.

The program, with rational data (floats are taken at their exact binary value):

    minimise c·x  subject to  row_lower ≤ A x ≤ row_upper,  col_lower ≤ x ≤ col_upper

(infinite bounds allowed; an equality row has row_lower = row_upper). HiGHS's dual or primal simplex (Huangfu and
Hall 2018) returns an optimal *basis*: which variables (columns x_j and row activities r_i = A_i·x) are basic, and at
which bound each nonbasic one sits. A basis determines its vertex and its dual point by two square linear systems.
Here they are solved exactly (python-flint's rational matrices), and primal and dual feasibility are checked exactly:

* the vertex: nonbasic columns at their bound, nonbasic rows at theirs, and K x_B = (those rows' bounds − their
  nonbasic part), K = A[nonbasic rows, basic columns] (square: every basic column stands for a nonbasic row);
* the duals: y_i = 0 on basic rows, Kᵀ y_N = c_B; the reduced costs d_j = c_j − Aⱼ·y of the nonbasic columns, and
  y_i itself for a nonbasic row (the reduced cost of r_i in A x − r = 0);
* optimal when every basic variable lies within its bounds and every nonbasic reduced cost has the sign of its bound
  (≥ 0 at a lower bound, ≤ 0 at an upper one, 0 when free, anything when fixed): then c·x equals the dual objective,
  so c·x is the exact minimum and (x, y) its proof.

Where the floating-point basis is not optimal in exact arithmetic (a badly scaled program: a reduced cost of −1e−12
HiGHS took for 0), exact simplex pivots finish from it, the standard method of exact linear programming (Applegate,
Cook, Dash and Espinoza 2007, QSopt_ex; Gleixner, Steffy and Wolter 2016, SoPlex): a primal simplex where the basis
is primal feasible, a dual simplex where it is dual feasible, and otherwise a primal simplex on bounds shifted to
hold the basic values (Koberstein 2005, §6.2), then the dual simplex on the true bounds. Every step uses Bland's rule
(lowest index entering and leaving; Bland 1977 for the primal, its dual form for the dual), so none cycles. Each
pivot solves the basis afresh: the exact phase is meant for the few pivots a solver's basis leaves.

Proof: ``proofs/exact_lp.md``.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
import numpy.typing as npt

from fairaudit.base.errors import InputError

if TYPE_CHECKING:
    from flint import fmpq

__all__ = ["ExactProgram", "SimplexOptimum", "to_fraction"]

Status = Literal["basic", "lower", "upper", "zero"]
"""Where a variable stands in a basis: basic, or nonbasic at its lower bound, its upper bound, or 0 (free)."""


def to_fraction(x: Any) -> Fraction | None:
    """A finite number as an exact :class:`~fractions.Fraction` (a float at its binary value); None for ±inf.

    Examples
    --------
    >>> to_fraction(0.5), to_fraction(math.inf), to_fraction(Fraction(1, 3))
    (Fraction(1, 2), None, Fraction(1, 3))
    """
    if isinstance(x, (float, np.floating)) and math.isinf(x):
        return None
    return Fraction(x)


def _fmpq(x: Fraction) -> fmpq:
    from flint import fmpq

    return fmpq(x.numerator, x.denominator)


@dataclass(frozen=True)
class SimplexOptimum:
    """The outcome of :meth:`ExactProgram.minimize`, every number exact.

    Attributes
    ----------
    status : {"optimal", "infeasible", "unbounded", "unproved"}
        Proved exactly: "optimal" by a primal and a dual feasible basis of equal objective; "infeasible" by a basic
        variable out of its bounds that no nonbasic one can move (a row of the basis inverse: Farkas); "unbounded"
        by a feasible basis and an improving direction the ratio test does not stop. "unproved": the solver's basis,
        not optimal in exact arithmetic, as it is (``pivot=False``): its duals, and its vertex where feasible.
    value : Fraction or None
        min c·x, exactly; None unless optimal.
    point : tuple of Fraction or None
        The optimal vertex x, shape (n,); None unless optimal (or "unproved" with a feasible vertex).
    duals : tuple of Fraction or None
        The row multipliers y, shape (m,): c − Aᵀy has the sign of each column's bound at the vertex and y_i that of
        row i's, so Σ_i y_i·(row i's bound) + Σ_j d_j·(column j's bound) is a lower bound of c·x for every feasible
        x (weak duality) equal to ``value``; None unless optimal or "unproved" (then the bound is below the minimum,
        by the wrong-signed reduced costs times their variables' ranges).
    basis : tuple of str
        The final basis: a status per column, then per row ("basic", "lower", "upper", "zero"), shape (n + m,).
    pivots : int
        The exact pivots (and bound flips) taken from the starting basis: 0 where it was optimal as given.
    start : str
        Where the exact phase started: "solver" (HiGHS's basis), "given" (a basis passed in) or "slack" (the slack
        basis, where the solver's was singular in exact arithmetic).
    """

    status: Literal["optimal", "infeasible", "unbounded", "unproved"]
    value: Fraction | None
    point: tuple[Fraction, ...] | None
    duals: tuple[Fraction, ...] | None
    basis: tuple[Status, ...]
    pivots: int
    start: str


class _Basis:
    """A basis of an :class:`ExactProgram`, its vertex and duals solved exactly (python-flint's rational matrices: the
    products with A are single calls; K⁻¹ v and K⁻ᵀ v, the vertex, the duals and a pivot's directions and rates, are
    exact solves with the basis matrix K, never its inverse)."""

    def __init__(self, prog: ExactProgram, status: list[Status], lower: list[Any], upper: list[Any]) -> None:
        self.prog, self.status, self.lower, self.upper = prog, status, lower, upper
        n = prog.n
        self.cols = [j for j in range(n) if status[j] == "basic"]
        self.rows = [i for i in range(prog.m) if status[n + i] != "basic"]  # nonbasic rows: K's rows
        if len(self.cols) != len(self.rows):
            raise ValueError("not a basis: the basic variables do not number the rows")
        self._solve()

    def at(self, v: int) -> Any:
        """The value of a nonbasic variable: its bound, or 0 when free."""
        s = self.status[v]
        return self.lower[v] if s == "lower" else self.upper[v] if s == "upper" else 0

    def _solve(self) -> None:
        from flint import fmpq_mat

        prog, n, m, flat = self.prog, self.prog.n, self.prog.m, self.prog.flat
        k = len(self.cols)
        self.matrix = fmpq_mat(k, k, [flat[i * n + j] for i in self.rows for j in self.cols]) if k else None
        x = [0 if self.status[j] == "basic" else self.at(j) for j in range(n)]
        ax = prog.times(x)
        rhs = [self.at(n + i) - ax[i] for i in self.rows]
        self.x = _scatter(x, self.cols, self._solved(rhs, transposed=False))  # (K singular: ZeroDivisionError)
        ax = prog.times(self.x)
        self.r = [ax[i] if self.status[n + i] == "basic" else self.at(n + i) for i in range(m)]
        self.y = _scatter([0] * m, self.rows, self._solved([prog.c[j] for j in self.cols], transposed=True))
        ya = prog.transposed_times(self.y)
        self.d = [c - t for c, t in zip(prog.c, ya, strict=True)]

    def _solved(self, v: Sequence[Any], transposed: bool) -> list[Any]:
        """K⁻¹ v, or K⁻ᵀ v (``transposed``), by one exact solve (no inverse)."""
        if self.matrix is None:
            return []
        from flint import fmpq_mat

        k = self.matrix.transpose() if transposed else self.matrix
        return list(k.solve(fmpq_mat(len(v), 1, list(v))).entries())

    def value(self, v: int) -> Any:
        n = self.prog.n
        return self.x[v] if v < n else self.r[v - n]

    def reduced_cost(self, v: int) -> Any:
        """The reduced cost of a nonbasic variable: c_j − Aⱼ·y for a column, y_i for a row."""
        n = self.prog.n
        return self.d[v] if v < n else self.y[v - n]

    def direction(self, v: int) -> dict[int, Any]:
        """The change of every basic variable per unit increase of the nonbasic variable ``v``."""
        prog, n = self.prog, self.prog.n
        if v < n:
            dx = [-t for t in self._solved([prog.flat[i * n + v] for i in self.rows], transposed=False)]
        else:
            dx = self._solved([1 if i == v - n else 0 for i in self.rows], transposed=False)
        step = _scatter([0] * n, self.cols, dx)
        if v < n:
            step[v] = 1
        moved = prog.times(step)
        out = dict(zip(self.cols, dx, strict=True))
        out.update({n + i: moved[i] for i in range(prog.m) if self.status[n + i] == "basic"})
        return out

    def row_rates(self, b: int) -> dict[int, Any]:
        """∂(basic variable ``b``)/∂(nonbasic v) for every nonbasic v: one row of the basis inverse times N."""
        prog, n = self.prog, self.prog.n
        if b < n:  # row k of K⁻¹: K⁻ᵀ e_k
            unit = [int(j == b) for j in self.cols]
        else:
            unit = [prog.flat[(b - n) * n + j] for j in self.cols]
        w = [-t for t in self._solved(unit, transposed=True)]
        weights = _scatter([0] * prog.m, self.rows, w)
        if b >= n:
            weights[b - n] = 1  # r_b = A_b·x: its own row, then the basic columns' share through w
        through = prog.transposed_times(weights)
        return {v: through[v] if v < n else -weights[v - n] for v in range(n + prog.m) if self.status[v] != "basic"}

    def infeasible(self) -> int | None:
        """The lowest-indexed basic variable outside its bounds, or None."""
        for v in range(len(self.status)):
            if self.status[v] == "basic":
                x, lo, hi = self.value(v), self.lower[v], self.upper[v]
                if (lo is not None and x < lo) or (hi is not None and x > hi):
                    return v
        return None

    def improving(self) -> tuple[int, int] | None:
        """The lowest-indexed nonbasic variable whose move lowers c·x, and its direction (+1 or −1), or None."""
        for v, s in enumerate(self.status):
            if s == "basic" or (self.lower[v] is not None and self.lower[v] == self.upper[v]):
                continue
            d = self.reduced_cost(v)
            if (s == "lower" and d < 0) or (s == "zero" and d < 0):
                return v, 1
            if (s == "upper" and d > 0) or (s == "zero" and d > 0):
                return v, -1
        return None


def _scatter(out: list[Any], at: Sequence[int], values: Sequence[Any]) -> list[Any]:
    """``out`` with ``values`` written at the indices ``at``, in place (a basic solution's entries into its vector)."""
    for i, v in zip(at, values, strict=True):
        out[i] = v
    return out


def _column_status(lower: Any, upper: Any) -> Status:
    """The slack basis's place for a nonbasic variable: a finite bound, else 0 (free)."""
    return "lower" if lower is not None else "upper" if upper is not None else "zero"


class ExactProgram:
    """min c·x over {row_lower ≤ A x ≤ row_upper, col_lower ≤ x ≤ col_upper}, solved by HiGHS and proved exactly.

    The constraint data are fixed; the cost is given to each :meth:`minimize`, which starts HiGHS from the basis the
    last solve ended at (a warm start), so a sequence of costs over one polytope (Dinkelbach's steps, the pairs of a
    worst-case search) costs a few simplex iterations each. Proof: ``proofs/exact_lp.md``.

    Parameters
    ----------
    matrix : array_like, shape (m, n)
        A, floats (taken exactly) or :class:`~fractions.Fraction`.
    row_lower, row_upper : sequence, shape (m,)
        Row bounds; ±inf (float) for none.
    col_lower, col_upper : sequence, shape (n,)
        Column bounds; ±inf for none.

    Raises
    ------
    InputError
        On shapes that disagree, NaN, or a lower bound above its upper bound (naming the row or column).

    Examples
    --------
    max x + y (min −x − y) over 0 ≤ x, y ≤ 1 and x + 2y ≤ 3/2: the vertex (1, 1/4), value −5/4, proved by the dual
    y = −1/2 on the row (its reduced costs −1/2 at x's upper bound and 0 at y, basic).

    >>> prog = ExactProgram([[1, 2]], [-math.inf], [1.5], [0, 0], [1, 1])
    >>> r = prog.minimize([-1, -1])
    >>> r.status, r.value, r.point, r.duals
    ('optimal', Fraction(-5, 4), (Fraction(1, 1), Fraction(1, 4)), (Fraction(-1, 2),))
    """

    def __init__(
        self,
        matrix: Sequence[Sequence[Any]] | npt.NDArray[Any],
        row_lower: Sequence[Any],
        row_upper: Sequence[Any],
        col_lower: Sequence[Any],
        col_upper: Sequence[Any],
    ) -> None:
        dense = isinstance(matrix, np.ndarray) and matrix.dtype.kind == "f"  # (floats: read in bulk, exactly)
        self.m = len(matrix)
        self.n = len(col_lower)
        for name, bounds, size in (
            ("row_lower", row_lower, self.m),
            ("row_upper", row_upper, self.m),
            ("col_upper", col_upper, self.n),
        ):
            if len(bounds) != size:
                raise InputError(name, f"must have length {size}", len(bounds))
        for i, r in enumerate(matrix):
            if len(r) != self.n:
                raise InputError("matrix", f"row {i} must have {self.n} entries", len(r))
        if dense:
            self._floats = np.asarray(matrix, dtype=np.float64).reshape(self.m, self.n)
            if not np.all(np.isfinite(self._floats)):
                i, j = np.argwhere(~np.isfinite(self._floats))[0].tolist()
                raise InputError("matrix", f"must be finite (at {(i, j)})", self._floats[i, j])
            from flint import fmpq

            # each finite float at its exact binary value
            self.flat: list[Any] = [fmpq(*v.as_integer_ratio()) if v else 0 for v in self._floats.ravel().tolist()]
        else:
            exact = [[_finite("matrix", (i, j), v) for j, v in enumerate(r)] for i, r in enumerate(matrix)]
            self._floats = np.array([[float(v) for v in r] for r in exact], dtype=np.float64).reshape(self.m, self.n)
            self.flat = [_fmpq(v) if v else 0 for r in exact for v in r]  # A, row-major

        def checked(name: str, bounds: Sequence[Any]) -> list[Fraction | None]:
            return [_checked(name, k, v) for k, v in enumerate(bounds)]

        lower_fr = checked("col_lower", col_lower) + checked("row_lower", row_lower)
        upper_fr = checked("col_upper", col_upper) + checked("row_upper", row_upper)
        for v, (lo, hi) in enumerate(zip(lower_fr, upper_fr, strict=True)):
            if lo is not None and hi is not None and lo > hi:
                name, k = ("col_lower", v) if v < self.n else ("row_lower", v - self.n)
                raise InputError(name, f"exceeds the upper bound {hi} at {k}", lo)
        self.lower = [None if v is None else _fmpq(v) for v in lower_fr]
        self.upper = [None if v is None else _fmpq(v) for v in upper_fr]
        self._unbounded = [
            v for v, (lo, hi) in enumerate(zip(lower_fr, upper_fr, strict=True)) if lo is None or hi is None
        ]
        self.c: list[Any] = [0] * self.n
        self._highs: Any = None
        self._matrix: Any = None

    def times(self, x: Sequence[Any]) -> list[Any]:
        """A x, exactly (one rational matrix product), shape (m,)."""
        from flint import fmpq_mat

        if self._matrix is None:
            self._matrix = fmpq_mat(self.m, self.n, self.flat)
        return list((self._matrix * fmpq_mat(self.n, 1, list(x))).entries()) if self.m else []

    def transposed_times(self, y: Sequence[Any]) -> list[Any]:
        """Aᵀ y, exactly, shape (n,)."""
        from flint import fmpq_mat

        if self._matrix is None:
            self._matrix = fmpq_mat(self.m, self.n, self.flat)
        return list((fmpq_mat(1, self.m, list(y)) * self._matrix).entries()) if self.m else [0] * self.n

    def minimize(
        self, cost: Sequence[Any], basis: Sequence[Status] | None = None, *, pivot: bool = True
    ) -> SimplexOptimum:
        """min c·x, exactly: HiGHS's basis (or ``basis``) checked and, where not optimal, finished by exact pivots.

        Parameters
        ----------
        cost : sequence, shape (n,)
            c, floats (taken exactly) or fractions.
        basis : sequence of str, shape (n + m,), optional
            A starting basis in place of HiGHS's (statuses as :attr:`SimplexOptimum.basis`): the exact phase
            alone, from there (tests start it anywhere).
        pivot : bool
            Whether a basis that is not optimal is finished by exact pivots. False: it is returned as it is, with
            status "unproved", its exact duals, and its vertex where that is feasible (a caller that only needs a
            feasible vertex, or a bound by weak duality from the duals, saves the pivots).

        Returns
        -------
        SimplexOptimum

        Raises
        ------
        InputError
            On a cost of the wrong length, NaN or ±inf, or a ``basis`` that is not one.
        """
        if len(cost) != self.n:
            raise InputError("cost", f"must have length {self.n}", len(cost))
        exact_cost = [_finite("cost", j, v) for j, v in enumerate(cost)]
        self.c = [_fmpq(v) if v else 0 for v in exact_cost]
        if basis is None:
            start, status, _ = self._solver_basis([float(v) for v in exact_cost])
        else:
            start, status = "given", self._given(basis)
        try:
            state = _Basis(self, status, self.lower, self.upper)
        except ZeroDivisionError:  # singular in exact arithmetic: start from the slack basis
            start, state = "slack", _Basis(self, self._slack(), self.lower, self.upper)
        if not pivot and (state.infeasible() is not None or state.improving() is not None):
            feasible = state.infeasible() is None
            point = tuple(_fraction_of(v) for v in state.x) if feasible else None
            duals = tuple(_fraction_of(v) for v in state.y)
            return SimplexOptimum("unproved", None, point, duals, tuple(state.status), 0, start)
        outcome, state, pivots = _exact_simplex(self, state)
        if self._highs is not None:
            self._warm(state.status)
        return self._optimum(outcome, state, pivots, start)

    def vertex(self, basis: Sequence[Status]) -> tuple[Fraction, ...] | None:
        """The vertex of ``basis`` (statuses as :attr:`SimplexOptimum.basis`, shape (n + m,)), exactly, where it lies
        within every bound and row; None where it does not, or the basis is singular or not one of this program.

        Examples
        --------
        >>> prog = ExactProgram([[1, 2]], [-math.inf], [1.5], [0, 0], [1, 1])
        >>> prog.vertex(("upper", "basic", "upper")), prog.vertex(("basic", "upper", "upper"))
        ((Fraction(1, 1), Fraction(1, 4)), None)
        """
        if len(basis) != self.n + self.m:
            return None
        self.c = [0] * self.n
        try:
            state = _Basis(self, self._given(basis), self.lower, self.upper)
        except (ZeroDivisionError, ValueError):  # (singular, or not a basis: an InputError is a ValueError)
            return None
        return None if state.infeasible() is not None else tuple(_fraction_of(v) for v in state.x)

    def solver_duals(self, cost: npt.ArrayLike) -> tuple[list[Status], npt.NDArray[np.float64] | None]:
        """HiGHS's final basis for min c·x and its row duals y, in floating point: nothing is solved exactly.

        A dual point whose bound by weak duality a caller checks exactly before, or in place of, the exact solve,
        which :meth:`minimize` does from that basis (``basis``). HiGHS starts from the basis the last solve ended at.

        Parameters
        ----------
        cost : array_like, shape (n,)
            c, finite floats.

        Returns
        -------
        basis : list of str, shape (n + m,)
            HiGHS's final basis, a status per column then per row (as :attr:`SimplexOptimum.basis`); the slack basis
            where HiGHS has no valid one.
        duals : numpy.ndarray, shape (m,), or None
            Its row duals y at the scale of c (HiGHS solves c divided by its largest magnitude); None without a valid
            basis.

        Raises
        ------
        InputError
            On a cost of the wrong shape, NaN or ±inf.

        Examples
        --------
        The class's example: x at its upper bound, y basic, the row at its upper bound, the dual −1/2 on the row, and
        the basis :meth:`minimize` proves optimal exactly.

        >>> prog = ExactProgram([[1, 2]], [-math.inf], [1.5], [0, 0], [1, 1])
        >>> basis, duals = prog.solver_duals([-1.0, -1.0])
        >>> basis, abs(float(duals[0]) + 0.5) <= 1e-12, tuple(basis) == prog.minimize([-1, -1]).basis
        (['upper', 'basic', 'upper'], True, True)
        """
        c = np.asarray(cost, dtype=float)
        if c.shape != (self.n,) or not np.all(np.isfinite(c)):
            raise InputError("cost", f"must be {self.n} finite numbers", c.shape)
        _, status, duals = self._solver_basis(c)
        return status, duals

    def _optimum(self, outcome: str, state: _Basis, pivots: int, start: str) -> SimplexOptimum:
        basis = tuple(state.status)
        if outcome != "optimal":
            return SimplexOptimum(outcome, None, None, None, basis, pivots, start)  # type: ignore[arg-type]
        point = tuple(_fraction_of(v) for v in state.x)
        value = sum((_fraction_of(c) * x for c, x in zip(self.c, point, strict=True)), Fraction(0))
        duals = tuple(_fraction_of(v) for v in state.y)
        return SimplexOptimum("optimal", value, point, duals, basis, pivots, start)

    def _given(self, basis: Sequence[Status]) -> list[Status]:
        status = list(basis)
        if len(status) != self.n + self.m or not set(status) <= {"basic", "lower", "upper", "zero"}:
            raise InputError("basis", f"must give one of basic, lower, upper, zero for each of {self.n + self.m}")
        if status.count("basic") != self.m:
            raise InputError("basis", f"must hold {self.m} basic variables, one per row", status.count("basic"))
        # (only a variable without one of its bounds can sit at it wrongly; "zero" is for a free one alone)
        loose = [v for v, s in enumerate(status) if s == "zero"] if "zero" in status else []
        for v in sorted({*self._unbounded, *loose}):
            s = status[v]
            wrong = (s == "lower" and self.lower[v] is None) or (s == "upper" and self.upper[v] is None)
            if wrong or (s == "zero" and (self.lower[v] is not None or self.upper[v] is not None)):
                status[v] = _column_status(self.lower[v], self.upper[v])
        return status

    def _slack(self) -> list[Status]:
        cols = [_column_status(self.lower[j], self.upper[j]) for j in range(self.n)]
        return cols + ["basic"] * self.m

    def _solver_basis(
        self, cost: Sequence[float] | npt.NDArray[np.float64]
    ) -> tuple[str, list[Status], npt.NDArray[np.float64] | None]:
        """HiGHS's simplex on the floating-point program, warm-started from the last basis; its final basis and row
        duals (at the scale of ``cost``; None without a valid basis)."""
        h = self._highs if self._highs is not None else self._build()
        c = np.asarray(cost, dtype=float)
        scale = float(np.abs(c).max()) if c.size else 0.0
        h.changeColsCost(self.n, np.arange(self.n, dtype=np.int32), c / scale if scale > 0 else c)
        h.run()
        b = h.getBasis()
        if not b.valid:
            return "slack", self._slack(), None
        names = {code.value: s for s, code in _highs_statuses().items()}
        status = [names.get(s.value, "zero") for s in [*b.col_status, *b.row_status]]  # (by value: no enum hashing)
        duals = np.asarray(h.getSolution().row_dual, dtype=float) * (scale if scale > 0 else 1.0)
        return "solver", self._given(status), duals

    def _build(self) -> Any:
        import highspy

        h = _quiet_highs()
        inf = highspy.kHighsInf

        def floats(bounds: list[Any], side: float) -> npt.NDArray[np.float64]:
            return np.array([side if v is None else float(_fraction_of(v)) for v in bounds], dtype=float)

        h.addVars(self.n, floats(self.lower[: self.n], -inf), floats(self.upper[: self.n], inf))
        dense = self._floats
        lo, hi = floats(self.lower[self.n :], -inf), floats(self.upper[self.n :], inf)
        rows, cols = np.nonzero(dense)  # (row-major: each row's entries together, in column order)
        starts = np.searchsorted(rows, np.arange(self.m)).astype(np.int32)
        h.addRows(self.m, lo, hi, rows.size, starts, cols.astype(np.int32), dense[rows, cols])
        self._highs = h
        return h

    def _warm(self, status: Sequence[Status]) -> None:
        """Give HiGHS the exact phase's final basis, the start of the next solve."""
        import highspy

        codes = _highs_statuses()
        b = highspy.HighsBasis()
        b.col_status = [codes[s] for s in status[: self.n]]
        b.row_status = [codes[s] for s in status[self.n :]]
        self._highs.setBasis(b)


def _highs_statuses() -> dict[Status, Any]:
    """HiGHS's basis status for each of ours (any other status of HiGHS's reads as "zero")."""
    import highspy

    code = highspy.HighsBasisStatus
    return {"basic": code.kBasic, "lower": code.kLower, "upper": code.kUpper, "zero": code.kZero}


def _fraction_of(v: Any) -> Fraction:
    """An exact number (Fraction, int or python-flint's fmpq) as a Fraction."""
    return v if isinstance(v, Fraction) else Fraction(v) if isinstance(v, int) else Fraction(int(v.p), int(v.q))


def _finite(name: str, index: Any, v: Any) -> Fraction:
    """One datum as a fraction, refused by name when NaN or infinite."""
    out = _checked(name, index, v)
    if out is None:
        raise InputError(name, f"must be finite (at {index})", v)
    return out


def _checked(name: str, index: Any, v: Any) -> Fraction | None:
    """One datum as a fraction (None for ±inf), refused by name when NaN or not a number."""
    if isinstance(v, bool) or not isinstance(v, (int, float, Fraction, np.integer, np.floating)):
        raise InputError(name, f"must hold numbers (at {index})", v)
    if isinstance(v, (float, np.floating)) and math.isnan(v):
        raise InputError(name, f"must not be NaN (at {index})", v)
    return to_fraction(v)


_BANNER_SHOWN = False


def _quiet_highs() -> Any:
    """A HiGHS instance with its output off. The library prints a banner to the C-level standard output when the
    first instance of a process is made; that once, file descriptor 1 is pointed at the null device."""
    global _BANNER_SHOWN
    import highspy

    if _BANNER_SHOWN:
        h = highspy.Highs()
    else:
        import sys

        sys.stdout.flush()
        saved = os.dup(1)
        try:
            with open(os.devnull, "wb") as null:
                os.dup2(null.fileno(), 1)
                h = highspy.Highs()
        finally:
            os.dup2(saved, 1)
            os.close(saved)
        _BANNER_SHOWN = True
    h.setOptionValue("output_flag", False)
    h.setOptionValue("solver", "simplex")
    return h


def _exact_simplex(prog: ExactProgram, state: _Basis) -> tuple[str, _Basis, int]:
    """From any basis to an exact optimum, or an exact proof of infeasibility or unboundedness.

    Primal feasible: the primal simplex. Dual feasible: the dual simplex. Neither: the primal simplex over bounds
    shifted to hold the basic values, which ends dual feasible; then the dual simplex over the true bounds.
    """
    if state.infeasible() is None:
        return _primal(prog, state)
    if state.improving() is None:
        return _dual(prog, state)
    lower, upper = list(prog.lower), list(prog.upper)
    for v, s in enumerate(state.status):
        if s == "basic":
            x = state.value(v)
            if lower[v] is not None and x < lower[v]:
                lower[v] = x
            if upper[v] is not None and x > upper[v]:
                upper[v] = x
    shifted = _Basis(prog, state.status, lower, upper)
    outcome, shifted, pivots = _primal(prog, shifted)
    true = _Basis(prog, shifted.status, prog.lower, prog.upper)
    if outcome == "unbounded":  # a ray of the shifted program is one of the true one: unbounded if feasible
        saved, prog.c = prog.c, [0] * prog.n
        try:
            found, _, steps = _dual(prog, _Basis(prog, true.status, prog.lower, prog.upper))
        finally:
            prog.c = saved
        return ("unbounded" if found == "optimal" else "infeasible"), true, pivots + steps
    outcome, state, steps = _dual(prog, true)
    return outcome, state, pivots + steps


def _primal(prog: ExactProgram, state: _Basis) -> tuple[str, _Basis, int]:
    """The primal simplex with bounded variables and Bland's rule, from a primal feasible basis."""
    steps = 0
    while (entering := state.improving()) is not None:
        v, sign = entering
        rates = state.direction(v)
        best: Any = None
        leaving: int | None = None
        bound: Status = "lower"
        side: Status
        for b in sorted(rates):
            rate = rates[b] * sign
            x = state.value(b)
            if rate < 0 and state.lower[b] is not None:
                t, side = (x - state.lower[b]) / (-rate), "lower"
            elif rate > 0 and state.upper[b] is not None:
                t, side = (state.upper[b] - x) / rate, "upper"
            else:
                continue
            if best is None or t < best:
                best, leaving, bound = t, b, side
        lo, hi = state.lower[v], state.upper[v]
        span = None if lo is None or hi is None else hi - lo
        status: list[Status] = list(state.status)
        if span is not None and (best is None or span <= best):
            status[v] = "upper" if sign > 0 else "lower"  # a bound flip: no basis change
        elif leaving is None:
            return "unbounded", state, steps
        else:
            status[v], status[leaving] = "basic", bound
        state = _Basis(prog, status, state.lower, state.upper)
        steps += 1
    return "optimal", state, steps


def _dual(prog: ExactProgram, state: _Basis) -> tuple[str, _Basis, int]:
    """The dual simplex with bounded variables and Bland's rule, from a dual feasible basis."""
    steps = 0
    while (b := state.infeasible()) is not None:
        x = state.value(b)
        below = state.lower[b] is not None and x < state.lower[b]
        need = 1 if below else -1
        best, entering = None, None
        for v, rate in sorted(state.row_rates(b).items()):
            s = state.status[v]
            if not rate or (state.lower[v] is not None and state.lower[v] == state.upper[v]):
                continue
            moves = [1] if s == "lower" else [-1] if s == "upper" else [1, -1]
            if not any(m * rate * need > 0 for m in moves):
                continue
            ratio = abs(state.reduced_cost(v) / rate)
            if best is None or ratio < best:
                best, entering = ratio, v
        if entering is None:
            return "infeasible", state, steps
        status = list(state.status)
        status[entering], status[b] = "basic", ("lower" if below else "upper")
        state = _Basis(prog, status, state.lower, state.upper)
        steps += 1
    return "optimal", state, steps
