"""The privacy filter between the robot and the decision model: randomized response on every attribute of every
candidate's profile, independently, and a mechanism on the context.

One keep probability p on every attribute gives an attribute of k values ε = ln(p (k − 1) / (1 − p)); a profile's
ε is the sum over its attributes, and a candidate's that of everything its prompt shows about it, M_cand
(docs/design.md, "k candidates behind a filter", and "The paper's errors, not repeated").

The analysis reads the attributes' :class:`fairaudit.Mechanism` s; what the model is shown is released by the one
deployable filter, a :class:`fairaudit.PrivacyFilter` per attribute and one on the context, built from the same
ε (exact rational rows, integer sampling, its ε at most the analysis's: :data:`RELEASE_RULE`).
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from fairaudit import (
    Mechanism,
    MechanismFamily,
    PrivacyFilter,
    epsilon_scale,
    identity,
    keep_probability,
    product,
    randomized_response,
    real,
    split_by_keep,
)

from ..slots import candidate_mechanism, candidate_mechanism_epsilon, epsilon_factor
from .tasks import DeliveryTask

__all__ = ["RELEASE_RULE", "SPLIT_RULE", "TaskFilter", "candidate_family", "profile_budget"]

RELEASE_RULE = (
    "the release is drawn exactly from the filter's rational rows (a fairaudit.PrivacyFilter per attribute and one "
    "on the context, at the epsilon above or less), from a source seeded by the query's seed for reproducibility "
    "(a deployment uses the secure default)"
)
"""How the paper design draws what the model is shown (:meth:`TaskFilter.release`), as reports state it."""

SPLIT_RULE = (
    "one keep probability p on every attribute: an attribute with k values gets k-ary randomized response at "
    "epsilon = ln(p (k - 1) / (1 - p)) (0, shown uniformly at random, where p < 1/k); a profile's epsilon is the sum "
    "over its attributes, and a candidate's that of everything its prompt shows about it"
)
"""How a privacy budget is split over a profile's attributes (:meth:`TaskFilter.from_epsilon`), as reports state it."""


