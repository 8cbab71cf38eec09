"""The scene from a scan, end to end over the wire: the depth camera (``camera.capture``) over scenes whose
truth we know (the KUKA on its table with a box and a can, examples/scenes/table.json; the remote-lab cell:
two arms with coupled joints, a store with its cube, two conveyors, three sensors), the clouds turned into
a scene (``scene.fromScan``), and the scene checked against the truth by geometry of our own here:

- every scanned point that is not the robot's, grown by the noise, lies inside an obstacle (boxes in their
  frame, hulls by the facets of the OBJ file written);
- the objects' covers are at most 1.5 times the volume of the true box and can (the lab: conveyors);
- the twin's verdicts on 200 configurations: with the unseen space blocked, no configuration colliding in
  the true scene is called free.
"""

from __future__ import annotations

import functools
import json
import math
import struct
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from rpc_backend import BackendProcess, RpcClient, RpcError
from scipy.spatial import ConvexHull
from simhelp import KUKA, SCENES

from robwot_sim.model.rotations import quat_from_rpy, quat_matrix
from robwot_sim.scan.clouds import read_cloud

#: the camera's depth noise (m at 1 m) and the scan's noise bound: over 3 standard deviations at 2.5 m
CAMERA_NOISE, NOISE = 0.0003, 0.005
CAMERAS = [((1.5, 0.2, 1.3), (0.4, 0.0, 0.0)), ((0.3, 1.6, 1.2), (0.4, 0.0, 0.0)),
           ((0.3, -1.6, 1.2), (0.4, 0.0, 0.0)), ((-0.6, 0.0, 1.8), (0.5, 0.0, 0.0))]
Q = [0.3, 0.5, 0.0, -1.2, 0.0, 0.6, 0.0]


def _world_points(files: list[str]) -> np.ndarray:
    """The clouds read back and placed by their viewpoints: what the scan holds, in the world frame."""
    out = []
    for f in files:
        cloud = read_cloud(f)
        assert cloud.viewpoint is not None
        out.append(cloud.viewpoint[:3] + cloud.points @ quat_matrix(cloud.viewpoint[3:]).T)
    return np.concatenate(out)


def _slack(points: np.ndarray, obstacle: dict[str, Any], folder: Path) -> np.ndarray:
    """Per point, how deep inside ``obstacle`` it lies (m; negative: outside), by geometry written here."""
    shape = obstacle["shape"]
    if shape["type"] == "box":
        local = (points - obstacle["position"]) @ quat_matrix(obstacle["orientation"])
        return np.min(np.asarray(shape["size"]) / 2 - np.abs(local), axis=1)
    assert shape["type"] == "mesh"
    eq = _facets(str(folder / shape["file"]))
    return np.asarray(-(points @ eq[:, :3].T + eq[:, 3]).max(axis=1))


@functools.cache
def _facets(file: str) -> np.ndarray:
    """The facet planes of the hull of an OBJ file's vertices, read here."""
    lines = Path(file).read_text().splitlines()
    vertices = np.array([[float(v) for v in line.split()[1:4]] for line in lines if line.startswith("v ")])
    return np.asarray(ConvexHull(vertices).equations)


def _depth_inside(points: np.ndarray, obstacles: list[dict[str, Any]], folder: Path) -> np.ndarray:
    """Per point, the deepest it lies inside any of ``obstacles``."""
    return np.max([_slack(points, o, folder) for o in obstacles], axis=0)


#: the centre and 26 points of the unit sphere (the directions of a 3 x 3 x 3 lattice): a point grown by
#: the noise (the ball of that radius) is held by a union of boxes on a grid coarser than the noise, or by
#: one convex obstacle, when these points of its ball are
LATTICE = np.array([[x, y, z] for x in (-1, 0, 1) for y in (-1, 0, 1) for z in (-1, 0, 1)], dtype=float)
LATTICE[LATTICE.any(axis=1)] /= np.linalg.norm(LATTICE[LATTICE.any(axis=1)], axis=1)[:, None]


