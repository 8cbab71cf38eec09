"""`robot.*` methods except motion: load/remove/model/export, joints, FK, IK, collision check."""

from __future__ import annotations

from typing import Any

from robwot_sim.errors import Busy
from robwot_sim.motion_runner import require_robot
from robwot_sim.rpc.dispatch import Call, Dispatcher
from robwot_sim.rpc.params import Params
from robwot_sim.rpc.services import Services
from robwot_sim.sim.types import RobotModel


def robot_param(p: Params, s: Services) -> RobotModel:
    """The `robot` param, resolved to its model (UnknownRobot names the loaded ids)."""
    robot = str(p["robot"])
    require_robot(s.world, robot)
    return s.world.robot_model(robot)


def register(d: Dispatcher, s: Services) -> None:
    @d.method("robot.load")
    async def load(p: Params, call: Call) -> dict[str, Any]:
        # both have defaults in the contract
        base_position, base_orientation = p.floats("basePosition"), p.quaternion("baseOrientation")
        assert base_position is not None and base_orientation is not None

        def run() -> RobotModel:
            return s.world.load_robot(p["urdf"], robot_id=p["id"], base_position=base_position,
                                      base_orientation=base_orientation, ee_link=p["eeLink"],
                                      package_roots=p["packageRoots"], srdf=p["srdf"],
                                      clearance=float(p["clearance"]), decompose=bool(p["decompose"]))

        # off the loop: a robot's first load decomposes its concave meshes (minutes), and the loop must
        # keep answering the heartbeat `ping` meanwhile (the world's lock keeps other calls out)
        return (await s.run_blocking(run)).to_json()

    @d.method("robot.remove")
    async def remove(p: Params, call: Call) -> dict[str, Any]:
        model = robot_param(p, s)
        await s.motions.stop_and_wait([model.id])
        if model.id in s.world.robot_ids():
            s.world.remove_robot(model.id)
        return {}

    @d.method("robot.model")
    async def model(p: Params, call: Call) -> dict[str, Any]:
        return robot_param(p, s).to_json()

    @d.method("robot.export")
    async def export(p: Params, call: Call) -> dict[str, Any]:
        model = robot_param(p, s)
        return s.world.export_robot(model.id, p["outDir"])

    @d.method("robot.getJointPositions")
    async def get_joints(p: Params, call: Call) -> dict[str, Any]:
        model = robot_param(p, s)
        q = s.world.get_joint_positions(model.id)
        return {"names": list(model.controllable), "positions": [float(v) for v in q]}

    @d.method("robot.setJointPositions")
    async def set_joints(p: Params, call: Call) -> dict[str, Any]:
        model = robot_param(p, s)
        q = p.joint_vector("positions", model.dof)
        assert q is not None  # required by the contract
        if s.motions.is_moving(model.id):
            raise Busy(model.id)
        s.world.set_joint_positions(model.id, q)
        now = s.world.get_joint_positions(model.id)
        return {"names": list(model.controllable), "positions": [float(v) for v in now]}

    @d.method("robot.fk")
    async def fk(p: Params, call: Call) -> dict[str, Any]:
        model = robot_param(p, s)
        return s.world.fk(model.id, p.joint_vector("positions", model.dof)).to_json()

    @d.method("robot.ik")
    async def ik(p: Params, call: Call) -> dict[str, Any]:
        model = robot_param(p, s)
        position = p.floats("position")
        assert position is not None  # required by the contract
        return s.world.ik(model.id, position, p.quaternion("orientation"),
                          seed=p.joint_vector("seed", model.dof),
                          collision_free=bool(p["collisionFree"])).to_json()

    @d.method("robot.checkCollision")
    async def check(p: Params, call: Call) -> dict[str, Any]:
        model = robot_param(p, s)
        return s.world.check_collision(model.id, p.joint_vector("positions", model.dof)).to_json()
