"""The cell around the robots: conveyor belts carrying objects (``conveyors.py``), presence and colour
sensors watching them (``sensors.py``) and the cell's simulated time, on a planning scene
(``planning_scene.Scene``), whose objects they move.

A conveyor's belt is a static obstacle of the scene named as the conveyor (a scene document's conveyors
are read as obstacles, ``scene_files.read_scene``, so every world rebuilt from a document has them); the
world's listings show it as a conveyor, not among the obstacles. Removing that obstacle removes the
conveyor; moving it moves the conveyor. Sensor names are unique among sensors.

``advance(dt)`` runs the cell for ``dt`` s in sub-steps (a running belt moves an object at most
``BELT_SUB_STEP`` m per sub-step): each sub-step the running belts, by name, carry the objects resting on
them (each object by one belt at most), an object carried clear of a belt's end without end stop is let fall
(settled as ``Scene.move_object`` settles it: onto what is below, or the floor), and then every sensor is
read; a sensor's presence rising or falling is an event. Objects moved are put at their new poses in the
scene at once (a version bump, as any move), so every check sees them. Objects held by a gripper are not the
scene's objects while held: the cell neither sees nor moves them.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from robwot_sim.errors import InvalidParams, NameTaken, SimError, UnknownConveyor
from robwot_sim.limits import BELT_SUB_STEP, MAX_CELL_DT, MAX_CONVEYORS, MAX_SENSORS
from robwot_sim.sim.bounds import Body
from robwot_sim.sim.conveyors import Belt, Conveyor, carry, running_belts
from robwot_sim.sim.planning_scene import Scene
from robwot_sim.sim.scene_files import SceneFiles, read_scene
from robwot_sim.sim.sensors import Sensor
from robwot_sim.sim.settle import Placed


class Cell:
    """The conveyors and sensors of one scene, and the cell's time (s)."""

    def __init__(self, scene: Scene) -> None:
        self.scene = scene
        self._conveyors: dict[str, Conveyor] = {}
        self._sensors: dict[str, Sensor] = {}
        self._seen: dict[str, str | None] = {}  # per sensor: the object it read at the last advance
        self.time = 0.0
        #: the objects robots hold, with their colours (``Grippers.held_bodies``): sensors see them too
        self.held: Callable[[], list[tuple[Body, Sequence[float] | None]]] = list

    # the world's scene documents and listings, with the cell's parts
    def load_scene(self, scene: dict[str, Any] | str | Path,
                   package_roots: Mapping[str, str] | None = None) -> dict[str, Any]:
        """``Scene.load_scene`` with the document's conveyors and sensors."""
        return self.add_scene(read_scene(scene, package_roots))

    def add_scene(self, files: SceneFiles) -> dict[str, Any]:
        """``Scene.add_scene`` (all or nothing; the conveyors' belts among its obstacles), then its conveyors
        and sensors; a sensor named as one the cell holds: ``NameTaken``, nothing added."""
        try:
            self._check_room(files)
        except Exception:
            files.cleanup()
            raise
        loaded = self.scene.add_scene(files)
        self._conveyors.update((c.name, c) for c in files.conveyors)
        bodies = self._bodies()
        for sensor in files.sensors:
            self._sensors[sensor.name] = sensor
            self._seen[sensor.name] = sensor.reading(bodies, {})["object"]
        return {**loaded, "obstacles": [n for n in loaded["obstacles"] if n not in self._conveyors],
                "conveyors": [c.name for c in files.conveyors], "sensors": [s.name for s in files.sensors]}

    def _check_room(self, files: SceneFiles) -> None:
        """A document's sensors named as none the cell holds, its conveyors and sensors within the world's
        limits."""
        for sensor in files.sensors:
            if sensor.name in self._sensors:
                raise NameTaken(sensor.name)
        counts = (("conveyors", len(self._conveyors), len(files.conveyors), MAX_CONVEYORS),
                  ("sensors", len(self._sensors), len(files.sensors), MAX_SENSORS))
        for kind, have, more, most in counts:
            if have + more > most:
                raise InvalidParams(
                    f"a world holds at most {most} {kind}: it holds {have}, {more} more asked for",
                    param=kind, expected=f"at most {most} {kind}", got=have + more)

    def listed(self, listed: dict[str, Any]) -> dict[str, Any]:
        """A world listing (``Scene.list``) with the conveyors (their belts out of the obstacles) and
        sensors."""
        belts = self._belts(listed["obstacles"])
        return {**listed, "obstacles": [o for o in listed["obstacles"] if o["name"] not in belts],
                **self._parts(belts)}

    def documented(self, doc: dict[str, Any]) -> dict[str, Any]:
        """A scene document of the world (``scene_doc.scene_spec``) with its conveyors (their state now)
        and sensors: the conveyors' belts out of its obstacles."""
        belts = self._belts(doc["obstacles"])
        return {**doc, "obstacles": [o for o in doc["obstacles"] if o["name"] not in belts],
                "conveyors": [self._conveyors[n].to_json(belt) for n, belt in belts.items()],
                "sensors": [s.to_json() for s in self._sensors.values()]}

    def clear(self) -> None:
        """No conveyor, no sensor, the time 0 (the scene reset)."""
        self._conveyors.clear()
        self._sensors.clear()
        self._seen.clear()
        self.time = 0.0

    def remove_obstacle(self, name: str) -> None:
        """``Scene.remove_obstacle``; a conveyor's belt: the conveyor goes with it."""
        self.scene.remove_obstacle(name)
        self._conveyors.pop(name, None)

    # the cell's own methods
    def set_conveyor(self, name: str, state: str, speed: float | None = None) -> dict[str, Any]:
        """Run conveyor ``name`` ``forward`` / ``backward`` or stop it, at ``speed`` (m/s; None: as it is);
        idempotent (``changed``: whether its state or speed changed). Checked first: a refusal changes
        nothing."""
        belts = self._belts(self.scene.list()["obstacles"])
        if name not in belts:
            raise UnknownConveyor(str(name), belts)
        changed = self._conveyors[name].set(state, speed)
        return {"conveyor": self._conveyors[name].to_json(belts[name]), "changed": changed}

    def listing(self) -> dict[str, Any]:
        """``cell.list``: the conveyors, the sensors with their readings now, and the cell's time (s)."""
        return {"time": self.time, **self._parts(self._belts(self.scene.list()["obstacles"]))}

    def advance(self, dt: float) -> dict[str, Any]:
        """Run the cell for ``dt`` s, in (0, ``MAX_CELL_DT``] (module docstring): the objects moved (where
        they are now), the events in time order, the sensors' readings and the cell's time after it."""
        number = isinstance(dt, int | float) and not isinstance(dt, bool)
        if not number or not 0.0 < dt <= MAX_CELL_DT:
            raise InvalidParams(f"dt must be in (0, {MAX_CELL_DT:g}] s", param="dt",
                                expected=f"number in (0, {MAX_CELL_DT:g}]", got=dt)
        obstacles = self.scene.list()["obstacles"]
        belts = running_belts({n: self._conveyors[n] for n in self._belts(obstacles)}, obstacles)
        fastest = max((self._conveyors[n].speed for n in belts), default=0.0)
        steps = max(1, math.ceil(fastest * dt / BELT_SUB_STEP - 1e-9))
        start, events, moved = self.time, list[dict[str, Any]](), set[str]()
        bodies = {b.name: b for b in self._bodies()}
        for k in range(1, steps + 1):
            self.time = start + dt * k / steps
            now: set[str] = set()  # moved by one belt: not carried by another in the same sub-step
            for name, belt in belts.items():
                now |= self._carry(self._conveyors[name], belt, bodies, now, dt / steps, events)
            moved |= now
            events += self._edges(self._sensed(bodies))
        self.time = start + dt
        objects = {o["name"]: o for o in self.scene.list()["objects"]}
        return {"time": self.time, "moved": [objects[n] for n in sorted(moved) if n in objects],
                "events": events, "sensors": self._readings(self._sensed(bodies))}

    # steps
    def _carry(self, conveyor: Conveyor, belt: Belt, bodies: dict[str, Body], moved: set[str], step: float,
               events: list[dict[str, Any]]) -> set[str]:
        """One sub-step of one belt over ``bodies`` but those ``moved`` already: the bodies it moved put in
        the scene (and in ``bodies``), those carried off its end let fall; the names of the objects moved."""
        free = [b for name, b in bodies.items() if name not in moved]
        done = carry(conveyor, belt, free, conveyor.speed * step)
        for name, body in done.moved.items():
            self.scene.carry_object(name, body.placed.position)
            bodies[name] = body
        at = {"conveyor": conveyor.name, "time": self.time}
        events += [{"type": "atEnd", "object": name, **at} for name in done.arrived]
        for name in done.off:
            try:
                rest = self.scene.move_object(name, bodies[name].placed.position)
            except SimError as e:  # it would rest touching a robot: it stays where it left the belt
                events.append({"type": "stuck", "object": name, **at, "reason": e.message})
                continue
            bodies[name] = self._body(rest)
            events.append({"type": "fell", "object": name, **at, "position": list(rest["position"])})
        return set(done.moved)

    def _edges(self, bodies: list[Body]) -> list[dict[str, Any]]:
        """The sensors read now against what they read last: presence rising or falling."""
        events = []
        for reading in self._readings(bodies):
            name, now = reading["name"], reading["object"]
            before = self._seen.get(name)
            if before is None and now is not None:
                events.append({"type": "detectedObject", "sensor": name, "object": now, "time": self.time})
            elif before is not None and now is None:
                events.append({"type": "objectLeft", "sensor": name, "object": before, "time": self.time})
            self._seen[name] = now
        return events

    def _sensed(self, bodies: dict[str, Body]) -> list[Body]:
        """What the sensors see: the objects at rest and those robots hold."""
        return [*bodies.values(), *(body for body, _ in self.held())]

    def _readings(self, bodies: list[Body]) -> list[dict[str, Any]]:
        colors = {o["name"]: o["color"] for o in self.scene.list()["objects"] if "color" in o}
        colors.update({body.name: color for body, color in self.held() if color is not None})
        return [s.reading(bodies, colors) for s in self._sensors.values()]

    def _parts(self, belts: dict[str, dict[str, Any]]) -> dict[str, Any]:
        """The conveyors and the sensors with their readings now, as listed."""
        resting = {b.name: b for b in self._bodies()} if self._sensors else {}
        readings = self._readings(self._sensed(resting)) if self._sensors else []
        return {"conveyors": [self._conveyors[n].to_json(belt) for n, belt in belts.items()],
                "sensors": [{**s.to_json(), "reading": r}
                            for s, r in zip(self._sensors.values(), readings, strict=True)]}

    def _belts(self, obstacles: list[dict[str, Any]]) -> dict[str, dict[str, Any]]:
        """The conveyors' belts (scene obstacle specs) by conveyor name, in the conveyors' order; conveyors
        whose belt is gone (removed through the scene) dropped."""
        specs = {o["name"]: o for o in obstacles}
        for name in [n for n in self._conveyors if n not in specs]:
            del self._conveyors[name]
        return {name: specs[name] for name in self._conveyors}

    def _bodies(self) -> list[Body]:
        """The scene's objects (at rest, not held) as the cell measures them."""
        return self._measured(self.scene.list()["objects"])

    def _body(self, spec: dict[str, Any]) -> Body:
        return self._measured([spec])[0]

    def _measured(self, specs: list[dict[str, Any]]) -> list[Body]:
        """Objects (their specs) with the shapes their bodies were built from, and PyBullet's box of a mesh
        whose points we do not hold."""
        shapes = {s["name"]: s["shape"] for s in self.scene.built_specs()}
        ids = {s["name"]: body for body, s in self.scene.obstacle_bodies()}
        out = []
        for spec in specs:
            shape = shapes.get(spec["name"], spec["shape"])
            box = self.scene.bullet.aabb(ids[spec["name"]]) if shape["type"] == "mesh" else None
            placed = Placed(shape, spec["position"], spec["orientation"], spec.get("mass", 0.0))
            out.append(Body(spec["name"], placed, box))
        return out
