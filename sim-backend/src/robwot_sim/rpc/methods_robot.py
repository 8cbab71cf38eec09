"""`robot.*` methods except motion: load/remove/model/export, joints, FK, IK, collision check."""

from __future__ import annotations

from typing import Any

from robwot_sim.errors import Busy, NameTaken, UnknownRobot
from robwot_sim.model.decompose import MeshDone
from robwot_sim.model.robot_model import RobotModel
from robwot_sim.rpc.dispatch import Call, Dispatcher
from robwot_sim.rpc.params import Params
from robwot_sim.rpc.services import Services
from robwot_sim.sim.world import World
from robwot_sim.sim.world_thread import Kind


def robot_param(p: Params, s: Services) -> RobotModel:
    """The `robot` param, resolved to its model from the loop's record (UnknownRobot names the loaded
    ids); no world needed, so it never waits for one."""
    robot = str(p["robot"])
    model = s.robots.get(robot)
    if model is None:
        raise UnknownRobot(robot, list(s.robots))
    return model


def register(d: Dispatcher, s: Services) -> None:
    _register_lifecycle(d, s)
    _register_state(d, s)


def _register_lifecycle(d: Dispatcher, s: Services) -> None:
    """A robot's life in the world: load, remove, its model, its export."""

    @d.method("robot.load")
    async def load(p: Params, call: Call) -> dict[str, Any]:
        # both have defaults in the contract
        base_position, base_orientation = p.floats("basePosition"), p.quaternion("baseOrientation")
        assert base_position is not None and base_orientation is not None
        if p["id"] is not None and p["id"] in s.robots:
            raise NameTaken(p["id"])
        # off the world's thread: a robot's first load decomposes its concave meshes (minutes); the world
        # then only creates the body
        progress = s.threadsafe(call.notify)

        def mesh_done(m: MeshDone) -> None:
            progress("robot.loadProgress", {"mesh": m.mesh, "done": m.done, "total": m.total,
                                            "seconds": m.seconds, "parts": m.parts, "elapsed": m.elapsed,
                                            "eta": m.eta, "cache": m.cache})

        files = await s.off_world(lambda: World.read_robot(
            p["urdf"], robot_id=p["id"], ee_link=p["eeLink"], package_roots=p["packageRoots"],
            srdf=p["srdf"], decompose=bool(p["decompose"]), on_mesh=mesh_done,
            couplings=p["couplings"] or (), keep_level=p["keepLevel"] or ()), background=True)
        try:
            model = await s.change_world(lambda: s.world.add_robot(
                files, robot_id=p["id"], base_position=base_position, base_orientation=base_orientation,
                clearance=float(p["clearance"]), accelerations=dict(p["accelerationLimits"]),
                jerks=dict(p["jerkLimits"])), Kind.LONG)
        finally:
            files.cleanup()  # add_robot did, unless it never ran
        # what the load guessed or skipped (a package taken by its folder's name, SRDF entries of unknown
        # names): the result's only, robot.model does not repeat it
        return {**model.to_json(), "warnings": list(files.notes)}

    @d.method("robot.remove")
    async def remove(p: Params, call: Call) -> dict[str, Any]:
        model = robot_param(p, s)
        await s.motions.stop_and_wait([model.id])

        def run() -> None:
            if model.id in s.world.robot_ids():
                s.world.remove_robot(model.id)

        await s.change_world(run)
        return {}

    @d.method("robot.model")
    async def model(p: Params, call: Call) -> dict[str, Any]:
        return robot_param(p, s).to_json()

    @d.method("robot.export")
    async def export(p: Params, call: Call) -> dict[str, Any]:
        model = robot_param(p, s)
        write = await s.on_world(lambda: s.world.export_job(model.id, p["outDir"]), robot=model.id)
        return await s.off_world(write)  # copying files needs no world


def _register_state(d: Dispatcher, s: Services) -> None:
    """A robot's joints and what follows from them: read, set, FK, IK, collision check."""

    @d.method("robot.getJointPositions")
    async def get_joints(p: Params, call: Call) -> dict[str, Any]:
        model = robot_param(p, s)
        q = await s.on_world(lambda: s.world.get_joint_positions(model.id), robot=model.id)
        return {"names": list(model.controllable), "positions": [float(v) for v in q]}

    @d.method("robot.setJointPositions")
    async def set_joints(p: Params, call: Call) -> dict[str, Any]:
        model = robot_param(p, s)
        q = p.joint_vector("positions", model.dof)
        assert q is not None  # required by the contract
        if s.motions.is_moving(model.id):
            raise Busy(model.id)

        def run() -> Any:
            s.world.set_joint_positions(model.id, q)
            return s.world.get_joint_positions(model.id)

        now = await s.on_world(run, robot=model.id, writes=True)
        return {"names": list(model.controllable), "positions": [float(v) for v in now]}

    @d.method("robot.fk")
    async def fk(p: Params, call: Call) -> dict[str, Any]:
        model = robot_param(p, s)
        q = p.joint_vector("positions", model.dof)
        return (await s.on_world(lambda: s.world.fk(model.id, q), robot=model.id)).to_json()

    @d.method("robot.ik")
    async def ik(p: Params, call: Call) -> dict[str, Any]:
        model = robot_param(p, s)
        position = p.floats("position")
        assert position is not None  # required by the contract
        orientation, seed = p.quaternion("orientation"), p.joint_vector("seed", model.dof)
        collision_free = bool(p["collisionFree"])
        # a search (up to RESTARTS + 2 attempts): a long job, with checkpoints between attempts
        result = await s.on_world(lambda: s.world.ik(model.id, position, orientation, seed=seed,
                                                     collision_free=collision_free),
                                  Kind.LONG, robot=model.id)
        return result.to_json()

    @d.method("robot.checkCollision")
    async def check(p: Params, call: Call) -> dict[str, Any]:
        model = robot_param(p, s)
        q = p.joint_vector("positions", model.dof)
        return (await s.on_world(lambda: s.world.check_collision(model.id, q), robot=model.id)).to_json()
