"""A gripper on a robot and the object it holds (MoveIt's attached collision object).

A gripper is declared per robot (``Grippers.configure``): parallel ``fingers`` driven by finger joints
(controllable joints off the end effector's chain whose parent link is on it; their mimic partners
follow), or a ``suction`` cup at the TCP. Its joints are pinned (``BoundRobot.pinned``): moves, IK, searches
and draws keep them; only ``close`` and ``open`` move them. A gripper starts open.

Closing catches the object nearest the TCP (the end-effector link's frame) within ``capture`` m of it: the
TCP inside the object or that close to its surface. Fingers close until they touch it (fully, on nothing).
The object then becomes part of the robot: the robot's body is rebuilt with the object as a fixed link on
the end effector, named as the object (``model/held.py``), so every check (moves, validation, planning,
LIN/CIRC, programs, the mirror worlds, the sure hits) sees it, against everything but the hand: the link
the gripper is mounted on and every link below it (pairs filtered, as an SRDF's ``disable_collisions``;
pairs with it are never taken for always-colliding ones). The body is built from the URDF as PyBullet
loaded the robot (no mesh read, checked or split again) and keeps the robot's filtered pairs (nothing
sampled); the mirror worlds read a portable copy of its URDF with the link. Opening rebuilds the robot
without it and lets it go where it is: it settles onto what is below it (``settle.py``), allowed to rest
touching the robot that let it go (the robot leaves such a contact as any other, ``exit_contact.py``).
"""

from __future__ import annotations

import contextlib
import shutil
import tempfile
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import pybullet as pb

from robwot_sim.errors import InvalidParams
from robwot_sim.model.couplings import chain_to
from robwot_sim.model.held import HeldUrdf, held_urdf
from robwot_sim.model.joints import MOVABLE, UrdfModel, parse_model
from robwot_sim.model.urdf import PreparedUrdf, parse_urdf
from robwot_sim.sim.bounds import Body
from robwot_sim.sim.loader import RobotEntry, RobotFiles
from robwot_sim.sim.planning_scene import Scene
from robwot_sim.sim.scene_files import ReadObstacle
from robwot_sim.sim.settle import Placed
from robwot_sim.sim.types import Pose

#: how far (m) a holding robot's own body is parked from its base (``Grippers._hold_body``)
PARK = (1000.0, 1000.0, -1000.0)
#: radius (m) of the probe ``object_at`` measures from
PROBE_RADIUS = 1e-4
#: steps a closing finger takes from open to closed, stopping at the first that touches the object
CLOSE_STEPS = 50
KINDS = ("fingers", "suction")


@dataclass(frozen=True)
class Gripper:
    """A robot's gripper: its kind, finger joints with their open and closed values, the time (s) opening
    or closing takes, and how far (m) from the TCP an object is caught."""

    kind: str
    joints: tuple[str, ...]
    open: tuple[float, ...]
    closed: tuple[float, ...]
    time: float
    capture: float

    def as_json(self) -> dict[str, Any]:
        return {"kind": self.kind, "joints": list(self.joints), "open": list(self.open),
                "closed": list(self.closed), "time": self.time, "capture": self.capture}


@dataclass
class Held:
    """An object a robot holds: its spec and shape as it was caught, its pose in the end-effector frame,
    the robot's own URDF (without it), the temporary folder of the URDF with it (``written``,
    ``model/held.py``) and the robot's link pairs never checked while it holds it (the object and the
    hand)."""

    name: str
    read: ReadObstacle
    offset: tuple[Sequence[float], Sequence[float]]
    urdf: Path
    folder: Path
    written: HeldUrdf
    pairs: frozenset[tuple[str, str]]

    def files(self, own: RobotEntry) -> RobotFiles:
        """The files of robot ``own`` (its own body) with the object, from what its body knows: no file of
        the robot read again. PyBullet loads its URDF as it loaded it with the object's link added; its
        model is the portable copy's (which the mirror worlds read); its filtered pairs carry over as the
        always-colliding ones (nothing sampled), the object's pairs with the hand added, the object's other
        pairs checked."""
        m, w = own.model, self.written
        doc = parse_urdf(w.urdf)
        model = parse_model(doc).coupled([c.expression for c in m.couplings if c.source != "mimic"])
        tmp = Path(tempfile.mkdtemp(prefix="robwot-urdf-", dir=self.folder))  # removed once loaded
        prepared = PreparedUrdf(doc, w.add_to(own.loaded_urdf, tmp / "robot.urdf"), {}, str(tmp),
                                own.collision_parts)
        srdf = Path(m.srdf) if m.srdf else None
        return RobotFiles(w.urdf, doc, model, m.ee_link, srdf, self.pairs, prepared, w.package_roots,
                          always_checked=frozenset({w.link}), always_colliding=frozenset(m.filtered_pairs))


