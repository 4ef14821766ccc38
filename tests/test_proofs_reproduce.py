"""Every ```python block in proofs/*.md prints exactly the ```text block that follows it.

The proofs quote numbers; this keeps each of them the output of the code shown next to it.
"""

from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

import pytest

PROOFS = Path(__file__).resolve().parents[1] / "proofs"
BLOCK = re.compile(r"```python\n(.*?)```\n```text\n(.*?)```", re.S)


def _blocks():
    for path in sorted(PROOFS.glob("*.md")):
        for i, m in enumerate(BLOCK.finditer(path.read_text(encoding="utf-8"))):
            yield pytest.param(m.group(1), m.group(2), id=f"{path.name}#{i + 1}")


@pytest.mark.slow
@pytest.mark.parametrize("code, want", list(_blocks()))
def test_proof_block_prints_its_text(code, want, monkeypatch):
    monkeypatch.syspath_prepend(str(PROOFS))
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(code, "<proof block>", "exec"), {"__name__": "__proof__"})
    assert out.getvalue().strip() == want.strip()
