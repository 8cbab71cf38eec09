"""The backend's contract, read from `schemas/protocol.openrpc.json` (OpenRPC 1.3): the one description of
every method's params, result and errors and of every notification. The TS types of `sim-client` and
`PROTOCOL.md` are generated from the same file (`npm run gen:contract`).

Here it validates params before a handler runs (replacing per-method hand-written checks), fills in the
defaults of nested values (a program step's `speed`, `blend`, ...: a handler reads them, never a default of
its own) and, when
asked (`ROBWOT_CHECK_RESULTS=1`, set by the test suites), the results too. A failure names the param
(`positions[3]`, `shape.size[0]`), what the contract expects and what was received.

Each schema is checked by a compiled validator first, the Python one saying why it refused
(`schemacheck.py`).
"""

from __future__ import annotations

import copy
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from functools import cache
from typing import Any

from jsonschema import Draft7Validator, validators
from jsonschema.exceptions import ValidationError, best_match

from robwot_sim.limits import contract_document
from robwot_sim.rpc.protocol import Fault
from robwot_sim.schemacheck import accepts, compiled

#: OpenRPC has no notification object: server-to-client notifications are listed under this extension.
NOTIFICATIONS_KEY = "x-notifications"
#: the draft the contract's schemas follow (OpenRPC 1.3's)
DRAFT_7 = "http://json-schema.org/draft-07/schema#"


