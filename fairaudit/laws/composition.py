"""The law of decisions behind privacy filters: a kernel composed with the mechanisms on A and X.

:func:`compose` builds ``Q[x, a, u] = Σ_{x̃, ã} M_X[x, x̃] M_A[a, ã] K[x̃, ã, u]`` from a
:class:`~fairaudit.laws.tables.Kernel`; :func:`check_representable` refuses a law with a cell that
floating point cannot hold (also used where a law is composed in closed form).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from fairaudit.base.arrays import BoolArray, FloatArray
from fairaudit.base.errors import InputError, UnderflowError
from fairaudit.base.labels import format_label, label_list
from fairaudit.laws.mechanisms import Mechanism, identity
from fairaudit.laws.tables import Kernel, Law

__all__ = ["compose"]


def compose(kernel: Kernel, sensitive: Mechanism | None = None, context: Mechanism | None = None) -> Law:
    """The law of decisions behind privacy filters on A and X.

    Proof: ``proofs/x_privacy.md`` (privacy of the context).

    ``Q[x, a, u] = Σ_{x̃, ã} M_X[x, x̃] M_A[a, ã] K[x̃, ã, u]`` (paper, main
    text "Turning privacy into fairness guarantees"; docs/design.md layout).

    Parameters
    ----------
    kernel : Kernel
        P(U | X̃, Ã), shape (n_released_contexts, n_released_groups, n_decisions).
    sensitive : Mechanism, optional
        M_A, shape (n_groups, n_released_groups); its outputs must be the
        kernel's groups. Default: the identity.
    context : Mechanism, optional
        M_X, shape (n_contexts, n_released_contexts); its outputs must be the
        kernel's contexts. Default: the identity.

    Returns
    -------
    Law
        Shape (n_contexts, n_groups, n_decisions), labelled by the mechanisms'
        inputs.

    Raises
    ------
    InputError
        If a mechanism's outputs do not match the kernel's labels, or if an
        empty cell of an estimated kernel is reached with positive probability.
    UnderflowError
        (an InputError) If a cell of the law is positive exactly but below the
        smallest normal float, 2.2e-308 (randomized response above about 708
        nats): its float has lost its relative precision, and the metrics of
        the law would be wrong (+inf for ln(p/q) = ε).

    Examples
    --------
    The paper's X-privacy example (SI C): a model that outputs U = 1 when
    x̃ = a, behind M_X = [[0.9, 0.1], [0.7, 0.3]].

    >>> from fairaudit.laws.mechanisms import from_matrix
    >>> k = Kernel([[[1, 0], [0, 1]], [[0, 1], [1, 0]]], [0, 1], [0, 1], [1, 0])
    >>> law = compose(k, context=from_matrix([[0.9, 0.1], [0.7, 0.3]], [0, 1]))
    >>> law.probabilities[:, :, 0].round(12).tolist()
    [[0.9, 0.1], [0.7, 0.3]]
    """
    if not isinstance(kernel, Kernel):
        raise InputError("kernel", "must be a Kernel", type(kernel).__name__)
    m_a = sensitive if sensitive is not None else identity(kernel.groups)
    m_x = context if context is not None else identity(kernel.contexts)
    _check_outputs(m_a, kernel.groups, "groups")
    _check_outputs(m_x, kernel.contexts, "contexts")
    k = kernel.probabilities
    same_a, same_x = m_a.is_identity, m_x.is_identity  # never materialise an identity matrix
    if not kernel.complete:
        _check_unreached(kernel, m_a, m_x, filtered=sensitive is not None or context is not None)
        k = np.nan_to_num(k, nan=0.0)
    if same_x and same_a:
        q = k
    elif same_x:
        q = np.matmul(m_a.matrix, k)  # Σ_ã M_A[a, ã] K[x, ã, u], per context
    elif same_a:
        q = np.tensordot(m_x.matrix, k, axes=1)  # Σ_x̃ M_X[x, x̃] K[x̃, a, u]
    else:
        q = np.einsum("xy,ab,ybu->xau", m_x.matrix, m_a.matrix, k, optimize=True)
    check_representable(q, lambda: _support(k, m_a, m_x), (m_a, m_x), (m_x.inputs, m_a.inputs, kernel.decisions))
    # Clean rounding so rows sum to 1 within tolerance.
    q = q / np.einsum("...u->...", q)[..., None]
    return Law(q, m_x.inputs, m_a.inputs, kernel.decisions, name="law", _owned=True)


def _support(k: FloatArray, m_a: Mechanism, m_x: Mechanism) -> BoolArray:
    """Where the exact law Σ M_X M_A K is positive: the same composition of the supports (a sum of nonnegative terms
    is positive when one term is)."""
    s = (k > 0).astype(float)
    if not m_a.is_identity:
        s = np.matmul(m_a.support.astype(float), s)
    if not m_x.is_identity:
        s = np.tensordot(m_x.support.astype(float), s, axes=1)
    return s > 0


def check_representable(
    q: FloatArray,
    support: Callable[[], BoolArray],
    mechanisms: Sequence[Mechanism | tuple[str, float, float]],
    labels: tuple[tuple, ...],
) -> None:
    """No cell of the law is positive exactly but below the smallest normal float, where its float (0 or a
    subnormal) has lost its relative precision and a ratio or logarithm of it would be wrong.

    Parameters
    ----------
    q : numpy.ndarray, shape (n_contexts, n_groups, n_decisions)
        The law in floats.
    support : callable
        Where the exact law is positive (a boolean array of q's shape), called only when some cell of q is below
        2.2e-308.
    mechanisms : sequence of Mechanism or of (name, epsilon, smallest positive entry)
        The filters behind which q is composed, to name the one with an exact entry below the float range.
    labels : tuple of three label tuples
        The contexts, groups and decisions, to name the first such cell.

    Raises
    ------
    UnderflowError
        Naming the mechanism with an exact entry below that (randomized response above about 708 nats), else the
        kernel, and the first such cell.
    """
    low = q < np.finfo(float).tiny
    if not np.any(low):
        return
    lost = low & support()
    if not np.any(lost):
        return
    tiny = np.finfo(float).tiny
    named = [
        m if isinstance(m, tuple) else (m.name, m.epsilon, float(np.min(m.matrix[m.support], initial=1.0)))
        for m in mechanisms
        if isinstance(m, tuple) or not m.is_identity
    ]
    culprit = next((m for m in named if m[2] < tiny), None)
    field = "kernel" if culprit is None else f"mechanism '{culprit[0]}'"
    raise UnderflowError(
        field,
        "the law behind the privacy filter has a cell of positive probability below the smallest normal float "
        "(2.2e-308), which floating point cannot hold: its metrics would be wrong"
        + ("" if culprit is None else f" (epsilon = {culprit[1]:g} nats)"),
        "P(U = {2} | X = {0}, A = {1})".format(*(format_label(ls[i]) for ls, i in zip(labels, np.argwhere(lost)[0]))),
    )


def _check_outputs(mechanism: Mechanism, labels: tuple, what: str) -> None:
    """The mechanism releases exactly the kernel's ``labels`` (its ``what``: groups or contexts), in order."""
    if tuple(mechanism.outputs) != tuple(labels):
        raise InputError(
            f"mechanism '{mechanism.name}' outputs",
            f"must be the kernel's {what} {label_list(labels, most=3)}",
            [format_label(o) for o in mechanism.outputs[:3]],
        )


def _check_unreached(kernel: Kernel, m_a: Mechanism, m_x: Mechanism, *, filtered: bool) -> None:
    """No empty cell of an estimated kernel is reached with positive probability behind the mechanisms.

    A released cell (x̃, ã) is reached when some input maps to x̃ and some
    input maps to ã; ``filtered`` says a mechanism was given (for the message).
    """
    reach_x = True if m_x.is_identity else np.any(m_x.support, axis=0)[:, None]
    reach_a = True if m_a.is_identity else np.any(m_a.support, axis=0)[None, :]
    hit = ~kernel.observed & reach_x & reach_a
    if np.any(hit):
        i, j = np.argwhere(hit)[0]
        raise InputError(
            "kernel",
            f"empty cell (context={format_label(kernel.contexts[i])!r}, group={format_label(kernel.groups[j])!r}) "
            + (
                "is reached by the privacy filter; give counts for it"
                if filtered
                else "has no records; give counts for it"
            ),
        )
