"""The ACLU's published audits, checked (issue 81): held-out data, not shipped, never tuned on.

Gerchick et al., "Auditing the Audits" (FAccT 2025), publish ``audits/audits_full.csv``: 4,507 rows of 116 bias audits
under NYC Local Law 144, with their own missing-data bounds on each impact ratio (``impact_ratio_lower_bound`` /
``_upper_bound``: every unknown applicant in the row's category, the comparator's rate held; ``..._bound2``: the
unknowns in proportion to the known shares). The data is theirs (CC BY-NC 4.0), so it is not in this repository;
get it with::

    git clone https://github.com/aclu-national/auditing-the-audits-facct-2025
    python benchmarks/bench_published_aclu.py auditing-the-audits-facct-2025/audits/audits_full.csv

The script runs ``fairaudit.check_published`` on the file as it is (the ACLU's column names are its defaults) and
reports: the tables checked, the rows with a finding of each kind (``fairaudit.statistics.published_audit.FINDINGS``)
and the impact ratios recomputed; then, for each of the ACLU's four bound columns, on how many rows fairaudit's value
equals theirs (to 1e-9 relative: both are the same rational formula in floating point), differs, or only one side
gives a value. Exit status 1 when a value differs. Rows where only one side gives a value come from how their code
runs, not from the formula: it bounds the unknown rows themselves (fairaudit bounds categories only); its
proportional variant is NA wherever one category of the table prints no applicants (R's ``sum`` without ``na.rm``),
where fairaudit takes the shares of the categories that print them; and it leaves the first variant empty for
Hackerrank's audits, which its analysis sets aside (a selection there is a negative outcome).
"""

from __future__ import annotations

import argparse
import math
import sys
from collections import Counter, defaultdict
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _bench_common import emit, machine_line, table  # noqa: E402

BOUNDS = {
    "impact_ratio_lower_bound": "aclu_lower",
    "impact_ratio_upper_bound": "aclu_upper",
    "impact_ratio_lower_bound2": "aclu_lower_proportional",
    "impact_ratio_upper_bound2": "aclu_upper_proportional",
}
"""Each of the ACLU's bound columns and the field of :class:`fairaudit.statistics.published_audit.PublishedRow`."""


def _number(text: str) -> float | None:
    try:
        value = float(text)
    except ValueError:
        return None
    return value if math.isfinite(value) else None


def _category(row: dict[str, str]) -> str:
    return " x ".join(p for p in (row["sex"], row["race_ethnicity"]) if p != "Total")


def main(argv: list[str] | None = None) -> int:
    import pandas as pd

    import fairaudit as fa
    from fairaudit.statistics.published_audit import FINDINGS

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("path", help="the ACLU's audits/audits_full.csv")
    parser.add_argument("--output", help="write the report there (Markdown) as well")
    args = parser.parse_args(argv)
    frame = pd.read_csv(args.path, dtype=str, keep_default_na=False)
    checked = fa.check_published(frame)
    # the ACLU's row of each checked row: same audit, type, category and applicants (the rows come in table order)
    records = frame.to_dict("records")
    pool: dict[tuple, list[int]] = defaultdict(list)
    for i, r in enumerate(records):
        pool[(r["audit_id"], r["protected_char_group"], _category(r), _number(r["number_of_applications"]))].append(i)
    theirs = [pool[(r.audit, r.type, r.category, r.applicants)].pop(0) for r in checked.rows]
    tables = {(r.audit, r.rate_kind, r.type) for r in checked.rows}
    kinds = Counter(f.split(":")[0] for r in checked.rows for f in r.findings)
    head = ["what", "rows", "agreement (max rel. diff)"]
    rows = [["tables (audit, rate, category type)", str(len(tables)), "—"],
            ["rows", str(len(checked.rows)), "—"],
            ["impact ratios recomputed", str(sum(r.recomputed_ratio is not None for r in checked.rows)), "—"]]  # fmt: skip
    rows += [[f"rows flagged '{kind}'", str(kinds[kind]), "—"] for kind in FINDINGS]
    differ = 0
    for column, field in BOUNDS.items():
        tally, worst = Counter(), 0.0
        for row, i in zip(checked.rows, theirs, strict=True):
            ours, published = getattr(row, field), _number(records[i][column])
            if ours is None or published is None:
                if (ours is None) != (published is None):
                    tally["only ours" if published is None else "only theirs"] += 1
                continue
            gap = abs(ours - published) / max(1.0, abs(published))
            worst = max(worst, gap)
            tally["equal" if gap <= 1e-9 else "differ"] += 1
        differ += tally["differ"]
        counts = ", ".join(f"{tally[k]} {k}" for k in ("equal", "differ", "only theirs", "only ours"))
        rows.append([f"`{column}`", counts, f"{worst:.2g}"])
    text = "\n".join([f"# The ACLU's published audits, checked ({machine_line(('pandas',))})", "",
                      table(head, rows), ""])  # fmt: skip
    emit(text, args.output)
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
