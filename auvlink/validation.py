"""One validation mechanism for every TOML file of the project (pydantic v2).

The vehicle configuration (:mod:`auvlink.config`), the scene (:mod:`auvlink.sim.scene`), the
simulator settings (:mod:`auvlink.sim.settings`) and the classifier's training settings
(:mod:`classify.training.config`) are described by pydantic models (dataclasses or ``BaseModel``) built from
the pieces here: every table forbids unknown keys, numbers are strict (no ``"30"`` for 30, no
``true`` for 1, finite), sizes are bounded. :func:`validate` turns pydantic's errors into one
:class:`~auvlink.errors.ConfigError` of the project's form::

    config key 'devices[0].fromat': unknown key (allowed here: format, mounting, name, options, url)
    config key 'survey.lines': 1000000000 is out of range (use a value in [1, 1000])

(key path, problem, and the allowed keys or the allowed range). :func:`json_schema` gives the JSON
Schema that ``docs/schemas/*.schema.json`` publishes (``scripts/gen_schemas.py`` writes them).
"""

from __future__ import annotations

import tomllib
import types
import typing
from pathlib import Path
from typing import Annotated, Any, TypeVar

import annotated_types
from pydantic import BaseModel, ConfigDict, Field, Strict, TypeAdapter, ValidationError
from pydantic.dataclasses import dataclass as pydantic_dataclass
from pydantic.fields import FieldInfo

from auvlink.errors import ConfigError

T = TypeVar("T")

#: the pydantic configuration of every table: unknown keys are errors, no NaN or inf
CONFIG = ConfigDict(extra="forbid", allow_inf_nan=False)

#: a finite number (an integer is accepted; a string or a boolean is not)
Number = Annotated[float, Strict()]
#: a whole number (not a float, not a boolean)
Integer = Annotated[int, Strict()]
#: a non-empty string
Text = Annotated[str, Strict(), Field(min_length=1)]
Boolean = Annotated[bool, Strict()]
Vec2 = tuple[Number, Number]
Vec3 = tuple[Number, Number, Number]
Latitude = Annotated[Number, Field(ge=-90.0, le=90.0, description="WGS84 latitude, degrees north")]
Longitude = Annotated[Number, Field(ge=-180.0, le=180.0, description="WGS84 longitude, degrees east")]


@pydantic_dataclass(frozen=True, config=CONFIG)
class Site:
    """``[site]``: the WGS84 position (degrees) of the NED origin W on the surface; both optional."""

    latitude: Latitude | None = None
    longitude: Longitude | None = None


# -- errors ------------------------------------------------------------------------------------
def _strip(tp: Any) -> Any:
    """The type under ``Annotated`` and ``X | None``."""
    while True:
        if typing.get_origin(tp) is Annotated:
            tp = typing.get_args(tp)[0]
            continue
        if typing.get_origin(tp) in (typing.Union, types.UnionType):
            args = [a for a in typing.get_args(tp) if a is not type(None)]
            if len(args) == 1:
                tp = args[0]
                continue
        return tp


def _fields(tp: Any) -> dict[str, Any] | None:
    """``{key: FieldInfo}`` of a model or pydantic dataclass (keys as written in the file)."""
    infos = getattr(tp, "__pydantic_fields__", None)
    if infos is None and isinstance(tp, type) and issubclass(tp, BaseModel):
        infos = tp.model_fields
    if infos is None:
        return None
    return {(info.alias or name): info for name, info in infos.items()}


def _members(tp: Any) -> list[Any]:
    if typing.get_origin(tp) in (typing.Union, types.UnionType):
        return [_strip(a) for a in typing.get_args(tp) if a is not type(None)]
    return [tp]


