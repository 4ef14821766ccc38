"""A published bias audit, checked: every rate and impact ratio its rows allow recomputed and compared with the
printed figure at its printed precision, the 2% exclusions, the missing-data bounds and the verdicts.

A published table (NYC Local Law 144; 6 RCNY § 5-301) has one row per category of a category type: applicants,
selected (or above the median score), the rate, the impact ratio; and a row for the applicants of unknown
category. :func:`check_published` reads such a table, one audit or many (the ACLU's dataset of published audits,
Gerchick et al. 2025, has one row per category of each audit: its column names are the defaults), and reports per
row what it finds:

* ``rate``: the printed rate is not selected / applicants rounded to its printed decimals;
* ``ratio``: the printed ratio is not the rate over the highest rate of the type (from the counts; from the printed
  rates where there are no counts, over the whole range the rates' rounding allows);
* ``above 1``: a printed ratio above 1, which no ratio to the highest rate can be;
* ``excluded``: no ratio printed for a category holding 2% or more of the type's applicants.

A printed figure matches when it is within half a unit of its last printed decimal of the exact value (any rounding
rule; a truncation that differs is a mismatch). Where a type's ratios all match the rates over one other category's
rate, that category is named as the table's comparator. Exact arithmetic throughout (the figures are read as the
decimals they print).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from fractions import Fraction
from typing import TYPE_CHECKING, Any

from fairaudit.base.errors import InputError
from fairaudit.base.json_values import Report, number
from fairaudit.statistics.ll144 import THRESHOLD, VERDICTS
from fairaudit.statistics.missing_demographics import aclu_bounds, missing_data_bounds
from fairaudit.statistics.rate_ratio import adjusted, equal_rates_test

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["FINDINGS", "PublishedAudit", "PublishedRow", "check_published", "printed"]

FINDINGS = ("rate", "ratio", "above 1", "excluded")
"""What :func:`check_published` flags in a row (module docstring)."""

ROLES = {
    "audit": ("audit_id", "audit"),
    "rate_kind": ("selection_or_scoring_rate", "rate_kind"),
    "type": ("protected_char_group", "type", "category_type"),
    "category": ("category",),
    "applicants": ("number_of_applications", "applicants", "n"),
    "selected": ("n_selected_or_n_above_median", "selected", "above_median"),
    "rate": ("result", "rate", "selection_rate", "scoring_rate"),
    "impact_ratio": ("impact_ratio",),
    "comparator": ("comparator_group", "comparator"),
}
"""Each column role and the names it is found under, first match wins (the ACLU's names first). ``rate_kind`` tells
apart the tables of one audit (the ACLU's ``selection_or_scoring_rate``: "Scoring", "Selection", "Selection, top",
...: tiers of one tool are tables of their own); ``comparator`` flags the row a table's ratios divide by (true,
TRUE, yes or 1; the ACLU's ``comparator_group``), which their bounds divide by."""

PARTS = ("sex", "race_ethnicity")
"""Without a ``category`` column, the category is these columns' values joined, a part "Total" left out."""

UNKNOWN = ("missing/unknown", "unknown", "missing")
"""Category labels (any case) of the applicants of unknown category."""

SMALL_SHARE = Fraction(2, 100)

FIGURES = ("applicants", "selected", "rate", "impact_ratio")
"""The roles read as printed figures (:func:`printed`); the others are labels."""


@dataclass(frozen=True)
class Printed:
    """A printed figure: its exact decimal value and half a unit of its last printed place."""

    value: Fraction
    half_unit: Fraction

    def matches(self, exact: Fraction) -> bool:
        """Within half a unit of the last printed place of ``exact``."""
        return abs(exact - self.value) <= self.half_unit


def printed(text: Any) -> Printed | None:
    """A printed figure read exactly: ``"0.85"``, ``"85%"``, ``"85.0 %"``, ``1``; None when empty or missing.

    Examples
    --------
    >>> p = printed("85.5%")
    >>> str(p.value), str(p.half_unit)
    ('171/200', '1/2000')
    >>> printed("0.85").matches(Fraction(17, 20) + Fraction(1, 300))
    True
    """
    if text is None or (isinstance(text, float) and math.isnan(text)):
        return None
    raw = repr(float(text)) if isinstance(text, float) else str(text)  # numpy's float64 too, not 'np.float64(..)'
    body = raw.strip().replace(",", "")
    if not body or body.lower() in ("na", "nan", "n/a", "-", "—"):
        return None
    percent = body.endswith("%")
    body = body.rstrip("%").strip()
    try:
        value = Fraction(body)
    except (ValueError, ZeroDivisionError):
        raise InputError("published", "a figure must be a number or a percentage", raw) from None
    decimals = len(body.split(".")[1]) if "." in body and "e" not in body.lower() else 0
    scale = Fraction(1, 100) if percent else Fraction(1)
    return Printed(value * scale, Fraction(1, 2 * 10**decimals) * scale)


@dataclass(frozen=True)
class PublishedRow:
    """One row of a published table, checked.

    Attributes
    ----------
    audit : str or None
    type : str
    category : str
    applicants, selected : float or None
        As printed.
    rate, impact_ratio : float or None
        As printed (a percentage as a share).
    recomputed_rate, recomputed_ratio : float or None
        From the counts (the ratio from the printed rates where there are no counts).
    share : float or None
        The category's share of the type's applicants (the unknown row included).
    findings : tuple of str
        The items of :data:`FINDINGS` that apply, each with what was expected.
    unknown : bool
        The row of the applicants of unknown category.
    ratio_lower, ratio_upper : float or None
        The sharp range of the impact ratio over every way the unknown applicants could belong to the categories
        (:func:`~fairaudit.statistics.missing_demographics.missing_data_bounds`; needs the unknown row's selected).
    aclu_lower, aclu_upper, aclu_lower_proportional, aclu_upper_proportional : float or None
        The ACLU's two variants (:func:`~fairaudit.statistics.missing_demographics.aclu_bounds`), over the rate of
        the row flagged ``comparator``, else the highest printed rate of the table (the unknown row's included), as
        their code (``calc_audit_bounds``) does.
    p_value, verdict : float or None, str or None
        From whole counts: Fisher's two-sided test of equal rates with the type's highest recomputed rate, Holm-adjusted
        over the audit's tested rows, and the verdict of the recomputed ratio against 0.8
        (:data:`~fairaudit.statistics.ll144.VERDICTS`); None for the comparator's p-value, and where the row has no
        whole counts or no printed ratio.
    """

    audit: str | None
    type: str
    category: str
    applicants: float | None
    selected: float | None
    rate: float | None
    impact_ratio: float | None
    recomputed_rate: float | None
    recomputed_ratio: float | None
    share: float | None
    findings: tuple[str, ...]
    unknown: bool
    ratio_lower: float | None = None
    ratio_upper: float | None = None
    aclu_lower: float | None = None
    aclu_upper: float | None = None
    aclu_lower_proportional: float | None = None
    aclu_upper_proportional: float | None = None
    p_value: float | None = None
    verdict: str | None = None
    rate_kind: str | None = None


@dataclass(frozen=True)
class PublishedAudit:
    """What :func:`check_published` found; repeats the columns it read.

    Attributes
    ----------
    rows : tuple of PublishedRow
        In the table's order.
    columns : dict of str to str
        The column of each role found.
    comparators : dict of (audit, type) to str
        Where every printed ratio of a type matches the rates over one category's rate other than the highest:
        that category.
    """

    rows: tuple[PublishedRow, ...]
    columns: dict[str, str]
    comparators: dict[tuple[str | None, str], str]

    @property
    def consistent(self) -> bool:
        """No row has a finding (``fairaudit audit --published`` exits 0, else 1)."""
        return not any(r.findings for r in self.rows)

    def to_dict(self) -> Report:
        """``{"published": [...], "published_details": {...}}``: each row's fields (``findings`` a list), the
        columns read, the comparators found (``"audit / type": category``), ``consistent`` and the rows checked."""
        rows = [
            {f: (list(v) if f == "findings" else number(v) if isinstance(v, float) else v) for f, v in vars(r).items()}
            for r in self.rows
        ]
        comparators = {" / ".join(filter(None, key)): c for key, c in self.comparators.items()}
        details = {"columns": dict(self.columns), "comparators": comparators, "consistent": self.consistent}
        return {"published": rows, "published_details": {**details, "rows": len(self.rows)}}

    def to_frame(self) -> pd.DataFrame:
        """One row per table row; the columns are :class:`PublishedRow`'s fields, ``findings`` joined by "; "."""
        import pandas as pd

        fields = list(PublishedRow.__dataclass_fields__)
        frame = pd.DataFrame([[getattr(r, f) for f in fields] for r in self.rows], columns=fields)
        frame["findings"] = ["; ".join(r.findings) for r in self.rows]
        return frame


def check_published(table: pd.DataFrame, columns: dict[str, str] | None = None) -> PublishedAudit:
    """Check a published impact-ratio table (module docstring).

    Parameters
    ----------
    table : pandas.DataFrame
        The published rows; figures as printed (text keeps the printed decimals; numbers are read by their
        shortest repr).
    columns : dict of str to str, optional
        Column of a role (:data:`ROLES`: ``audit``, ``rate_kind``, ``type``, ``category``, ``applicants``,
        ``selected``, ``rate``, ``impact_ratio``, ``comparator``) where its name differs from the defaults.

    Returns
    -------
    PublishedAudit

    Raises
    ------
    InputError
        No category (neither ``category`` nor the :data:`PARTS` columns), neither counts nor rates, a column named
        in ``columns`` that is not in the table, or a figure that is not a number.

    Examples
    --------
    >>> import pandas as pd
    >>> t = pd.DataFrame({"category": ["Female", "Male", "Unknown"], "applicants": [100, 120, 10],
    ...                   "selected": [30, 48, 3], "rate": ["0.30", "0.40", "0.30"], "impact_ratio": ["0.80", "1.00", ""]})
    >>> checked = check_published(t)
    >>> checked.consistent, checked.rows[0].findings
    (False, ('ratio: printed 0.80, from the counts 0.75',))
    """
    found = _columns(table, columns or {})
    rows = [_read(table, found, i) for i in range(len(table))]
    out: dict[int, PublishedRow] = {}
    comparators: dict[tuple[str | None, str], str] = {}
    groups: dict[tuple, list[int]] = {}
    for i, r in enumerate(rows):
        groups.setdefault((r["audit"], r["rate_kind"], r["type"]), []).append(i)
    for (audit, kind, type_), members in groups.items():
        checked, comparator = _check_type([rows[i] for i in members])
        out.update(zip(members, checked, strict=True))
        if comparator is not None:
            comparators[(" / ".join(v for v in (audit, kind) if v) or None, type_)] = comparator
    return PublishedAudit(tuple(_verdicts([out[i] for i in range(len(rows))])), found, comparators)


def _columns(table: pd.DataFrame, given: dict[str, str]) -> dict[str, str]:
    """The column of each role present in the table."""
    names = {str(c).strip().lower(): str(c) for c in table.columns}
    found: dict[str, str] = {}
    for role, column in given.items():
        if role not in ROLES:
            raise InputError("columns", f"roles are {', '.join(ROLES)}", role)
        if column not in table.columns:
            raise InputError(role, "is not a column of the published table", column)
        found[role] = column
    for role, aliases in ROLES.items():
        if role not in found:
            hit = next((names[a] for a in aliases if a in names), None)
            if hit is not None:
                found[role] = hit
    if "category" not in found and not any(p in names for p in PARTS):
        raise InputError("category", f"the published table needs a category column (or {' and '.join(PARTS)})")
    if "rate" not in found and not {"applicants", "selected"} <= set(found):
        raise InputError("rate", "the published table needs rates, or applicants and selected")
    found.update({p: names[p] for p in PARTS if p in names and "category" not in found})
    return found


def _read(table: pd.DataFrame, found: dict[str, str], i: int) -> dict[str, Any]:
    """Row i as the roles' values: counts and figures as :class:`Printed`, labels as text."""
    row = table.iloc[i]

    def text(role: str) -> str | None:
        value = row[found[role]] if role in found else None
        return None if value is None or (isinstance(value, float) and math.isnan(value)) else str(value).strip()

    if "category" in found:
        category = text("category") or ""
        parts = [category]
    else:
        parts = [p for p in (text(q) for q in PARTS if q in found) if p and p.lower() != "total"]
        category = " x ".join(parts)
    flag = (text("comparator") or "").lower()
    if flag not in ("", "na", "true", "false", "yes", "no", "1", "0"):
        raise InputError(found["comparator"], "flags the comparator row: true or false", flag)
    return {
        "audit": text("audit"),
        "rate_kind": text("rate_kind"),
        "comparator": flag in ("true", "yes", "1"),
        "type": text("type") or "",
        "category": category,
        "unknown": any(p.lower() in UNKNOWN for p in parts),
        **{role: printed(row[found[role]]) if role in found else None for role in FIGURES},
    }


def _check_type(group: list[dict[str, Any]]) -> tuple[list[PublishedRow], str | None]:
    """The rows of one category type of one audit, checked, and the comparator its ratios match, if any."""
    known = [r for r in group if not r["unknown"]]
    total = sum((r["applicants"].value for r in group if r["applicants"] is not None), Fraction(0))
    exact = {id(r): _exact_rate(r) for r in group}
    included = [r for r in known if r["impact_ratio"] is not None]
    top = max((v for v in (exact[id(r)] for r in included) if v is not None), default=None)
    comparator = _comparator(included, exact)
    bounds = _missing(group, known)
    out = []
    for r in group:
        findings: list[str] = []
        rate = exact[id(r)]
        if rate is not None and r["rate"] is not None and r["selected"] is not None and not r["rate"].matches(rate):
            findings.append(f"rate: printed {_text(r['rate'])}, from the counts {float(rate):.4g}")
        ratio = None if rate is None or top is None or r["unknown"] else (rate / top if top else Fraction(1))
        if r["impact_ratio"] is not None and not r["unknown"]:
            if r["impact_ratio"].value > 1:
                findings.append(f"above 1: printed {_text(r['impact_ratio'])}")
            elif not _ratio_holds(r, included):
                want = "the counts" if r["selected"] is not None else "the printed rates"
                findings.append(f"ratio: printed {_text(r['impact_ratio'])}, from {want} {float(ratio or 0):.4g}")
        share = None if r["applicants"] is None or not total else r["applicants"].value / total
        if r["impact_ratio"] is None and not r["unknown"] and share is not None and share >= SMALL_SHARE:
            findings.append(f"excluded: no ratio printed, yet {float(share):.2%} of the applicants (at least 2%)")
        out.append(
            PublishedRow(
                r["audit"], r["type"], r["category"], _float(r["applicants"]), _float(r["selected"]),
                _float(r["rate"]), _float(r["impact_ratio"]), None if rate is None else float(rate),
                None if ratio is None else float(ratio), None if share is None else float(share),
                tuple(findings), r["unknown"], **bounds.get(id(r), {}), rate_kind=r["rate_kind"],
            )
        )  # fmt: skip
    return out, comparator


def _exact_rate(r: dict[str, Any]) -> Fraction | None:
    """selected / applicants exactly, else the printed rate's value."""
    if r["selected"] is not None and r["applicants"] is not None and r["applicants"].value > 0:
        return r["selected"].value / r["applicants"].value
    return None if r["rate"] is None else r["rate"].value


def _ratio_holds(r: dict[str, Any], included: list[dict[str, Any]]) -> bool:
    """Whether the printed ratio is the rate over the highest included rate: exactly from counts; over the box of
    the printed rates' rounding where a rate comes from print (``proofs/impact_ratio.md`` §1's range)."""

    def ends(x: dict[str, Any]) -> tuple[Fraction, Fraction] | None:
        if x["selected"] is not None and x["applicants"] is not None and x["applicants"].value > 0:
            v = x["selected"].value / x["applicants"].value
            return v, v
        p = x["rate"]
        return None if p is None else (max(Fraction(0), p.value - p.half_unit), min(Fraction(1), p.value + p.half_unit))

    mine = ends(r)
    others = [ends(x) for x in included if x is not r]
    if mine is None or any(o is None for o in others):
        return True  # not recomputable
    lo_others = max((o[0] for o in others if o), default=Fraction(0))
    hi_others = max((o[1] for o in others if o), default=Fraction(0))
    low = Fraction(1) if mine[0] >= hi_others else mine[0] / hi_others
    high = Fraction(1) if mine[1] >= lo_others else mine[1] / lo_others
    p = r["impact_ratio"]
    return low - p.half_unit <= p.value <= high + p.half_unit


def _comparator(included: list[dict[str, Any]], exact: dict[int, Fraction | None]) -> str | None:
    """The category c, other than the highest-rate one, with every printed ratio = rate / rate of c."""
    rates = [(r, exact[id(r)]) for r in included]
    if len(rates) < 2 or any(v is None for _, v in rates):
        return None
    top = max(v for _, v in rates if v is not None)
    for c, rc in rates:
        if rc is None or rc == 0 or rc == top:
            continue
        if all(r["impact_ratio"].matches(v / rc) for r, v in rates if v is not None):
            return str(c["category"])
    return None


def _missing(group: list[dict[str, Any]], known: list[dict[str, Any]]) -> dict[int, dict[str, Any]]:
    """The missing-data bounds of each included row, by id: sharp, and the ACLU's two variants."""
    unknown = [r for r in group if r["unknown"] and r["applicants"] is not None]
    counted = [r for r in known if r["applicants"] is not None and r["applicants"].value > 0 and r["selected"]]
    if not unknown or not counted:
        return {}
    u = unknown[0]  # several unknown rows: theirs take the first (R's ifelse keeps one element); the sharp range none
    out: dict[int, dict[str, Any]] = {id(r): {} for r in counted}
    # the ACLU's bounds reach the categories with no known applicant too (theirs: 0 to all the unknowns' rate)
    empty = [r for r in known if r["applicants"] is not None and r["applicants"].value == 0 and r["selected"]]
    if u["selected"] is not None and len(unknown) == 1:
        b = missing_data_bounds(
            [id(r) for r in counted], [r["applicants"].value for r in counted], [r["selected"].value for r in counted],
            u["applicants"].value, u["selected"].value,
        )  # fmt: skip
        for r, lo, hi in zip(counted, b.ratio_lower, b.ratio_upper, strict=True):
            out[id(r)].update(ratio_lower=float(lo), ratio_upper=float(hi))
    # theirs: the flagged comparator's printed rate, else max(result) with the unknown row in
    printed_rates = [r["rate"].value for r in group if r["rate"] is not None]
    flagged = [r["rate"].value for r in group if r["comparator"] and r["rate"] is not None]
    top = max(flagged[:1] or printed_rates or [v for v in map(_exact_rate, group) if v is not None], default=None)
    if top:
        n = [float(r["applicants"].value) for r in counted]
        s = [float(r["selected"].value) for r in counted]
        for proportional, names in (
            (False, ("aclu_lower", "aclu_upper")),
            (True, ("aclu_lower_proportional", "aclu_upper_proportional")),
        ):
            lows, highs = aclu_bounds(n, s, float(u["applicants"].value), float(top), proportional)
            for r, low, high in zip(counted, lows, highs, strict=True):
                out[id(r)].update({names[0]: low, names[1]: high})
        if empty and u["applicants"].value > 0:  # (their proportional variant adds none there: 0/0, no bound)
            lows, highs = aclu_bounds([0.0] * len(empty), [0.0] * len(empty), float(u["applicants"].value), float(top))
            for r, low, high in zip(empty, lows, highs, strict=True):
                out[id(r)] = {"aclu_lower": low, "aclu_upper": high}
    return out


def _float(p: Printed | None) -> float | None:
    return None if p is None else float(p.value)


def _text(p: Printed) -> str:
    """A printed figure as it reads (its decimals kept)."""
    digits = max(0, -int(math.floor(math.log10(float(p.half_unit * 2)))))
    return f"{float(p.value):.{digits}f}"


def _verdicts(rows: list[PublishedRow]) -> list[PublishedRow]:
    """Each row with whole counts and a printed ratio, tested against its type's highest recomputed rate (Fisher,
    Holm over each audit's tests) and its recomputed ratio read against four-fifths."""
    counts = {
        i: (r.selected, r.applicants)
        for i, r in enumerate(rows)
        if r.selected is not None and r.applicants and r.impact_ratio is not None and not r.unknown
        and float(r.selected).is_integer() and float(r.applicants).is_integer()
    }  # fmt: skip
    out = list(rows)
    for audit in dict.fromkeys((r.audit, r.rate_kind) for r in rows):
        tests: list[tuple[int, float]] = []
        for kind in dict.fromkeys(r.type for r in rows if (r.audit, r.rate_kind) == audit):
            counted = [i for i in counts if (rows[i].audit, rows[i].rate_kind) == audit and rows[i].type == kind]
            if len(counted) < 2:
                continue
            top = max(counted, key=lambda i: counts[i][0] / counts[i][1])
            tests += [(i, equal_rates_test(*counts[i], *counts[top])) for i in counted if i != top]
            out[top] = replace(rows[top], verdict=VERDICTS[2])
        for (i, _), p in zip(tests, adjusted([p for _, p in tests], "holm"), strict=True):
            ratio = rows[i].recomputed_ratio
            below = ratio is not None and ratio < THRESHOLD
            out[i] = replace(
                rows[i], p_value=float(p), verdict=VERDICTS[0 if p < 0.05 else 1] if below else VERDICTS[2]
            )
    return out
