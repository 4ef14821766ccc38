"""The Markdown report of an experiment (``report.md``), from its certificate JSON."""

from __future__ import annotations

__all__ = ["experiment_markdown", "paper_design_markdown"]


def _f(v: float | str | None, digits: int = 4) -> str:
    if v is None:
        return "n/a"
    if isinstance(v, str):
        return "∞" if v == "inf" else v
    return f"{v:.{digits}g}" if abs(v) >= 1e-3 or v == 0 else f"{v:.2e}"


def _ivs(d: dict) -> str:
    iv = d.get("interval")
    return "" if iv is None else f" [{_f(iv[0])}, {_f(iv[1])}]"


def _seen(d: dict) -> str:
    """Two cells of a table: an observed value with its interval, then its range over the unparsed reply's utility."""
    return f"{_f(d['value'])}{_ivs(d)} | {_range(d)}"


def _range(d: dict) -> str:
    """An observed value's range over the unparsed reply's utility, ``[lower, upper]``, or "n/a"."""
    r = d.get("unparsed_range")
    return "n/a" if r is None else f"[{_f(r[0])}, {_f(r[1])}]"


def _bound(p: dict, name: str) -> str:
    """A point's certified bound, with its range over the unparsed reply's utility when that is not one value."""
    r = ((p["bounds"].get("unparsed_range") or {}).get(name) or {}).get("range")
    if r is None or r[0] == r[1]:
        return _f(p["bounds"][name])
    return f"{_f(p['bounds'][name])} [{_f(r[0])}, {_f(r[1])}]"


def _bounds_range_md(d: dict) -> str:
    """One sentence: whether the certified bounds depend on the unparsed reply's utility, and why."""
    ranges = (d["points"][0]["bounds"].get("unparsed_range") or {}) if d["points"] else {}
    if "black_box" not in ranges:
        return ""
    point = all(v["range"][0] == v["range"][1] for p in d["points"] for v in p["bounds"]["unparsed_range"].values())
    return (
        f" Certified bounds over the unparsed reply's utility: the corollary is ε of the filter, and "
        f"{ranges['black_box']['reason']}" + ("." if point else " (in the bounds' columns).")
    )


def _warning_md(d: dict) -> list[str]:
    """The warning when shown cells put more than 0.2 of their mass on unparsed replies."""
    m = d.get("unparsed_mass") or {}
    return ["", f"**Warning:** {m['warning']}."] if m.get("warning") else []


def _range_md(d: dict) -> str:
    """What the unparsed range means."""
    u = d["utility"]
    low, high = u.get("unparsed_range", [None, None])
    head = (
        f"The unparsed range is the exact range of the value over every utility of an unparsed reply in "
        f"[{_f(low)}, {_f(high)}] (min g, max g), chosen independently for every cell of the per-candidate "
    )
    if d.get("design") == "paper":
        return head + "law observed at that ε (context @ position, candidate); the value itself uses the stated one."
    return head + "kernel; the value itself uses the stated one. A target is met only when the upper end meets it."


def experiment_markdown(d: dict) -> str:
    """The Markdown report of :func:`fairaudit.experiments.report.experiment_dict`."""
    lines = _intro_md(d) + _warning_md(d) + _baseline_md(d)
    if d.get("position_split") is not None:
        lines += _split_md(d)
    lines += _curve_md(d)
    if d.get("budgets"):
        lines += _budgets_md(d)
    if d["paper_design"]:
        lines += _paper_design_md(d)
    lines += [
        "",
        "The black-box bound holds for every decision model behind the filter (exact worst case); the "
        "observed values are this model's. "
        + (
            "Files: kernel.csv (the model's exact kernel, probabilities), candidates.csv, certificate.json, curve.csv."
            if d.get("route") == "exact"
            else "Files: kernel.csv (the model's kernel with counts), candidates.csv, records.csv (per-candidate "
            "records for `fairaudit audit`), certificate.json, curve.csv, queries.jsonl (every query and reply)."
        ),
        "",
    ]
    return "\n".join(lines)