def _walk(root: Any, loc: tuple[int | str, ...]) -> tuple[str, Any, Any]:
    """The dotted key of ``loc``, the type holding its last part and the FieldInfo of that part."""
    key, tp, info, parent = "", _strip(root), None, None
    for part in loc:
        if isinstance(part, int):
            if typing.get_origin(tp) is tuple:  # a vector: the key is the vector itself
                break
            key += f"[{part}]"
            args = typing.get_args(tp)
            tp = _strip(args[0]) if args else Any
            continue
        found = False
        for member in _members(tp):
            fields = _fields(member)
            if fields is not None and part in fields:
                parent, info = member, fields[part]
                key = f"{key}.{part}" if key else part
                tp = _strip(info.annotation)
                found = True
                break
            if typing.get_origin(member) is dict or member is dict:
                parent, info = member, None
                key = f"{key}.{part}" if key else part
                args = typing.get_args(member)
                tp = _strip(args[1]) if len(args) == 2 else Any
                found = True
                break
        if not found:
            members = [m for m in _members(tp) if _fields(m) is not None]
            if any(getattr(m, "__name__", None) == part for m in _members(tp)):
                tp = next(m for m in _members(tp) if getattr(m, "__name__", None) == part)
                continue  # a union member's tag
            if members and part not in ("function-after", "function-before"):
                parent, info = members[0], None  # an unknown key of this table
                key = f"{key}.{part}" if key else part
                tp = Any
    return key, parent, info


def _constraints(tp: Any) -> list[Any]:
    """Every annotated-types constraint inside ``tp`` (through Annotated, Field and X | None)."""
    out: list[Any] = []
    if typing.get_origin(tp) is Annotated:
        base, *metas = typing.get_args(tp)
        out += _constraints(base)
        for meta in metas:
            out += list(getattr(meta, "metadata", ())) if isinstance(meta, FieldInfo) else [meta]
    elif typing.get_origin(tp) in (typing.Union, types.UnionType):
        for arg in typing.get_args(tp):
            out += _constraints(arg)
    return out


def _bounds(info: Any) -> str:
    lo, hi, lb, rb = "-inf", "inf", "[", "]"
    metas = list(getattr(info, "metadata", ())) + _constraints(getattr(info, "annotation", None))
    for meta in metas:
        if isinstance(meta, annotated_types.Ge):
            lo = repr(meta.ge)
        elif isinstance(meta, annotated_types.Gt):
            lo, lb = repr(meta.gt), "("
        elif isinstance(meta, annotated_types.Le):
            hi = repr(meta.le)
        elif isinstance(meta, annotated_types.Lt):
            hi, rb = repr(meta.lt), ")"
    return f"{lb}{lo}, {hi}{rb}"


_KIND = {"float": "a finite number", "int": "an integer", "string": "a string", "bool": "true or false",
         "finite": "a finite number"}
_FIX = {"float": "write a plain number, e.g. 1.0", "finite": "write a plain number, e.g. 1.0",
        "int": "write a whole number, e.g. 4", "string": "quote it", "bool": "write true or false"}


#: most characters of a bad value quoted in an error line (a 10,000-entry list is named, not printed)
SHOWN_CHARS = 80


def _shown(value: Any) -> str:
    """``repr(value)``, cut to :data:`SHOWN_CHARS` characters."""
    text = repr(value)
    return text if len(text) <= SHOWN_CHARS else text[:SHOWN_CHARS - 3] + "..."