def _held(points: np.ndarray, obstacles: list[dict[str, Any]], folder: Path, noise: float) -> np.ndarray:
    """Per point, whether its ball of radius ``noise`` lies inside the union of ``obstacles``."""
    out = np.ones(len(points), dtype=bool)
    for offset in LATTICE * noise:
        todo = np.flatnonzero(out)  # the points held at every offset so far
        inside = np.zeros(len(todo), dtype=bool)
        for o in obstacles:
            left = np.flatnonzero(~inside)
            inside[left] = _slack(points[todo[left]] + offset, o, folder) >= -1e-9
        out[todo] = inside
    return out


@pytest.fixture(scope="module")
def scan(backend: BackendProcess, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    folder = tmp_path_factory.mktemp("scan")
    c = backend.client()
    c.call("world.reset")
    c.call("world.loadScene", {"path": str(SCENES / "table.json")})
    c.call("robot.setJointPositions", {"robot": "kuka", "positions": Q})
    files, scans = _scanned(c, folder, CAMERAS)
    truth = c.call("world.list")["obstacles"]
    return {"client": c, "files": files, "truth": truth, "scans": scans, "folder": folder}


def _scanned(c: RpcClient, folder: Path, cameras: list[tuple[tuple[float, ...], tuple[float, ...]]],
             ) -> tuple[list[str], dict[str, Any]]:
    """The world as it stands captured by ``cameras`` (position, target) into ``folder``, and the scene
    made of the clouds with unseen space reported and blocked."""
    files = []
    for i, (position, target) in enumerate(cameras):
        f = str(folder / f"cam{i}.ply")
        c.call("camera.capture", {"file": f, "position": list(position), "target": list(target),
                                  "noise": CAMERA_NOISE, "dropout": 0.02, "seed": i + 1})
        files.append(f)
    scans = {occluded: c.call("scene.fromScan", {"clouds": [{"file": f} for f in files], "noise": NOISE,
                                                 "occluded": occluded, "meshDir": str(folder / occluded)})
             for occluded in ("report", "block")}
    return files, scans


def test_a_known_positive_is_caught(scan: dict[str, Any]) -> None:
    """The checker itself: a point of the true box's surface lies inside the truth, one 5 cm off it not."""
    box = next(o for o in scan["truth"] if o["name"] == "box")
    centre = np.asarray(box["position"])
    depth = _slack(np.array([centre, centre + np.array([0.0, 0.0, 0.15])]), box, scan["folder"])
    assert depth[0] > 0.04 and depth[1] < -0.04


def test_every_scanned_point_lies_inside_the_scene(scan: dict[str, Any]) -> None:
    points = _world_points(scan["files"])
    far = _far_from_robot(points, 0.011)
    for result in scan["scans"].values():
        counts = result["points"]
        assert counts["read"] == len(points)
        assert counts["robots"] > 1000 and counts["objects"] > 1000 and counts["supports"] > 10_000
        held = _held(points, result["obstacles"], scan["folder"], NOISE)
        # every point farther than the padding from the robot is held: the robot's points are the only ones
        # the covers may leave out (and a support lowered for the robot standing on it, only under its base)
        under = _under_lowered(points, result)
        assert int((~held[far & ~under]).sum()) == 0, points[far & ~under & ~held][:10]


def _under_lowered(points: np.ndarray, result: dict[str, Any]) -> np.ndarray:
    """Points whose ball (of the noise's radius) reaches over the part of a support lowered for the robot
    standing on it (the piece whose top is below its support's other pieces'), by the piece's own box."""
    out = np.zeros(len(points), dtype=bool)
    for support in result["supports"]:
        if support["lowered"] <= 0:
            continue
        pieces = [o for o in result["obstacles"] if o["name"].startswith(support["name"] + "-")]
        tops = [o["position"][2] + o["shape"]["size"][2] / 2 for o in pieces]
        for piece, top in zip(pieces, tops, strict=True):
            if top < max(tops) - 1e-9:
                local = (points - piece["position"]) @ quat_matrix(piece["orientation"])
                reach = np.asarray(piece["shape"]["size"][:2]) / 2 + NOISE  # a point's ball reaching over it
                out |= (np.abs(local[:, :2]) <= reach).all(axis=1)
    return out


#: a robot placed for ``_far_from_robot``: URDF, base position, base quaternion, movable joints' values
#: (None: every joint at zero)
Placed = tuple[str, list[float], list[float], list[float] | None]


def _far_from_robot(points: np.ndarray, distance: float,
                    robots: tuple[Placed, ...] | None = None) -> np.ndarray:
    """Points farther than ``distance`` from the robots' links, by PyBullet's own distance query on a probe
    sphere (a world of its own: the backend's is not used for this); default the KUKA at ``Q``."""
    import pybullet as pb
    import pybullet_data

    cid = pb.connect(pb.DIRECT)
    try:
        pb.setAdditionalSearchPath(pybullet_data.getDataPath(), physicsClientId=cid)
        sphere = pb.createCollisionShape(pb.GEOM_SPHERE, radius=1e-4, physicsClientId=cid)
        probe = pb.createMultiBody(0, sphere, physicsClientId=cid)
        out = np.ones(len(points), dtype=bool)
        for urdf, base, orientation, q in robots or ((KUKA, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0], Q),):
            robot = pb.loadURDF(urdf, base, orientation, useFixedBase=True, physicsClientId=cid)
            movable = [j for j in range(pb.getNumJoints(robot, physicsClientId=cid))
                       if pb.getJointInfo(robot, j, physicsClientId=cid)[2] != pb.JOINT_FIXED]
            for j, v in zip(movable, q if q is not None else [0.0] * len(movable), strict=True):
                pb.resetJointState(robot, j, v, physicsClientId=cid)
            boxes = [pb.getAABB(robot, link, physicsClientId=cid)
                     for link in range(-1, pb.getNumJoints(robot, physicsClientId=cid))]
            maybe = np.zeros(len(points), dtype=bool)  # near a link's box: the others are far for sure
            for b_lo, b_hi in boxes:
                lo_b, hi_b = np.asarray(b_lo) - distance, np.asarray(b_hi) + distance
                maybe |= ((points >= lo_b) & (points <= hi_b)).all(axis=1)
            for i in np.flatnonzero(maybe & out):
                pb.resetBasePositionAndOrientation(probe, points[i].tolist(), [0, 0, 0, 1],
                                                   physicsClientId=cid)
                if pb.getClosestPoints(probe, robot, distance, physicsClientId=cid):
                    out[i] = False
        return out
    finally:
        pb.disconnect(cid)


