"""What a certificate records to check its black box with (``bound_details.black_box``): :class:`Evidence`, the
proofs and witness points read against the certificate's ``inputs`` (:mod:`~fairaudit.verification.black_box_check`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

from fairaudit.verification.enclosures import INF, exact, group_free
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
        labels = {"context": list(pop["contexts"]), "group": list(pop["groups"]), "other_group": list(pop["groups"])}
        n_x, n_g = len(pop["contexts"]), len(pop["groups"])
        released = len(inputs["sensitive_mechanism"]["outputs"])
        own = inputs["context_mechanism"]["kind"] == "identity"  # (else L's program spans every context)
        values = inputs["utility"]["values"]
        if own:  # a point over the released groups: E[g | x, ã], or a row of P(u | x, ã) each (g by group)
            point: tuple[int, ...] = (released,) if group_free(values) else (released, len(values[0][0]))
        else:  # the table over every released context
            n_dec = len(values[0][0]) if isinstance(values[0], list) else len(values)
            point = (len(inputs["context_mechanism"]["outputs"]), released, n_dec)
        where, glob = "bound_details.black_box", detail.get("global") or {}
        keys, global_keys = ("context", "group", "other_group"), ("group", "other_group")
        local = _read(detail, f"{where}.duals", keys, labels, "floors", (n_g,) if own else (n_x, n_g))
        global_ = _read(glob, f"{where}.global.duals", global_keys, labels, "floors", (n_x, n_g))
        local_theta = _read(detail, f"{where}.screens", keys, labels, "theta", ())
        global_theta = _read(glob, f"{where}.global.screens", global_keys, labels, "theta", ())
        # the maximiser's point (its labels are checked by verify's maximiser check, which fails a wrong one)
        local_point = global_point = None
        if detail.get("witness_point") is not None and all(detail.get(k) in labels[k] for k in keys):
            h = _array(detail["witness_point"], point, f"{where}.witness_point")
            local_point = (*(labels[k].index(detail[k]) for k in keys), h)
        if glob.get("witness_point") is not None and all(glob.get(k) in labels[k] for k in global_keys):
            hs = _array(glob["witness_point"], (n_x, *point) if own else point, f"{where}.global.witness_point")
            global_point = (*(labels[k].index(glob[k]) for k in global_keys), hs)
        return cls(local, global_, local_point, global_point, local_theta, global_theta)


def _read(
    detail: Mapping[str, Any], where: str, keys: tuple[str, ...], labels: Mapping[str, list[Any]], field: str,
    shape: tuple[int, ...],
) -> dict[Any, Any]:  # fmt: skip
    """The recorded proofs of a kind (``duals``, ``screens``: ``where``), each an array of ``shape`` under ``field``,
    by the positions of its program's labels (``keys``)."""
    out = {}
    for i, d in enumerate(detail.get(where.rsplit(".", 1)[1]) or []):
        name = f"{where}[{i}]"
        out[tuple(_index(d, key, labels[key], name) for key in keys)] = _array(d.get(field), shape, f"{name}.{field}")
    return out


def _index(record: Mapping[str, Any], key: str, labels: list[Any], name: str) -> int:
    """The position of ``record[key]`` among ``labels``."""
    value = record.get(key)
    if value not in labels:
        raise CertificateError(f"{name}.{key}", "is not a label of the inputs' population", value)
    return labels.index(value)


def _array(value: Any, shape: tuple[int, ...], name: str) -> Any:
    """A recorded array of finite numbers (a float, or an exact rational ``"n/d"``) of ``shape``, exactly."""
    if not shape:
        try:
            number = exact(value, name)
        except CertificateError:
            number = INF
        if not isinstance(number, Fraction):
            raise CertificateError(name, 'must be a finite number or an exact rational "n/d"', value)
        return number
    if not isinstance(value, list) or len(value) != shape[0]:
        raise CertificateError(name, f"must be a list of {shape[0]} {'numbers' if len(shape) == 1 else 'lists'}", value)
    return [_array(v, shape[1:], f"{name}[{i}]") for i, v in enumerate(value)]
