"""Exact sampling with integers only: uniform integers below any bound, outputs by cumulative numerators.

No floating point touches a draw (Mironov 2012, "On significance of the least
significant bits for differential privacy", CCS): a uniform integer in
[0, D) comes from uniform random bits by rejection, and an output is picked by
comparing that integer with the row's cumulative integer numerators, so
P(output = o) = numerator[o] / D exactly.

Integers of any size are numpy arrays of unsigned 64-bit words, most
significant first: shape (n, n_words). The bits come from a function
``random_bytes(n) -> bytes`` (by default :func:`secrets.token_bytes`, the
operating system's cryptographically secure source), read as little-endian
words, so a seeded source gives the same draws on every machine.
"""

from __future__ import annotations

import secrets
from collections.abc import Callable

import numpy as np
import numpy.typing as npt

__all__ = [
    "WORD_BITS",
    "RandomBytes",
    "below",
    "pick",
    "random_words",
    "uniform_below",
    "word_count",
    "words",
]

WORD_BITS = 64
"""Bits in one word of a multi-word integer."""

RandomBytes = Callable[[int], bytes]
"""A source of uniform random bytes: ``random_bytes(n)`` returns ``n`` bytes."""

Words = npt.NDArray[np.uint64]
_MASK = (1 << WORD_BITS) - 1


def word_count(bound: int) -> int:
    """The number of 64-bit words that hold every integer in [0, ``bound``) (at least 1).

    Examples
    --------
    >>> word_count(1), word_count(2**64), word_count(2**64 + 1)
    (1, 1, 2)
    """
    return max(1, -(-(bound - 1).bit_length() // WORD_BITS))


def words(value: int, n_words: int) -> Words:
    """The integer ``value`` ≥ 0 as ``n_words`` words, most significant first (shape (n_words,)).

    Examples
    --------
    >>> words(2**64 + 5, 2).tolist()
    [1, 5]
    """
    return np.array([(value >> (WORD_BITS * (n_words - 1 - i))) & _MASK for i in range(n_words)], dtype=np.uint64)


def below(x: Words, value: Words) -> npt.NDArray[np.bool_]:
    """Where the multi-word integers ``x`` (n, n_words) are below ``value`` (n_words,) or (n, n_words).

    Compared word by word from the most significant, as numbers.
    """
    n = x.shape[0]
    less = np.zeros(n, dtype=bool)
    equal = np.ones(n, dtype=bool)
    value = np.broadcast_to(value, x.shape)
    for i in range(x.shape[1]):
        less |= equal & (x[:, i] < value[:, i])
        equal &= x[:, i] == value[:, i]
    return less


def random_words(n: int, n_words: int, random_bytes: RandomBytes) -> Words:
    """``n`` × ``n_words`` uniform random words from ``random_bytes`` (little-endian, 8 bytes a word).

    Raises
    ------
    ValueError
        When ``random_bytes`` returns a number of bytes other than the one asked for.
    """
    size = 8 * n * n_words
    data = random_bytes(size)
    if len(data) != size:
        raise ValueError(f"random_bytes({size}) returned {len(data)} bytes")
    return np.frombuffer(bytes(data), dtype="<u8").astype(np.uint64).reshape(n, n_words)


def uniform_below(bound: int, n: int, random_bytes: RandomBytes | None = None) -> Words:
    """``n`` independent uniform integers in [0, ``bound``), exactly, as words (n, :func:`word_count` (bound)).

    Each is drawn as the bits of ``bound − 1``'s length from ``random_bytes``
    and drawn again while it is ≥ ``bound`` (rejection: fewer than half are
    drawn again, on average); only the rejected ones are drawn again, all of
    them at once. No floating point.

    Parameters
    ----------
    bound : int
        D ≥ 1.
    n : int
        How many, ≥ 0.
    random_bytes : callable, optional
        ``random_bytes(k) -> bytes``; default :func:`secrets.token_bytes`.

    Examples
    --------
    >>> import random
    >>> draws = uniform_below(3, 6, random.Random(1).randbytes)
    >>> draws.shape, bool((draws < 3).all())
    ((6, 1), True)
    """
    source = secrets.token_bytes if random_bytes is None else random_bytes
    n_words = word_count(bound)
    out = np.zeros((n, n_words), dtype=np.uint64)
    if bound <= 1 or n == 0:
        return out
    bits = (bound - 1).bit_length()
    top = np.uint64((1 << (bits - WORD_BITS * (n_words - 1))) - 1)
    fits = bound >> (WORD_BITS * n_words) == 0  # else bound = 2^(64 n_words): every draw is below it
    limit = words(bound, n_words) if fits else None
    todo = np.arange(n)
    while todo.size:
        draw = random_words(todo.size, n_words, source)
        draw[:, 0] &= top
        ok = below(draw, limit) if limit is not None else np.ones(todo.size, dtype=bool)
        out[todo[ok]] = draw[ok]
        todo = todo[~ok]
    return out


def pick(draws: Words, numerators: tuple[int, ...]) -> npt.NDArray[np.intp]:
    """The output each uniform draw in [0, D) picks from one row of integer numerators summing to D.

    Output o is picked when C[o − 1] ≤ draw < C[o], C the cumulative sums of
    ``numerators`` (C[−1] = 0): with probability ``numerators[o] / D`` exactly.
    An output of numerator 0 is never picked.

    Examples
    --------
    >>> d = np.array([[0], [1], [2], [3]], dtype=np.uint64)
    >>> pick(d, (1, 0, 3)).tolist()
    [0, 2, 2, 2]
    """
    out = np.zeros(draws.shape[0], dtype=np.intp)
    cumulative = 0
    for numerator in numerators[:-1]:
        cumulative += numerator
        if cumulative >> (WORD_BITS * draws.shape[1]):
            break  # above every draw, as are the sums after it
        out += ~below(draws, words(cumulative, draws.shape[1]))
    return out