def _finite_number(_checker: Any, value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def _integer(checker: Any, value: Any) -> bool:
    return _finite_number(checker, value) and float(value).is_integer()


# JSON Schema's "number" admits the NaN/Infinity a lenient JSON parser produces; ours does not.
_Validator = validators.extend(
    Draft7Validator,
    type_checker=Draft7Validator.TYPE_CHECKER.redefine("number", _finite_number)
    .redefine("integer", _integer),
)


def describe(value: Any) -> str:
    """A short, JSON-safe description of a received value for `error.data.got`."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return f"boolean {str(value).lower()}"
    if isinstance(value, float) and math.isnan(value):
        return "NaN"
    if isinstance(value, float) and math.isinf(value):
        return "Infinity" if value > 0 else "-Infinity"
    if isinstance(value, int | float):
        return f"number {value!r}"
    if isinstance(value, str):
        text = value if len(value) <= 60 else value[:57] + "..."
        return f"string {text!r}"
    if isinstance(value, list):
        return f"array of length {len(value)}"
    if isinstance(value, dict):
        return f"object of {len(value)} entries"
    return "object"


def invalid_param(param: str, expected: str, got: Any, *, missing: bool = False) -> Fault:
    """`E_INVALID_PARAMS` naming the param, the expectation and what was received."""
    got_text = "nothing (missing)" if missing else describe(got)
    return Fault.of(
        "E_INVALID_PARAMS",
        f"invalid param '{param}': expected {expected}, got {got_text}",
        param=param, expected=expected, got=got_text,
    )


def _join(path: list[str | int]) -> str:
    out = ""
    for part in path:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out


@dataclass(frozen=True)
class MethodContract:
    """One method: the schema of its params object, their defaults, and its result schema."""

    name: str
    params: tuple[str, ...]
    defaults: Mapping[str, Any]
    params_schema: dict[str, Any]
    result_schema: dict[str, Any]


class Contract:
    """An OpenRPC document: method lookup, params validation (defaults filled in), result checks."""

    def __init__(self, document: Mapping[str, Any]) -> None:
        self.document = document
        self._components = dict(document.get("components", {}))
        self.methods: dict[str, MethodContract] = {}
        for method in document.get("methods", []):
            params = method.get("params", [])
            schema = {
                "type": "object",
                "properties": {p["name"]: p["schema"] for p in params},
                "required": [p["name"] for p in params if p.get("required")],
                "additionalProperties": False,
            }
            defaults = {p["name"]: self._default(p["schema"]) for p in params}
            result = method.get("result", {}).get("schema", {})
            self.methods[method["name"]] = MethodContract(
                method["name"], tuple(p["name"] for p in params),
                {k: v for k, v in defaults.items() if v is not None}, schema, result)
        self._params = {name: self._validator(m.params_schema) for name, m in self.methods.items()}
        self._results = {name: self._validator(m.result_schema) for name, m in self.methods.items()}
        self.notifications = {n["name"]: self._validator(n["params"])
                              for n in document.get(NOTIFICATIONS_KEY, [])}
        self._fast: dict[tuple[str, str], Any] = {}  # compiled validators, by (params or result, method)

    def _default(self, schema: Mapping[str, Any]) -> Any:
        """A param's default: on its schema, or on the component it refers to."""
        return schema["default"] if "default" in schema else self.resolve(schema).get("default")

    def _validator(self, schema: Mapping[str, Any]) -> Any:
        # `#/components/...` references resolve against a root that carries the document's components
        return _Validator({**schema, "components": self._components})

    def fast(self, method: str, part: str = "params") -> Any:
        """The compiled validator of a method's ``params`` or ``result``, compiled when first asked for (each
        holds every component: compiling all at start would delay the backend's readiness)."""
        validator = self._fast.get((part, method))
        if validator is None:
            m = self.methods[method]
            schema = m.params_schema if part == "params" else m.result_schema
            validator = compiled({**schema, "components": self._components, "$schema": DRAFT_7})
            self._fast[(part, method)] = validator
        return validator

    def resolve(self, schema: Mapping[str, Any]) -> Mapping[str, Any]:
        """`schema` with a local `$ref` followed (one level at a time)."""
        while "$ref" in schema:
            _, section, name = schema["$ref"].lstrip("#/").split("/")
            schema = self._components[section][name]
        return schema

    def validate_params(self, method: str, raw: Mapping[str, Any] | list[Any] | None) -> dict[str, Any]:
        """The params object checked against the method's params schema, or a `Fault` naming the param;
        nested defaults filled in (`with_defaults`; a param's own default is `MethodContract.defaults`)."""
        if isinstance(raw, list):
            raise Fault.of("E_INVALID_PARAMS", "params must be an object of named parameters, not an array",
                           param="params", expected="object", got=describe(raw))
        # JSON-RPC clients often send null for "not given": it counts as absent
        values = {k: v for k, v in (raw or {}).items() if v is not None}
        if not accepts(self.fast(method), values):
            errors = list(self._params[method].iter_errors(values))
            # an unknown (misspelt) name first: the other errors are often its consequence
            unknown = [e for e in errors if e.validator == "additionalProperties" and not e.absolute_path]
            error = best_match(unknown or errors)
            if error is not None:
                raise self._fault(error)
        schemas = self.methods[method].params_schema["properties"]
        return {k: self.with_defaults(schemas[k], v) for k, v in values.items()}

    def with_defaults(self, schema: Mapping[str, Any], value: Any) -> Any:
        """``value`` (valid against ``schema``) with the defaults of the properties of the objects it holds
        filled in where absent, through arrays and `$ref`s."""
        schema = self.resolve(schema)
        if isinstance(value, list) and isinstance(schema.get("items"), Mapping):
            return [self.with_defaults(schema["items"], v) for v in value]
        if isinstance(value, dict) and "properties" in schema:
            out = dict(value)
            for name, sub in schema["properties"].items():
                if name in out:
                    out[name] = self.with_defaults(sub, out[name])
                elif (default := self._default(sub)) is not None:
                    out[name] = copy.deepcopy(default)
            return out
        return value

    def check_result(self, method: str, result: Any) -> None:
        """Raise E_INTERNAL when a result contradicts the contract (a bug in the backend)."""
        if accepts(self.fast(method, "result"), result):
            return
        error = best_match(self._results[method].iter_errors(result))
        if error is not None:
            where = _join(list(error.absolute_path)) or "result"
            raise Fault.of("E_INTERNAL", f"result of {method} contradicts the contract at {where}: "
                           f"{error.message}", method=method)

    def check_notification(self, method: str, params: Any) -> str | None:
        """Why a notification contradicts the contract, or None."""
        error = best_match(self.notifications[method].iter_errors(params))
        return None if error is None else f"{_join(list(error.absolute_path)) or 'params'}: {error.message}"

    # ---- error translation ----

    def _fault(self, error: ValidationError) -> Fault:
        error = self._narrow(error)
        path: list[str | int] = list(error.absolute_path)
        instance = error.instance
        if error.validator == "additionalProperties":
            known = sorted(self.resolve(error.schema).get("properties", {}))
            extra = sorted(k for k in instance if k not in known)[0]
            what = "param" if not path else "field"
            return invalid_param(_join([*path, extra]), f"no such {what}; valid {what}s: {known}",
                                 instance[extra])
        if error.validator == "required":
            missing = next(k for k in error.validator_value if k not in instance)
            return invalid_param(_join([*path, missing]), "a value (this param is required)", None,
                                 missing=True)
        return invalid_param(_join(path) or "params", self.expectation(error.schema), instance)

    def _narrow(self, error: ValidationError) -> ValidationError:
        """For a failed `oneOf`/`anyOf` of objects told apart by `type` (shapes), the error of the member
        the value's `type` names; for other values the whole `oneOf`/`anyOf`, not one member's error."""
        while error.parent is not None and error.parent.validator in ("oneOf", "anyOf") \
                and not isinstance(error.instance, dict):
            error = error.parent
        while error.validator in ("oneOf", "anyOf") and error.context:
            instance = error.instance
            if not isinstance(instance, dict):
                return error
            members = [self.resolve(m) for m in error.validator_value]
            kinds = [m.get("properties", {}).get("type", {}).get("const") for m in members]
            if instance.get("type") not in kinds:
                if any(k is not None for k in kinds):
                    return ValidationError("bad type", validator="enum", validator_value=kinds,
                                           instance=instance.get("type"), schema={"enum": kinds},
                                           path=[*error.absolute_path, "type"])
                return error
            index = kinds.index(instance["type"])
            inside = [e for e in error.context if e.relative_schema_path[0] == index]
            if not inside:
                return error
            narrowed = best_match(inside)
            assert narrowed is not None
            error = narrowed
        return error

    def expectation(self, schema: Mapping[str, Any]) -> str:
        """What a schema accepts, in words (`a finite number >= 0.001 and <= 1`)."""
        schema = self.resolve(schema)
        if "const" in schema:
            return json.dumps(schema["const"])
        if "enum" in schema:
            return f"one of {schema['enum']}"
        members = schema.get("oneOf") or schema.get("anyOf")
        if members:
            return " or ".join(self.expectation(m) for m in members)
        kind = schema.get("type")
        if kind in ("number", "integer"):
            bounds = []
            if "minimum" in schema:
                bounds.append(f">= {schema['minimum']:g}")
            if "exclusiveMinimum" in schema:
                bounds.append(f"> {schema['exclusiveMinimum']:g}")
            if "maximum" in schema:
                bounds.append(f"<= {schema['maximum']:g}")
            noun = "a finite number" if kind == "number" else "an integer"
            return " ".join([noun, " and ".join(bounds)]) if bounds else noun
        if kind == "array":
            items = self.resolve(schema.get("items", {}))
            noun = {"number": "finite numbers", "string": "strings"}.get(str(items.get("type")), "items")
            lo, hi = schema.get("minItems"), schema.get("maxItems")
            count = f"{lo} " if lo is not None and lo == hi else ""
            limits = f" ({lo} to {hi})" if lo is not None and hi is not None and lo != hi else (
                f" (at most {hi})" if hi is not None and lo is None else "")
            within = ""
            if "minimum" in items and "maximum" in items:
                within = f" within [{items['minimum']:g}, {items['maximum']:g}]"
            return f"an array of {count}{noun}{within}{limits}"
        if kind == "string":
            noun = "a non-empty string" if schema.get("minLength") else "a string"
            return f"{noun} of at most {schema['maxLength']} characters" if "maxLength" in schema else noun
        if kind == "boolean":
            return "true or false"
        if kind == "object":
            tag = schema.get("properties", {}).get("type", {}).get("const")
            if tag is None:
                most = schema.get("maxProperties")
                return "an object" if most is None else f"an object of at most {most} entries"
            fields = ", ".join(k for k in schema.get("required", []) if k != "type")
            return f'{{"type": "{tag}", {fields}}}'

        return "a valid value"


@cache
def contract() -> Contract:
    """The backend's own contract (package data)."""
    return Contract(copy.deepcopy(contract_document()))