def test_covers_are_within_half_again_the_true_volume(scan: dict[str, Any]) -> None:
    truth = {o["name"]: o for o in scan["truth"]}
    can = truth["can"]["shape"]
    true_volume = {"box": float(np.prod(truth["box"]["shape"]["size"])),
                   "can": float(np.pi * can["radius"] ** 2 * can["length"])}
    result = scan["scans"]["report"]
    for name, volume in true_volume.items():
        centre = np.asarray(truth[name]["position"])
        near = [o for o in result["objects"] if _holds(result, o["name"], centre, scan["folder"])]
        assert len(near) == 1, (name, near)
        ratio = near[0]["volume"] / volume
        print(f"{name}: cover {near[0]['cover']} {near[0]['volume'] * 1e3:.3f} l, ratio {ratio:.2f}")
        assert 1.0 <= ratio <= 1.5


def _holds(result: dict[str, Any], name: str, point: np.ndarray, folder: Path) -> bool:
    parts = [o for o in result["obstacles"] if o["name"] == name or (o["name"].startswith(name + "-")
             and not o["name"].startswith(name + "-shadow"))]
    return bool(_depth_inside(point[None], parts, folder)[0] > 0)


def test_verdicts_match_the_true_scene_where_the_scan_saw(scan: dict[str, Any]) -> None:
    """200 targets around and in the box, the can and the table top, each reached by IK with the robot
    alone: a configuration colliding in the true scene is colliding in the scanned one with the unseen
    space blocked (0 false free); the false free of the reported-only scene and the false colliding of
    both printed."""
    c: RpcClient = scan["client"]
    rng = np.random.default_rng(3)
    c.call("world.reset")
    c.call("robot.load", {"urdf": KUKA, "id": "kuka"})
    qs: list[list[float]] = []
    while len(qs) < 200:  # targets beyond the robot's reach skipped
        target = rng.uniform([0.3, -0.45, -0.05], [0.75, 0.45, 0.3])
        try:
            qs.append(c.call("robot.ik", {"robot": "kuka", "position": target.tolist(),
                                          "collisionFree": False})["positions"])
        except RpcError as e:
            assert "E_UNREACHABLE" in str(e.error), e.error

    def verdicts(obstacles: list[dict[str, Any]]) -> np.ndarray:
        c.call("world.reset")
        c.call("robot.load", {"urdf": KUKA, "id": "kuka"})
        c.call("world.loadScene", {"scene": {"version": 1, "obstacles": obstacles, "robots": []}})
        return np.array([c.call("robot.checkCollision", {"robot": "kuka", "positions": q})["collisionFree"]
                         for q in qs])

    truth = verdicts(scan["truth"])
    assert 20 < int((~truth).sum()) < 180  # both verdicts occur: the comparison means something
    for occluded, result in scan["scans"].items():
        free = verdicts(result["obstacles"])
        false_free = int((free & ~truth).sum())
        false_colliding = int((~free & truth).sum())
        print(f"{occluded}: {int((~truth).sum())} colliding in truth; false free {false_free}, "
              f"false colliding {false_colliding} of 200")
        if occluded == "block":
            assert false_free == 0


