"""A helper for the verification tests: certify a spec's text, read its certificate as its JSON holds it, verify it."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import fairaudit


def certified_and_verified(spec: str, folder: Path) -> tuple[dict[str, Any], fairaudit.Verification, set[str]]:
    """The certificate of ``spec`` (TOML text), its verification (asserted to hold) and the names of its checks."""
    path = folder / "spec.toml"
    path.write_text(spec, encoding="utf-8")
    cert = json.loads(json.dumps(fairaudit.certify(path).to_dict()))
    result = fairaudit.verify(cert)
    assert result.holds, [c.line() for c in result.failures]
    return cert, result, {c.name for c in result.checks}