def _framing_md(d: dict) -> list[str]:
    """Title and the per-candidate framing: context, group, outcome, utility, positions."""
    lines = [f"# {d['experiment']}: {d['model']}", ""]
    cands = d["candidates"]
    who = " or ".join(cands) if len(cands) <= 4 else f"one of {len(cands)} profiles"
    slots = d.get("slots", 2)
    where = f"{d['context']} @ position" if slots > 1 else d["context"]
    lines += [
        f"Per-candidate framing: context = {where}, group = the "
        f"candidate's true profile ({who}), outcome = its own; "
        f"utility: {d['utility']['name']}."
        + _unparsed_md(d["utility"])
        + (f" Positions: {d['positions']}." if slots > 1 else " One candidate per prompt."),
        "",
    ]
    return lines


def _unparsed_md(utility: dict) -> str:
    """The sentence on g of an unparsed reply: its value, given or the default, and the rule."""
    u = utility.get("unparsed")
    if u is None:
        return ""
    how = "given: `[utility] unparsed`" if u["source"] == "given" else f"{u['source']}: {u['rule']}"
    return f" An unparsed reply counts g = {_f(u['value'])} ({how})."


def _intro_md(d: dict) -> list[str]:
    """Title, the framing, and the queries (or the exact route) behind the kernel."""
    q = d["queries"]
    lines = _framing_md(d)
    if d.get("route") == "exact":
        lines += [
            "Exact route: the kernel is the model's own law of its reply on every shown cell of the table design, "
            f"from its token probabilities ({_scoring_words(d)}): no sampling "
            "error, so no intervals; the filter is applied by exact "
            f"composition at every ε. On average {_f(q['unparsed_share'], 3)} of the probability mass is on "
            "replies that would not parse; it counts as 'unparsed'."
            + _coverage_words((d.get("run") or {}).get("scoring") or {})
        ]
    else:
        lines += [
            f"Queries: {q['table']} in the table design ({d['samples']} per shown cell; the filter is applied by "
            f"exact composition, so they serve every ε); {q['unparsed']} replies could not be parsed and count as "
            f"'unparsed'."
        ]
        lines += _sampling_md(d) + _replies_md(d)
    if q["paper"]:
        lines += [
            f"The paper's design (sampling through the filter) used {q['paper']} more, "
            f"{q['paper_design_needs_per_epsilon']} per ε."
        ]
    return lines


def _baseline_md(d: dict) -> list[str]:
    """L and L̄ without a filter, the baseline figure and the decision shares per context and order."""
    conf = d["confidence"]
    lines = [
        "",
        "## Baseline: no filter",
        "",
        f"L = {_f(d['baseline']['local']['value'])} nats{_ivs(d['baseline']['local'])}, "
        f"L̄ = {_f(d['baseline']['global']['value'])} nats{_ivs(d['baseline']['global'])}"
        + (f" ({conf:g} simultaneous intervals)." if conf else "."),
        "",
        f"Over the unparsed reply's utility: L in {_range(d['baseline']['local'])}, "
        f"L̄ in {_range(d['baseline']['global'])} nats. " + _range_md(d),
        "",
        "![baseline](baseline.png)",
        "",
    ]
    shares = d["baseline"]["shares"]
    decisions = next(iter(next(iter(shares.values())).values()))
    if len(decisions) > 12:
        return lines + [
            f"The decision shares of the true prompts are in certificate.json ({len(decisions)} decisions)."
        ]
    head = "| context | " + ("order" if d.get("slots", 2) > 1 else "candidate") + " | " + " | ".join(decisions) + " |"
    lines += [head, "|" + "---|" * (head.count("|") - 1)]
    rows = [(ctx, order, s) for ctx, orders in shares.items() for order, s in orders.items()]
    for ctx, order, s in rows[:_MAX_ROWS]:
        lines.append(f"| {ctx} | {order} | " + " | ".join(_f(v, 3) for v in s.values()) + " |")
    if len(rows) > _MAX_ROWS:
        lines += ["", f"({len(rows) - _MAX_ROWS} more rows in certificate.json.)"]
    return lines


_MAX_ROWS = 24


def listed_order(task_name: str) -> str:
    """What the task's own order of the candidates is called: the paper's (built-in tasks) or the listed one."""
    from .taskfile import BUILT_IN

    return "paper's order" if task_name in BUILT_IN else "listed order"


