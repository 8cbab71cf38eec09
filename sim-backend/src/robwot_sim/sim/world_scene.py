"""World scene: static obstacles, scene documents and the scene of the current world."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from robwot_sim.errors import InvalidParams, MeshError, UnknownObject
from robwot_sim.meshcheck import check_mesh
from robwot_sim.scene import normalise_obstacle, read_scene, resolve_file
from robwot_sim.sim import validate as v
from robwot_sim.sim.client import quat_from_rpy
from robwot_sim.sim.world_base import Quat, Vec3, WorldBase, _locked


class WorldScene(WorldBase):
    """Obstacles and scenes on top of ``WorldBase``."""

    @_locked
    def load_scene(
        self, scene: dict[str, Any] | str | Path, package_roots: Mapping[str, str] | None = None
    ) -> dict[str, Any]:
        """Add a scene's obstacles and robots, all or nothing: ``{"robots": [id], "obstacles": [name]}``."""
        if not isinstance(scene, (dict, str, Path)):
            raise InvalidParams(
                "scene must be an object or a file path", param="scene", expected="object", got=scene
            )
        roots = v.string_map("packageRoots", package_roots)
        doc, base, _file = read_scene(scene)
        specs = [normalise_obstacle(o, base, checked=True) for o in doc.get("obstacles", [])]
        for s in specs:
            self._check_free_name(s["name"])
        added_obs: list[str] = []
        added_rob: list[str] = []
        try:
            for s in specs:
                added_obs.append(self._add_obstacle(s)["name"])
            for r in doc.get("robots", []):
                quat = r.get("baseOrientation") or (
                    quat_from_rpy(r["baseRpy"]) if "baseRpy" in r else (0.0, 0.0, 0.0, 1.0)
                )
                model = self.load_robot(
                    r["urdf"],
                    robot_id=r.get("id"),
                    base_position=r.get("basePosition", (0.0, 0.0, 0.0)),
                    base_orientation=quat,
                    ee_link=r.get("eeLink"),
                    package_roots={**roots, **r.get("packageRoots", {})},
                    srdf=resolve_file(r["srdf"], base, what="SRDF file") if "srdf" in r else None,
                    _base_dir=base,
                )
                added_rob.append(model.id)
                if "positions" in r:
                    self.set_joint_positions(model.id, r["positions"])
        except Exception:  # all or nothing: undo what this scene added
            for rid in added_rob:
                self.remove_robot(rid)
            for name in added_obs:
                self.remove_obstacle(name)
            raise
        return {"robots": added_rob, "obstacles": added_obs}

    def _add_obstacle(self, spec: dict[str, Any]) -> dict[str, Any]:
        self._check_free_name(spec["name"])
        shape = spec["shape"]
        if shape["type"] == "mesh":  # PyBullet crashes on some broken meshes: our parser reads it first
            try:
                shape = {**shape, "file": str(check_mesh(Path(shape["file"])))}
            except MeshError as e:
                name = spec["name"]
                raise MeshError(f"obstacle {name!r}: {e.message}", obstacle=name, **e.data) from None
        try:
            body = self.bullet.create_static(shape, spec["position"], spec["orientation"])
        except Exception as e:  # a mesh PyBullet cannot read
            raise InvalidParams(
                f"obstacle {spec['name']!r}: {e}", param="shape", expected="loadable shape", got=spec["shape"]
            ) from None
        self._obstacles[spec["name"]] = (body, spec)
        self.table.names[body] = spec["name"]
        self._changed()
        return spec

    @_locked
    def add_obstacle(self, spec: dict[str, Any]) -> dict[str, Any]:
        """Add a static obstacle ``{name, shape, position, orientation? | rpy?}``; returns it normalised."""
        return self._add_obstacle(normalise_obstacle(spec))

    @_locked
    def move_obstacle(
        self, name: str, position: Vec3, orientation: Quat | None = None, rpy: Vec3 | None = None
    ) -> dict[str, Any]:
        if name not in self._obstacles:
            raise UnknownObject(str(name), self._obstacles)
        pos = v.position("position", position)
        if orientation is not None and rpy is not None:
            raise InvalidParams(
                "give orientation or rpy, not both", param="rpy", expected="one of them", got=rpy
            )
        body, spec = self._obstacles[name]
        if orientation is not None:
            quat = v.quaternion("orientation", orientation)
        elif rpy is not None:
            quat = list(quat_from_rpy(v.position("rpy", rpy)))
        else:
            quat = list(spec["orientation"])
        self.bullet.reset_base(body, pos, quat)
        spec = {**spec, "position": pos, "orientation": quat}
        self._obstacles[name] = (body, spec)
        self._changed()
        return spec

    @_locked
    def remove_obstacle(self, name: str) -> None:
        if name not in self._obstacles:
            raise UnknownObject(str(name), self._obstacles)
        body, _ = self._obstacles.pop(name)
        self.bullet.remove_body(body)
        del self.table.names[body]
        self._changed()

    @_locked
    def list(self) -> dict[str, Any]:
        robots = [
            {
                "id": rid,
                "urdf": e.model.urdf,
                "basePosition": list(e.model.base_position),
                "baseOrientation": list(e.model.base_orientation),
                "eeLink": e.model.ee_link,
            }
            for rid, e in self._robots.items()
        ]
        return {"robots": robots, "obstacles": [spec for _, spec in self._obstacles.values()]}

    @_locked
    def reset(self) -> None:
        """Remove every robot and obstacle."""
        for rid in list(self._robots):
            self.remove_robot(rid)
        for name in list(self._obstacles):
            self.remove_obstacle(name)

    @_locked
    def scene_spec(self) -> dict[str, Any]:
        """The current world as a scene document (absolute paths); ``load_scene`` rebuilds it."""
        robots = []
        for rid, e in self._robots.items():
            r: dict[str, Any] = {
                "id": rid,
                "urdf": str(e.urdf_path),
                "basePosition": list(e.model.base_position),
                "baseOrientation": list(e.model.base_orientation),
                "eeLink": e.model.ee_link,
                "positions": [float(x) for x in e.bound.q],
            }
            if e.model.srdf:
                r["srdf"] = e.model.srdf
            if e.package_roots:
                r["packageRoots"] = {
                    k: str(Path(p).expanduser().resolve()) for k, p in e.package_roots.items()
                }
            robots.append(r)
        return {"version": 1, "obstacles": [spec for _, spec in self._obstacles.values()], "robots": robots}