def _box_stl(path: Path, size: tuple[float, float, float]) -> None:
    """A binary STL of a box of ``size`` standing on z = 0, centred on the z axis."""
    sx, sy, sz = size
    corners = np.array([[x, y, z] for x in (-sx / 2, sx / 2) for y in (-sy / 2, sy / 2) for z in (0.0, sz)])
    tris = corners[ConvexHull(corners).simplices]
    body = b"".join(struct.pack("<12fH", 0, 0, 0, *t.reshape(-1), 0) for t in tris)
    path.write_bytes(b"\0" * 80 + struct.pack("<I", len(tris)) + body)


def test_an_object_matching_a_model_is_placed_as_it(scan: dict[str, Any]) -> None:
    """The box's model (a 0.1 x 0.1 x 0.2 m box) fits the box where the true scene has it (turned 0.3 rad,
    standing on the table); the can fits no model; every point is still held."""
    c: RpcClient = scan["client"]
    model = scan["folder"] / "box.stl"
    _box_stl(model, (0.1, 0.1, 0.2))
    result = c.call("scene.fromScan", {"clouds": [{"file": f} for f in scan["files"]], "noise": NOISE,
                                       "models": [{"name": "crate", "file": str(model)}]})
    fitted = [o for o in result["objects"] if "model" in o]
    assert len(fitted) == 1, [o.get("model") for o in result["objects"]]
    placed = next(o for o in result["obstacles"] if o["name"] == f"{fitted[0]['name']}-crate")
    assert np.hypot(placed["position"][0] - 0.55, placed["position"][1] - 0.25) < 0.01
    assert abs(placed["position"][2] - (-0.01)) < 0.005  # standing on the table's top
    turn = math.remainder(fitted[0]["model"]["yaw"] - 0.3, math.pi / 2)
    assert abs(turn) < 0.05, fitted[0]["model"]
    truth = {o["name"]: o for o in scan["truth"]}
    can = np.asarray(truth["can"]["position"])
    covers = {**result, "obstacles": [o for o in result["obstacles"] if o is not placed]}
    at_can = [o for o in result["objects"] if _holds(covers, o["name"], can, scan["folder"])]
    assert len(at_can) == 1 and "model" not in at_can[0]
    # the model adds to the object's cover, it replaces none
    cover = [o for o in result["obstacles"] if o["name"] == fitted[0]["name"]
             or (o["name"].startswith(fitted[0]["name"] + "-") and o is not placed)]
    assert len(cover) == fitted[0]["parts"] >= 1


# ---------------------------------------------------------------- the remote-lab cell

LAB = SCENES.parent / "cells" / "remote-lab" / "scene.json"
LAB_CAMERAS = [((0.9, 0.5, 0.6), (0.3, 0.0, 0.0)), ((-0.3, -0.5, 0.6), (0.3, 0.0, 0.0)),
               ((0.3, -0.8, 0.5), (0.3, 0.0, 0.0)), ((0.3, 0.8, 0.5), (0.3, 0.0, 0.0))]


