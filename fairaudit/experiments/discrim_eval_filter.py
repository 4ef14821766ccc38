"""A privacy filter on a discrim-eval run's fills, and the certificate of the law behind it at each ε.

``fairaudit experiment FILE.jsonl ... --epsilon E [E ...]`` releases each attribute of a fill (age, gender, race)
through k-ary randomized response before the model reads the prompt, one keep probability on every attribute
(:func:`fairaudit.split_by_keep`, the experiments' split rule), so that the fill's ε is E: the product of those
randomized responses on the fills, which are the groups. The law behind the filter is the run's law composed with
it (``docs/concepts.md``). For each E the run writes

* ``spec-eps-<E>.toml``: a ``fairaudit certify`` spec of that law, its model the run's ``law.csv`` (the exact
  probabilities the model gave, :func:`~fairaudit.experiments.discrim_eval_run.law_frame`), its sensitive
  mechanism the product, its utility the run's g (1 for yes, 0 for no, 1/2 for an unparsed reply, named
  ``unparsed``); ``fairaudit calibrate --spec`` moves along its product family;
* ``certificate-eps-<E>.json``: what ``fairaudit certify spec-eps-<E>.toml --format json`` run in that folder
  writes, which ``fairaudit verify`` checks.

A filter needs every combination of the attributes' values among the fills, in every scenario (the product
releases any of them): a file without some is refused in one line naming one that is missing.
"""

from __future__ import annotations

import itertools
import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

import fairaudit as fa
from fairaudit import InputError, write_atomic

if TYPE_CHECKING:
    from .discrim_eval import DiscrimEvalRows
    from .discrim_eval_run import DiscrimEvalRun

__all__ = ["FilterPoint", "attribute_values", "certify_filters", "filter_spec", "spec_name"]


@dataclass(frozen=True)
class FilterPoint:
    """The law behind the filter at one ε, certified.

    Attributes
    ----------
    epsilon : float
        The fill's ε, nats.
    attribute_epsilons : dict of str to float
        Each attribute's ε (nats), summing to ``epsilon``.
    keep : float
        The keep probability every attribute shares (for an attribute shown uniformly at random, ε = 0, its own is
        lower: 1/k).
    certificate : fairaudit.Certificate
        ``fairaudit.certify`` of the spec ``spec`` names: the observed L and L̄ behind the filter, its bounds.
    spec : str
        The spec's file name in the run's folder (``spec-eps-<E>.toml``); the certificate's is
        ``certificate-eps-<E>.json``.
    """

    epsilon: float
    attribute_epsilons: dict[str, float]
    keep: float
    certificate: Any
    spec: str

    def to_dict(self) -> dict[str, Any]:
        """The point as JSON values: ε, each attribute's, the keep probability, L and L̄ behind the filter and the
        certificate's bounds (nats; ``"inf"`` for +inf)."""
        c = self.certificate.to_dict()
        observed = c.get("observed") or {}
        return {
            "epsilon": fa.number(self.epsilon),
            "attributes": {k: fa.number(v) for k, v in self.attribute_epsilons.items()},
            "keep": fa.number(self.keep),
            "local_fairness": (observed.get("local") or {}).get("value"),
            "global_fairness": (observed.get("global") or {}).get("value"),
            "bound": c["bounds"]["best"],
            "bound_form": c["bounds"]["best_form"],
            "global_bound": c["bounds"].get("global"),
            "spec": self.spec,
            "certificate": self.spec.replace("spec-", "certificate-").replace(".toml", ".json"),
        }


def spec_name(epsilon: float) -> str:
    """The spec's file name at ε, as the TOML tasks' runs name theirs.

    Examples
    --------
    >>> spec_name(1.0), spec_name(0.693147)
    ('spec-eps-1.toml', 'spec-eps-0.6931.toml')
    """
    return f"spec-eps-{epsilon:.4g}.toml"


def attribute_values(rows: DiscrimEvalRows) -> dict[str, list[str]]:
    """Each attribute's values as the group labels write them (text), in order of first appearance, checked to be
    fit for a filter: every combination of them a fill of every scenario.

    Raises
    ------
    InputError
        Field ``--epsilon``: an attribute with one value, or a combination that some scenario lacks (naming both).

    Examples
    --------
    >>> from fairaudit.experiments.discrim_eval import read_rows
    >>> attribute_values(read_rows("examples/discrim_eval/sample.jsonl"))
    {'age': ['20', '60'], 'gender': ['female', 'male'], 'race': ['black', 'white']}
    """
    attributes = rows.attributes
    values = {str(c): list(dict.fromkeys(attributes[c].astype(str))) for c in attributes.columns}
    for name, seen in values.items():
        if len(seen) < 2:
            raise InputError("--epsilon", f"needs at least two values of each attribute; {name!r} has", seen)
    present = set(zip(rows.scenarios, rows.groups))
    for scenario in dict.fromkeys(rows.scenarios):
        for combination in itertools.product(*values.values()):
            if (scenario, " & ".join(combination)) not in present:
                problem = (
                    f"needs every combination of the attributes' values in every scenario; scenario {scenario} lacks"
                )
                raise InputError("--epsilon", problem, " & ".join(combination))
    return values


