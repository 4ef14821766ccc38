"""The certificate's JSON Schema, ``certificate.schema.json`` (draft 2020-12), checked with ``jsonschema``.

The schema ships with the package. It is strict on what ``fairaudit verify`` reads (``format``, ``format_version``,
``tolerance``, ``inputs_sha256``, ``inputs``, ``bounds`` and ``privacy``: every key required, no other key) and
types the keys of the other sections that docs/cli.md lists (they may hold more). The format is
``docs/certificates.md`` ("The certificate's format"). ``jsonschema`` is imported when a certificate is checked, not
with ``fairaudit``.
"""

from __future__ import annotations

import functools
import json
from collections.abc import Collection, Mapping
from importlib import resources
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from jsonschema import Draft202012Validator
    from jsonschema.exceptions import ValidationError

__all__ = ["SCHEMA_FILE", "CertificateError", "certificate_schema", "check_certificate", "json_path", "other_document"]

SCHEMA_FILE = "certificate.schema.json"
"""The schema's file name in the package ``fairaudit.verification``."""

_WEAK = frozenset({"anyOf", "oneOf"})


class CertificateError(ValueError):
    """What ``verify`` cannot read (a certificate, a filter's parameters): one line naming the field, saying what is
    wrong and quoting the value (``repr``, cut after 80 characters), as fairaudit's ``InputError`` words it; the
    command line prints it and exits 2. Its own class, so that the verification package imports nothing else of
    fairaudit.

    Parameters
    ----------
    field : str
        The JSON path at fault (``inputs.utility.tau``).
    problem : str
        What is wrong.
    value : object, optional
        The offending value (none given: :attr:`NO_VALUE`).

    Examples
    --------
    >>> str(CertificateError("tolerance", "must be positive", -1.0)), str(CertificateError("tolerance", "is required"))
    ('tolerance: must be positive (got -1.0)', 'tolerance: is required')
    """

    NO_VALUE = object()

    def __init__(self, field: str, problem: str, value: object = NO_VALUE) -> None:
        self.field, self.problem, self.value = field, problem, value
        text = " ".join(repr(value).split())
        text = text if len(text) <= 80 else f"{text[:80]}… ({len(text)} characters)"
        super().__init__(f"{field}: {problem}" + (f" (got {text})" if value is not self.NO_VALUE else ""))


MAX_DEPTH = 64
"""The deepest nesting of arrays and objects a certificate may have (one nests 8 deep): the schema's check and the
verifier walk a document recursively, so a deeper one is refused first, by a walk that does not recurse."""


def certificate_schema() -> dict[str, Any]:
    """The certificate's JSON Schema, read from the package data (a new copy each call).

    Examples
    --------
    >>> s = certificate_schema()
    >>> s["$schema"], s["properties"]["format_version"]
    ('https://json-schema.org/draft/2020-12/schema', {'const': 3})
    """
    return json.loads(resources.files("fairaudit.verification").joinpath(SCHEMA_FILE).read_text(encoding="utf-8"))


@functools.cache
def _validator() -> Draft202012Validator:
    """The schema's validator, built once, of the schema with each ``$ref`` to its ``$defs`` replaced by the
    definition (the same schema: no definition refers to itself, a reference's siblings are descriptions; resolving a reference per number of a large
    certificate took half of its check)."""
    from jsonschema import Draft202012Validator

    schema = certificate_schema()

    def inline(node: Any) -> Any:
        if isinstance(node, list):
            return [inline(v) for v in node]
        if not isinstance(node, dict):
            return node
        if "$ref" in node:  # (its siblings are descriptions only)
            return inline(schema["$defs"][node["$ref"].removeprefix("#/$defs/")])
        return {k: v if k == "$defs" else inline(v) for k, v in node.items()}

    return Draft202012Validator(inline(schema))


def json_path(parts: Collection[str | int]) -> str:
    """A path into a JSON document as fairaudit's errors name fields: keys joined by dots, indices in brackets.

    Examples
    --------
    >>> json_path(["inputs", "population", "probabilities", 0, 1])
    'inputs.population.probabilities[0][1]'
    >>> json_path([])
    ''
    """
    out = ""
    for p in parts:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else str(p))
    return out


