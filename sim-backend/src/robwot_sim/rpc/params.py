"""Validation of JSON-RPC params: wrong type, wrong length, NaN/Infinity, missing -> -32602.

Every failure names the param (`positions[3]`), what was expected and what was got, so a client
can point at its mistake. Validation happens before the world is touched.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import Any, Final

from robwot_sim.rpc.protocol import INVALID_PARAMS, Fault
from robwot_sim.sim.validate import MIN_QUATERNION_NORM, unit_quaternion


class _Missing:
    def __repr__(self) -> str:
        return "MISSING"


MISSING: Final = _Missing()


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
    return "object"


def invalid_param(param: str, expected: str, got: Any, *, missing: bool = False) -> Fault:
    got_text = "nothing (missing)" if missing else describe(got)
    return Fault(
        INVALID_PARAMS,
        f"invalid param '{param}': expected {expected}, got {got_text}",
        {"code": "E_INVALID_PARAMS", "param": param, "expected": expected, "got": got_text},
    )


def _is_number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def check_number(param: str, value: Any, minimum: float | None = None, maximum: float | None = None,
                 *, exclusive_minimum: bool = False) -> float:
    """A finite JSON number within optional bounds, as float."""
    bounds = ""
    if minimum is not None:
        bounds += f" {'>' if exclusive_minimum else '>='} {minimum:g}"
    if maximum is not None:
        bounds += f"{' and' if bounds else ''} <= {maximum:g}"
    expected = f"a finite number{bounds}"
    if not _is_number(value) or not math.isfinite(value):
        raise invalid_param(param, expected, value)
    number = float(value)
    if minimum is not None and (number <= minimum if exclusive_minimum else number < minimum):
        raise invalid_param(param, expected, value)
    if maximum is not None and number > maximum:
        raise invalid_param(param, expected, value)
    return number


def check_vector(param: str, value: Any, length: int | None = None) -> list[float]:
    """An array of finite numbers, of exactly `length` items when given."""
    expected = f"an array of {length} finite numbers" if length is not None else "an array of finite numbers"
    if not isinstance(value, list) or (length is not None and len(value) != length):
        raise invalid_param(param, expected, value)
    out: list[float] = []
    for i, item in enumerate(value):
        if not _is_number(item) or not math.isfinite(item):
            raise invalid_param(f"{param}[{i}]", "a finite number", item)
        out.append(float(item))
    return out


class Params:
    """Typed, named access to one request's params (an object; positional arrays are refused)."""

    def __init__(self, raw: Mapping[str, Any] | list[Any] | None, allowed: Iterable[str] = ()) -> None:
        if isinstance(raw, list):
            raise Fault(
                INVALID_PARAMS,
                "params must be an object of named parameters, not an array",
                {"code": "E_INVALID_PARAMS", "param": "params", "expected": "object",
                 "got": describe(raw)},
            )
        self.raw: dict[str, Any] = dict(raw or {})
        allowed_set = set(allowed)
        for key in sorted(self.raw):
            if key not in allowed_set:
                raise invalid_param(key, f"no such param; valid params: {sorted(allowed_set)}", self.raw[key])

    def has(self, name: str) -> bool:
        return name in self.raw and self.raw[name] is not None

    def _get(self, name: str, default: Any) -> Any:
        if name in self.raw and self.raw[name] is not None:
            return self.raw[name]
        if default is MISSING:
            raise invalid_param(name, "a value (this param is required)", None, missing=True)
        return default

    def string(self, name: str, default: Any = MISSING, *, choices: Iterable[str] | None = None) -> Any:
        value = self._get(name, default)
        if value is default and default is not MISSING:
            return value
        options = sorted(choices) if choices is not None else None
        expected = f"one of {options}" if options else "a non-empty string"
        if not isinstance(value, str) or not value or (options and value not in options):
            raise invalid_param(name, expected, value)
        return value

    def number(self, name: str, default: Any = MISSING, *, minimum: float | None = None,
               maximum: float | None = None, exclusive_minimum: bool = False) -> Any:
        value = self._get(name, default)
        if value is default and default is not MISSING:
            return value
        return check_number(name, value, minimum, maximum, exclusive_minimum=exclusive_minimum)

    def integer(self, name: str, default: Any = MISSING, *, minimum: int | None = None,
                maximum: int | None = None) -> Any:
        value = self._get(name, default)
        if value is default and default is not MISSING:
            return value
        ok = _is_number(value) and math.isfinite(value) and float(value).is_integer()
        lo = -math.inf if minimum is None else minimum
        hi = math.inf if maximum is None else maximum
        if not ok or not lo <= value <= hi:
            lower = f" >= {minimum}" if minimum is not None else ""
            bounds = lower + (f" <= {maximum}" if maximum is not None else "")
            raise invalid_param(name, f"an integer{bounds}", value)
        return int(value)

    def boolean(self, name: str, default: Any = MISSING) -> Any:
        value = self._get(name, default)
        if not isinstance(value, bool):
            raise invalid_param(name, "true or false", value)
        return value

    def vector(self, name: str, length: int | None = None, default: Any = MISSING) -> Any:
        value = self._get(name, default)
        if value is default and default is not MISSING:
            return value
        return check_vector(name, value, length)

    def quaternion(self, name: str, default: Any = MISSING) -> Any:
        """`[x, y, z, w]` of norm >= MIN_QUATERNION_NORM, returned normalised."""
        value = self._get(name, default)
        if value is default and default is not MISSING:
            return value
        quat = unit_quaternion(check_vector(name, value, 4))
        if quat is None:
            raise invalid_param(name, f"a quaternion [x, y, z, w] of norm >= {MIN_QUATERNION_NORM:g}", value)
        return quat

    def obj(self, name: str, default: Any = MISSING) -> Any:
        value = self._get(name, default)
        if value is default and default is not MISSING:
            return value
        if not isinstance(value, dict):
            raise invalid_param(name, "an object", value)
        return value

    def string_map(self, name: str, default: Any = MISSING) -> Any:
        """An object whose values are non-empty strings (e.g. packageRoots: {name: dir})."""
        value = self.obj(name, default)
        if value is default and default is not MISSING:
            return value
        for key, item in value.items():
            if not isinstance(item, str) or not item:
                raise invalid_param(f"{name}.{key}", "a non-empty string", item)
        return dict(value)