def object_at(scene: Scene, position: Sequence[float], within: float) -> str | None:
    """The object nearest ``position`` (m, world) among those within ``within`` m of it (inside one:
    distance below 0), or None."""
    bullet = scene.bullet
    probe = bullet.create_body({"type": "sphere", "radius": PROBE_RADIUS}, position, (0, 0, 0, 1), 0.0)
    try:
        near = [(min(c.distance for c in points), name) for name, body in scene.object_bodies().items()
                if (points := bullet.closest(probe, body, within))]
    finally:
        bullet.remove_body(probe)
    return min(near)[1] if near else None


def touches(scene: Scene, robot_id: str, name: str) -> bool:
    """Some link of the robot touches object ``name``."""
    body = scene.object_bodies()[name]
    return any(c.distance <= 0.0 for c in scene.bullet.closest(scene.entry(robot_id).bound.body, body, 0.0))


def finger_joints(model: UrdfModel, ee: str) -> list[str]:
    """The controllable joints off the end effector's chain whose parent link is on it (or is it)."""
    chain = chain_to(ee, model.joints)
    on_chain = {ee, *(j.parent for j in chain), *(j.child for j in chain)}
    chain_joints = {j.name for j in chain}
    types = {j.name: j for j in model.joints}
    return [n for n in model.controllable
            if n not in chain_joints and types[n].type in MOVABLE and types[n].parent in on_chain]


def hand_links(model: UrdfModel, ee: str, mount: str) -> set[str]:
    """``mount`` and every link below it, with the end effector and the links below it."""
    children: dict[str, list[str]] = {}
    for j in model.joints:
        children.setdefault(j.parent, []).append(j.child)
    out: set[str] = set()
    todo = [mount, ee]
    while todo:
        link = todo.pop()
        if link not in out:
            out.add(link)
            todo.extend(children.get(link, ()))
    return out


