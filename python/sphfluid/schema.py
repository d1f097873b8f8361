"""The scene format's JSON Schema (``scene.schema.json``) and a scene's problems
against it, each by JSON path in the loader's words.

The schema is the one statement of the format's keys, types, ranges, defaults
and the rules between keys that a schema can say; ``sphfluid schema`` prints it
for editors. ``problems`` turns jsonschema's errors into messages such as
``fluid.rest_density: must be > 0, got -1`` and ``solvr: unknown key (did you
mean "solver"?)``; the loader (scene.py) then checks what a schema cannot say:
geometry, memory, and comparisons between values.

Wording: a subschema's ``"x-messages"`` maps a keyword to the message shown
when that keyword fails there (editors ignore the key); otherwise the message
follows from the keyword.
"""
from __future__ import annotations

import difflib
import functools
import json
import math
from collections.abc import Iterable, Iterator, Sequence
from importlib import resources
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import jsonschema

SCHEMA_FILE = "scene.schema.json"

# Messages that end in the value found: ", got <value>" is added to these.
_SHOWS_VALUE = {"type", "const", "enum", "minItems", "maxItems", "items", "oneOf", "minimum", "maximum",
                "exclusiveMinimum", "exclusiveMaximum", "pattern"}
_TYPE_WORDS = {"number": "a number", "integer": "an integer", "string": "a string",
               "boolean": "true or false", "object": "an object", "array": "a list",
               "null": "null"}
_MAX_DEPTH = 64  # nesting of JSON arrays and objects a scene may have
TOO_DEEP = f"nested more than {_MAX_DEPTH} levels deep"


@functools.lru_cache(maxsize=None)
def scene_schema(name: str = SCHEMA_FILE) -> dict:
    """The schema (or another of the package's, by file name), parsed (shared: do
    not modify)."""
    text = resources.files("sphfluid").joinpath(name).read_text(encoding="utf-8")
    return json.loads(text)


@functools.lru_cache(maxsize=None)
def _validator(name: str = SCHEMA_FILE) -> jsonschema.Draft202012Validator:
    import jsonschema  # ~50 ms: on the first scene, not on import

    schema = scene_schema(name)
    return jsonschema.Draft202012Validator(_inline_refs(schema, schema.get("$defs", {})))


def _inline_refs(node: Any, defs: dict) -> Any:
    """The schema with each "$ref": "#/$defs/NAME" replaced by that definition
    (its sibling keys kept): the same rules, checked about twice as fast on a
    polygon of thousands of points, as jsonschema resolves no reference per point."""
    if isinstance(node, list):
        return [_inline_refs(v, defs) for v in node]
    if not isinstance(node, dict):
        return node
    out = {k: _inline_refs(v, defs) for k, v in node.items() if k not in ("$ref", "$defs")}
    ref = node.get("$ref", "")
    if ref.startswith("#/$defs/"):
        out = {**_inline_refs(defs[ref[len("#/$defs/"):]], defs), **out}
    return out


def default(*keys: str) -> Any:
    """The schema's "default" of the key at the path ``keys`` (object keys only)."""
    node = scene_schema()
    for k in keys:
        node = node["properties"][k]
    return node["default"]


def keys(*path: str) -> list[str]:
    """The keys the object at ``path`` (object keys only) may have, in order."""
    node = scene_schema()
    for k in path:
        node = node["properties"][k]
    return list(node["properties"])


def json_path(parts: Iterable[Any]) -> str:
    """["walls", 3, "polyline"] as walls[3].polyline; a key that would read as a
    path (a sweep's "solver.cfl") in brackets: vary["solver.cfl"]."""
    text = ""
    for p in parts:
        if isinstance(p, int):
            text += f"[{p}]"
        elif not p or any(c in str(p) for c in '.[]" '):
            text += f"[{json.dumps(p)}]"
        else:
            text += f".{p}" if text else str(p)
    return text


def problems(data: Any, name: str = SCHEMA_FILE) -> list[tuple[str, str]]:
    """(JSON path, message) for each place ``data`` breaks the schema (the scene
    format's, or the package's schema file ``name``) or holds a number that is
    not finite, one per path, in the schema's order."""
    deep = _too_deep(data)
    if deep is not None:  # not checked further: nothing in it is to be trusted
        return [(json_path(deep), TOO_DEEP)]
    out: dict[str, str] = {}
    for path, message in _non_finite(data):
        out.setdefault(json_path(path), message)
    for error in _validator(name).iter_errors(data):
        for path, message in _messages(error):
            out.setdefault(json_path(path), message)
    return list(out.items())


def shown(value: Any) -> str:
    """A value as JSON, cut short when long."""
    try:
        text = json.dumps(value, allow_nan=True)
    except (TypeError, ValueError):
        text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def kind(value: Any) -> str:
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, (int, float)):
        return f"the number {shown(value)}"
    if isinstance(value, str):
        return f"the string {shown(value)}"
    if isinstance(value, list):
        return f"a list of {len(value)}"
    if isinstance(value, dict):
        return "an object"
    return type(value).__name__


def did_you_mean(word: Any, options: Sequence[Any]) -> str:
    strings = [o for o in options if isinstance(o, str)]
    near = difflib.get_close_matches(word, strings, n=1) if isinstance(word, str) else []
    return f' (did you mean "{near[0]}"?)' if near else ""


