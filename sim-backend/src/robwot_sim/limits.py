"""The backend contract's value ranges and defaults, read from the contract itself.

`schemas/protocol.openrpc.json` is the one place a boundary number lives (a speed, a clearance, a time
step, a coordinate, a name's length); parameter validation (`rpc/contract.py`) applies it to every
request, and the checks below the RPC layer read the same numbers from here rather than keeping copies.
This module sits at the bottom of the package: it imports nothing of ours.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from functools import cache
from importlib import resources
from typing import Any


@cache
def contract_document() -> dict[str, Any]:
    """The OpenRPC document (package data), parsed once."""
    text = resources.files("robwot_sim").joinpath("schemas/protocol.openrpc.json").read_text(encoding="utf-8")
    doc: dict[str, Any] = json.loads(text)
    return doc


def value_schema(name: str) -> dict[str, Any]:
    """The contract's component schema ``name`` (``Speed``, ``Clearance``, ...)."""
    schema: dict[str, Any] = contract_document()["components"]["schemas"][name]
    return schema


@dataclass(frozen=True)
class Range:
    """A closed range ``[minimum, maximum]`` with the default the contract gives (None: none)."""

    minimum: float
    maximum: float
    default: float | None

    @classmethod
    def of(cls, name: str) -> Range:
        s = value_schema(name)
        default = float(s["default"]) if "default" in s else None
        return cls(float(s["minimum"]), float(s["maximum"]), default)

    def __contains__(self, value: object) -> bool:
        number = isinstance(value, int | float) and not isinstance(value, bool)
        return number and self.minimum <= value <= self.maximum  # type: ignore[operator]


#: fraction of the URDF velocity limits a motion runs at, and the default
SPEED = Range.of("Speed")
DEFAULT_SPEED = float(value_schema("Speed")["default"])
#: fraction of the acceleration limits a motion runs at; seconds a joint without an acceleration limit takes
#: to reach its velocity limit from rest; the end effector's acceleration (m/s^2) along a LIN or CIRC
ACCELERATION = Range.of("Acceleration")
DEFAULT_ACCELERATION = float(value_schema("Acceleration")["default"])
ACCELERATION_TIME = float(value_schema("Acceleration")["x-accelerationTime"])
TCP_ACCELERATION = float(value_schema("Acceleration")["x-tcpAcceleration"])
#: the end effector's speed (m/s) along a LIN or CIRC, and the default
TCP_SPEED = Range.of("TcpSpeed")
DEFAULT_TCP_SPEED = float(value_schema("TcpSpeed")["default"])
#: time step (s) of an interpolated motion, and the default
DT = Range.of("Dt")
DEFAULT_DT = float(value_schema("Dt")["default"])
#: clearance (m) a robot's checked paths and motions keep to other bodies, and the one it keeps by default
CLEARANCE = Range.of("Clearance")
DEFAULT_CLEARANCE = float(value_schema("Clearance")["default"])
#: voxel side (m) of a reachability map
REACH_VOXEL = Range.of("ReachVoxel")
#: largest |coordinate| (m) of a position, and |angle| (rad) of an rpy triple
MAX_COORDINATE = float(value_schema("Position")["items"]["maximum"])
#: quaternions of a smaller norm count as zero (no orientation)
MIN_QUATERNION_NORM = float(value_schema("QuatXyzw")["x-minNorm"])
#: longest robot id or obstacle name
MAX_NAME_LENGTH = int(value_schema("Name")["maxLength"])
#: seconds a plan (robot.plan, a move's or a program's planning) may use the world's thread before it is
#: refused with E_PLAN_BUDGET
PLAN_BUDGET = float(contract_document()["components"]["errors"]["E_PLAN_BUDGET"]["x-budget"])
#: most samples of a program's trajectory (a longer program is sampled at a lower rate)
MAX_TRAJECTORY_SAMPLES = int(
    value_schema("ProgramPlan")["properties"]["trajectory"]["properties"]["positions"]["maxItems"])
#: most joints a joint_limits file may name: its velocities and accelerations both cross the contract
MAX_LIMITED_JOINTS = min(int(value_schema("JointVelocities")["maxProperties"]),
                         int(value_schema("JointAccelerations")["maxProperties"]))
#: most objects a world (and a scene file) holds
MAX_OBJECTS = int(value_schema("SceneObjects")["maxItems"])
#: an object's mass (kg) unless given
DEFAULT_MASS = float(value_schema("Mass")["default"])
#: most physics steps (1/240 s each) an added or moved object settles for
SETTLE_STEPS = int(value_schema("ObjectSpec")["x-settleSteps"])
#: deepest (m) an object may be placed into another body (settled bodies rest slightly inside their support)
OVERLAP_TOLERANCE = float(value_schema("ObjectSpec")["x-overlapTolerance"])
#: a conveyor belt's highest speed (m/s; above 0), and its speed unless given
MAX_BELT_SPEED = float(value_schema("BeltSpeed")["maximum"])
DEFAULT_BELT_SPEED = float(value_schema("ConveyorSpec")["properties"]["speed"]["default"])
#: how far (m) an object's bottom may be from a belt's top face for the belt to carry it
BELT_REST_TOLERANCE = float(value_schema("ConveyorSpec")["x-restTolerance"])
#: the farthest (m) a belt carries an object in one sub-step of ``cell.advance``
BELT_SUB_STEP = float(value_schema("ConveyorSpec")["x-subStep"])
#: the longest time step (s) of one ``cell.advance`` (above 0)
MAX_CELL_DT = float(value_schema("CellDt")["maximum"])
#: the colour (RGB 0-255) a colour sensor reads of an object without one
DEFAULT_SENSOR_COLOR = tuple(int(c) for c in value_schema("SensorSpec")["x-defaultColor"])
#: most conveyors and sensors a world (and a scene file) holds
MAX_CONVEYORS = int(value_schema("SceneConveyors")["maxItems"])
MAX_SENSORS = int(value_schema("SceneSensors")["maxItems"])