def check_certificate(data: Mapping[str, Any]) -> None:
    """Check a certificate's JSON against the certificate's JSON Schema (``certificate.schema.json``).

    Parameters
    ----------
    data : mapping
        A certificate as JSON values (``json.load`` of ``fairaudit certify --format json``, or
        ``Certificate.to_dict()``): str keys; str, numbers, bools, None, lists and dicts as values.

    Raises
    ------
    CertificateError
        On the first (most relevant, ``jsonschema.exceptions.best_match``) departure from the schema: its field is
        the JSON path of the part at fault (``inputs.utility.tau``, ``inputs.population.probabilities[0][1]``; a
        missing or unknown key named at its own path, ``inputs_sha256``), its value the offending value.

    Notes
    -----
    The schema checks types, required and known keys, enums, the format's name and version, the SHA-256's form and
    the ranges of probabilities; it does not check that arrays' shapes agree with their labels, that rows sum to 1
    or that the SHA-256 is the inputs' (``fairaudit verify`` does). Source: docs/certificates.md ("The
    certificate's format").

    Examples
    --------
    >>> import fairaudit as fa
    >>> data = fa.certify(fa.parse_spec('''
    ... [sensitive]
    ... name = "office"
    ... values = ["HR_1", "HR_2"]
    ... [decision]
    ... name = "chosen"
    ... values = ["yes", "no"]
    ... [privacy.sensitive]
    ... mechanism = "randomized_response"
    ... keep = 0.7
    ... [utility]
    ... decision = "yes"
    ... tau = 0.25
    ... ''')).to_dict()
    >>> check_certificate(data)
    >>> data["inputs"]["utility"]["tau"] = "0.25"
    >>> check_certificate(data)
    Traceback (most recent call last):
    ...
    fairaudit.verification.schema.CertificateError: inputs.utility.tau: must be a number >= 0, or null (got '0.25')
    """
    if not isinstance(data, Mapping):
        raise CertificateError("certificate", "must be a JSON object", data)
    deep = _too_deep(data, MAX_DEPTH)
    if deep is not None:
        raise CertificateError(json_path(deep), f"is nested deeper than {MAX_DEPTH} arrays and objects")
    other = other_document(data)
    if other is not None:
        raise CertificateError("certificate", other)
    from jsonschema.exceptions import best_match

    errors = list(_validator().iter_errors(data))
    if not errors:
        return
    # a concrete error (an unknown enum value) before "valid under none of" at the same or a shallower place
    top = max(errors, key=lambda e: (e.validator not in _WEAK, -len(e.absolute_path)))
    raise _input_error(_chosen_branch(best_match([top])))


def _too_deep(data: Any, limit: int) -> list[str | int] | None:
    """The path of the first array or object nested deeper than ``limit``, or None, by a walk with its own stack.

    Examples
    --------
    >>> _too_deep({"a": [1, {"b": []}]}, 4), _too_deep({"a": [1, {"b": []}]}, 3), _too_deep({"a": [1, {"b": []}]}, 2)
    (None, ['a', 1, 'b'], ['a', 1])
    """
    stack: list[tuple[Any, int, list[str | int]]] = [(data, 1, [])]
    while stack:
        value, depth, path = stack.pop()
        items = value.items() if isinstance(value, Mapping) else enumerate(value) if isinstance(value, list) else ()
        for key, inner in items:
            if isinstance(inner, (Mapping, list)):
                if depth + 1 > limit:
                    return [*path, key]
                stack.append((inner, depth + 1, [*path, key]))
    return None