class Grippers:
    """The grippers of a scene's robots and what each holds."""

    def __init__(self, scene: Scene) -> None:
        self._scene = scene
        self._grippers: dict[str, Gripper] = {}
        self._state: dict[str, str] = {}  # "open" | "closed"
        self._held: dict[str, Held] = {}
        self._own: dict[str, RobotEntry] = {}  # a holding robot's own body, parked (``_hold_body``)
        self._trying = False  # within ``trial``: a held object's files stay for the trial's end

    @contextlib.contextmanager
    def trial(self, robot_id: str) -> Iterator[None]:
        """Within: ``close`` and ``open`` of ``robot_id``'s gripper change the world as they would (a program
        planned across its grip steps); at the end the world is as before: what the robot held, its body,
        its gripper's state and pins, every object where it was (put back, not settled again)."""
        scene = self._scene
        held, state = self._held.get(robot_id), self._state.get(robot_id)
        pins, q = dict(scene.entry(robot_id).bound.pinned), scene.entry(robot_id).bound.q.copy()
        objects = {name: scene.object_read(name) for name in scene.object_bodies()}
        self._trying = True
        try:
            yield
        finally:
            self._trying = False
            self._undo(robot_id, held, objects)
            if state is not None:
                self._state[robot_id] = state
            scene.entry(robot_id).bound.pinned = pins
            scene.entry(robot_id).bound.apply(q)

    def _undo(self, robot_id: str, held: Held | None, objects: dict[str, ReadObstacle]) -> None:
        """``trial``'s end: the robot holding ``held`` again (or nothing), the objects as ``objects``."""
        scene, now = self._scene, self._held.get(robot_id)
        if now is not held:
            if now is not None:
                self._own_body(robot_id)
                del self._held[robot_id]
                shutil.rmtree(now.folder, ignore_errors=True)
            if held is not None:
                if held.name in scene.object_bodies():
                    scene.remove_object(held.name)
                self._hold_body(robot_id, held.files(scene.entry(robot_id)), held.urdf)
                self._held[robot_id] = held
        for name in scene.object_bodies():
            if name not in objects or scene.object_read(name)[0] != objects[name][0]:
                scene.remove_object(name)
        for name, read in objects.items():
            if name not in scene.object_bodies():
                scene.return_object(read, None, settle=False)

    def close_all(self) -> None:
        """Every gripper forgotten (the world reset or closed)."""
        for robot_id in [*self._grippers]:
            self.forget(robot_id)

    def forget(self, robot_id: str) -> None:
        """A robot removed: its gripper, what it held and its parked body go with it."""
        held = self._held.pop(robot_id, None)
        if held is not None:
            shutil.rmtree(held.folder, ignore_errors=True)
        own = self._own.pop(robot_id, None)
        if own is not None:
            self._scene.bullet.remove_body(own.bound.body)
        self._grippers.pop(robot_id, None)
        self._state.pop(robot_id, None)

    def _gripper(self, robot_id: str) -> Gripper:
        self._scene.entry(robot_id)
        if robot_id not in self._grippers:
            raise InvalidParams(f"robot {robot_id!r} has no gripper (declare one: generate --gripper)",
                                param="robotId", expected="a robot with a gripper", got=robot_id)
        return self._grippers[robot_id]

    # declaring
    def configure(self, robot_id: str, kind: str, joints: Sequence[str] | None = None, time: float = 0.5,
                  capture: float = 0.01) -> dict[str, Any]:
        """Declare ``robot_id``'s gripper and open it. ``joints``: the finger joints (fingers; default all
        found, ``finger_joints``). Refused while it holds an object."""
        e = self._scene.entry(robot_id)
        if robot_id in self._held:
            raise InvalidParams(f"robot {robot_id!r} holds {self._held[robot_id].name!r}: open the gripper "
                                "first", param="robotId", expected="an empty gripper", got=robot_id)
        if kind not in KINDS:
            raise InvalidParams(f"gripper kind must be one of {', '.join(KINDS)}", param="kind",
                                expected=list(KINDS), got=kind)
        names: list[str] = []
        if kind == "fingers":
            found = finger_joints(e.bound.urdf, e.model.ee_link)
            names = list(joints) if joints else found
            unknown = [n for n in names if n not in found]
            if not names or unknown:
                raise InvalidParams(
                    f"robot {robot_id!r} has no finger joint"
                    f"{' ' + ', '.join(map(repr, unknown)) if unknown else 's'}"
                    f" (finger joints: controllable joints off the chain to {e.model.ee_link!r} whose parent "
                    f"link is on it: {', '.join(found) or 'none'}); a suction cup needs none",
                    param="joints", expected=found, got=list(joints or []))
        opened, closed = self._finger_ends(robot_id, names)
        e.bound.pinned.clear()
        self._grippers[robot_id] = Gripper(kind, tuple(names), opened, closed, float(time), float(capture))
        self._set_fingers(robot_id, opened)
        self._state[robot_id] = "open"
        return self.state(robot_id)

    def _finger_ends(self, robot_id: str,
                     names: Sequence[str]) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """Each finger joint's open and closed value: of its two limits, the one at which the links it moves
        (with its mimic partners) lie farther apart is open."""
        b = self._scene.entry(robot_id).bound
        saved = b.q.copy()
        opened, closed = [], []
        try:
            for name in names:
                k = b.ctrl_names.index(name)
                spread = []
                for value in (b.lower[k], b.upper[k]):
                    q = saved.copy()
                    q[k] = value
                    b.apply(q)
                    points = np.array([b.bullet.link_frame(b.body, i)[0] for i in b.moving_links])
                    spread.append(float(np.ptp(points, axis=0).sum()) if len(points) else 0.0)
                lo, hi = float(b.lower[k]), float(b.upper[k])
                opened.append(hi if spread[1] > spread[0] else lo)
                closed.append(lo if spread[1] > spread[0] else hi)
        finally:
            b.apply(saved)
        return tuple(opened), tuple(closed)

    def _set_fingers(self, robot_id: str, values: Sequence[float]) -> None:
        """The finger joints teleported to ``values`` and pinned there."""
        g = self._grippers[robot_id]
        b = self._scene.entry(robot_id).bound
        q = b.q.copy()
        for name, value in zip(g.joints, values, strict=True):
            k = b.ctrl_names.index(name)
            q[k] = value
            b.pinned[k] = float(value)
        self._scene.set_joint_positions(robot_id, q)

    # reading
    def state(self, robot_id: str) -> dict[str, Any]:
        g = self._gripper(robot_id)
        held = self._held.get(robot_id)
        return {"robotId": robot_id, "state": self._state[robot_id], "holding": held.name if held else None,
                "gripper": g.as_json()}

    def held_objects(self) -> list[dict[str, Any]]:
        """The held objects' specs where they are now, each with ``heldBy``."""
        out = []
        for rid, held in self._held.items():
            pose = self._held_pose(rid)
            out.append({**held.read[0], "position": list(pose.position), "orientation": list(pose.quat_xyzw),
                        "heldBy": rid})
        return out

    def held_bodies(self) -> list[tuple[Body, Sequence[float] | None]]:
        """The held objects as the cell's sensors measure them (their shapes as built, where they are now,
        PyBullet's box of the link), with their colours."""
        out: list[tuple[Body, Sequence[float] | None]] = []
        for rid, held in self._held.items():
            pose, (spec, built) = self._held_pose(rid), held.read
            b = self._scene.entry(rid).bound
            box = b.bullet.aabb(b.body, b.link_index[held.written.link])
            placed = Placed(built, pose.position, pose.quat_xyzw, spec.get("mass", 0.0))
            out.append((Body(held.name, placed, box), spec.get("color")))
        return out

    def _held_pose(self, robot_id: str) -> Pose:
        held = self._held[robot_id]
        ee = self._scene.fk(robot_id)
        pos, quat = pb.multiplyTransforms(ee.position, ee.quat_xyzw, held.offset[0], held.offset[1])
        return Pose(tuple(pos), tuple(quat))

    # closing and opening
    def close(self, robot_id: str) -> dict[str, Any]:
        """Close on the object nearest the TCP within the capture distance, if any, and hold it."""
        g = self._gripper(robot_id)
        if robot_id in self._held:
            return self.state(robot_id)
        caught = object_at(self._scene, self._scene.fk(robot_id).position, g.capture)
        values = self._closing(robot_id, g, caught)
        self._set_fingers(robot_id, values)
        self._state[robot_id] = "closed"
        if caught is not None:
            self._hold(robot_id, caught)
        return self.state(robot_id)

    def _closing(self, robot_id: str, g: Gripper, caught: str | None) -> tuple[float, ...]:
        """The finger values a closing stops at: the last step before a finger touches ``caught``."""
        if caught is None or not g.joints:
            return g.closed
        opened, closed = np.array(g.open), np.array(g.closed)
        last = opened
        for k in range(1, CLOSE_STEPS + 1):
            values = opened + (closed - opened) * (k / CLOSE_STEPS)
            self._set_fingers(robot_id, values.tolist())
            if touches(self._scene, robot_id, caught):
                break
            last = values
        out = tuple(float(v) for v in last)
        self._set_fingers(robot_id, out)
        return out

    def _hold(self, robot_id: str, name: str) -> None:
        e = self._scene.entry(robot_id)
        read = self._scene.object_read(name)
        spec = read[0]
        ee = self._scene.fk(robot_id)
        inv_p, inv_q = pb.invertTransform(ee.position, ee.quat_xyzw)
        offset = pb.multiplyTransforms(inv_p, inv_q, spec["position"], spec["orientation"])
        own = Path(e.model.urdf)
        folder = Path(tempfile.mkdtemp(prefix="robwot-held-"))
        try:
            written = held_urdf(parse_urdf(own), e.package_roots, e.model.ee_link, name, read[1], offset,
                                folder)
            link = written.link
            pairs = frozenset((min(link, h), max(link, h))
                              for h in hand_links(e.bound.urdf, e.model.ee_link, self._mount(robot_id)))
            held = Held(name, read, offset, own, folder, written, pairs)
            files = held.files(e)
            self._scene.remove_object(name)
            try:
                self._hold_body(robot_id, files, own)
            except Exception:
                self._scene.return_object(read, robot_id)
                raise
        except Exception:
            shutil.rmtree(folder, ignore_errors=True)
            raise
        self._held[robot_id] = held

    def _mount(self, robot_id: str) -> str:
        """The link the gripper is mounted on: the finger joints' parent, else the nearest link at or above
        the end effector with collision geometry (a suction cup's), else the end effector."""
        g = self._grippers[robot_id]
        e = self._scene.entry(robot_id)
        joints = {j.name: j for j in e.bound.urdf.joints}
        if g.joints:
            return joints[g.joints[0]].parent
        b = e.bound
        for j in reversed(chain_to(e.model.ee_link, e.bound.urdf.joints)):
            if b.bullet.has_collision_shape(b.body, b.link_index[j.child]):
                return j.child
        return e.model.ee_link

    def _hold_body(self, robot_id: str, files: RobotFiles, own: Path) -> None:
        """The robot becomes a body of ``files`` (its URDF with the held object; its model keeps naming
        ``own``) at the same base and joints. Its own body stays in the client, parked ``PARK`` away from
        every check, and solves its IK (``BoundRobot.ik_via``): a freed body's address may be reused by a
        new body, which then inherits PyBullet's IK data of the freed one (a body of other joints: "Error in
        calculateInverseKinematics", at random), so a body that ever solved IK is never freed here."""
        scene = self._scene
        old = scene.entry(robot_id)
        m = old.model
        entry = scene.build_entry(files, robot_id, m.base_position, m.base_orientation, old.clearance,
                                  m.accelerations, m.jerks)
        if entry.bound.ctrl_names != old.bound.ctrl_names:  # never: only a fixed link was added
            scene.bullet.remove_body(entry.bound.body)
            raise RuntimeError(f"robot {robot_id!r} rebuilt with other joints")
        entry.model = replace(entry.model, urdf=str(own), package_roots=m.package_roots)
        entry.bound.apply(old.bound.q)
        entry.bound.pinned.update(old.bound.pinned)
        entry.bound.ik_via = (old.bound, PARK)
        scene.swap_entry(robot_id, entry)
        at, turned = scene.bullet.base_pose(old.bound.body)  # its inertial frame's, as reset_base sets it
        scene.bullet.reset_base(old.bound.body, [v + d for v, d in zip(at, PARK, strict=True)], turned)
        self._own[robot_id] = old

    def _own_body(self, robot_id: str) -> None:
        """The robot's own body back in place of the one holding an object (freed: it never solved IK)."""
        scene = self._scene
        own = self._own.pop(robot_id)
        holding = scene.entry(robot_id)
        own.bound.pinned = dict(holding.bound.pinned)
        own.bound.apply(holding.bound.q)
        at, turned = scene.bullet.base_pose(own.bound.body)
        scene.bullet.reset_base(own.bound.body, [v - d for v, d in zip(at, PARK, strict=True)], turned)
        scene.swap_entry(robot_id, own)
        scene.bullet.remove_body(holding.bound.body)

    def open(self, robot_id: str) -> dict[str, Any]:
        """Open the fingers (or let go of the cup) and release what is held where it is: it settles."""
        g = self._gripper(robot_id)
        held = self._held.get(robot_id)
        released: dict[str, Any] | None = None
        if held is not None:
            pose = self._held_pose(robot_id)
            spec, built = held.read
            self._own_body(robot_id)
            try:
                released = self._scene.return_object(
                    ({**spec, "position": list(pose.position), "orientation": list(pose.quat_xyzw)}, built),
                    robot_id)
            except Exception:  # it cannot be let go there: held as it was
                self._hold_body(robot_id, held.files(self._scene.entry(robot_id)), held.urdf)
                raise
            del self._held[robot_id]
            if not self._trying:
                shutil.rmtree(held.folder, ignore_errors=True)
        self._set_fingers(robot_id, g.open)
        self._state[robot_id] = "open"
        return {**self.state(robot_id), "released": released}

