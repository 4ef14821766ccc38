"""The TOML spec's tables as pydantic models: each field validated, unknown fields refused.

:func:`fairaudit.certification.spec.parse_spec` imports this module when it reads a spec (pydantic is imported
only then); :class:`~fairaudit.certification.spec.Spec` builds the objects the validated tables name.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal, Self

from pydantic import AfterValidator, BaseModel, ConfigDict, Field, field_validator, model_validator
from pydantic import Strict as StrictType

from fairaudit.base.checks import real
from fairaudit.base.errors import InputError
from fairaudit.base.toml_documents import FieldProblem, distinct_labels, toml_label, value_kind


class StrictModel(BaseModel):
    """A TOML table: unknown keys are errors, the validated model is frozen."""

    model_config = ConfigDict(extra="forbid", frozen=True)


Number = Annotated[float, StrictType()]
"""A TOML number: an integer or a float (converted to float); a string or a boolean is an error."""


def _finite(v: float | None, what: str = "value") -> float | None:
    """``v`` (None stays None) if it is finite; else a problem of the field ``.what``."""
    if v is None:
        return v
    try:
        return real(v, what, what="finite")
    except InputError as exc:
        raise FieldProblem(f".{exc.field}", exc.problem, exc.value) from None


def _numbers_in(v: list[Any], levels: int, where: str = "") -> None:
    """Every entry of the nested list ``v`` (at most ``levels`` deep) is a TOML number that fits a float."""
    for i, x in enumerate(v):
        here = f"{where}[{i}]"
        if isinstance(x, list):
            if levels <= 1:
                raise FieldProblem(here, "must be a number, not a list (nested too deeply)", x)
            _numbers_in(x, levels - 1, here)
        elif isinstance(x, bool) or not isinstance(x, (int, float)):
            raise FieldProblem(here, f"must be a number, not {value_kind(x)}", x)
        elif isinstance(x, int) and not -(2**1023) < x < 2**1023:
            raise FieldProblem(here, "is too large for a number", x)


Labels = Annotated[list[Any] | None, AfterValidator(lambda v, info: distinct_labels(v, info.field_name or "values"))]
"""A list of labels, distinct as text and as values, of one kind (:func:`~fairaudit.base.toml_documents.distinct_labels`,
whose errors name the field)."""


class AttributeSpec(StrictModel):
    """An alphabet: a name and its ordered values."""

    name: str
    values: Labels = None


class DecisionSpec(AttributeSpec):
    """The decisions: an alphabet and optionally ``unparsed``, the value that stands for replies read as no option."""

    unparsed: Any = None


class ContextSpec(AttributeSpec):
    """The context: an alphabet and optionally its distribution P(X)."""

    distribution: list[Number] | None = None


class MechanismSpec(StrictModel):
    """A mechanism: identity, randomized_response, matrix or product."""

    mechanism: Literal["identity", "randomized_response", "matrix", "product"] = "identity"
    epsilon: Number | None = Field(default=None, ge=0)
    keep: Number | None = Field(default=None, gt=0, le=1)
    rows: list[list[Number]] | None = None
    outputs: Labels = None
    values: Labels = None
    components: list[MechanismSpec] | None = None
    name: str | None = None

    @model_validator(mode="after")
    def _fields_fit(self) -> Self:
        m = self.mechanism
        if m == "randomized_response" and (self.epsilon is None) == (self.keep is None):
            raise ValueError("randomized_response needs exactly one of epsilon and keep")
        if m == "matrix" and self.rows is None:
            raise ValueError("matrix needs rows")
        if m == "product" and not self.components:
            raise ValueError("product needs components")
        if m != "product" and self.components:
            raise ValueError(f"components are only for mechanism = 'product', not {m!r}")
        if m != "matrix" and (self.rows is not None or self.outputs is not None):
            raise ValueError(f"rows and outputs are only for mechanism = 'matrix', not {m!r}")
        if m not in {"randomized_response"} and (self.epsilon is not None or self.keep is not None):
            raise ValueError(f"epsilon and keep are only for mechanism = 'randomized_response', not {m!r}")
        return self


class WeightedInput(StrictModel):
    """One entry of a group's mixture in ``[privacy.family] mixtures``: a product's input and its weight."""

    weight: Number = Field(ge=0)
    input: list[Any]


class FamilySpec(StrictModel):
    """``[privacy.family]``: the family calibration moves along, a product of randomized responses seen on some rows.

    ``components`` are randomized responses (values, and epsilon or keep: the split of ε, as a product's); each
    sensitive value, in the order of ``[sensitive] values``, is one of the product's inputs (``inputs``) or a
    weighted mixture of them (``mixtures``: weights non-negative, summing to 1 to 1e-9).
    """

    components: list[MechanismSpec]
    inputs: list[list[Any]] | None = None
    mixtures: list[list[WeightedInput]] | None = None
    name: str | None = None

    @model_validator(mode="after")
    def _fields_fit(self) -> Self:
        for i, c in enumerate(self.components):
            if c.mechanism != "randomized_response" or c.values is None:
                raise FieldProblem(f".components[{i}]", "must be a randomized_response with values", c.mechanism)
        if (self.inputs is None) == (self.mixtures is None):
            raise ValueError("give exactly one of inputs (one row per group) and mixtures (weighted rows per group)")
        n = f"needs one value per component ({len(self.components)})"
        for i, row in enumerate(self.inputs or []):
            if len(row) != len(self.components):
                raise FieldProblem(f".inputs[{i}]", n, row)
        for i, mix in enumerate(self.mixtures or []):
            weights = [m.weight for m in mix]
            if not abs(sum(weights) - 1) <= 1e-9:
                raise FieldProblem(f".mixtures[{i}]", "weights must sum to 1 (to 1e-9)", weights)
            for j, m in enumerate(mix):
                if len(m.input) != len(self.components):
                    raise FieldProblem(f".mixtures[{i}][{j}].input", n, m.input)
        return self


class PrivacySpec(StrictModel):
    """``[privacy]``: the mechanisms on the sensitive attribute and on the context (identity by default), and
    optionally the family calibration moves along."""

    sensitive: MechanismSpec = MechanismSpec()
    context: MechanismSpec = MechanismSpec()
    family: FamilySpec | None = None


class PopulationSpec(StrictModel):
    """``[population]``: the joint P(X, A) (n_contexts × n_groups) or P(A) with X ⊥ A."""

    probabilities: list[list[Number]] | None = None
    group_distribution: list[Number] | None = None

    @model_validator(mode="after")
    def _one(self) -> Self:
        if self.probabilities is not None and self.group_distribution is not None:
            raise ValueError("give probabilities or group_distribution, not both")
        return self


class CsvSpec(StrictModel):
    """``[model.csv]``: how a text file of the model is read (:class:`~fairaudit.data.csv_format.CsvFormat`)."""

    header: bool = True
    names: list[str] | None = None
    sep: str | None = None
    na_values: list[str] = []
    skip_initial_space: bool = False


class ModelSpec(StrictModel):
    """``[model]``: the kernel P(U | X̃, Ã) as an aggregated table (counts or probabilities) or as records."""

    table: str | None = None
    records: str | None = None
    count_column: str | None = None
    probability_column: str | None = None
    where: dict[str, Any] = {}
    csv: CsvSpec | None = None
    weight_column: str | None = None

    @model_validator(mode="after")
    def _one(self) -> Self:
        if (self.table is None) == (self.records is None):
            raise ValueError("give exactly one of table (aggregated counts or probabilities) and records")
        if self.weight_column is not None and self.records is None:
            raise ValueError("weight_column weighs records: a table gives its counts already")
        if self.count_column is not None and self.probability_column is not None:
            raise ValueError("give count_column or probability_column, not both")
        return self


class UtilitySpec(StrictModel):
    """``[utility]``: g (indicator of a decision, or a table), its class [lower, γ], τ, L_A and the metric."""

    kind: Literal["indicator", "table"] = "indicator"
    decision: Any = None
    values: list[Any] | None = None
    gamma: Number | None = Field(default=None, ge=0)
    lower: Number | None = Field(default=None, ge=0)
    tau: Number | None = Field(default=None, gt=0)
    lipschitz: Number | None = Field(default=None, ge=0)
    metric: list[list[Number]] | None = None
    name: str | None = None

    @field_validator("decision")
    @classmethod
    def _decision(cls, v: Any) -> Any:
        return None if v is None else toml_label(v, "")

    @field_validator("values")
    @classmethod
    def _numbers(cls, v: list[Any] | None) -> list[Any] | None:
        if v is not None:
            _numbers_in(v, 3)  # a list over decisions or a [context][group][decision] table
        return v

    @model_validator(mode="after")
    def _fields_fit(self) -> Self:
        for f in ("gamma", "lower", "tau", "lipschitz"):
            _finite(getattr(self, f), f)
        if self.kind == "indicator" and self.decision is None:
            raise ValueError("kind = 'indicator' needs decision (the decision value whose probability is g)")
        if self.kind == "table" and self.values is None:
            raise ValueError("kind = 'table' needs values (a list over decisions, or [context][group][decision])")
        if self.gamma is not None and self.lower is not None and self.lower > self.gamma:
            raise FieldProblem(".lower", f"cannot exceed gamma = {self.gamma:g}", self.lower)
        if self.gamma is not None and self.tau is not None and self.tau > self.gamma:
            raise FieldProblem(".tau", f"cannot exceed gamma = {self.gamma:g} (E[g | x, a] <= max g)", self.tau)
        return self


class TargetSpec(StrictModel):
    """``[target]``: targets on local and global g-fairness, in nats."""

    local: Number | None = Field(default=None, ge=0)
    global_: Number | None = Field(default=None, ge=0, alias="global")

    model_config = ConfigDict(extra="forbid", frozen=True, populate_by_name=True)


class SpecModel(StrictModel):
    """The whole spec, validated field by field (unknown fields are errors)."""

    title: str | None = None
    sensitive: AttributeSpec
    context: ContextSpec | None = None
    decision: DecisionSpec
    population: PopulationSpec | None = None
    privacy: PrivacySpec = PrivacySpec()
    model: ModelSpec | None = None
    utility: UtilitySpec
    target: TargetSpec | None = None

    @model_validator(mode="after")
    def _values_present(self) -> Self:
        if self.decision.values is None:
            raise ValueError("decision.values is required")
        if self.context is not None and self.context.values is None:
            raise ValueError("context.values is required when [context] is present")
        if (
            self.population is not None
            and self.population.probabilities is not None
            and self.context is not None
            and self.context.distribution is not None
        ):
            raise ValueError("give context.distribution or population.probabilities, not both")
        if self.sensitive.values is None and self.privacy.sensitive.mechanism != "product":
            raise ValueError("sensitive.values is required (it may be left out only with a product mechanism)")
        return self
