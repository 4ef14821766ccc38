"""The spec families of ``benchmarks/spec_families.py`` (issue 80), for the tests that need a long certify."""

from __future__ import annotations

import importlib.util
from pathlib import Path

_PATH = Path(__file__).resolve().parents[1] / "benchmarks" / "spec_families.py"
_spec = importlib.util.spec_from_file_location("fairaudit_benchmark_spec_families", _PATH)
assert _spec is not None and _spec.loader is not None
_module = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_module)

write_spec = _module.write_spec
"""``write_spec(family, seed, folder, *, epsilon=2.0, groups=200, small=False)``: the spec's path."""