def _split_md(d: dict) -> list[str]:
    """The listed order's log ratio split into position and group, overall and per context."""
    sp = d["position_split"]
    c1, c2 = sp.get("pair") or d["candidates"]
    order = listed_order(d["experiment"])
    two = len(d["candidates"]) == 2 and d.get("slots", 2) == 2
    if two:
        intro = (
            f"In the {order} ({c1} listed first) the log ratio of the two candidates' expected "
            f"utility is {_f(sp['raw'])} nats. Showing both orders splits it exactly into a position part "
            f"(first against second, same candidate) and a group part ({c1} against {c2}, same position); "
            "L̄ above is the group part's kind, with position as a context."
        )
    else:
        intro = (
            f"In the {order} ({c1} in the first slot, {c2} in the second) the log ratio of the two candidates' "
            f"expected utility is {_f(sp['raw'])} nats. Showing all orders splits it exactly into a position "
            f"part (first slot against second, averaged over the candidates), a group part ({c1} against {c2}, "
            "averaged over the slots) and the interaction of the two (what neither average explains)."
        )
    parts = ("raw", "position", "group") if two else ("raw", "position", "group", "interaction")
    head = f"| context | raw ({order}) | " + " | ".join(parts[1:]) + " |"
    lines = ["", "## Position or group", "", intro, "", head, "|" + "---|" * (len(parts) + 1)]
    lines += [f"| {ctx} | " + " | ".join(_f(v[p]) for p in parts) + " |" for ctx, v in sp["per_context"].items()]
    lines.append("| all (mean utility) | " + " | ".join(_f(sp[p]) for p in parts) + " |")
    ex = sp["explained"]
    if ex["position"] is not None and ex["group"] is not None:  # (NaN, null: raw 0, or a part undefined)
        lines += [
            "",
            f"Position explains {_f(ex['position'] * 100, 3)}% of the raw disparity and group "
            f"{_f(ex['group'] * 100, 3)}%.",
        ]
    return lines


