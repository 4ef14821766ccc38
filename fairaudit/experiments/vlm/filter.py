"""The privacy filter between the robot and the decision model.

Before the model sees a query, every attribute of every candidate's profile
passes randomized response on its own values, independently (the paper's
Methods: "each attribute (name, age, race) is sampled according to preset
probabilities"), and the context (the document type) may pass a mechanism too.

The correct privacy budgets (docs/design.md, the paper's errors 1 and 2):

* binary randomized response that keeps the truth with probability p is
  ln(p / (1 − p))-DP (0.847 nats for p = 0.7, not 0.7 / 0.3);
* a profile of several attributes randomized independently is a product
  mechanism; with every pair of profiles adjacent its ε is the **sum** of the
  attributes' (3 ln(7/3) = 2.542 nats for name, age and race at p = 0.7);
* the query shows both candidates' profiles. In the paper's experiment a
  candidate's profile also fixes its rival's (Tom faces Mary, Mary faces Tom),
  so what the model sees about a candidate's group is the pair of released
  profiles: the mechanism that protects a candidate is
  M_cand[a, (ã_self, ã_rival)] = M_P[a, ã_self] · M_P[rival(a), ã_rival],
  whose ε is twice the profile's (:meth:`PrivacyFilter.candidate_mechanism`).
  Every certificate of the experiments is computed on that mechanism.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..._errors import InputError
from ..._validation import real
from ...privacy import Mechanism, MechanismFamily, identity, keep_probability, product, randomized_response
from .tasks import DeliveryTask

__all__ = ["PrivacyFilter", "candidate_family", "released_pair_label"]


def released_pair_label(task: DeliveryTask, own: tuple, rival: tuple) -> str:
    """Label of what the model sees about a candidate: its released profile, then its rival's.

    Examples
    --------
    >>> from fairaudit.experiments.taskfile import HR_DELIVERY
    >>> released_pair_label(HR_DELIVERY, ("Tom", 25, "Asian"), ("Mary", 55, "American"))
    'Tom & 25 & Asian | Mary & 55 & American'
    """
    return f"{task.profile_label(own)} | {task.profile_label(rival)}"


@dataclass(frozen=True, eq=False)
class PrivacyFilter:
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

    @classmethod
    def from_epsilon(cls, task: DeliveryTask, epsilon: float, *, context_epsilon: float | None = None) -> PrivacyFilter:
        """The filter whose profile mechanism has privacy budget ``epsilon``, split equally over the attributes.

        Parameters
        ----------
        task : DeliveryTask
        epsilon : float
            ε of one candidate's profile (nats, ≥ 0, +inf for no filter). Each
            of the n attributes gets randomized response at ε / n, so the
            product's ε is ``epsilon`` (paper's error 2).
        context_epsilon : float, optional
            ε of randomized response on the context; None for the identity.

        Raises
        ------
        InputError
            If an ε is negative or NaN (naming ``--epsilon`` or ``--context-epsilon``).

        Examples
        --------
        Name, age and race each kept with p = 0.7 (the paper's filter):

        >>> from fairaudit.experiments.taskfile import HR_DELIVERY
        >>> import math
        >>> f = PrivacyFilter.from_epsilon(HR_DELIVERY, 3 * math.log(7 / 3))
        >>> [round(p, 6) for p in f.keep_probabilities], round(f.epsilon_profile, 6)
        ([0.7, 0.7, 0.7], 2.541894)
        >>> round(f.candidate_mechanism().epsilon, 6)                  # both profiles are in the query
        5.083787
        """
        eps = _nats(epsilon, "epsilon")
        n = len(task.attributes)
        mechs = tuple(
            randomized_response(a.values, eps / n, name=f"randomized response on {a.name}") for a in task.attributes
        )
        if context_epsilon is None:
            ctx = identity(task.contexts, name=f"identity on {task.context_name}")
        else:
            ctx = randomized_response(
                task.contexts,
                _nats(context_epsilon, "context_epsilon"),
                name=f"randomized response on {task.context_name}",
            )
        return cls(task, mechs, ctx)

    # -- privacy ---------------------------------------------------------------------------------
    @property
    def profile_mechanism(self) -> Mechanism:
        """M_P: the product of the attribute mechanisms on one profile, shape (n_profiles, n_profiles)."""
        return product(*self.attribute_mechanisms, name=f"randomized response on each of {self._names()}")

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

    @property
    def epsilon_query(self) -> float:
        """ε of the whole query's sensitive part, every candidate's profile together, nats."""
        return len(self.task.options) * self.epsilon_profile

    @property
    def epsilon_context(self) -> float:
        """ε of the context mechanism, nats (+inf for the identity)."""
        return self.context_mechanism.epsilon

    def candidate_mechanism(self) -> Mechanism:
        """What the model sees about a candidate's group: M_cand, shape (2, n_profiles²).

        Inputs: the task's two candidates (profile labels); outputs: the
        labels ``"own | rival"`` of the released profiles (own first), in
        row-major order of (own, rival) over :attr:`DeliveryTask.profiles`.
        M_cand[a, (s, o)] = M_P[a, s] · M_P[rival(a), o]: the rival of one
        candidate is the other, as in the paper's experiment.
        """
        return _candidate_mechanism(self.task, self.profile_mechanism)

    def release(self, context: str, profiles: Sequence[tuple], rng: np.random.Generator) -> tuple:
        """Draw what the model is shown: (released context, released profiles), one draw.

        Each attribute of each profile, and the context, is drawn from its
        mechanism's row (the paper's design, which samples through the filter).
        """
        task = self.task
        ctx_row = self.context_mechanism.matrix[task.contexts.index(context)]
        out_ctx = self.context_mechanism.outputs[draw(rng, ctx_row)]
        shown = []
        for profile in profiles:
            values = []
            for mech, value in zip(self.attribute_mechanisms, profile):
                row = mech.matrix[mech.inputs.index(value)]
                values.append(mech.outputs[draw(rng, row)])
            shown.append(tuple(values))
        return out_ctx, tuple(shown)

    def describe(self) -> str:
        """One line: the attribute mechanisms, their keep probability and the ε that follow."""
        p = ", ".join(f"{a.name} p = {k:.4g}" for a, k in zip(self.task.attributes, self.keep_probabilities))
        return (
            f"randomized response on each attribute ({p}): ε = {self.epsilon_profile:.4g} nats per profile, "
            f"{self.candidate_mechanism().epsilon:.4g} per candidate (own and rival's profile); "
            f"context: {self.context_mechanism.name}"
        )

    def _names(self) -> str:
        return ", ".join(a.name for a in self.task.attributes)


def _candidate_mechanism(task: DeliveryTask, m_p: Mechanism) -> Mechanism:
    if len(task.candidates) != 2:
        raise InputError(
            "task.candidates", "the per-candidate view is defined for two candidates", len(task.candidates)
        )
    profiles = task.profiles
    idx = [profiles.index(tuple(c)) for c in task.candidates]
    rows = [np.outer(m_p.matrix[idx[i]], m_p.matrix[idx[1 - i]]).ravel() for i in range(2)]
    outputs = [released_pair_label(task, s, o) for s in profiles for o in profiles]
    return Mechanism(
        np.vstack(rows),
        [task.profile_label(c) for c in task.candidates],
        outputs,
        name=f"per-candidate view of {m_p.name}",
    )


def candidate_family(task: DeliveryTask) -> MechanismFamily:
    """ε ↦ M_cand at candidate budget ε: each profile at ε / 2, each attribute at ε / (2 n).

    The member at ε has ε(M_cand) = ε exactly (nats); its keep probability is
    the chance that a candidate's own profile is shown unchanged,
    Π_i e^{ε/(2n)} / (e^{ε/(2n)} + k_i − 1).

    Examples
    --------
    >>> from fairaudit.experiments.taskfile import HR_DELIVERY
    >>> fam = candidate_family(HR_DELIVERY)
    >>> import math
    >>> eps = 6 * math.log(7 / 3)                     # p = 0.7 on each of the 6 attributes shown
    >>> round(fam(eps).epsilon, 6), round(fam.keep_probability(eps), 6)
    (5.083787, 0.343)
    """
    n = len(task.attributes)

    def build(eps: float) -> Mechanism:
        return PrivacyFilter.from_epsilon(task, eps / 2).candidate_mechanism()

    def keep(eps: float) -> float:
        return float(np.prod([keep_probability(eps / (2 * n), len(a.values)) for a in task.attributes]))

    inputs = tuple(task.profile_label(c) for c in task.candidates)
    return MechanismFamily(f"randomized response on each attribute of both profiles ({task.name})", inputs, build, keep)


def _nats(eps: float, name: str) -> float:
    return real(eps, name, low=0.0, finite=False, what="a number of nats >= 0")


def draw(rng: np.random.Generator, row: np.ndarray) -> int:
    """One index drawn from the weights ``row`` (not necessarily normalised) with one uniform number of ``rng``.

    Examples
    --------
    >>> draw(np.random.default_rng(0), np.array([0.0, 1.0, 0.0]))
    1
    """
    return int(np.searchsorted(np.cumsum(row), rng.random() * row.sum(), side="right").clip(0, row.size - 1))