def config_error(root: Any, exc: ValidationError, prefix: str = "") -> ConfigError:
    """The first of pydantic's errors in the project's form (key, problem, fix)."""
    errors = exc.errors(include_url=False)
    unknown = [e for e in errors if e["type"] in ("extra_forbidden", "unexpected_keyword_argument")]
    err = (unknown or errors)[0]  # a misspelt key first: its "missing" twin follows from it
    key, parent, info = _walk(root, tuple(err["loc"]))
    key = f"{prefix}{key}" if key else prefix.rstrip(".") or "<document>"
    kind, value, ctx = err["type"], err.get("input"), err.get("ctx") or {}
    name = key.rpartition(".")[2]
    if kind in ("extra_forbidden", "unexpected_keyword_argument"):
        allowed = sorted(_fields(parent) or {})
        return ConfigError(key, "unknown key", f"allowed here: {', '.join(allowed)}")
    if kind == "missing" and err["loc"] and isinstance(err["loc"][-1], int):  # a vector too short
        n = len(typing.get_args(_strip(getattr(info, "annotation", None)))) or err["loc"][-1] + 1
        return ConfigError(key, f"expected a list of {n} numbers, got {_shown(value)}",
                           f"write [{', '.join(['0.0'] * n)}]")
    if kind.startswith(("datetime", "date_")):
        return ConfigError(key, f"not an ISO 8601 time: {_shown(value)}", 'write "2026-01-01T00:00:00Z"')
    if kind == "missing" or kind == "missing_argument":
        return ConfigError(key, "missing", f"add `{name} = ...`")
    if kind in ("greater_than", "greater_than_equal", "less_than", "less_than_equal"):
        shown = value if isinstance(value, int) else float(value)
        return ConfigError(key, f"{shown} is out of range", f"use a value in {_bounds(info)}")
    if kind == "too_long" and "max_length" in ctx and isinstance(value, list | tuple) \
            and typing.get_origin(_strip(getattr(info, "annotation", None))) is not tuple:  # objects, ...
        return ConfigError(key, f"{len(value)} entries are too many", f"use at most {ctx['max_length']}")
    if kind in ("too_short", "too_long") and isinstance(value, list | tuple):
        n = len(typing.get_args(_strip(getattr(info, "annotation", None))))
        return ConfigError(key, f"expected a list of {n} numbers, got {_shown(value)}",
                           f"write [{', '.join(['0.0'] * n)}]")
    if kind == "literal_error":
        return ConfigError(key, f"{_shown(value)} is not allowed", f"use one of {ctx.get('expected', '')}")
    if kind in ("dataclass_type", "model_type", "dict_type", "model_attributes_type"):
        return ConfigError(key, f"expected a table, got {type(value).__name__}", f"write [{key}] or {name} = {{ ... }}")
    if kind in ("tuple_type", "list_type"):
        return ConfigError(key, f"expected a list, got {_shown(value)}", f"write {name} = [ ... ]")
    if kind == "string_too_short":
        return ConfigError(key, f"must be a non-empty string, got {_shown(value)}", "quote it")
    base = kind.split("_")[0]
    if base in _KIND or kind == "finite_number":
        return ConfigError(key, f"expected {_KIND.get(base, 'a finite number')}, got {_shown(value)}",
                           _FIX.get(base, "fix the value"))
    return ConfigError(key, err["msg"].removeprefix("Value error, "), "")


_ADAPTERS: dict[Any, TypeAdapter[Any]] = {}


def adapter(tp: type[T]) -> TypeAdapter[T]:
    """The (cached) pydantic TypeAdapter of ``tp``."""
    if tp not in _ADAPTERS:
        _ADAPTERS[tp] = TypeAdapter(tp)
    return _ADAPTERS[tp]


def validate(tp: type[T], data: Any, prefix: str = "") -> T:
    """``data`` (a parsed TOML table) as a ``tp``, or :class:`ConfigError` naming the key."""
    try:
        return adapter(tp).validate_python(data)
    except ValidationError as exc:
        raise config_error(tp, exc, prefix) from exc


def json_schema(tp: Any, title: str, description: str = "") -> dict[str, Any]:
    """The JSON Schema (draft 2020-12) of a file described by ``tp``."""
    schema = adapter(tp).json_schema()
    schema = {"$schema": "https://json-schema.org/draft/2020-12/schema", **schema, "title": title}
    if description:
        schema["description"] = description
    return schema


def read_toml(path: str | Path, what: str) -> tuple[dict[str, Any], str]:
    """``(document, text)`` of a TOML file; ConfigError keyed ``what`` when unreadable or invalid."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise ConfigError(what, f"cannot read {p}: {exc.strerror or exc}", "check the path") from exc
    except UnicodeDecodeError as exc:  # a binary file given for a TOML one
        raise ConfigError(what, f"{p} is not UTF-8 text (byte {exc.start})", "give the TOML file") from exc
    return loads_toml(text, what), text


def loads_toml(text: str, what: str) -> dict[str, Any]:
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(what, f"not valid TOML: {exc}", "fix the TOML syntax at the position given") from exc
    except RecursionError as exc:  # tomllib recurses once per nested array or inline table
        raise ConfigError(what, "arrays or tables nested too deeply", "write a plain TOML file") from exc


def plain(obj: Any) -> Any:
    """A validated object as plain JSON-ready data (tuples as lists)."""
    return adapter(type(obj)).dump_python(obj, mode="json")