@dataclass(frozen=True, eq=False)
class TaskFilter:
    """Randomized response on each profile attribute, and a mechanism on the context.

    Attributes
    ----------
    task : DeliveryTask
    attribute_mechanisms : tuple of Mechanism
        One per profile attribute, in the task's order, each square on that
        attribute's values.
    context_mechanism : Mechanism
        M_X on the task's contexts (identity: the document type is shown as is).

    Use :meth:`from_epsilon` to make one.
    """

    task: DeliveryTask
    attribute_mechanisms: tuple
    context_mechanism: Mechanism

    @functools.cached_property
    def attribute_filters(self) -> tuple[PrivacyFilter, ...]:
        """The filters that release each attribute (:meth:`release`): randomized response at the same ε as
        :attr:`attribute_mechanisms` (:meth:`fairaudit.PrivacyFilter.from_mechanism`), with exact rational rows; each
        one's own ε is at most its mechanism's."""
        return tuple(PrivacyFilter.from_mechanism(m) for m in self.attribute_mechanisms)

    @functools.cached_property
    def context_filter(self) -> PrivacyFilter:
        """The filter that releases the context, at the same ε as :attr:`context_mechanism` (or the identity)."""
        return PrivacyFilter.from_mechanism(self.context_mechanism)

    @classmethod
    def from_epsilon(cls, task: DeliveryTask, epsilon: float, *, context_epsilon: float | None = None) -> TaskFilter:
        """The filter whose profile mechanism has privacy budget ``epsilon``, every attribute kept with one probability.

        The split rule (:func:`fairaudit.split_by_keep`): every
        attribute keeps its value with the same probability p, so attribute i
        with k_i values gets ε_i = ln(p (k_i − 1) / (1 − p)) and Σ ε_i =
        ``epsilon``. An attribute that p would keep less often than uniformly
        (p < 1/k_i) is shown uniformly at random (ε_i = 0). Attributes with
        the same number of values get ``epsilon`` / n each; a keep probability
        p given for every attribute is exactly this split of Σ_i ln(p (k_i −
        1) / (1 − p)).

        Parameters
        ----------
        task : DeliveryTask
        epsilon : float
            ε of one candidate's profile (nats, ≥ 0, +inf for no filter), the
            sum of its attributes' ε (every pair of profiles adjacent; the
            paper's error 2).
        context_epsilon : float, optional
            ε of randomized response on the context; None for the identity.

        Raises
        ------
        InputError
            If an ε is negative or NaN (naming ``epsilon`` or ``context_epsilon``).

        Examples
        --------
        Name, age and race each kept with p = 0.7 (the paper's filter):

        >>> from fairaudit.experiments.taskfile import HR_DELIVERY
        >>> import math
        >>> f = TaskFilter.from_epsilon(HR_DELIVERY, 3 * math.log(7 / 3))
        >>> [round(p, 6) for p in f.keep_probabilities], round(f.epsilon_profile, 6)
        ([0.7, 0.7, 0.7], 2.541894)
        >>> round(f.candidate_mechanism().epsilon, 6)                  # both profiles are in the query
        5.083787
        """
        eps = _nats(epsilon, "epsilon")
        split = [float(e) for e in split_by_keep(eps, [len(a.values) for a in task.attributes])]
        names = [f"randomized response on {a.name}" for a in task.attributes]
        mechs = tuple(randomized_response(a.values, e, name=n) for a, e, n in zip(task.attributes, split, names))
        if context_epsilon is None:
            ctx = identity(task.contexts, name=f"identity on {task.context_name}")
        else:
            name = f"randomized response on {task.context_name}"
            ctx = randomized_response(task.contexts, _nats(context_epsilon, "context_epsilon"), name=name)
        return cls(task, mechs, ctx)

    @classmethod
    def for_candidates(
        cls,
        task: DeliveryTask,
        epsilon: float,
        positions: str = "balanced",
        *,
        context_epsilon: float | None = None,
    ) -> TaskFilter:
        """The filter that gives each candidate privacy budget ``epsilon``: the profile's ε_P, then its split.

        The one rule from a candidate's ε to the filter: ε_P =
        :func:`profile_budget` (``task``, ``positions``) (``epsilon``), the
        profile ε at which ε(M_cand) = ``epsilon``, split over the attributes
        by one keep probability (:meth:`from_epsilon`). The member of
        :func:`candidate_family` at ``epsilon`` is this filter's
        :meth:`candidate_mechanism` (``positions``).

        Parameters
        ----------
        task : DeliveryTask
        epsilon : float
            ε of what one candidate's prompt shows about it, M_cand (nats,
            ≥ 0, +inf for no filter).
        positions : str
            How the candidates take the slots (:func:`fairaudit.experiments.slots.candidate_mechanism`).
        context_epsilon : float, optional
            ε of randomized response on the context; None for the identity.

        Returns
        -------
        TaskFilter

        Raises
        ------
        InputError
            If an ε is negative or NaN (naming ``epsilon`` or ``context_epsilon``).

        Examples
        --------
        Each candidate at 6 ln(7/3) nats: each of its 6 attributes shown (own and rival) kept with p = 0.7:

        >>> from fairaudit.experiments.taskfile import HR_DELIVERY
        >>> import math
        >>> f = TaskFilter.for_candidates(HR_DELIVERY, 6 * math.log(7 / 3))
        >>> [round(p, 6) for p in f.keep_probabilities], round(f.candidate_mechanism().epsilon, 6)
        ([0.7, 0.7, 0.7], 5.083787)
        """
        return cls.from_epsilon(task, profile_budget(task, positions)(epsilon), context_epsilon=context_epsilon)

    # -- privacy ---------------------------------------------------------------------------------
    @property
    def profile_mechanism(self) -> Mechanism:
        """M_P: the product of the attribute mechanisms on one profile, shape (n_profiles, n_profiles)."""
        return product(
            *self.attribute_mechanisms,
            name=f"randomized response on each of {', '.join(a.name for a in self.task.attributes)}",
        )

    @property
    def epsilon_attributes(self) -> tuple:
        """ε of each attribute's randomized response, nats."""
        return tuple(m.epsilon for m in self.attribute_mechanisms)

    @property
    def keep_probabilities(self) -> tuple:
        """Probability that each attribute is shown unchanged (the paper's p)."""
        return tuple(float(np.min(np.diag(m.matrix))) for m in self.attribute_mechanisms)

    @property
    def epsilon_profile(self) -> float:
        """ε of one profile: the sum of the attributes' ε (every pair of profiles adjacent), nats."""
        return float(sum(self.epsilon_attributes))

    def candidate_mechanism(self, positions: str = "balanced") -> Mechanism:
        """What the model sees about a candidate's group: M_cand, shape (n_groups, n_profiles^k).

        Inputs: the task's candidates (profile labels); outputs: the views,
        the released profiles from the candidate's own slot on, ``"own |
        rival"`` for two (:func:`fairaudit.experiments.slots.candidate_mechanism`).
        For the paper's pair, M_cand[a, (s, o)] = M_P[a, s] · M_P[rival(a), o].
        """
        return candidate_mechanism(self.task, self.profile_mechanism, positions)

    def release(
        self, context: str, profiles: Sequence[tuple], random_bytes: Callable[[int], bytes] | None = None
    ) -> tuple:
        """Draw what the model is shown: (released context, released profiles), one draw.

        The context goes through :attr:`context_filter`, then attribute i of every profile through
        ``attribute_filters[i]`` (:meth:`fairaudit.PrivacyFilter.apply`): exact rational rows, integer sampling,
        no floating point (the paper's design, which samples through the filter).

        Parameters
        ----------
        context : str
            The true context, among the task's.
        profiles : sequence of tuple
            The true profiles, one value per attribute each.
        random_bytes : callable, optional
            ``random_bytes(n) -> bytes``, uniform random bytes. The harness passes a source seeded by the query's
            seed, so that a resumed run redraws the same release (:data:`RELEASE_RULE`); the default is
            :meth:`fairaudit.PrivacyFilter.apply`'s cryptographically secure source, as a deployment uses.

        Returns
        -------
        tuple
            (released context, tuple of released profiles, each a tuple of values).

        Examples
        --------
        >>> import math
        >>> from fairaudit.experiments.taskfile import HR_DELIVERY
        >>> f = TaskFilter.from_epsilon(HR_DELIVERY, math.inf)                   # no filter: shown as they are
        >>> f.release("sick leave", HR_DELIVERY.candidates) == ("sick leave", tuple(HR_DELIVERY.candidates))
        True
        """
        shown_context = self.context_filter.apply([context], random_bytes=random_bytes)[0]
        columns = [
            f.apply([profile[i] for profile in profiles], random_bytes=random_bytes)
            for i, f in enumerate(self.attribute_filters)
        ]
        return shown_context, tuple(zip(*columns))


