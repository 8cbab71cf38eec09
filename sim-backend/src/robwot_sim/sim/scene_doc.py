"""A world written as a scene document: what a rebuilt world (a labelling worker's, a restarted backend's)
loads to hold the same robots, obstacles and objects."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from robwot_sim.sim.planning_scene import Scene


def scene_spec(scene: Scene) -> dict[str, Any]:
    """The current scene as a scene document (absolute paths); ``load_scene`` rebuilds it (its objects
    as obstacles at their poses)."""
    robots = []
    for rid, e in scene.entries().items():
        r: dict[str, Any] = {
            "id": rid,
            "urdf": e.model.urdf,
            "basePosition": list(e.model.base_position),
            "baseOrientation": list(e.model.base_orientation),
            "eeLink": e.model.ee_link,
            "positions": [float(x) for x in e.bound.q],
        }
        if e.model.srdf:
            r["srdf"] = e.model.srdf
        added = [c.expression for c in e.model.couplings if c.source != "mimic"]
        if added:
            r["couplings"] = added  # the rules flattened: keep-level ones included
        if e.package_roots:
            r["packageRoots"] = {
                k: str(Path(p).expanduser().resolve()) for k, p in e.package_roots.items()
            }
        robots.append(r)
    # objects as obstacles where they rest now (a rebuilt world holds them there, settled already)
    obstacles = [{k: v for k, v in spec.items() if k != "mass"} for _, spec in scene.obstacle_bodies()]
    return {"version": 1, "obstacles": obstacles, "robots": robots}
