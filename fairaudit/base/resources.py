"""The memory a computation may take, and the refusal before it allocates more.

A command plans the memory its inputs imply before it allocates, and refuses with one line (an
:class:`~fairaudit.base.errors.MemoryLimitError`, an ``InputError``: exit status 2) when even the smallest piece of
the work would not fit. The limit, in this order:

1. the size given to the computation (``max_memory=``, the command's ``--max-memory SIZE``);
2. the environment variable :data:`ENVIRONMENT` (``FAIRAUDIT_MAX_MEMORY``; empty counts as unset);
3. :data:`DEFAULT_FRACTION` (one half) of the memory available now: Linux's ``MemAvailable`` (``/proc/meminfo``),
   elsewhere ``os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")``, or when neither can be read the
   physical memory (``SC_PHYS_PAGES``); and never more than the address space left under a finite ``RLIMIT_AS``
   (``ulimit -v``) less the process's present size (``VmSize`` of ``/proc/self/status``). When none of these can be
   read there is no limit.

Sizes (:func:`parse_size`): a number, then optionally one of ``K``, ``M``, ``G``, ``T`` (any case), then optionally
``i``, ``iB`` or ``B``; the units are binary whatever the spelling (``4G`` = ``4GB`` = ``4GiB`` = 4 · 2^30 bytes).
Without a unit the number is bytes and must be whole (``1048576`` or ``1048576B``); with one it may have a
fractional part (``2.5GiB``), and the bytes are rounded down. The result is at least one byte.
"""

from __future__ import annotations

import os
import re
from contextlib import suppress
from dataclasses import dataclass
from fractions import Fraction

from fairaudit.base.errors import InputError, MemoryLimitError

__all__ = [
    "DEFAULT_FRACTION",
    "ENVIRONMENT",
    "MemoryLimit",
    "available_memory",
    "check_memory",
    "human_size",
    "memory_limit",
    "parse_size",
]

ENVIRONMENT = "FAIRAUDIT_MAX_MEMORY"
"""The environment variable that sets the memory limit when no size is given to the computation."""

DEFAULT_FRACTION = 0.5
"""The share of the memory available now that a computation may take when no limit is set."""

_UNITS = {"": 0, "K": 1, "M": 2, "G": 3, "T": 4}
_SIZE = re.compile(r"(?P<number>\d+(?:\.\d*)?|\.\d+)\s*(?P<unit>[KMGT]?)(?P<suffix>(?:i|iB|B)?)", re.IGNORECASE)


def parse_size(text: str | int, field: str = "max_memory") -> int:
    """Bytes of a size: a number with an optional binary unit (see the module's grammar).

    Parameters
    ----------
    text : str or int
        The size, e.g. ``"4G"``, ``"512M"``, ``"2.5GiB"``, ``"1048576"``, or a whole number of bytes.
    field : str
        Named by the error.

    Returns
    -------
    int
        Bytes, at least 1.

    Raises
    ------
    InputError
        Naming ``field`` and the value, when it is not a size of the grammar or is below one byte.

    Examples
    --------
    >>> parse_size("4G"), parse_size("512m"), parse_size("2.5GiB"), parse_size("1K"), parse_size("100")
    (4294967296, 536870912, 2684354560, 1024, 100)
    >>> parse_size("1.5kB"), parse_size(" 2 TiB "), parse_size("7B"), parse_size(4096)
    (1536, 2199023255552, 7, 4096)
    >>> parse_size("lots", "FAIRAUDIT_MAX_MEMORY")
    Traceback (most recent call last):
    fairaudit.base.errors.InputError: FAIRAUDIT_MAX_MEMORY: must be a size such as 4G, 512M, 2.5GiB or a whole number of bytes (got 'lots')
    """
    problem = "must be a size such as 4G, 512M, 2.5GiB or a whole number of bytes"
    if isinstance(text, int) and not isinstance(text, bool):
        if text < 1:
            raise InputError(field, "must be at least one byte", text)
        return text
    match = _SIZE.fullmatch(text.strip()) if isinstance(text, str) else None
    if match is None:
        raise InputError(field, problem, text)
    number, unit, suffix = match["number"], match["unit"].upper(), match["suffix"]
    if not unit and (suffix.lower().startswith("i") or "." in number):
        raise InputError(field, problem, text)
    nbytes = int(Fraction(number) * 1024 ** _UNITS[unit])  # (exact, rounded down)
    if nbytes < 1:
        raise InputError(field, "must be at least one byte", text)
    return nbytes


