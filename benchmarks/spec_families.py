"""Generators of the spec families certify is tuned and measured on (issue 80): each writes a spec and its model's
count table into a folder, from a seed, so that anyone can reproduce a figure.

* ``intersectional``: 18 groups (4 with ``small``), a product of randomized responses on 2 x 3 x 3 values (ε split 1 : 1.5 : 1.5 around
  ``epsilon``), three contexts behind a 3 x 3 matrix, ten decisions, a utility by context, τ at 0.05, a count model.
* ``near_tie``: the same shape with the model's rates drawn so that E[g | x, a] sits just above τ for every group
  (the floors nearly bind, and many pairs' programs tie at 1/τ).
* ``counts``: ``groups`` groups (default 200) behind randomized response, two contexts, three decisions, a utility of
  the decision, τ, from a count table.

Usage: ``python benchmarks/spec_families.py FAMILY SEED FOLDER`` prints the spec's path.
"""

from __future__ import annotations

import argparse
import itertools
import json
from pathlib import Path

import numpy as np

FAMILIES = ("intersectional", "near_tie", "counts")


def _toml_list(values: list) -> str:
    return json.dumps(values)


def _header(title: str, groups: list[str] | None, contexts: list[str], decisions: list[str]) -> str:
    """The spec's title, [sensitive] (its values unless a product names them), [context] and [decision] tables."""
    values = "" if groups is None else f"values = {_toml_list(groups)}\n"
    return f"""title = "{title}"

[sensitive]
name = "group"
{values}
[context]
name = "context"
values = {_toml_list(contexts)}

[decision]
name = "decision"
values = {_toml_list(decisions)}
"""


def _counts(
    path: Path, contexts: list[str], groups: list[str], decisions: list[str], rates: np.ndarray, n: int
) -> None:
    """A count table: n records per (context, group), split by ``rates`` [x, a, u] (largest remainders)."""
    lines = ["context,group,decision,count"]
    for x, a in itertools.product(range(len(contexts)), range(len(groups))):
        raw = rates[x, a] * n
        counts = np.floor(raw).astype(int)
        counts[np.argsort(counts - raw)[: n - counts.sum()]] += 1
        counts = np.maximum(counts, 1)
        lines += [f"{contexts[x]},{groups[a]},{decisions[u]},{counts[u]}" for u in range(len(decisions))]
    path.write_text("\n".join(lines) + "\n")


def _product_spec(
    seed: int, near_tie: bool, epsilon: float, small: bool
) -> tuple[str, np.ndarray, list[str], list[str], list[str]]:
    rng = np.random.default_rng(seed)
    parts = [["f", "m"], ["young", "old"]] if small else [["f", "m"], ["young", "mid", "old"], ["a", "b", "c"]]
    groups = [" & ".join(t) for t in itertools.product(*parts)]
    k, n_u = len(groups), 4 if small else 10
    contexts, decisions = ["x0", "x1", "x2"], [f"d{u}" for u in range(n_u)]
    utility = rng.choice([0.0, 0.25, 0.5, 1.0], size=(3, n_u))
    utility[:, 0] = 1.0
    tau = 0.05
    if near_tie:  # E[g | x, a] = tau (1 + small): mass on the zero-utility decisions, a little on the rest
        rates = np.zeros((3, k, n_u))
        for x in range(3):
            g = utility[x]
            zero, pos = np.flatnonzero(g == 0), np.flatnonzero(g > 0)
            if zero.size == 0:
                zero = np.array([int(np.argmin(g))])
            for a in range(k):
                w = rng.dirichlet(np.ones(pos.size))
                share = tau * (1 + rng.uniform(0.01, 0.2)) / float(w @ g[pos])
                rates[x, a, pos] = share * w
                rates[x, a, zero] += (1 - rates[x, a].sum()) * rng.dirichlet(np.ones(zero.size))
    else:
        rates = rng.dirichlet(np.ones(n_u) * 0.7, size=(3, k))
    shares = (np.array([1.0, 1.5]) / 2.5) if small else (np.array([1.0, 1.5, 1.5]) / 4.0)
    components = "".join(
        f"""
[[privacy.sensitive.components]]
name = "part{i}"
mechanism = "randomized_response"
values = {_toml_list(part)}
epsilon = {float(epsilon * shares[i])!r}
"""
        for i, part in enumerate(parts)
    )
    matrix = rng.dirichlet(np.ones(3) * 0.5, size=3) * 0.4 + np.eye(3) * 0.6
    title = f"intersectional family, seed {seed}{' (near ties)' if near_tie else ''}"
    spec = f"""{_header(title, None, contexts, decisions)}
[privacy.sensitive]
mechanism = "product"
{components}
[privacy.context]
mechanism = "matrix"
rows = {_toml_list(matrix.tolist())}

[model]
table = "counts.csv"

[utility]
kind = "table"
values = {_toml_list([[list(map(float, utility[x]))] * k for x in range(3)])}
tau = {tau}

[target]
local = 1.0
"""
    return spec, rates, contexts, groups, decisions


def _count_spec(seed: int, groups_n: int) -> tuple[str, np.ndarray, list[str], list[str], list[str]]:
    rng = np.random.default_rng(seed)
    groups = [f"g{a}" for a in range(groups_n)]
    contexts, decisions = ["x0", "x1"], ["yes", "maybe", "no"]
    rates = rng.dirichlet(np.ones(3) * 2, size=(2, groups_n))
    rates[..., 0] = np.maximum(rates[..., 0], 0.1)
    rates /= rates.sum(axis=-1, keepdims=True)
    spec = f"""{_header(f"{groups_n} groups from counts, seed {seed}", groups, contexts, decisions)}
[privacy.sensitive]
mechanism = "randomized_response"
epsilon = 3.0

[model]
table = "counts.csv"

[utility]
kind = "table"
values = [1.0, 0.5, 0.0]
tau = 0.05

[target]
local = 1.0
"""
    return spec, rates, contexts, groups, decisions


def write_spec(
    family: str, seed: int, folder: Path, *, epsilon: float = 2.0, groups: int = 200, small: bool = False
) -> Path:
    """Write the family's spec for ``seed`` and its count table into ``folder``; return the spec's path.

    Parameters
    ----------
    family : {"intersectional", "near_tie", "counts"}
    seed : int
    folder : pathlib.Path
        Created if missing.
    epsilon : float
        The product's total ε in nats (intersectional families).
    groups : int
        The number of groups of the ``counts`` family.
    small : bool
        The product families on 2 x 2 values and four decisions (a smoke test's size).
    """
    if family not in FAMILIES:
        raise ValueError(f"family must be one of {FAMILIES}, got {family!r}")
    folder.mkdir(parents=True, exist_ok=True)
    if family == "counts":
        spec, rates, contexts, names, decisions = _count_spec(seed, groups)
    else:
        spec, rates, contexts, names, decisions = _product_spec(seed, family == "near_tie", epsilon, small)
    _counts(folder / "counts.csv", contexts, names, decisions, rates, 1000)
    path = folder / f"{family}_{seed}.toml"
    path.write_text(spec)
    return path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("family", choices=FAMILIES)
    parser.add_argument("seed", type=int)
    parser.add_argument("folder", type=Path)
    parser.add_argument("--groups", type=int, default=200)
    args = parser.parse_args()
    print(write_spec(args.family, args.seed, args.folder, groups=args.groups))


if __name__ == "__main__":
    main()
