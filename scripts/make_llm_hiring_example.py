"""Build examples/llm_hiring/gpt_rank_counts.csv from the shared GPT resume-ranking data.

Source: ../shared/data/llm_hiring/bloomberg_gpt_rank_counts_main.csv (Bloomberg's
GPT hiring study, main 1,000-run set; see ../shared/data/README.md). Output: one
row per (model, job, demo, rank) with the number of runs in which the model gave
a candidate of that race-by-gender group that rank; "unranked" counts the replies
in which the name was not found. Each run ranks 8 candidates, one per group, so
every (model, job, demo) row sums to 1,000.

Usage: python scripts/make_llm_hiring_example.py [SHARED_DATA_DIR]
"""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
RANKS = [str(r) for r in range(1, 9)] + ["unranked"]


def main(argv: list[str]) -> int:
    data = Path(argv[1]) if len(argv) > 1 else ROOT.parent / "shared" / "data"
    source = data / "llm_hiring" / "bloomberg_gpt_rank_counts_main.csv"
    wide = pd.read_csv(source)
    columns = {f"n_rank{r}": str(r) for r in range(1, 9)} | {"n_rankNA": "unranked"}
    long = wide.melt(id_vars=["model", "job", "demo"], value_vars=list(columns), var_name="rank", value_name="count")
    long["rank"] = long["rank"].map(columns)
    long["rank"] = pd.Categorical(long["rank"], categories=RANKS, ordered=True)
    long = long.sort_values(["model", "job", "demo", "rank"]).reset_index(drop=True)
    totals = long.groupby(["model", "job", "demo"], observed=True)["count"].sum()
    if not (totals == wide.set_index(["model", "job", "demo"])["n_runs"]).all():
        raise SystemExit("rank counts do not add up to n_runs")
    out = ROOT / "examples" / "llm_hiring" / "gpt_rank_counts.csv"
    long.to_csv(out, index=False)
    print(f"wrote {out.relative_to(ROOT)}: {len(long)} rows")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
