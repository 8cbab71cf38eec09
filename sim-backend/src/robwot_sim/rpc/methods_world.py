"""`ping`, `world.*` methods."""

from __future__ import annotations

from typing import Any

import pybullet_data

from robwot_sim import __version__
from robwot_sim.rpc.contract import invalid_param
from robwot_sim.rpc.dispatch import Call, Dispatcher
from robwot_sim.rpc.params import Params
from robwot_sim.rpc.services import Services
from robwot_sim.sim.client import pybullet_version
from robwot_sim.sim.world import World
from robwot_sim.sim.world_thread import Kind


def register(d: Dispatcher, s: Services) -> None:
    @d.method("ping")
    async def ping(p: Params, call: Call) -> dict[str, Any]:
        return {"version": __version__, "pybullet": pybullet_version(),
                "pybulletData": pybullet_data.getDataPath()}

    @d.method("world.reset")
    async def reset(p: Params, call: Call) -> dict[str, Any]:
        await s.motions.stop_and_wait()
        await s.change_world(s.world.reset)
        return {}

    @d.method("world.list")
    async def list_(p: Params, call: Call) -> dict[str, Any]:
        return await s.on_world(s.world.list)

    @d.method("world.loadScene")
    async def load_scene(p: Params, call: Call) -> dict[str, Any]:
        if p.has("path") == p.has("scene"):
            raise invalid_param("path", "exactly one of 'path' (string) or 'scene' (object)",
                                p["path"], missing=not p.has("path"))
        source: dict[str, Any] | str = p["path"] if p.has("path") else p["scene"]
        # read off the world's thread like robot.load (a scene's robots may need their meshes decomposed,
        # its mesh obstacles parsing); the world then only creates the bodies
        files = await s.off_world(lambda: World.read_scene(source, package_roots=p["packageRoots"],
                                                           decompose=bool(p["decompose"])),
                                  background=True)
        try:
            return await s.change_world(lambda: s.world.add_scene(files), Kind.LONG)
        finally:
            files.cleanup()
