"""The head of the specs in the spec tests (``tests/certification/test_spec*.py``): a sensitive attribute, two
decisions and the utility of one of them, to which each test adds its tables (the values first, by ``replace``)."""

from __future__ import annotations

HEAD = """
[sensitive]
name = "profile"
[decision]
name = "office"
values = ["HR_1", "HR_2"]
[utility]
decision = "HR_2"
"""

HEAD_TAU = HEAD + "tau = 0.1\n"
"""The same head with τ = 0.1 in its ``[utility]`` table."""
