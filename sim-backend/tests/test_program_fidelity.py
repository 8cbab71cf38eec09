"""Programs against the independent exact-mesh reference (Pinocchio + Coal, ``robwot_bench.reference``)
with the scene's boxes added to it: on the UR5 as published for ROS (example-robot-data, with its SRDF)
carrying a 12 cm box tool, random programs of PTP (joints and poses) and LIN steps, some blended, are
validated by the twin, and every state a run of each valid one passes (the timed states, subdivided so no
point of the arm moves more than 2 mm between two checked ones) is checked by the reference: none may touch
an obstacle or the robot itself. The reference is first shown to catch a known positive (the tool inside a
box)."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from simhelp import steps_of

from robwot_bench.reference import ExactReference, example_robot
from robwot_sim.model.tool import attach_tool
from robwot_sim.sim.program import plan_program
from robwot_sim.sim.world import World

DT = 1 / 240
#: metres from the shoulder to the tool's tip, at most (UR5 0.85 m + the 12 cm tool): bounds how far a
#: point moves for a joint step
REACH = 1.0
#: metres any point may move between two states the reference checks
STEP = 0.002
BOXES = [([1.4, 1.4, 0.02], [0.0, 0.0, -0.06]),      # the table, 5 cm below the base
         ([0.15, 0.15, 0.3], [0.3, -0.4, 0.1]),
         ([0.1, 0.4, 0.1], [-0.3, -0.4, 0.35])]
PROGRAMS = 12


def _reference(urdf: str, roots: dict[str, str], joints: tuple[str, ...], srdf: object,
               boxes: list[tuple[list[float], list[float]]]) -> ExactReference:
    from pathlib import Path
    return ExactReference(Path(urdf), roots, joints, srdf if isinstance(srdf, Path) else None,
                          obstacles=[(size, pos, [0.0, 0.0, 0.0, 1.0]) for size, pos in boxes])


def _dense(states: np.ndarray) -> np.ndarray:
    """The states with enough linear subdivisions between neighbours that no point moves more than STEP."""
    out = [states[:1]]
    for a, b in itertools.pairwise(states):
        n = max(1, math.ceil(float(np.max(np.abs(b - a))) * REACH / STEP))
        out.append(a + np.arange(1, n + 1)[:, None] / n * (b - a))
    return np.concatenate(out)


@pytest.fixture(scope="module")
def ur5_with_tool(tmp_path_factory: pytest.TempPathFactory) -> object:
    r = example_robot("ur5")
    tool = attach_tool(r.urdf, r.package_roots, "tool0", [0, 0, 0.12, 0, 0, 0],
                       shape={"type": "box", "size": [0.05, 0.05, 0.12]})
    return r, tool


def test_every_state_of_every_valid_program_is_free_for_the_exact_reference(ur5_with_tool: object) -> None:
    r, tool = ur5_with_tool  # type: ignore[misc]
    rng = np.random.default_rng(5)
    runs: list[np.ndarray] = []
    with World() as world:
        model = world.load_robot(str(tool.urdf), package_roots=tool.package_roots, srdf=r.srdf,
                                 ee_link=tool.tcp_link)
        rid = model.id
        for k, (size, pos) in enumerate(BOXES):
            world.add_obstacle({"name": f"box{k}", "shape": {"type": "box", "size": size}, "position": pos})
        home = np.array([0.0, -1.57, 1.57, -1.57, -1.57, 0.0])
        lo, hi = model.limits()
        world.set_joint_positions(rid, home)
        p0 = np.asarray(world.fk(rid, home).position)
        blended = 0
        for _ in range(PROGRAMS):
            world.set_joint_positions(rid, home)
            steps = [
                {"motion": "lin", "position": (p0 + rng.uniform(-0.15, 0.15, 3)).tolist(), "tcpSpeed": 0.3,
                 "blend": 0.05},
                {"motion": "ptp", "position": (p0 + rng.uniform(-0.2, 0.2, 3)).tolist(), "blend": 0.05},
                {"motion": "lin", "position": (p0 + rng.uniform(-0.15, 0.15, 3)).tolist()},
                {"target": np.clip(home + rng.uniform(-0.8, 0.8, len(home)), lo, hi).tolist(), "speed": 0.8},
                {"target": home.tolist(), "acceleration": 0.5},
            ]
            program = plan_program(world, rid, steps_of(steps, model.dof), DT, 50.0)
            if program.path is not None:
                runs.append(program.path.rows())
                blended += sum(bool(s.get("blended")) for s in program.report["steps"])
        joints = model.controllable
        assert len(runs) >= PROGRAMS // 2, f"{len(runs)} of {PROGRAMS} programs valid: the test proves little"
        assert blended >= len(runs), f"only {blended} blended junctions in {len(runs)} valid programs"
        # a known positive first: a small box around the tool's tip at a state of a valid run
        mid = runs[0][len(runs[0]) // 2]
        tip = list(world.fk(rid, mid).position)
    catching = _reference(str(tool.urdf), tool.package_roots, joints, r.srdf, [([0.03, 0.03, 0.03], tip)])
    assert not catching.collision_free(mid[None, :])[0], "the reference misses the tool inside a box"
    reference = _reference(str(tool.urdf), tool.package_roots, joints, r.srdf, BOXES)
    assert reference.collision_free(home[None, :])[0]
    for run in runs:
        dense = _dense(run)
        free = reference.collision_free(dense)
        assert free.all(), f"the exact reference finds contact at {dense[~free][0].tolist()}"
