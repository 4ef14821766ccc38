"""The proofs and witnesses a certificate records for its black box (``bound_details.black_box``), read exactly
against its inputs: :class:`Evidence`. :mod:`~fairaudit.verification.table_check` checks them
(``proofs/verification.md`` §4f).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

from fairaudit.verification.enclosures import exact, recorded_array
from fairaudit.verification.schema import CertificateError

__all__ = ["Evidence"]


@dataclass(frozen=True)
class Evidence:
    """What a certificate records to check its black box with: the floors' multipliers of each program bounded by a
    linear program, and the maximiser's point, indexed by population position.

    ``local[(x, a, b)]`` is ν over the groups for L's program at context x and pair (a, b) (per context behind a
    context mechanism other than the identity, whose L program spans every context); ``global_[(a, b)]`` is ν per
    context (the population's order) for L̄'s. ``local_point`` is (x, a, b, h) of L's maximiser, h over the released
    groups; ``global_point`` is (a, b, h) of L̄'s, h per context. For a utility that depends on the group each h over
    the released groups is the maximiser's table instead, a row over the decisions per released group; behind a
    context mechanism other than the identity both points are the table over every released context.
    """

    local: dict[tuple[int, int, int], list[Any]] = field(default_factory=dict)  # ν, or ν per context
    global_: dict[tuple[int, int], list[list[Fraction]]] = field(default_factory=dict)
    local_point: tuple[int, int, int, list[Any]] | None = None
    global_point: tuple[int, int, list[list[Any]]] | None = None
    local_theta: dict[tuple[int, int, int], Fraction] = field(default_factory=dict)  # one-floor thresholds θ
    global_theta: dict[tuple[int, int], Fraction] = field(default_factory=dict)

    @classmethod
    def from_record(cls, detail: Mapping[str, Any] | None, inputs: Mapping[str, Any]) -> Evidence:
        """Read ``bound_details.black_box`` (``detail``; None: no evidence) against the certificate's ``inputs``.

        Raises
        ------
        CertificateError
            Naming the field (``bound_details.black_box.duals[0].group``) whose label is not the inputs' or whose
            numbers are not finite, or whose shape is not (groups,) or (contexts, groups) (``released`` for a point).
        """
        if not detail:
            return cls()
        pop = inputs["population"]
        contexts, groups = list(pop["contexts"]), list(pop["groups"])
        released = len(inputs["sensitive_mechanism"]["outputs"])
        own = inputs["context_mechanism"]["kind"] == "identity"  # (else L's program spans every context)
        where = "bound_details.black_box"
        local: dict[tuple[int, int, int], Any] = {}
        for i, d in enumerate(detail.get("duals") or []):
            name = f"{where}.duals[{i}]"
            key = (_index(d, "context", contexts, name), _index(d, "group", groups, name),
                   _index(d, "other_group", groups, name))  # fmt: skip
            floors = d.get("floors")
            if own:
                local[key] = _vector(floors, len(groups), f"{name}.floors")
            else:
                local[key] = _matrix(floors, len(contexts), len(groups), f"{name}.floors")
        glob = detail.get("global") or {}
        global_ = {}
        for i, d in enumerate(glob.get("duals") or []):
            name = f"{where}.global.duals[{i}]"
            key2 = (_index(d, "group", groups, name), _index(d, "other_group", groups, name))
            global_[key2] = _matrix(d.get("floors"), len(contexts), len(groups), f"{name}.floors")
        local_theta = _thetas(
            detail, f"{where}.screens", [("context", contexts), ("group", groups), ("other_group", groups)]
        )
        global_theta = _thetas(glob, f"{where}.global.screens", [("group", groups), ("other_group", groups)])
        # the maximiser's point (its labels are checked by verify's maximiser check, which fails a wrong one)
        local_point = None
        named = all(detail.get(k) in labels for k, labels in (("context", contexts), ("group", groups),
                                                             ("other_group", groups)))  # fmt: skip
        n_u = _decisions(inputs)
        if detail.get("witness_point") is not None and named:
            name = f"{where}.witness_point"
            h = _point(detail["witness_point"], released, n_u, name) if own else _tables(detail, name, inputs)
            local_point = (contexts.index(detail["context"]), groups.index(detail["group"]),
                           groups.index(detail["other_group"]), h)  # fmt: skip
        global_point = None
        if glob.get("witness_point") is not None and glob.get("group") in groups and glob.get("other_group") in groups:
            name = f"{where}.global.witness_point"
            if own:
                if not isinstance(glob["witness_point"], list) or len(glob["witness_point"]) != len(contexts):
                    raise CertificateError(name, f"must be a list of {len(contexts)} lists", glob["witness_point"])
                hs = [_point(h, released, n_u, f"{name}[{i}]") for i, h in enumerate(glob["witness_point"])]
            else:
                hs = _tables(glob, name, inputs)
            global_point = (groups.index(glob["group"]), groups.index(glob["other_group"]), hs)
        return cls(local, global_, local_point, global_point, local_theta, global_theta)


def _thetas(detail: Mapping[str, Any], where: str, keys: list[tuple[str, list[Any]]]) -> dict[Any, Fraction]:
    """The recorded one-floor thresholds θ (``screens``: each program's labels and its θ, a finite number), exactly,
    by the programs' positions."""
    out = {}
    for i, d in enumerate(detail.get("screens") or []):
        name = f"{where}[{i}]"
        theta = exact(d.get("theta"), f"{name}.theta") if isinstance(d.get("theta"), (int, float, str)) else None
        if not isinstance(theta, Fraction):
            raise CertificateError(
                f"{name}.theta", 'must be a finite number or an exact rational "n/d"', d.get("theta")
            )
        out[tuple(_index(d, key, labels, name) for key, labels in keys)] = theta
    return out


def _index(record: Mapping[str, Any], key: str, labels: list[Any], name: str) -> int:
    """The position of ``record[key]`` among ``labels``."""
    value = record.get(key)
    if value not in labels:
        raise CertificateError(f"{name}.{key}", "is not a label of the inputs' population", value)
    return labels.index(value)


def _vector(value: Any, n: int, name: str) -> list[Fraction]:
    """A recorded list of n finite numbers, exactly."""
    if not isinstance(value, list) or len(value) != n:
        raise CertificateError(name, f"must be a list of {n} numbers", value)
    out = recorded_array(value, name)
    if any(not isinstance(v, Fraction) for v in out):
        raise CertificateError(name, "must hold finite numbers", value)
    return out


def _decisions(inputs: Mapping[str, Any]) -> int | None:
    """The number of decisions when the utility depends on the group (its witness points are tables), else None."""
    values = inputs["utility"]["values"]
    if not values or not isinstance(values[0], list):
        return None
    if all(row == table[0] for table in values for row in table):
        return None
    return len(values[0][0])


def _tables(record: Mapping[str, Any], name: str, inputs: Mapping[str, Any]) -> list[list[list[Fraction]]]:
    """A recorded table over every released context (behind a context mechanism other than the identity): shape
    (released contexts, released groups, decisions)."""
    value = record["witness_point"]
    n_x = len(inputs["context_mechanism"]["outputs"])
    values = inputs["utility"]["values"]
    n_u = len(values[0][0]) if values and isinstance(values[0], list) else len(values)
    if not isinstance(value, list) or len(value) != n_x:
        raise CertificateError(name, f"must be a list of {n_x} lists", value)
    return [_matrix(t, len(inputs["sensitive_mechanism"]["outputs"]), n_u, f"{name}[{i}]") for i, t in enumerate(value)]


def _point(value: Any, released: int, n_u: int | None, name: str) -> list[Any]:
    """A recorded point over the released groups: n numbers, or (``n_u`` given) a table of rows of ``n_u``."""
    return _vector(value, released, name) if n_u is None else _matrix(value, released, n_u, name)


def _matrix(value: Any, rows: int, n: int, name: str) -> list[list[Fraction]]:
    """A recorded list of ``rows`` lists of n finite numbers, exactly."""
    if not isinstance(value, list) or len(value) != rows:
        raise CertificateError(name, f"must be a list of {rows} lists", value)
    return [_vector(row, n, f"{name}[{i}]") for i, row in enumerate(value)]
