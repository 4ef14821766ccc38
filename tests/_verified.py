"""Helpers for the verification tests: certify a spec's text, read its certificate as its JSON holds it, verify it;
the spec of a product of binary randomized responses with a utility by group."""

from __future__ import annotations

import json
import random
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


def product_by_group(components: int, seed: int) -> str:
    """The spec of ``components`` binary randomized responses keeping 0.7 (2^components groups), g(chosen, a) drawn
    from 0.6 to 1 (two digits, seeded), g(not chosen, a) = 0, tau = 0.1: programs over the model's table."""
    rng = random.Random(seed)
    component = '[[privacy.sensitive.components]]\nname = "c{i}"\nmechanism = "randomized_response"\n'
    text = "".join(component.format(i=i) + "values = [0, 1]\nkeep = 0.7\n" for i in range(components))
    values = [[[round(rng.uniform(0.6, 1.0), 2), 0.0] for _ in range(2**components)]]
    return (
        '[sensitive]\nname = "profile"\n[decision]\nname = "outcome"\nvalues = ["chosen", "not chosen"]\n'
        f'[privacy.sensitive]\nmechanism = "product"\n{text}[utility]\nkind = "table"\nvalues = {values}\ntau = 0.1\n'
    )