def _curve_md(d: dict) -> list[str]:
    """The curve's figure and, per requested ε, the filter's privacy, the bounds and the observed values."""
    if len(d["candidates"]) == 2 and d.get("slots", 2) == 2:
        what = (
            "the filter shows each attribute of both profiles through "
            "randomized response, and a candidate's profile fixes its rival's, so both count."
        )
    else:
        what = (
            "the filter shows each attribute of every profile through randomized response; ε is that of "
            "all a candidate's prompt shows about it (its own profile, and its rivals' when the population ties "
            "them to it)."
        )
    lines = [
        "",
        "## Fairness–privacy curve",
        "",
        "![curve](curve.png)",
        "",
        "ε is the candidate's privacy budget (nats): " + what,
        "",
        "| ε candidate | ε per profile | keep p per attribute | certified L ≤ (black-box) | corollary | observed L | "
        "L, unparsed range | observed L̄ | L̄, unparsed range | black-box L̄ |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for p in d["points"]:
        keep = ", ".join(f"{_f(v, 3)}" for v in p["privacy"]["keep_probability_per_attribute"].values())
        lines.append(
            f"| {_f(p['epsilon'])} | {_f(p['privacy']['epsilon_profile'])} | {keep} | "
            f"{_bound(p, 'black_box')} | {_bound(p, 'corollary')} | "
            f"{_seen(p['observed']['local'])} | {_seen(p['observed']['global'])} | "
            f"{_bound(p, 'black_box_global')} |"
        )
    if d["points"]:
        lines += ["", _range_md(d) + _bounds_range_md(d)]
    return lines + _filter_md(d)


def _filter_md(d: dict) -> list[str]:
    """The filter at each requested ε: what was asked, the split rule, and per attribute k, keep p and ε."""
    points = [p for p in d["points"] if p["privacy"].get("attributes")]
    if not points:
        return []
    asked = (d.get("run") or {}).get("filter") or {}
    wanted = ""
    if asked.get("keep") is not None:
        wanted = f"Asked: keep p = {', '.join(_f(v) for v in asked['keep'])} on every attribute. "
    elif asked.get("epsilon") is not None:
        wanted = f"Asked: the candidate's ε = {', '.join(_f(v) for v in asked['epsilon'])} nats. "
    lines = [
        "",
        "### The filter",
        "",
        wanted + f"Split rule: {points[0]['privacy']['split']}.",
        "",
        "| ε candidate | attribute | values k | keep p | ε (nats) |",
        "|---|---|---|---|---|",
    ]
    for p in points:
        for a in p["privacy"]["attributes"]:
            lines.append(
                f"| {_f(p['epsilon'])} | {a['name']} | {a['values']} | {_f(a['keep_probability'], 6)} | "
                f"{_f(a['epsilon'], 6)} |"
            )
        lines.append(f"| {_f(p['epsilon'])} | profile (sum) | | | {_f(p['privacy']['epsilon_profile'], 6)} |")
    return lines


def _budgets_md(d: dict) -> list[str]:
    """The largest ε per target, for this model (met by the unparsed range's upper end; the stated default beside)
    and for any model."""
    lines = [
        "",
        "## The privacy budget per target",
        "",
        "The largest candidate's ε (nats) that meets each target: for this model (white-box: its own L or L̄ "
        "behind the filter stays at or below the target at every smaller ε"
        + (", estimated from the counts" if d.get("route") != "exact" else "")
        + ") and for any model behind the filter (black-box: the exact worst case). "
        "+∞: no filter is needed; n/a: no ε meets it. A target is met by this model's upper end: the "
        "first column's ε holds for every utility of an unparsed reply in [min g, max g] (the upper end of the "
        "unparsed range stays at or below the target). The next column is the ε under the stated utility of an "
        "unparsed reply, then the upper end of the unparsed range at that ε; **not met** marks a stated ε that "
        "some utility of the unparsed reply in [min g, max g] breaks.",
        "",
        "| target (nats) | on | ε, this model (upper end) | ε, stated unparsed utility | upper end at that ε | "
        "ε, any model |",
        "|---|---|---|---|---|---|",
    ]

    def eps(c: dict) -> str:
        return _f(c["epsilon"]) if c["feasible"] else "n/a"

    for b in d["budgets"]:
        this, anym = b["this_model"], b["any_model"]
        stated = this.get("stated_default", this)
        upper = stated.get("unparsed_upper") if stated["feasible"] else None
        flag = " **not met**" if stated.get("overturned_by_unparsed") else ""
        lines.append(
            f"| {_f(b['target'])} | {'L' if b['kind'] == 'local' else 'L̄'} | {eps(this)} | {eps(stated)} | "
            f"{_f(upper)}{flag} | {eps(anym)} |"
        )
    return lines


def _paper_design_md(d: dict) -> list[str]:
    """The observed L and L̄ of the paper's design (sampled through the filter) at each ε."""
    lines = [
        "",
        "The paper's design at the same ε (each ε queried through the filter; its unparsed ranges are over a utility "
        "per cell of the per-candidate law observed at that ε):",
        "",
        "| ε candidate | queries | observed L | L, unparsed range | observed L̄ | L̄, unparsed range |",
        "|---|---|---|---|---|---|",
    ]
    for p in d["paper_design"]:
        lines.append(f"| {_f(p['epsilon'])} | {p['queries']} | {_seen(p['local'])} | {_seen(p['global'])} |")
    return lines


def _scoring_words(d: dict) -> str:
    """How the exact route scored a decision, in words (``run.scoring``: the method, the route, the bound)."""
    scoring = (d.get("run") or {}).get("scoring") or {}
    if scoring.get("method") == "first-token":
        words = "first-token scoring: the mass of the first tokens that read as each option"
    else:
        words = (
            "continuation scoring: the probability that the reply begins with each decision's text, by the chain "
            "rule over its tokens"
        )
    route = scoring.get("route")
    if route == "prompt-logprobs":
        words += ", read from the server's prompt log-probabilities"
    elif route == "completions-echo":
        words += (
            ", read from the log-probabilities the server's text completions echoed for the messages rendered as "
            f"stated ({scoring.get('rendering')}), not by the model's own chat template"
        )
    elif route in ("top-logprobs", "first-token"):
        words += (
            ", read from the top log-probabilities the server listed: each decision's probability is a lower "
            f"bound, short by at most {_f(scoring.get('missing_bound', 0.0), 3)} in any cell (tokens not listed)"
        )
    return words


def _coverage_words(scoring: dict) -> str:
    """The replies that say each decision (``run.scoring.variants``) and the mass on them (``coverage``), in words."""
    variants, c = scoring.get("variants") or {}, scoring.get("coverage")
    said = "; ".join(f"{r!r}: {', '.join(repr(v) for v in vs)}" for r, vs in (variants.get("replies") or {}).items())
    words = f" Each decision is said by its variants ({said})." if said else ""
    if c is not None:
        words += (
            f" The mass on {'them' if said else 'the decisions'} (coverage) is {_f(c['min'], 3)} at least, "
            f"{_f(c['mean'], 3)} on average over the shown cells"
            + (f", below the {_f(c['threshold'], 3)} asked." if c.get("warning") else ".")
        )
    return words


def _replies_md(d: dict) -> list[str]:
    """How many logged replies the certificate counts, of how many the log holds, and the run's extensions."""
    run = d.get("run") or {}
    replies = run.get("replies")
    if not replies:
        return []
    line = (
        f"Replies: the certificate counts {replies['used']} of the {replies['logged']} answered queries logged in "
        "queries.jsonl"
    )
    grown = run.get("extended") or []
    if grown:
        steps = ", then ".join(f"from {e['from']} to {e['to']}" for e in grown)
        line += f"; `--samples` was extended (`--extend`) {steps}"
    return ["", line + "."]


def _sampling_md(d: dict) -> list[str]:
    """The stated sampling settings in one line of the report."""
    sampling = (d.get("run") or {}).get("sampling")
    if not sampling:
        return []
    line = (
        f"Sampling: temperature {sampling['temperature']:g}, top_p {sampling['top_p']:g}, max_tokens "
        f"{sampling['max_tokens']}, seed {sampling['seed']} (each request sends its query's own seed, derived from it)"
    )
    if "top_k" in sampling:
        line += f", top_k {sampling['top_k']}, min_p {sampling['min_p']:g}"
    if sampling["constrain"] != "none":
        line += f"; replies constrained ({sampling['constrain']}) to " + ", ".join(
            repr(r) for r in sampling.get("replies", ())
        )
    if "scoring" in sampling:
        line += (
            "; a reply is read as the decision whose text it begins with (continuation scoring, the exact route's)"
            if sampling["scoring"] == "continuation"
            else "; one-token replies read as the exact route's first-token scoring reads them"
        )
    return ["", line + "."]


def paper_design_markdown(d: dict) -> str:
    """The Markdown report of :func:`fairaudit.experiments.paper_design.paper_design_dict`."""
    q, conf = d["queries"], d["confidence"]
    b = d["baseline"]
    lines = _framing_md(d) + [
        f"The paper's design alone: {q['baseline']} queries on the true prompts without a filter (the baseline) "
        f"and {q['paper_design_needs_per_epsilon']} through the filter at each ε, every query sampled; "
        f"{q['unparsed']} replies could not be parsed and count as 'unparsed'. No kernel of shown cells is "
        "estimated, so the observed values at each ε are those of its own queries"
        + (f", with {conf:g} simultaneous intervals." if conf else "."),
        *_sampling_md(d),
        *_replies_md(d),
        "",
        "## Baseline: no filter",
        "",
        f"L = {_f(b['local']['value'])} nats{_ivs(b['local'])}, in {b['local']['context']}: "
        f"{b['local']['group']} over {b['local']['other_group']}; "
        f"L̄ = {_f(b['global']['value'])} nats{_ivs(b['global'])}: "
        f"{b['global']['group']} over {b['global']['other_group']}.",
        "",
        f"Over the unparsed reply's utility: L in {_range(b['local'])}, L̄ in {_range(b['global'])} nats. "
        + _range_md(d),
    ]
    lines += _curve_md(d) + _above_bound_md(d)
    lines += [
        "",
        "The black-box bound holds for every decision model behind the filter (exact worst case"
        + ("; here in closed form, ε(M_cand) itself" if all(p["bounds"]["closed_form"] for p in d["points"]) else "")
        + "); the observed values are this model's. Files: candidates.csv (per-candidate counts at each ε), "
        "records.csv (the baseline's per-candidate records for `fairaudit audit`), certificate.json, "
        "queries.jsonl (every query and reply).",
        "",
    ]
    return "\n".join(lines)


def _above_bound_md(d: dict) -> list[str]:
    """A note on each ε whose observed L is above the bound: an estimate from few queries, never a broken bound."""
    over = [p for p in d["points"] if _num(p["observed"]["local"]["value"]) > _num(p["bounds"]["black_box"])]
    if not over:
        return []
    at = ", ".join(_f(p["epsilon"]) for p in over)
    return [
        "",
        f"At ε = {at} the observed L is above the bound that holds for every model: it is an estimate from the "
        "queries at that ε (an outcome a group never got in them gives +∞), and the bound is on the model's own "
        "law; its interval is the statement to read, and more samples (`--samples`) narrow it.",
    ]


def _num(v: float | str | None) -> float:
    return float("inf") if v == "inf" else float("nan") if v is None else float(v)
