"""Parameter checks shared by the world methods: they raise ``InvalidParams`` naming the parameter."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from robwot_sim.errors import InvalidParams
from robwot_sim.limits import MAX_COORDINATE, MAX_NAME_LENGTH, MIN_QUATERNION_NORM

__all__ = ["MAX_COORDINATE", "MIN_QUATERNION_NORM"]


def _is_number(v: object) -> bool:
    if isinstance(v, bool):
        return False
    return isinstance(v, (int, float, np.floating, np.integer))


def vector(name: str, value: Any, n: int) -> list[float]:
    """A list of ``n`` finite numbers."""
    try:
        items = list(value)
    except TypeError:
        items = None
    if items is None or not all(_is_number(v) for v in items):
        raise InvalidParams(
            f"{name} must be an array of {n} numbers", param=name, expected=f"array of {n} numbers", got=value
        )
    if len(items) != n:
        raise InvalidParams(
            f"{name} must have {n} values, got {len(items)}", param=name, expected=n, got=len(items)
        )
    for k, v in enumerate(items):
        if not math.isfinite(float(v)):
            raise InvalidParams(
                f"{name}[{k}] is {v}, not a finite number",
                param=f"{name}[{k}]",
                expected="finite number",
                got=float(v),
            )
    return [float(v) for v in items]


def position(name: str, value: Any) -> list[float]:
    """Three finite numbers within +-MAX_COORDINATE (a position in m, or rpy angles in rad)."""
    p = vector(name, value, 3)
    for k, c in enumerate(p):
        if abs(c) > MAX_COORDINATE:
            raise InvalidParams(
                f"{name}[{k}] is {c:g}, beyond +-{MAX_COORDINATE:g}",
                param=f"{name}[{k}]",
                expected=f"number within +-{MAX_COORDINATE:g}",
                got=c,
            )
    return p


def unit_quaternion(q: Sequence[float]) -> list[float] | None:
    """``q`` (finite) normalised, or None when its norm is below MIN_QUATERNION_NORM. Components beyond
    ~1e154 (whose squares overflow) are scaled by the largest one first."""
    norm = math.sqrt(sum(c * c for c in q))
    if math.isinf(norm):
        big = max(abs(c) for c in q)
        q = [c / big for c in q]
        norm = math.sqrt(sum(c * c for c in q))
    if norm < MIN_QUATERNION_NORM:
        return None
    return [c / norm for c in q]


def quaternion(name: str, value: Any) -> list[float]:
    """A quaternion [x, y, z, w] of norm >= MIN_QUATERNION_NORM, returned normalised."""
    q = unit_quaternion(vector(name, value, 4))
    if q is None:
        raise InvalidParams(
            f"{name} has zero norm (< {MIN_QUATERNION_NORM:g})",
            param=name,
            expected="quaternion [x,y,z,w] with a non-zero norm",
            got=value,
        )
    return q


def name(param: str, value: Any) -> str:
    if not isinstance(value, str) or not value or len(value) > MAX_NAME_LENGTH:
        raise InvalidParams(f"{param} must be a non-empty string of at most {MAX_NAME_LENGTH} characters",
                            param=param, expected="string", got=value)
    return value


def string_map(param: str, value: Any) -> dict[str, str]:
    if value is None:
        return {}
    if not isinstance(value, Mapping) or not all(
        isinstance(k, str) and isinstance(v, str) for k, v in value.items()
    ):
        raise InvalidParams(
            f"{param} must map names to folder paths", param=param, expected="object of strings", got=value
        )
    return dict(value)


def flag(param: str, value: Any) -> bool:
    if not isinstance(value, bool):
        raise InvalidParams(f"{param} must be true or false", param=param, expected="boolean", got=value)
    return value
