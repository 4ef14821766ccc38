"""Certify and verify on the spec families of issue 80 (``spec_families.py``): time per spec, and certify against the
HiGHS solves inside it (the peer: what one floating-point simplex solve of each program costs, timed in the same run).

For each family and seed: the spec is written to a temporary folder; ``certify`` runs in process with every
``ExactProgram``'s HiGHS step timed apart (wrapped here, not in the library); the certificate's JSON is then verified
(``fairaudit.verify``). Columns: certify's seconds, the HiGHS seconds within it and their ratio (certify / HiGHS), the
programs and Dinkelbach steps solved, verify's seconds and whether it holds, the best bound.

Usage::

    python benchmarks/bench_certify.py                 # intersectional and near_tie seeds 1-3, counts at 200 groups
    python benchmarks/bench_certify.py --quick         # one small spec of each family (the smoke test)
    python benchmarks/bench_certify.py --family counts --groups 50 --seeds 1
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from spec_families import FAMILIES, write_spec  # noqa: E402


def _timed_highs() -> dict[str, float]:
    """Wrap ExactProgram's HiGHS step to add up its time and count its solves."""
    from fairaudit.base import exact_lp

    clock = {"highs": 0.0, "solves": 0}
    original = exact_lp.ExactProgram._solver_basis

    def timed(self, cost):  # type: ignore[no-untyped-def]
        start = time.perf_counter()
        try:
            return original(self, cost)
        finally:
            clock["highs"] += time.perf_counter() - start
            clock["solves"] += 1

    exact_lp.ExactProgram._solver_basis = timed  # type: ignore[method-assign]
    return clock


def run(family: str, seed: int, groups: int, clock: dict[str, float], small: bool = False) -> dict[str, object]:
    import fairaudit as fa
    from fairaudit.certification.spec import load_spec

    with tempfile.TemporaryDirectory() as folder:
        path = write_spec(family, seed, Path(folder), groups=groups, small=small)
        spec = load_spec(path)
        clock["highs"], clock["solves"] = 0.0, 0
        start = time.perf_counter()
        cert = fa.certify(spec)
        certify_s = time.perf_counter() - start
        highs_s, solves = clock["highs"], clock["solves"]
        document = json.loads(json.dumps(cert.to_dict()))
        start = time.perf_counter()
        checked = fa.verify(document)
        verify_s = time.perf_counter() - start
    return {
        "family": family,
        "seed": seed,
        "certify_s": certify_s,
        "highs_s": highs_s,
        "ratio": certify_s / highs_s if highs_s else float("nan"),
        "solves": solves,
        "verify_s": verify_s,
        "holds": bool(checked.holds),
        "bound": document.get("bounds", {}).get("best"),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--family", choices=FAMILIES, action="append")
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--groups", type=int, default=200)
    parser.add_argument(
        "--quick", action="store_true", help="one seed, 4 groups for the product families and 20 for counts"
    )
    args = parser.parse_args(argv)
    families = args.family or list(FAMILIES)
    seeds = 1 if args.quick else args.seeds
    groups = 20 if args.quick else args.groups
    clock = _timed_highs()
    rows = []
    print("| family | seed | certify s | HiGHS s | certify / HiGHS | HiGHS solves | verify s | holds | best bound |")
    print("|---|---|---|---|---|---|---|---|---|")
    for family in families:
        for seed in range(1, seeds + 1):
            r = run(family, seed, groups, clock, small=args.quick)
            rows.append(r)
            print(
                f"| {family} | {seed} | {r['certify_s']:.1f} | {r['highs_s']:.1f} | {r['ratio']:.1f} | {r['solves']} "
                f"| {r['verify_s']:.1f} | {r['holds']} | {r['bound']} |",
                flush=True,
            )
    failed = [r for r in rows if not r["holds"]]
    if failed:
        print(f"verify failed on {len(failed)} certificates", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
