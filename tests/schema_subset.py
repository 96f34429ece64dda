"""A validator for the subset of JSON Schema draft 2020-12 that ``docs/summary.schema.json`` uses.

``jsonschema`` is not a dependency (it brings four more packages, one of them compiled); this is the part of
the standard the schema needs, and a keyword outside it is an error, so the schema can never use one that is
silently ignored. Keywords: ``$schema $id title description $defs $ref`` (local ``#/$defs/name`` only),
``type`` (a name or a list), ``properties required additionalProperties`` (bool or schema), ``items``,
``enum const oneOf minimum maximum``.
"""

from __future__ import annotations

import math

KNOWN = {"$schema", "$id", "title", "description", "$defs", "$ref", "type", "properties", "required",
         "additionalProperties", "items", "enum", "const", "oneOf", "minimum", "maximum"}

_TYPES = {
    "object": lambda v: isinstance(v, dict),
    "array": lambda v: isinstance(v, list),
    "string": lambda v: isinstance(v, str),
    "boolean": lambda v: isinstance(v, bool),
    "null": lambda v: v is None,
    # JSON has no NaN (json.dumps(..., allow_nan=False) refuses it); bool is not a number in JSON
    "integer": lambda v: isinstance(v, int) and not isinstance(v, bool),
    "number": lambda v: isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v),
}


def errors(instance, schema: dict, root: dict | None = None, where: str = "$") -> list[str]:
    """Every violation of ``schema`` by ``instance`` as "path: what" lines (empty: valid)."""
    root = schema if root is None else root
    unknown = set(schema) - KNOWN
    if unknown:
        raise ValueError(f"schema at {where} uses keyword(s) {sorted(unknown)} this validator does not know")
    out: list[str] = []
    if "$ref" in schema:
        ref = schema["$ref"]
        if not ref.startswith("#/$defs/"):
            raise ValueError(f"{where}: only local #/$defs/ references are supported, got {ref}")
        out += errors(instance, root["$defs"][ref[len("#/$defs/"):]], root, where)
    if "type" in schema:
        names = schema["type"] if isinstance(schema["type"], list) else [schema["type"]]
        if not any(_TYPES[n](instance) for n in names):
            return out + [f"{where}: expected {' or '.join(names)}, got {type(instance).__name__} {instance!r:.60}"]
    if "const" in schema and not _equal(instance, schema["const"]):
        out.append(f"{where}: expected {schema['const']!r}, got {instance!r:.60}")
    if "enum" in schema and not any(_equal(instance, e) for e in schema["enum"]):
        out.append(f"{where}: {instance!r:.60} is not one of {schema['enum']}")
    if _TYPES["number"](instance):
        if "minimum" in schema and instance < schema["minimum"]:
            out.append(f"{where}: {instance} < minimum {schema['minimum']}")
        if "maximum" in schema and instance > schema["maximum"]:
            out.append(f"{where}: {instance} > maximum {schema['maximum']}")
    if isinstance(instance, dict):
        props = schema.get("properties", {})
        out += [f"{where}: required key {k!r} is missing" for k in schema.get("required", []) if k not in instance]
        extra = schema.get("additionalProperties", True)
        for key, value in instance.items():
            if key in props:
                out += errors(value, props[key], root, f"{where}.{key}")
            elif extra is False:
                out.append(f"{where}: key {key!r} is not in the schema (document it in docs/summary.schema.json)")
            elif isinstance(extra, dict):
                out += errors(value, extra, root, f"{where}.{key}")
    if isinstance(instance, list) and "items" in schema:
        for i, value in enumerate(instance):
            out += errors(value, schema["items"], root, f"{where}[{i}]")
    if "oneOf" in schema:
        results = [errors(instance, s, root, where) for s in schema["oneOf"]]
        passed = [i for i, r in enumerate(results) if not r]
        if len(passed) != 1:
            best = min(results, key=len)
            out.append(f"{where}: matches {len(passed)} of the oneOf alternatives (exactly one expected)"
                       + ("; nearest: " + "; ".join(best[:5]) if not passed else ""))
    return out


def _equal(a, b) -> bool:
    """JSON equality: ``true`` is not ``1``."""
    return type(a) is type(b) and a == b if isinstance(a, bool) or isinstance(b, bool) else a == b
