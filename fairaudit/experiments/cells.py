"""The first step of a run: the cells it asks and the filter it certifies (:class:`Cells`)."""

from __future__ import annotations

from dataclasses import dataclass, field

from .options import DEFAULT_KEEPS, RunOptions
from .vlm.tasks import DeliveryTask

__all__ = ["DEFAULT_SAMPLES", "Cells", "make_cells"]

DEFAULT_SAMPLES = 20
"""Queries per shown cell (and per true cell and ε in the paper's design) when ``samples`` is not given."""


@dataclass(frozen=True, eq=False, kw_only=True)
class Cells:
    """What a run asks and what its filter certifies; checked when made, before any model is.

    Attributes
    ----------
    task : DeliveryTask
        The contexts, the candidates' groups and the k slots of a prompt.
    design : {"table", "both", "paper"}
    positions : {"balanced", "latin", "fixed"}
        The orders in which the true candidates are shown.
    asked : dict
        The filter as asked: ``{"keep": [...]}`` (the keep probability of every attribute) or
        ``{"epsilon": [...]}``, and ``"split"``, the rule that splits a budget over the attributes.
    context_epsilon : float or None
        ε of randomized response on the context (None: shown as is).
    samples : int
        Queries per shown cell (and per true cell and ε in the paper's design).
    seed : int
        The run's seed: each query's seed is a hash of it and the query's key.
    targets : tuple of float
        Fairness targets (nats) at which the report gives the ε that meets them.
    confidence : float or None
        Level of the simultaneous intervals (None: none).
    method : str
        Their method.
    epsilons : tuple of float
        The candidate's privacy budgets (nats), ε(M_cand) of the filter at each point of the report: as asked, or
        of each keep probability (:func:`~fairaudit.experiments.slots.epsilon_from_keep`).

    Raises
    ------
    InputError
        A keep probability below 1/k for an attribute of k values; the table design when its kernel is too large
        (:func:`~fairaudit.experiments.slots.check_size`), the paper's when its bounds need a mechanism too large
        to build (:func:`~fairaudit.experiments.paper_design.paper_design_bounds`).
    """

    task: DeliveryTask
    design: str
    positions: str
    asked: dict
    context_epsilon: float | None
    samples: int
    seed: int
    targets: tuple[float, ...] = ()
    confidence: float | None = None
    method: str = "auto"
    epsilons: tuple[float, ...] = field(init=False)

    def __post_init__(self) -> None:
        from .paper_design import paper_design_bounds
        from .slots import check_size, epsilon_from_keep

        if "keep" in self.asked:
            epsilons = tuple(epsilon_from_keep(self.task, k, self.positions) for k in self.asked["keep"])
        else:
            epsilons = tuple(self.asked["epsilon"])
        object.__setattr__(self, "epsilons", epsilons)
        if self.design == "paper":  # no kernel: the bounds are refused here when they need too large a matrix
            for e in epsilons:
                paper_design_bounds(self.task, e, self.positions, context_epsilon=self.context_epsilon)
        else:
            check_size(self.task)  # before any model or kernel of the table design is made

    def settings(self) -> dict:
        """The settings of the cells that a run's log records and ``resume`` compares."""
        return {
            "seed": int(self.seed),
            "samples": self.samples,
            "design": self.design,
            "positions": self.positions,
            "epsilons": list(self.epsilons),
            "filter": {k: v for k, v in self.asked.items() if k != "split"},
            "context_epsilon": self.context_epsilon,
        }


def make_cells(task: DeliveryTask, options: RunOptions) -> Cells:
    """The cells of ``options`` on ``task``; what ``options`` leaves out comes from the task file (its positions,
    its ``[filter]`` budgets), else :data:`~fairaudit.experiments.options.DEFAULT_KEEPS`."""
    from .vlm.filter import SPLIT_RULE

    if options.epsilons is not None:
        asked = {"epsilon": [float(e) for e in options.epsilons]}
    elif options.keeps is None and task.epsilons is not None:
        asked = {"epsilon": [float(e) for e in task.epsilons]}
    else:
        keeps = options.keeps if options.keeps is not None else task.keeps if task.keeps is not None else DEFAULT_KEEPS
        asked = {"keep": [float(k) for k in keeps]}
    return Cells(
        task=task,
        design=options.design,
        positions=options.positions or task.positions,
        asked={**asked, "split": SPLIT_RULE},
        context_epsilon=options.context_epsilon,
        samples=DEFAULT_SAMPLES if options.samples is None else int(options.samples),
        seed=int(options.seed),
        targets=tuple(options.targets),
        confidence=options.confidence,
        method=options.method,
    )