def filter_spec(run: DiscrimEvalRun, epsilon: float, *, table: str = "law.csv") -> tuple[str, dict[str, float], float]:
    """The ``fairaudit certify`` spec (TOML) of ``run``'s law behind the filter at ``epsilon``.

    Parameters
    ----------
    run : DiscrimEvalRun
        A run whose fills are every combination of its attributes' values, in every scenario.
    epsilon : float
        The fill's ε, nats, finite and ≥ 0.
    table : str
        The model table, relative to the spec's folder: the run's law as
        :func:`~fairaudit.experiments.discrim_eval_run.law_frame` writes it.

    Returns
    -------
    text : str
        The spec.
    attribute_epsilons : dict of str to float
        Each attribute's ε, nats (:func:`fairaudit.split_by_keep`).
    keep : float
        The keep probability they share.

    Raises
    ------
    InputError
        Field ``--epsilon``: ε negative, infinite or NaN, an attribute with one value, or a combination of the attributes'
        values that is not a fill of every scenario (naming it).

    Examples
    --------
    >>> import math
    >>> from fairaudit.experiments.discrim_eval import read_rows
    >>> from fairaudit.experiments.discrim_eval_run import run_discrim_eval
    >>> rows = read_rows("examples/discrim_eval/sample.jsonl")
    >>> run = run_discrim_eval(rows, lambda reqs: [math.log(0.2)] * len(reqs), coefficients=False)
    >>> text, eps, keep = filter_spec(run, 3 * math.log(3))  # three attributes of two values: ln 3 each
    >>> [round(e, 12) for e in eps.values()], round(keep, 12)
    ([1.098612288668, 1.098612288668, 1.098612288668], 0.75)
    """
    if not np.isfinite(epsilon):  # (split_by_keep refuses a negative or NaN epsilon)
        raise InputError("--epsilon", "must be finite: the run's own law is the one without a filter", epsilon)
    values = attribute_values(run.rows)
    sizes = [len(v) for v in values.values()]
    split = [float(e) for e in fa.split_by_keep(epsilon, sizes)]
    # every attribute shares p: e^{eps_i} = p (k_i - 1)/(1 - p) where it is active (eps_i > 0); none is at eps = 0,
    # where p <= 1/k for every attribute: the largest such p
    active = [(e, k) for e, k in zip(split, sizes) if e > 0]
    keep = float(1 / (1 + (active[0][1] - 1) * np.exp(-active[0][0]))) if active else 1 / max(sizes)
    j = json.dumps
    law = run.law
    components = "\n".join(
        f'\n[[privacy.sensitive.components]]\nname = {j(name)}\nmechanism = "randomized_response"\n'
        f"values = {j(v)}\nepsilon = {j(e)}"
        for (name, v), e in zip(values.items(), split)
    )
    text = "\n".join([
        f"# discrim-eval: {run.model or 'a model'} on {run.rows.path}; each attribute of the fill released through "
        f"randomized response, the fill's epsilon = {epsilon:.6g} nats (keep p = {keep:.6g} on every attribute)",
        f"title = {j(f'discrim-eval: {run.model}, fills behind randomized response, epsilon = {epsilon:.6g}')}",
        "",
        "[sensitive]",
        'name = "group"',
        "",
        "[context]",
        'name = "scenario"',
        f"values = {j(list(law.contexts))}",
        "",
        "[decision]",
        'name = "decision"',
        f"values = {j(list(law.decisions))}",
        'unparsed = "unparsed"',
        "",
        "[privacy.sensitive]",
        'mechanism = "product"',
        components,
        "",
        "[model]",
        f"table = {j(table)}",
        'probability_column = "probability"',
        "",
        "[utility]",
        'kind = "table"',
        f"values = {j([float(v) for v in run.fairness.utility.values])}",
    ])  # fmt: skip
    return text + "\n", dict(zip(values, split)), keep


def certify_filters(run: DiscrimEvalRun, epsilons: Sequence[float], out: str | Path) -> DiscrimEvalRun:
    """The run with its :class:`FilterPoint` at each ε, their specs and certificates written to ``out``.

    Writes ``law.csv`` (the specs' model table), then per ε ``spec-eps-<E>.toml`` and the certificate that
    ``fairaudit certify`` of it gives, ``certificate-eps-<E>.json`` (its ``--format json``), each atomically.

    Parameters
    ----------
    run : DiscrimEvalRun
    epsilons : sequence of float
        The fill's ε of each filter, nats, each ≥ 0.
    out : str or Path
        The run's folder (created).

    Returns
    -------
    DiscrimEvalRun
        ``run`` with ``points``, one per ε in order; ``run`` itself when ``epsilons`` is empty.

    Raises
    ------
    InputError
        As :func:`filter_spec`, before anything is written.
    """
    import dataclasses

    from .discrim_eval_run import law_frame

    if not len(epsilons):
        return run
    specs = [(float(e), *filter_spec(run, float(e))) for e in epsilons]  # (every refusal before a file is written)
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    write_atomic(folder / "law.csv", law_frame(run).to_csv(index=False), field="--out")
    points = []
    for eps, text, split, keep in specs:
        name = spec_name(eps)
        write_atomic(folder / name, text, field="--out")
        certificate = fa.certify(fa.parse_spec(text, source=name, base=folder))  # (as certify run in the folder)
        body = json.dumps(certificate.to_dict(), indent=2, ensure_ascii=False, allow_nan=False) + "\n"
        write_atomic(folder / name.replace("spec-", "certificate-").replace(".toml", ".json"), body, field="--out")
        points.append(FilterPoint(eps, split, keep, certificate, name))
    return dataclasses.replace(run, points=tuple(points))
