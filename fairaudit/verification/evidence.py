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
    """What a certificate records to check its black box with, by its program's key in population positions: (x, a, b)
    for L's program at context x and the ordered pair (a, b), (a, b) for L̄'s.

    ``nu[key]`` is the floors' multipliers ν of a program bounded by a linear program: over the groups for L's (per
    context behind a context mechanism other than the identity, whose L program spans every context), per context (the
    population's order) for L̄'s. ``theta[key]`` is the one-floor threshold θ of a program bounded without one.
    ``points[key]`` is the maximiser's point: h over the released groups for L's, h per context for L̄'s. For a utility
    that depends on the group each h over the released groups is the maximiser's table instead, a row over the
    decisions per released group; behind a context mechanism other than the identity both points are the table over
    every released context.
    """

    nu: dict[tuple[int, ...], list[Any]] = field(default_factory=dict)
    theta: dict[tuple[int, ...], Fraction] = field(default_factory=dict)
    points: dict[tuple[int, ...], list[Any]] = field(default_factory=dict)

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
        where, out = "bound_details.black_box", cls()
        sides = [  # L's and L-bar's: the record, its program's labels, its path, its multipliers' and its point's shape
            (detail, ("context", "group", "other_group"), where, (n_g,) if own else (n_x, n_g), point),
            (detail.get("global") or {}, ("group", "other_group"), f"{where}.global", (n_x, n_g),
             (n_x, *point) if own else point),
        ]  # fmt: skip
        for record, keys, at, per, shape in sides:
            out.nu.update(_read(record, f"{at}.duals", keys, labels, "floors", per))
            out.theta.update(_read(record, f"{at}.screens", keys, labels, "theta", ()))
            # the maximiser's point (its labels are checked by verify's maximiser check, which fails a wrong one)
            if record.get("witness_point") is not None and all(record.get(k) in labels[k] for k in keys):
                h = _array(record["witness_point"], shape, f"{at}.witness_point")
                out.points[tuple(labels[k].index(record[k]) for k in keys)] = h
        return out


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