def one_of(options: Sequence[Any]) -> str:
    """'"a"', '"a" or "b"', 'one of "a", "b", "c"'."""
    words = [json.dumps(o) for o in options]
    if len(words) <= 2:
        return " or ".join(words)
    return "one of " + ", ".join(words)


# --------------------------------------------------------------------------- errors

def _messages(e: jsonschema.ValidationError) -> Iterator[tuple[list, str]]:
    path = list(e.absolute_path)
    custom = e.schema.get("x-messages", {}) if isinstance(e.schema, dict) else {}
    v, value, inst = e.validator, e.validator_value, e.instance
    if v == "oneOf":
        yield from _one_of(e, path, custom)
    elif v == "required":
        for k in value:
            if k not in inst:
                yield path + [k], custom.get("required", "required key is missing")
    elif v == "additionalProperties":
        allowed = list(e.schema.get("properties", {}))
        for k in inst:
            if k not in allowed:
                near = difflib.get_close_matches(k, allowed, n=1, cutoff=0.6)
                hint = f'did you mean "{near[0]}"?' if near else f"expected one of: {', '.join(allowed)}"
                yield path + [k], f"unknown key ({hint})"
    else:
        message = custom.get(v) or _message(v, value, inst) or e.message
        if v in _SHOWS_VALUE:
            message += f", got {kind(inst) if v == 'type' and v not in custom else shown(inst)}"
        if v == "enum":
            message += did_you_mean(inst, value)
        yield path, message


def _message(v: str, value: Any, inst: Any) -> str | None:
    """The message for keyword v (its value in the schema, the instance's);
    None for a keyword this module has no words for."""
    if v == "type":
        types = [value] if isinstance(value, str) else value
        return "expected " + " or ".join(_TYPE_WORDS.get(t, t) for t in types)
    if v in ("const", "enum"):
        return "expected " + one_of([value] if v == "const" else value)
    bounds = {"minimum": ">=", "exclusiveMinimum": ">", "maximum": "<=", "exclusiveMaximum": "<"}
    if v in bounds:
        return f"must be {bounds[v]} {value:g}"
    if v == "minItems":
        return f"expected at least {value} item{'s' if value != 1 else ''}"
    if v == "uniqueItems":
        seen: list = []
        for item in inst:
            if item in seen:
                return f"lists {shown(item)} more than once"
            seen.append(item)
    if v == "minLength":
        return "expected a non-empty string"
    return None


def _one_of(e: jsonschema.ValidationError, path: list, custom: dict) -> Iterator[tuple[list, str]]:
    """The alternatives of a oneOf: the one the value picks (by a key every
    alternative fixes with "const", else by JSON type), and its problems."""
    branches, inst = e.validator_value, e.instance
    key = _discriminator(branches)
    chosen: list[int] = []
    if key is not None and isinstance(inst, dict):
        consts = [b["properties"][key]["const"] for b in branches]
        if key not in inst:
            yield path + [key], f"required key is missing ({one_of(consts)})"
            return
        if inst[key] not in consts:
            yield path + [key], (f"expected {one_of(consts)}, got {shown(inst[key])}"
                                 f"{did_you_mean(inst[key], consts)}")
            return
        chosen = [consts.index(inst[key])]
    else:
        mismatch = {s.relative_schema_path[0] for s in e.context
                    if (s.validator == "type" and not s.relative_path)
                    or (s.validator == "const" and not s.relative_path)}
        chosen = [i for i in range(len(branches)) if i not in mismatch]
    if len(chosen) != 1:
        yield path, f"{custom.get('oneOf', 'matches none of the allowed forms')}, got {shown(inst)}"
        return
    for sub in e.context:
        if sub.relative_schema_path[0] == chosen[0]:
            yield from _messages(sub)


def _discriminator(branches: Sequence[Any]) -> str | None:
    """A key to which every alternative gives a "const" (a region's "shape")."""
    if not all(isinstance(b, dict) and "properties" in b for b in branches):
        return None
    common = set.intersection(*(set(b["properties"]) for b in branches))
    for k in sorted(common):
        if all(isinstance(b["properties"][k], dict) and "const" in b["properties"][k]
               for b in branches):
            return k
    return None


def _too_deep(data: Any) -> list | None:
    """The path of the first value nested deeper than _MAX_DEPTH, if any."""
    stack = [(data, [])]
    while stack:
        value, path = stack.pop()
        if len(path) > _MAX_DEPTH:
            return path[:_MAX_DEPTH]
        if isinstance(value, dict):
            stack.extend((v, path + [k]) for k, v in value.items())
        elif isinstance(value, list):
            stack.extend((v, path + [i]) for i, v in enumerate(value))
    return None


def _non_finite(data: Any) -> Iterator[tuple[list, str]]:
    """Numbers no double holds: NaN, infinities and integers beyond 1.8e308."""
    stack = [(data, [])]
    while stack:
        value, path = stack.pop()
        if isinstance(value, dict):
            stack.extend((v, path + [k]) for k, v in value.items())
        elif isinstance(value, list):
            stack.extend((v, path + [i]) for i, v in enumerate(value))
        elif isinstance(value, float) and not math.isfinite(value):
            yield path, f"must be finite, got {value!r}"
        elif isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > 1023:
            yield path, "must be finite, got an integer beyond 1.8e308"
