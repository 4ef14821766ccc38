"""The worst-case utility of a spec's decision model: the Python side of ``fairaudit worst-case SPEC``.

A spec with a ``[model]`` fixes a law, the model behind the spec's privacy
filter (the law whose metrics ``certify`` reports as observed).
:func:`spec_worst_utility` asks which utility g(u) of the spec's class
[lower, γ] (with E[g | x, a] ≥ τ) shows the largest local and global
disparity of that law (:func:`fairaudit.worstcase.known_law.worst_utility`), and puts it
beside the spec's own utility on the same law.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from fairaudit.base.checks import choice
from fairaudit.base.errors import InputError
from fairaudit.base.json_values import Report, number
from fairaudit.certification.spec import Spec, load_spec
from fairaudit.laws.composition import compose
from fairaudit.laws.utilities import UtilityClass
from fairaudit.metrics.observed import Observed, observe
from fairaudit.worstcase.known_law import WorstUtility, worst_utility
from fairaudit.worstcase.worst_cases import METHODS

__all__ = ["SpecWorstUtility", "spec_worst_utility"]


@dataclass(frozen=True, eq=False, kw_only=True)
class SpecWorstUtility:
    """The worst utility of a spec's model behind its filter (:func:`spec_worst_utility`); repeats its inputs.

    Attributes
    ----------
    spec : Spec
    worst : WorstUtility
        The utilities g(u) ∈ [lower, γ] that maximise L and L̄ of the law, each with its pair (and context).
    observed : Observed
        Every metric of the same law under the spec's own utility and population (what ``certify`` observes).
    """

    spec: Spec
    worst: WorstUtility
    observed: Observed

    def to_dict(self) -> Report:
        """The report dictionary (the JSON of ``fairaudit worst-case``).

        ``spec``, ``title``, ``law`` (which law, in words), ``sensitive``, ``context`` and ``decision`` (each its
        name), then :meth:`~fairaudit.worstcase.known_law.WorstUtility.to_dict` (``decisions``, ``lower``, ``gamma``,
        ``tau``, ``local`` and ``global`` with their ``utility``, ``population``, ``excluded``), and
        ``spec_utility``: the spec's own utility's ``name`` and its L (``local``) and L̄ (``global``) on the same
        law, in nats.
        """
        spec, o = self.spec, self.observed
        return {
            "spec": spec.source,
            "title": spec.model.title,
            "law": "the spec's decision model behind its privacy filter",
            "sensitive": spec.model.sensitive.name,
            "context": spec.context_name,
            "decision": spec.model.decision.name,
            **self.worst.to_dict(),
            "spec_utility": {
                "name": spec.utility.name,
                "local": number(o.local_fairness.value),
                "global": number(o.global_fairness.value),
            },
        }


def spec_worst_utility(
    spec: Spec | str | Path,
    *,
    utility_class: UtilityClass | None = None,
    method: str = "auto",
) -> SpecWorstUtility:
    """The utility of the spec's class that shows the largest disparity of its model behind its filter.

    The law is Q = compose(K, M_A, M_X), the spec's model K behind its
    mechanisms on the sensitive attribute and the context; the utilities are
    every g(u) ∈ [lower, γ] of the decision with E[g | x, a] ≥ τ in every
    cell (:func:`fairaudit.worstcase.known_law.worst_utility`, under the spec's
    population).

    Parameters
    ----------
    spec : Spec, str or Path
        A spec with a ``[model]`` (see :func:`fairaudit.certification.spec.load_spec`).
    utility_class : UtilityClass, optional
        The class of utilities, ``lower``, ``gamma`` and ``tau``; a field left
        None is the spec's (``utility.lower``, ``utility.gamma``,
        ``utility.tau``: for an indicator [0, 1]).
    method : {"auto", "threshold", "lp"}
        As :func:`~fairaudit.worstcase.known_law.worst_utility`.

    Returns
    -------
    SpecWorstUtility

    Raises
    ------
    InputError
        As :func:`~fairaudit.certification.spec.load_spec` for an invalid spec or model; field
        ``<spec>: model`` when the spec has no model; ``lower``, ``gamma``,
        ``tau`` or ``method`` when invalid (as ``worst_utility`` checks them).

    Examples
    --------
    The model of examples/hr_office chooses a candidate iff the candidate is shown with HR_2's profile; each of
    its three attributes is kept with p = 0.7, so HR_2 is chosen with 0.7³ and HR_1 (who differs in all three)
    with 0.3³: L = 3 ln(7/3). The worst utility over [0, 1] with τ = 0.02 is a multiple of the spec's own
    g = 1{chosen} (g(not chosen) = 0), and shows the same L:

    >>> import math
    >>> w = spec_worst_utility("examples/hr_office/hr_office.toml")
    >>> round(w.worst.local_fairness.value, 9), round(3 * math.log(7 / 3), 9), round(w.observed.local_fairness.value, 9)
    (2.541893581, 2.541893581, 2.541893581)
    >>> float(w.worst.local_fairness.utility.values[1]), w.worst.local_fairness.context
    (0.0, 'maternity leave')
    """
    if not isinstance(spec, Spec):
        spec = load_spec(spec)
    method = choice(method, "method", METHODS)
    kernel = spec.kernel()
    if kernel is None:
        raise InputError(
            f"{spec.source}: model",
            "worst-case needs a decision model ([model] table or records): the worst utility is that of a known law",
        )
    try:
        law = compose(kernel, spec.sensitive_mechanism, spec.context_mechanism)
    except InputError as exc:
        raise exc.under(f"{spec.source}: {exc.field}", keep_own=False) from None
    given = UtilityClass() if utility_class is None else utility_class
    if not isinstance(given, UtilityClass):
        raise InputError("utility_class", "must be a UtilityClass", type(given).__name__)
    chosen = UtilityClass(
        lower=spec.lower if given.lower is None else given.lower,
        gamma=spec.gamma if given.gamma is None else given.gamma,
        tau=spec.tau if given.tau is None else given.tau,
    )
    worst = worst_utility(law, utility_class=chosen, population=spec.population, method=method)
    return SpecWorstUtility(spec=spec, worst=worst, observed=observe(law, spec.utility, spec.population))
