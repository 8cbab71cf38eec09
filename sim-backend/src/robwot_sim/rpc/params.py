"""One request's params after the contract has checked them (`contract.py`): typed access with the
contract's defaults, plus the two checks a schema cannot state — a joint vector's length is the robot's
number of controllable joints, and a quaternion needs a non-zero norm."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from robwot_sim.rpc.contract import invalid_param
from robwot_sim.rpc.protocol import Fault
from robwot_sim.validate import MIN_QUATERNION_NORM, unit_quaternion


class Params:
    """Validated params by name; absent ones read as the contract's default (or None). ``where`` names
    the object they belong to in errors (``steps[2].``: a program's step)."""

    def __init__(self, values: Mapping[str, Any], defaults: Mapping[str, Any] | None = None,
                 where: str = "") -> None:
        self.raw = dict(values)
        self._defaults = dict(defaults or {})
        self.where = where

    def invalid(self, name: str, expected: str, *, missing: bool = False) -> Fault:
        """`E_INVALID_PARAMS` for param ``name`` (what was received, or missing)."""
        return invalid_param(self.where + name, expected, self.raw.get(name), missing=missing)

    def has(self, name: str) -> bool:
        return name in self.raw

    def __getitem__(self, name: str) -> Any:
        return self.raw.get(name, self._defaults.get(name))

    def floats(self, name: str) -> list[float] | None:
        """An array of numbers as floats (None when absent without default)."""
        value = self[name]
        return None if value is None else [float(v) for v in value]

    def joint_vector(self, name: str, dof: int) -> list[float] | None:
        """A joint vector with exactly one value per controllable joint (None when absent)."""
        value = self.floats(name)
        if value is not None and len(value) != dof:
            raise self.invalid(name, f"an array of {dof} finite numbers (one per controllable joint)")
        return value

    def quaternion(self, name: str) -> list[float] | None:
        """`[x, y, z, w]` of norm >= MIN_QUATERNION_NORM, normalised (None when absent)."""
        value = self.floats(name)
        if value is None:
            return None
        quat = unit_quaternion(value)
        if quat is None:
            raise self.invalid(name, f"a quaternion [x, y, z, w] of norm >= {MIN_QUATERNION_NORM:g}")
        return quat