def other_document(data: Mapping[str, Any]) -> str | None:
    """What a JSON object is when it is another of fairaudit's documents, not a certificate, and what to do; else None.

    ``fairaudit experiment`` writes ``certificate.json``: its report (the experiment, the model, a certificate's
    numbers per ε, docs/experiments.md "The files"), not a certificate in this format. The table design writes beside
    it a spec per ε, ``spec-eps-<ε>.toml``, whose certificate ``fairaudit certify`` writes; the paper's design alone
    writes none. A filter's parameters (``fairaudit filter --parameters``) are read by ``verify --filter``.

    Examples
    --------
    >>> other_document({"experiment": "hr-delivery", "model": "prefers-mary", "points": []}).split(", not")[0]
    "is the report of fairaudit experiment (task 'hr-delivery', model 'prefers-mary')"
    >>> other_document({"format": "fairaudit-filter"})
    "is a filter's parameters (fairaudit filter --parameters), not a certificate: pass it as --filter FILTER.json"
    >>> other_document({"format": "fairaudit-certificate"}) is None
    True
    >>> other_document({"format": "fairaudit-certificate", "format_version": 2})
    'is a certificate of format version 2, which this verify does not read: re-certify its spec (fairaudit certify) for format 3'
    """
    if data.get("format") == "fairaudit-certificate" and data.get("format_version") in (1, 2):
        return f"is a certificate of format version {data['format_version']}, which this verify does not read: re-certify its spec (fairaudit certify) for format 3"
    if data.get("format") == "fairaudit-filter":
        return "is a filter's parameters (fairaudit filter --parameters), not a certificate: pass it as --filter FILTER.json"
    if "format" in data or not {"experiment", "points"} <= set(data):
        return None
    run: Mapping[str, Any] = data["run"] if isinstance(data.get("run"), Mapping) else {}
    design = data.get("design", run.get("design"))
    what = f"is the report of fairaudit experiment (task {data['experiment']!r}, model {data.get('model')!r}), not a certificate"
    if design == "paper":
        return what + ": a run of the paper's design alone writes no spec to certify (run --design table or both)"
    return (
        what + ": certify a spec-eps-<epsilon>.toml the run wrote beside it "
        "(fairaudit certify SPEC --format json --output CERT.json) and verify that certificate"
    )


def _chosen_branch(error: ValidationError) -> ValidationError:
    """In a ``oneOf`` by ``kind``, the best error of the one branch whose ``kind`` matches (else the error itself)."""
    from jsonschema.exceptions import best_match

    if error.validator != "oneOf":
        return error
    branches: dict[int | str, list[ValidationError]] = {}
    for e in error.context or ():
        branches.setdefault(e.relative_schema_path[0], []).append(e)
    matching = [errs for errs in branches.values() if not any(e.validator == "const" for e in errs)]
    if len(matching) != 1:
        return error
    return _chosen_branch(best_match(matching[0]))


def _input_error(error: ValidationError) -> CertificateError:
    """One schema error as a CertificateError: its field the JSON path, its value the offending value."""
    path = list(error.absolute_path)
    instance = error.instance
    expected: Any = error.validator_value  # the failed keyword's value: required's list here
    if error.validator == "required" and isinstance(instance, Mapping):
        missing = next(k for k in expected if k not in instance)
        return CertificateError(json_path([*path, missing]), "is required")
    if error.validator == "additionalProperties" and isinstance(instance, Mapping):
        known = error.schema.get("properties", {}) if isinstance(error.schema, Mapping) else {}
        extra = next(k for k in instance if k not in known)
        return CertificateError(json_path([*path, extra]), "is not a known key", instance[extra])
    return CertificateError(json_path(path) or "certificate", _problem(error), instance)


def _problem(error: ValidationError) -> str:
    """What is wrong, without the value (the error quotes it)."""
    schema = error.schema if isinstance(error.schema, Mapping) else {}
    expected: Any = error.validator_value
    if error.validator == "const":
        return f"must be {expected!r}"
    if error.validator == "enum":
        return "must be one of " + ", ".join(repr(v) for v in expected)
    if error.validator in _WEAK:
        return f"must be {schema['description']}" if "description" in schema else "matches none of the allowed forms"
    return error.message.removeprefix(f"{error.instance!r} ").strip()
