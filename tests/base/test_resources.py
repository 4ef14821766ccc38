"""fairaudit.base.resources: sizes by hand, the limit's precedence (argument, environment, available memory), and
the refusal's one line."""

from __future__ import annotations

import pytest

from fairaudit.base import resources
from fairaudit.base.errors import InputError, MemoryLimitError
from fairaudit.base.resources import ENVIRONMENT, MemoryLimit, check_memory, human_size, memory_limit, parse_size


@pytest.mark.parametrize(
    "text,nbytes",
    [
        ("4G", 4 * 2**30),
        ("4g", 4 * 2**30),
        ("4GB", 4 * 2**30),
        ("4GiB", 4 * 2**30),
        ("4Gi", 4 * 2**30),
        ("512M", 512 * 2**20),
        ("2.5GiB", 5 * 2**29),
        ("1.5k", 1536),
        (".5K", 512),
        ("3B", 3),
        ("1T", 2**40),
        ("1048576", 2**20),
        (" 7 M ", 7 * 2**20),
        (123, 123),
    ],
)
def test_sizes_by_hand(text, nbytes):
    assert parse_size(text) == nbytes


@pytest.mark.parametrize("text", ["", "lots", "4X", "-1G", "2.5", "1.5B", "4iB", "4 G B", "1e9", "0", "0.0001K", True])
def test_bad_sizes_name_the_field(text):
    with pytest.raises(InputError) as info:
        parse_size(text, "FAIRAUDIT_MAX_MEMORY")
    assert str(info.value).startswith("FAIRAUDIT_MAX_MEMORY: ")
    assert "\n" not in str(info.value)


def test_human_size():
    assert human_size(0) == "0 bytes"
    assert human_size(1023) == "1023 bytes"
    assert human_size(1024) == "1 KiB"
    assert human_size(10 * 2**30 + 2**29) == "10.5 GiB"


def test_argument_over_environment_over_available(monkeypatch):
    monkeypatch.setenv(ENVIRONMENT, "2M")
    assert memory_limit("1K").nbytes == 1024
    assert memory_limit().nbytes == 2 * 2**20
    assert ENVIRONMENT in memory_limit().source
    monkeypatch.setenv(ENVIRONMENT, "  ")  # empty: unset
    monkeypatch.setattr(resources, "available_memory", lambda: 8 * 2**30)
    limit = memory_limit()
    assert limit.nbytes == 4 * 2**30
    assert "one half of the 8 GiB available now" in limit.source
    monkeypatch.setattr(resources, "available_memory", lambda: None)
    assert memory_limit().nbytes is None


def test_bad_environment_is_named(monkeypatch):
    monkeypatch.setenv(ENVIRONMENT, "4 gigs")
    with pytest.raises(InputError, match=r"^FAIRAUDIT_MAX_MEMORY: must be a size .*\(got '4 gigs'\)$"):
        memory_limit()
    assert memory_limit("1G").nbytes == 2**30  # the argument wins: the environment is not read


def test_available_memory_is_positive_here():
    available = resources.available_memory()
    assert available is None or available > 0


def test_check_memory_refuses_with_one_line():
    limit = MemoryLimit(2**20, "set by `max_memory`")
    check_memory(2**20, "one table", "`groups` 3", "give fewer `groups`", limit)  # at the limit: fits
    check_memory(10**30, "one table", "`groups` 3", "give fewer `groups`", MemoryLimit(None, "unknown"))
    with pytest.raises(MemoryLimitError) as info:
        check_memory(3 * 2**30, "one table", "`groups` 3", "give fewer `groups`", limit)
    assert str(info.value) == (
        "memory: one table would need 3 GiB (`groups` 3), more than the limit of 1 MiB (set by `max_memory`): "
        "give fewer `groups`"
    )
    assert isinstance(info.value, InputError)
