"""Shared helpers of the simulation-core tests (H1): model paths and an independent numpy FK."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np
import pybullet_data

from robwot_sim.rpc.contract import contract
from robwot_sim.rpc.methods_motion import program_steps
from robwot_sim.sim.program import ProgramStep

MODELS = Path(__file__).resolve().parent / "models"
SCENES = Path(__file__).resolve().parents[2] / "examples" / "scenes"
DATA = Path(pybullet_data.getDataPath())
KUKA = "kuka_iiwa/model.urdf"
PANDA = "franka_panda/panda.urdf"
XARM = "xarm/xarm6_robot.urdf"


def steps_of(steps: list[dict[str, Any]], dof: int) -> list[ProgramStep]:
    """Program steps as a `program.plan` request's are parsed: checked by the contract, its defaults
    filled in, each goal's rules checked."""
    values = contract().validate_params("program.plan", {"robot": "r", "steps": steps})
    return program_steps(values["steps"], dof)


def _rpy(r: float, p: float, y: float) -> np.ndarray:
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return rz @ ry @ rx


def _axis_angle(axis: np.ndarray, angle: float) -> np.ndarray:
    x, y, z = axis / np.linalg.norm(axis)
    k = np.array([[0, -z, y], [z, 0, -x], [-y, x, 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * (k @ k)


def _vec(s: str | None, default: str) -> np.ndarray:
    return np.array([float(v) for v in (s or default).split()])


def numpy_fk(urdf: Path, values: dict[str, float], link: str) -> np.ndarray:
    """4x4 pose of ``link``'s frame relative to the root link, computed from the URDF text alone
    (origin xyz/rpy, axis, joint type, mimic tags), independent of PyBullet and robwot_sim."""
    root = ET.parse(urdf).getroot()
    joints = {j.find("child").get("link"): j for j in root.findall("joint")}  # type: ignore[union-attr]
    by_name = {j.get("name"): j for j in root.findall("joint")}
    chain = []
    cur = link
    while cur in joints:
        chain.append(joints[cur])
        cur = joints[cur].find("parent").get("link")  # type: ignore[union-attr]
    t = np.eye(4)
    for j in reversed(chain):
        o = j.find("origin")
        xyz = _vec(o.get("xyz") if o is not None else None, "0 0 0")
        rpy = _vec(o.get("rpy") if o is not None else None, "0 0 0")
        step = np.eye(4)
        step[:3, :3] = _rpy(*rpy)
        step[:3, 3] = xyz
        jt = j.get("type")
        if jt != "fixed":
            a = j.find("axis")
            axis = _vec(a.get("xyz") if a is not None else None, "1 0 0")
            m = j.find("mimic")
            if m is not None:
                q = values[m.get("joint")] * float(m.get("multiplier", "1")) + float(m.get("offset", "0"))
            else:
                q = values[j.get("name")]
            motion = np.eye(4)
            if jt == "prismatic":
                motion[:3, 3] = axis / np.linalg.norm(axis) * q
            else:
                motion[:3, :3] = _axis_angle(axis, q)
            step = step @ motion
        t = t @ step
    assert by_name is not None
    return t


def quat_to_matrix(q: tuple[float, ...] | list[float]) -> np.ndarray:
    x, y, z, w = q
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )
