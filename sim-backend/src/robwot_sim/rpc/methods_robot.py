"""`robot.*` methods except motion: load/remove/model/export, joints, FK, IK, collision check."""

from __future__ import annotations

from typing import Any

from robwot_sim.errors import Busy
from robwot_sim.motion_runner import require_robot
from robwot_sim.rpc.dispatch import Call, Dispatcher
from robwot_sim.rpc.params import MISSING, Params
from robwot_sim.rpc.services import Services
from robwot_sim.sim.types import RobotModel


def robot_param(p: Params, s: Services) -> RobotModel:
    """The `robot` param, resolved to its model (UnknownRobot names the loaded ids)."""
    robot = p.string("robot")
    require_robot(s.world, robot)
    return s.world.robot_model(robot)


def joint_vector(p: Params, name: str, model: RobotModel, default: Any = None) -> Any:
    """A joint vector param: one finite number per controllable joint (rad or m); optional by default."""
    return p.vector(name, model.dof, default)


def register(d: Dispatcher, s: Services) -> None:
    @d.method("robot.load",
              ("urdf", "id", "basePosition", "baseOrientation", "eeLink", "packageRoots", "srdf"),
              "load a robot from a URDF file (and its SRDF's disabled collision pairs)")
    async def load(p: Params, call: Call) -> dict[str, Any]:
        urdf = p.string("urdf")
        robot_id = p.string("id", None)
        base_position = p.vector("basePosition", 3, [0.0, 0.0, 0.0])
        base_orientation = p.quaternion("baseOrientation", [0.0, 0.0, 0.0, 1.0])
        ee_link = p.string("eeLink", None)
        roots = p.string_map("packageRoots", None)
        srdf = p.string("srdf", None)
        model = s.world.load_robot(urdf, robot_id=robot_id, base_position=base_position,
                                   base_orientation=base_orientation, ee_link=ee_link, package_roots=roots,
                                   srdf=srdf)
        return model.to_json()

    @d.method("robot.remove", ("robot",), "remove a robot (stops its motion first)")
    async def remove(p: Params, call: Call) -> dict[str, Any]:
        model = robot_param(p, s)
        await s.motions.stop_and_wait([model.id])
        if model.id in s.world.robot_ids():
            s.world.remove_robot(model.id)
        return {}

    @d.method("robot.model", ("robot",), "the joint model")
    async def model(p: Params, call: Call) -> dict[str, Any]:
        return robot_param(p, s).to_json()

    @d.method("robot.export", ("robot", "outDir"), "write a self-contained URDF + meshes")
    async def export(p: Params, call: Call) -> dict[str, Any]:
        model = robot_param(p, s)
        return s.world.export_robot(model.id, p.string("outDir"))

    @d.method("robot.getJointPositions", ("robot",), "current joint vector")
    async def get_joints(p: Params, call: Call) -> dict[str, Any]:
        model = robot_param(p, s)
        q = s.world.get_joint_positions(model.id)
        return {"names": list(model.controllable), "positions": [float(v) for v in q]}

    @d.method("robot.setJointPositions", ("robot", "positions"), "teleport (limits checked)")
    async def set_joints(p: Params, call: Call) -> dict[str, Any]:
        model = robot_param(p, s)
        q = joint_vector(p, "positions", model, MISSING)
        if s.motions.is_moving(model.id):
            raise Busy(model.id)
        s.world.set_joint_positions(model.id, q)
        now = s.world.get_joint_positions(model.id)
        return {"names": list(model.controllable), "positions": [float(v) for v in now]}

    @d.method("robot.fk", ("robot", "positions"), "end-effector link frame pose")
    async def fk(p: Params, call: Call) -> dict[str, Any]:
        model = robot_param(p, s)
        q = joint_vector(p, "positions", model)
        return s.world.fk(model.id, q).to_json()

    @d.method("robot.ik", ("robot", "position", "orientation", "seed", "collisionFree"),
              "inverse kinematics for the end-effector link")
    async def ik(p: Params, call: Call) -> dict[str, Any]:
        model = robot_param(p, s)
        position = p.vector("position", 3)
        orientation = p.quaternion("orientation", None)
        seed = joint_vector(p, "seed", model)
        collision_free = p.boolean("collisionFree", True)
        return s.world.ik(model.id, position, orientation, seed=seed, collision_free=collision_free).to_json()

    @d.method("robot.checkCollision", ("robot", "positions"), "self + environment collision check")
    async def check(p: Params, call: Call) -> dict[str, Any]:
        model = robot_param(p, s)
        q = joint_vector(p, "positions", model)
        return s.world.check_collision(model.id, q).to_json()
