"""Pieces shared by the text and Markdown formats: numbers in words, pairs of groups, common lines."""

from __future__ import annotations

from .._json import Report

__all__ = ["PLAN_HEAD", "fmt", "goal", "measure", "nats", "pair", "plan_head", "plan_rows", "population_line"]


def fmt(v: object, digits: int = 6) -> str:
    """A JSON value for reading: ``n/a`` for None, ``yes``/``no``, integers as they are, floats to ``digits``.

    Examples
    --------
    >>> fmt(None), fmt(True), fmt(3), fmt(0.123456789), fmt("inf"), fmt(0.123456789, 3)
    ('n/a', 'yes', '3', '0.123457', 'inf', '0.123')
    """
    if v is None:
        return "n/a"
    if isinstance(v, str):
        return v
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, int):
        return str(v)
    return f"{v:.{digits}g}"


def nats(v: object) -> str:
    """A value in nats: ``0.5 nats``, ``inf`` or ``n/a``."""
    return "n/a" if v is None else ("inf" if v == "inf" else f"{fmt(v)} nats")


def pair(d: Report) -> str:
    """`` (a vs b in context x)`` of a measure's dictionary; empty without a group."""
    where = f" in context {d['context']!s}" if d.get("context") is not None else ""
    if d.get("group") is None:
        return ""
    return f" ({d['group']} vs {d['other_group']}{where})"


def population_line(d: Report) -> str:
    """The reports' population line."""
    p = d["population"]
    if p["independent"] == "assumed":
        return f"population P(X, A): {p['description']}"
    state = "independent" if p["independent"] else "dependent"
    return (
        f"population P(X, A): {p['description']}; X and A {state} in it (max |P(x,a) - P(x)P(a)| = "
        f"{fmt(p['max_deviation'], 3)} at context {fmt(p['context'])}, group {fmt(p['group'])})"
    )


def goal(kind: str, target: object) -> str:
    """'the local target 0.5 nats on L' (or on L-bar for the global one)."""
    return f"the {kind} target {nats(target)} on {'L' if kind == 'local' else 'L-bar'}"


def measure(d: Report) -> str:
    """``L-bar`` for a calibration of the global measure, else ``L``."""
    return "L-bar" if d.get("kind") == "global" else "L"


def plan_head(d: Report) -> list[str]:
    """The two lines that state a plan's question and its assumed model."""
    name = "L-bar" if d["kind"] == "global" else "L"
    ctx = f"{d['contexts']} context{'s' if d['contexts'] != 1 else ''}"
    filt = (
        f"queried behind {d['groups']}-ary randomized response at epsilon = {nats(d['epsilon'])}"
        if d["epsilon"] is not None
        else "no privacy filter"
    )
    return [
        f"queries per cell to certify {name} <= {nats(d['target'])} at confidence {fmt(d['confidence'])} "
        f"with power {fmt(d['power'])}",
        f"model: {d['groups']} groups x {ctx}, E[g] = {fmt(d['base_rate'])}, group 0 times "
        f"exp({fmt(d['disparity'])}); {filt}; true {name} = {nats(d['true_value'])}",
    ]


#: Columns of a plan's table, one row per method.
PLAN_HEAD = ("method", "n per cell", "n total", "power", "median upper end", "datasets")


def plan_rows(d: Report) -> list[tuple[str, ...]]:
    """A plan's table rows, one per method (columns :data:`PLAN_HEAD`)."""

    def upper(v: object) -> str:
        return "n/a" if v is None else ("inf" if v == "inf" else f"{fmt(v, 4)} nats")

    return [
        (
            p["method"],
            fmt(p["n_per_cell"]),
            fmt(p["n_total"]),
            fmt(p["achieved_power"], 3),
            upper(p["expected_upper"]),
            str(p["datasets"]),
        )
        for p in d["plans"]
    ]