@pytest.fixture(scope="module")
def lab(backend: BackendProcess, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """The remote-lab cell (two arms with coupled joints at zero, the store with its cube, two conveyors,
    three sensors on a bench top the camera does not see) scanned by four cameras."""
    folder = tmp_path_factory.mktemp("lab")
    c = backend.client()
    c.call("world.reset")
    c.call("world.loadScene", {"path": str(LAB)})
    listed = c.call("world.list")
    robots = []
    for r in json.loads(LAB.read_text())["robots"]:
        dof = len(c.call("robot.getJointPositions", {"robot": r["id"]})["positions"])
        c.call("robot.setJointPositions", {"robot": r["id"], "positions": [0.0] * dof})
        quat = quat_from_rpy(r.get("baseRpy", [0.0, 0.0, 0.0]))
        robots.append((str((LAB.parent / r["urdf"]).resolve()), r["basePosition"], quat, r))
    files, scans = _scanned(c, folder, LAB_CAMERAS)
    return {"client": c, "files": files, "listed": listed, "robots": robots, "scans": scans, "folder": folder}


def test_the_lab_cells_points_lie_inside_its_scanned_scene(lab: dict[str, Any]) -> None:
    """Every scanned point of the lab farther than the padding from its two arms (at zero, every joint,
    coupled ones too) lies inside the scene; the conveyors' covers are within 1.5 times their volume."""
    points = _world_points(lab["files"])
    robots = tuple((urdf, base, quat, None) for urdf, base, quat, _ in lab["robots"])
    far = _far_from_robot(points, 0.011, robots)
    for result in lab["scans"].values():
        counts = result["points"]  # the arms' points removed; the conveyors' tops are supports
        assert counts["robots"] > 5000 and counts["supports"] > 5000 and counts["objects"] > 1000, counts
        held = _held(points, result["obstacles"], lab["folder"], NOISE)
        assert int((~held[far]).sum()) == 0, points[far & ~held][:10]
    result = lab["scans"]["report"]
    for conveyor in lab["listed"]["conveyors"]:
        size = np.asarray(conveyor["size"])
        centre = np.asarray(conveyor["position"])
        near = [o for o in result["objects"] if _holds(result, o["name"], centre, lab["folder"])]
        assert len(near) == 1, (conveyor["name"], near)
        ratio = near[0]["volume"] / float(np.prod(size))
        print(f"{conveyor['name']}: cover {near[0]['cover']} ratio {ratio:.2f}")
        assert 1.0 <= ratio <= 1.5


def test_the_lab_arms_verdicts_match_the_true_cell(lab: dict[str, Any]) -> None:
    """200 configurations of the uArm-like arm drawn within its limits, the Dobot-like arm at zero: none
    colliding in the true cell is free in the scanned one with the unseen space blocked."""
    c: RpcClient = lab["client"]
    spec = {r["id"]: {**r, "urdf": urdf} for urdf, _, _, r in lab["robots"]}
    model = c.call("robot.model", {"robot": "uarm_like"})
    joints = {j["name"]: j for j in model["joints"]}
    lo = np.array([joints[name]["lower"] for name in model["controllable"]])
    hi = np.array([joints[name]["upper"] for name in model["controllable"]])
    qs = np.random.default_rng(5).uniform(lo, hi, size=(200, len(lo)))

    def verdicts(scene: dict[str, Any]) -> np.ndarray:
        c.call("world.reset")
        c.call("world.loadScene", {"scene": scene})
        return np.array([c.call("robot.checkCollision", {"robot": "uarm_like", "positions": q.tolist()})[
            "collisionFree"] for q in qs])

    truth_scene = {**json.loads(LAB.read_text()), "robots": list(spec.values())}
    truth = verdicts(truth_scene)
    assert 20 < int((~truth).sum()) < 180  # both verdicts occur: the comparison means something
    for occluded, result in lab["scans"].items():
        free = verdicts({"version": 1, "obstacles": result["obstacles"], "robots": list(spec.values())})
        false_free, false_colliding = int((free & ~truth).sum()), int((~free & truth).sum())
        print(f"lab {occluded}: {int((~truth).sum())} colliding in truth; false free {false_free}, "
              f"false colliding {false_colliding} of 200")
        if occluded == "block":
            assert false_free == 0