def human_size(nbytes: float) -> str:
    """Bytes in binary units, three significant digits.

    Examples
    --------
    >>> human_size(512), human_size(1536), human_size(2 * 1024**3), human_size(1.6e13)
    ('512 bytes', '1.5 KiB', '2 GiB', '14.6 TiB')
    """
    if nbytes < 1024:
        return f"{int(nbytes)} bytes"
    value, unit = float(nbytes), "bytes"
    for unit in ("KiB", "MiB", "GiB", "TiB", "PiB"):
        value /= 1024
        if value < 1024:
            break
    return f"{value:.3g} {unit}"


def available_memory() -> int | None:
    """Bytes of memory available now (see the module's order), or None when nothing can be read."""
    found = _proc_bytes("/proc/meminfo", "MemAvailable")
    for pages in ("SC_AVPHYS_PAGES", "SC_PHYS_PAGES"):
        if found is None:
            with suppress(OSError, ValueError, AttributeError):
                found = os.sysconf(pages) * os.sysconf("SC_PAGE_SIZE")
            if found is not None and found <= 0:
                found = None
    space = _address_space_left()
    if space is not None:
        found = space if found is None else min(found, space)
    return found


def _address_space_left() -> int | None:
    """Bytes of address space left under a finite ``RLIMIT_AS`` (None without one or where it cannot be read)."""
    try:
        import resource

        soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    except (ImportError, OSError, ValueError):
        return None
    used = _proc_bytes("/proc/self/status", "VmSize")
    if soft == resource.RLIM_INFINITY or soft < 0 or used is None:
        return None
    return max(soft - used, 0)


def _proc_bytes(path: str, key: str) -> int | None:
    """The bytes of the line ``key: N kB`` of a file of /proc, or None where it cannot be read."""
    try:
        with open(path, encoding="ascii") as lines:
            return next((int(line.split()[1]) * 1024 for line in lines if line.startswith(f"{key}:")), None)
    except (OSError, ValueError, IndexError):
        return None


@dataclass(frozen=True)
class MemoryLimit:
    """The memory a computation may take: ``nbytes`` (None: no limit) and where that number came from."""

    nbytes: int | None
    source: str

    def describe(self) -> str:
        """The limit and how to change it, as an error message says them."""
        if self.nbytes is None:
            return "no limit"
        return f"the limit of {human_size(self.nbytes)} ({self.source})"


def memory_limit(max_memory: str | int | None = None) -> MemoryLimit:
    """The memory limit: ``max_memory`` if given, else :data:`ENVIRONMENT`, else a share of the available memory.

    Examples
    --------
    >>> memory_limit("1K")
    MemoryLimit(nbytes=1024, source='set by `max_memory`')
    """
    if max_memory is not None:
        return MemoryLimit(parse_size(max_memory, "max_memory"), "set by `max_memory`")
    given = os.environ.get(ENVIRONMENT, "").strip()
    if given:
        return MemoryLimit(parse_size(given, ENVIRONMENT), f"{ENVIRONMENT}={given}; `max_memory` overrides it")
    available = available_memory()
    if available is None:
        return MemoryLimit(None, "the available memory cannot be read")
    share = "one half" if DEFAULT_FRACTION == 0.5 else f"{DEFAULT_FRACTION:g}"
    return MemoryLimit(
        int(available * DEFAULT_FRACTION),
        f"{share} of the {human_size(available)} available now; set `max_memory` or {ENVIRONMENT}",
    )


def check_memory(nbytes: float, what: str, driver: str, instead: str, limit: MemoryLimit | None = None) -> None:
    """Refuse, before allocating, work that would need more than the memory limit.

    Parameters
    ----------
    nbytes : float
        The bytes the work would need at least (its smallest piece, when it is done in pieces).
    what : str
        The work, e.g. ``"one simulated table of the plan"``.
    driver : str
        The inputs that drive the need, parameters in backticks (the command names them as its flags), e.g.
        ``"`groups` 1000 x `contexts` 1000"``.
    instead : str
        What to do instead.
    limit : MemoryLimit, optional
        Default :func:`memory_limit` ().

    Raises
    ------
    MemoryLimitError
        An ``InputError`` with field ``memory``: what it would need, the driver, the limit and where it comes from,
        and what to do instead.

    Examples
    --------
    >>> check_memory(2**30, "one table", "`groups` 1000", "give fewer groups", MemoryLimit(2**31, "set by you"))
    >>> check_memory(2**32, "one table", "`groups` 1000", "give fewer groups", MemoryLimit(2**31, "set by you"))
    Traceback (most recent call last):
    fairaudit.base.errors.MemoryLimitError: memory: one table would need 4 GiB (`groups` 1000), more than the limit of 2 GiB (set by you): give fewer groups
    """
    limit = memory_limit() if limit is None else limit
    if limit.nbytes is not None and nbytes > limit.nbytes:
        raise MemoryLimitError(
            "memory", f"{what} would need {human_size(nbytes)} ({driver}), more than {limit.describe()}: {instead}"
        )
