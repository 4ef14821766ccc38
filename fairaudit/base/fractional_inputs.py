"""The data of a linear-fractional program max (p·h)/(q·h), checked: the numerator and denominator, the box, the rows.

What :class:`fairaudit.base.linear_fractional.FractionalProgram` reads first: each function returns float64 arrays of the
caller's data (copies) or raises an :class:`~fairaudit.base.errors.InputError` naming the argument.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, TypeAlias

import numpy as np
import numpy.typing as npt

from fairaudit.base.arrays import FloatArray, as_float_array
from fairaudit.base.errors import InputError

if TYPE_CHECKING:
    import scipy.sparse as sp

__all__ = ["ConstraintMatrix", "check_bounds", "check_vectors", "constraint_rows"]

ConstraintMatrix: TypeAlias = "npt.ArrayLike | sp.sparray | sp.spmatrix"
"""A constraint matrix: dense (array_like) or a scipy.sparse matrix."""


def check_vectors(p: npt.ArrayLike, q: npt.ArrayLike) -> tuple[FloatArray, FloatArray]:
    """The numerator ``p`` and the denominator ``q`` as 1-D float arrays of one shape, every entry finite.

    Examples
    --------
    >>> check_vectors([1, 2], [3, 4])[1].tolist()
    [3.0, 4.0]
    >>> check_vectors([1, 2], [3])
    Traceback (most recent call last):
    ...
    fairaudit.base.errors.InputError: q: must have the shape of p (2,) (got (1,))
    """
    p = as_float_array(p, "p", ndim=1)
    q = as_float_array(q, "q", ndim=1)
    if p.shape != q.shape:
        raise InputError("q", f"must have the shape of p {p.shape}", q.shape)
    if not (np.all(np.isfinite(p)) and np.all(np.isfinite(q))):
        raise InputError("p", "p and q must be finite")
    return p, q


def check_bounds(lower: npt.ArrayLike | None, upper: npt.ArrayLike | None, n: int) -> tuple[FloatArray, FloatArray]:
    """The per-cell bounds ``lower`` and ``upper`` broadcast to shape (n,), finite, lower ≤ upper.

    Examples
    --------
    >>> [b.tolist() for b in check_bounds(0.5, [1.0, 2.0], 2)]
    [[0.5, 0.5], [1.0, 2.0]]
    """
    finite = "the bounds of h must be finite (the programs of fairaudit are over boxes)"
    if lower is None or upper is None:
        raise InputError("lower", finite)
    lo = np.broadcast_to(as_float_array(lower, "lower"), (n,)).copy()
    hi = np.broadcast_to(as_float_array(upper, "upper"), (n,)).copy()
    if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
        raise InputError("lower", finite)
    if np.any(lo > hi):
        i = int(np.argmax(lo > hi))
        raise InputError("lower", f"exceeds upper at cell {i} ({hi[i]:g})", float(lo[i]))
    return lo, hi


def constraint_rows(
    n: int,
    A_ub: ConstraintMatrix | None,
    b_ub: npt.ArrayLike | None,
    A_eq: ConstraintMatrix | None,
    b_eq: npt.ArrayLike | None,
) -> list[tuple[FloatArray, FloatArray, str]]:
    """The polytope's rows as (A dense, b, "le" or "eq") blocks, checked: finite data, shapes against ``n``.

    Examples
    --------
    >>> [(a.tolist(), b.tolist(), op) for a, b, op in constraint_rows(2, [[-0.3, -0.7]], [-0.5], None, None)]
    [([[-0.3, -0.7]], [-0.5], 'le')]
    """
    import scipy.sparse as sp

    out = []
    for name, a, b, op in (("A_ub", A_ub, b_ub, "le"), ("A_eq", A_eq, b_eq, "eq")):
        if a is None:
            continue
        dense = as_float_array(sp.csr_array(a).toarray() if sp.issparse(a) else a, name, ndim=2)
        if not np.all(np.isfinite(dense)):
            raise InputError(name, "must be finite")
        rhs = as_float_array(b, name.replace("A", "b"), ndim=1)
        if dense.shape != (rhs.size, n):
            raise InputError(name, f"shape must be ({rhs.size}, {n})", dense.shape)
        if not np.all(np.isfinite(rhs)):
            raise InputError(name.replace("A", "b"), "must be finite")
        out.append((dense, rhs, op))
    return out
