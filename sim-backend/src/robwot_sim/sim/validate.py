"""Parameter checks shared by the world methods: they raise ``InvalidParams`` naming the parameter."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from robwot_sim.errors import InvalidParams


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


def quaternion(name: str, value: Any) -> list[float]:
    """A non-zero quaternion [x, y, z, w], returned normalised."""
    q = vector(name, value, 4)
    norm = math.sqrt(sum(v * v for v in q))
    if norm < 1e-9:
        raise InvalidParams(f"{name} has zero norm", param=name, expected="unit quaternion [x,y,z,w]", got=q)
    return [v / norm for v in q]


def name(param: str, value: Any) -> str:
    if not isinstance(value, str) or not value or len(value) > 200:
        raise InvalidParams(
            f"{param} must be a non-empty string (<= 200 chars)", param=param, expected="string", got=value
        )
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