def candidate_family(task: DeliveryTask, positions: str = "balanced") -> MechanismFamily:
    """ε ↦ M_cand at candidate budget ε, every attribute of every profile kept with one probability.

    The member at ε has ε(M_cand) = ε (nats): ε_P = ε / c when the ratio c =
    ε(M_cand) / ε_P is a constant (:func:`fairaudit.experiments.slots.epsilon_factor`:
    2 for the paper's pair, each profile at ε / 2), else ε_P solves
    ε(M_cand(ε_P)) = ε (M_cand at a smaller ε_P is a garbling of the one at
    a larger, so the map is monotone). ε_P is split over the attributes by
    one keep probability (:meth:`TaskFilter.from_epsilon`,
    :func:`fairaudit.split_by_keep`). The family's keep probability
    is the chance that a candidate's own profile is shown unchanged,
    Π_i e^{ε_i} / (e^{ε_i} + k_i − 1).

    Examples
    --------
    >>> from fairaudit.experiments.taskfile import HR_DELIVERY
    >>> fam = candidate_family(HR_DELIVERY)
    >>> import math
    >>> eps = 6 * math.log(7 / 3)                     # p = 0.7 on each of the 6 attributes shown
    >>> round(fam(eps).epsilon, 6), round(fam.keep_probability(eps), 6)
    (5.083787, 0.343)
    """
    sizes = [len(a.values) for a in task.attributes]
    profile_epsilon = profile_budget(task, positions)

    def build(eps: float) -> Mechanism:
        return TaskFilter.from_epsilon(task, profile_epsilon(eps)).candidate_mechanism(positions)

    def keep(eps: float) -> float:
        split = split_by_keep(profile_epsilon(eps), sizes)
        return float(np.prod([keep_probability(float(e), k) for e, k in zip(split, sizes)]))

    inputs = tuple(task.profile_label(c) for c in task.candidates)
    return MechanismFamily(f"randomized response on each attribute of every profile ({task.name})", inputs, build, keep)


def profile_budget(task: DeliveryTask, positions: str = "balanced") -> Callable[[float], float]:
    """The map from a candidate's ε to the ε_P of each profile (nats), as :func:`candidate_family` uses it.

    Examples
    --------
    >>> from fairaudit.experiments.taskfile import HR_DELIVERY
    >>> profile_budget(HR_DELIVERY)(3.0)
    1.5
    """
    factor = epsilon_factor(task, positions)

    def epsilon_at(e: float) -> float:
        return candidate_mechanism_epsilon(task, TaskFilter.from_epsilon(task, e).profile_mechanism.matrix, positions)

    return epsilon_scale(epsilon_at, None if factor is None else float(factor))


def _nats(eps: float, name: str) -> float:
    return real(eps, name, low=0.0, finite=False, what="a number of nats >= 0")
