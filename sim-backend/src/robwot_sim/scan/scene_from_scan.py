"""A conservative scene from point clouds (``scene.fromScan``, ``robwot scene from-scan``).

The clouds are placed in the world (each by its sensor's pose), the robots' own points removed
(``robot_points.py``), near-horizontal support planes found and the rest clustered (``segment.py``); each
support and each cluster is covered (``shapes.py``). The one promise: every point that is not a robot's,
grown by ``noise`` in every direction, lies inside the obstacles written, so a twin built from the scan
never calls free a configuration the scan shows blocked. Two exceptions, both reported: a support a robot
stands on is lowered just below the robot's fixed links (``lowered``; else every configuration of the
robot would collide), and points within ``padding`` of a robot are taken for the robot's.

Space hidden behind an object from the sensors that saw it is its shadow (``shapes.shadow``): its volume
reported per object, and with ``occluded="block"`` an obstacle ``NAME-shadow`` too.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt
from scipy.spatial import ConvexHull, QhullError

from robwot_sim.model.objfile import write_obj
from robwot_sim.model.rotations import quat_matrix
from robwot_sim.scan.clouds import read_cloud
from robwot_sim.scan.fit import Model, fit
from robwot_sim.scan.robot_points import RobotSnapshot, robot_mask
from robwot_sim.scan.segment import Plane, clusters, find_supports
from robwot_sim.scan.shapes import (
    box_cover,
    hull_candidates,
    hull_cover,
    shadow,
    tightest,
    volume_of,
    voxel_cover,
)

FloatArray = npt.NDArray[np.float64]
IDENTITY = np.array([0.0, 0.0, 0.0, 1.0])
#: m a support lowered for a robot standing on it keeps below the robot's fixed links, and m its cut
#: reaches beyond their footprint: Bullet's margin around a hull (1 mm) would touch it otherwise
STAND_GAP = 0.003
#: m: a support this close below a robot's fixed links (or above their bottom) is one the robot stands on
STAND_REACH = 0.05


class ScanParams(NamedTuple):
    """``scene.fromScan``'s options (metres)."""

    noise: float = 0.005
    shape: str = "tightest"
    voxel: float = 0.02
    gap: float = 0.03
    padding: float = 0.01
    occluded: str = "report"
    reach: float = 2.0
    mesh_dir: Path | None = None
    models: tuple[Model, ...] = ()


class Placed(NamedTuple):
    """Clouds in the world frame: every point, the cloud each came from, each cloud's sensor position."""

    points: FloatArray
    source: npt.NDArray[np.int64]
    sensors: FloatArray
    dropped: int


def place_clouds(clouds: Sequence[dict[str, Any]]) -> Placed:
    """Reads each cloud (``clouds.read_cloud``) and places it by its sensor's pose: the one given, else the
    file's own viewpoint, else the world frame."""
    points, source, sensors, dropped = [], [], [], 0
    for i, spec in enumerate(clouds):
        cloud = read_cloud(spec["file"], spec.get("units", "m"))
        view = cloud.viewpoint
        position: FloatArray = np.asarray(spec.get("position", view[:3] if view is not None else np.zeros(3)),
                                          dtype=np.float64)
        quat = [float(v) for v in spec.get("orientation", view[3:] if view is not None else IDENTITY)]
        points.append(position + cloud.points @ quat_matrix(quat).T)
        source.append(np.full(len(cloud.points), i, dtype=np.int64))
        sensors.append(position)
        dropped += cloud.dropped
    return Placed(np.concatenate(points), np.concatenate(source), np.asarray(sensors), dropped)


def scene_from_scan(placed: Placed, robots: RobotSnapshot, params: ScanParams) -> dict[str, Any]:
    """The scene of ``placed`` clouds with ``robots``' points removed (``scene.fromScan``'s result)."""
    start = time.perf_counter()
    keep = ~robot_mask(placed.points, robots, params.padding)
    points, source = placed.points[keep], placed.source[keep]
    planes = find_supports(points, params.noise)
    obstacles: list[dict[str, Any]] = []
    heights = [float(p.offset / p.normal[2]) for p in planes]
    supports = [_support(i, points[p.inliers], p, max((h for h in heights if h < heights[i]), default=None),
                         robots, params, obstacles) for i, p in enumerate(planes)]
    rest = np.ones(len(points), dtype=bool)
    for p in planes:
        rest[p.inliers] = False
    objects = _objects(points[rest], source[rest], planes, placed.sensors, params, obstacles)
    counts = {"read": len(placed.points), "dropped": placed.dropped, "robots": int((~keep).sum()),
              "supports": int(len(points) - rest.sum()), "objects": int(rest.sum())}
    return {"obstacles": obstacles, "supports": supports, "objects": objects, "points": counts,
            "seconds": time.perf_counter() - start}


def _support(i: int, points: FloatArray, plane: Plane, below: float | None, robots: RobotSnapshot,
             params: ScanParams, obstacles: list[dict[str, Any]]) -> dict[str, Any]:
    """A support plane's box (its points grown by the noise; ``support-N``). Where a robot stands on it
    (its fixed links' box over the support and the support's top above their bottom), the box is cut around
    the robot's footprint and only the part under it lowered below the robot (``support-N-K``). What lies
    under it is unseen down to the next support ``below`` (its height), else ``reach``: with
    ``occluded="block"`` the boxes reach down so far."""
    name = f"support-{i + 1}"
    box = box_cover(points, params.noise)
    size, centre = np.asarray(box["shape"]["size"]), np.asarray(box["position"])
    yaw = _yaw_of(box["orientation"])
    lo, hi = -size / 2, size / 2  # in the box's frame
    top = float(centre[2] + hi[2])
    floor = below + params.noise if below is not None else top - params.reach
    hidden = max(0.0, float(centre[2] + lo[2]) - floor) * float(size[0] * size[1])
    if params.occluded == "block" and hidden > 0:
        lo[2] = floor - centre[2]
    pieces, lowered = [(lo, hi)], 0.0
    for stand_lo, stand_hi in robots.stands:
        foot = _footprint(stand_lo - STAND_GAP, stand_hi + STAND_GAP, centre, yaw)
        drop = top - (float(stand_lo[2]) - STAND_GAP)
        if drop <= 0 or top > float(stand_hi[2]) or top < float(stand_lo[2]) - STAND_REACH:
            continue
        cuts = [_cut(p, foot, drop) for p in pieces]
        if any(c is not None for c in cuts):
            pieces = [q for p, c in zip(pieces, cuts, strict=True) for q in (c if c is not None else [p])]
            lowered = max(lowered, drop)
    for k, (a, b) in enumerate(pieces):
        label = name if len(pieces) == 1 else f"{name}-{k + 1}"
        middle = centre + _turn(yaw, (a + b) / 2)
        obstacles.append({"name": label, "shape": {"type": "box", "size": [float(v) for v in b - a]},
                          "position": [float(v) for v in middle], "orientation": list(box["orientation"])})
    height = float(plane.offset / plane.normal[2])
    return {"name": name, "height": height, "points": len(points), "lowered": lowered, "occluded": hidden}


def _yaw_of(quat: list[float]) -> float:
    """The yaw of a yaw-only quaternion [0, 0, sin(yaw/2), cos(yaw/2)]."""
    return 2.0 * float(np.arctan2(quat[2], quat[3]))


def _turn(yaw: float, v: FloatArray) -> FloatArray:
    """``v`` turned by ``yaw`` about z."""
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1], v[2]])


def _footprint(lo: FloatArray, hi: FloatArray, centre: FloatArray,
               yaw: float) -> tuple[FloatArray, FloatArray]:
    """The box (lo, hi) of a robot's fixed links as x, y bounds in a support box's frame."""
    corners = np.array([[x, y, 0.0] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])]) - centre
    local = np.array([_turn(-yaw, c) for c in corners])[:, :2]
    return local.min(axis=0), local.max(axis=0)


Piece = tuple[FloatArray, FloatArray]


def _cut(piece: Piece, foot: tuple[FloatArray, FloatArray], drop: float) -> list[Piece] | None:
    """A box piece (lo, hi, support frame) cut around a footprint (x, y bounds): the parts beside it as
    they are, the part under it with its top ``drop`` lower (gone when that leaves nothing); None when the
    footprint is not over the piece."""
    lo, hi = piece
    f_lo, f_hi = np.maximum(foot[0], lo[:2]), np.minimum(foot[1], hi[:2])
    if (f_lo >= f_hi).any():
        return None
    out: list[Piece] = []

    def part(x0: float, x1: float, y0: float, y1: float, z1: float) -> None:
        if x1 > x0 and y1 > y0 and z1 > lo[2]:
            out.append((np.array([x0, y0, lo[2]]), np.array([x1, y1, z1])))

    part(lo[0], f_lo[0], lo[1], hi[1], hi[2])
    part(f_hi[0], hi[0], lo[1], hi[1], hi[2])
    part(f_lo[0], f_hi[0], lo[1], f_lo[1], hi[2])
    part(f_lo[0], f_hi[0], f_hi[1], hi[1], hi[2])
    part(f_lo[0], f_hi[0], f_lo[1], f_hi[1], hi[2] - drop)
    return out


def _objects(points: FloatArray, source: npt.NDArray[np.int64], planes: list[Plane], sensors: FloatArray,
             params: ScanParams, obstacles: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Each cluster of ``points`` covered, named ``object-N``, with its shadow."""
    if not len(points):
        return []
    labels = clusters(points, params.gap)
    order = np.argsort(labels, kind="stable")
    bounds = np.searchsorted(labels[order], np.arange(int(labels.max()) + 2))
    out = []
    for k in range(int(labels.max()) + 1):
        idx = order[bounds[k]:bounds[k + 1]]
        name = f"object-{k + 1}"
        kind, cover = _cover(points[idx], params)
        made = _obstacles(name, kind, cover, params)
        obstacles += made
        hidden = _shadow(name, points[idx], source[idx], planes, sensors, params, obstacles)
        entry = {"name": name, "points": len(idx), "cover": kind, "volume": float(volume_of(cover)),
                 "parts": len(made), "occluded": hidden}
        model = _model(name, points[idx], planes, params, obstacles)
        out.append({**entry, "model": model} if model else entry)
    return out


def _model(name: str, points: FloatArray, planes: list[Plane], params: ScanParams,
           obstacles: list[dict[str, Any]]) -> dict[str, Any] | None:
    """The user's model that fits a cluster best (``fit.py``), placed as an obstacle ``NAME-MODEL`` beside
    the cluster's cover; None when none fits."""
    floor = _floor(points + np.array([0.0, 0.0, params.noise]), planes)
    height = float(floor.offset / floor.normal[2]) if floor is not None else None
    fits = [(m, f) for m in params.models if (f := fit(m, points, params.noise, height)) is not None]
    if not fits:
        return None
    model, where = min(fits, key=lambda mf: mf[1].p95)
    half = where.yaw / 2
    obstacles.append({"name": f"{name}-{model.name}", "shape": {"type": "mesh", "file": model.file},
                      "position": [float(v) for v in where.position],
                      "orientation": [0.0, 0.0, float(np.sin(half)), float(np.cos(half))]})
    return {"name": model.name, "yaw": where.yaw, "median": where.median, "p95": where.p95}


def _cover(points: FloatArray, params: ScanParams) -> tuple[str, Any]:
    """The cover ``params.shape`` asks for (a hull only where it can be written: ``mesh_dir``)."""
    if params.shape == "box" or (params.shape == "hull" and params.mesh_dir is None):
        return "box", box_cover(points, params.noise)
    if params.shape == "hull":
        return "hull", hull_cover(points, params.noise)
    if params.shape == "voxels":
        return "voxels", voxel_cover(points, params.noise, params.voxel)
    return tightest(points, params.noise, params.voxel, hull=params.mesh_dir is not None)


def _obstacles(name: str, kind: str, cover: Any, params: ScanParams) -> list[dict[str, Any]]:
    """A cover as scene obstacles: one box or mesh, or one box per merged run of voxels."""
    if kind == "box":
        return [{"name": name, **cover}]
    if kind == "voxels":
        return [{"name": f"{name}-{i + 1}", **box} for i, box in enumerate(cover)]
    assert params.mesh_dir is not None
    params.mesh_dir.mkdir(parents=True, exist_ok=True)
    file = params.mesh_dir / f"{name}.obj"
    vertices, faces = cover
    write_obj(file, vertices, faces)
    return [{"name": name, "shape": {"type": "mesh", "file": str(file.resolve())},
             "position": [0.0, 0.0, 0.0], "orientation": IDENTITY.tolist()}]


def _volume(points: FloatArray) -> float:
    """The volume of the convex hull of ``points`` (0 when they span no volume)."""
    try:
        return float(ConvexHull(hull_candidates(points, boundary=False)).volume)
    except (QhullError, ValueError):
        return 0.0


def _floor(points: FloatArray, planes: list[Plane]) -> Plane | None:
    """The highest support plane below the lowest of ``points``."""
    below = [p for p in planes if float(p.offset / p.normal[2]) <= float(points[:, 2].min())]
    return max(below, key=lambda p: float(p.offset / p.normal[2]), default=None)


def _shadow(name: str, points: FloatArray, source: npt.NDArray[np.int64], planes: list[Plane],
            sensors: FloatArray, params: ScanParams, obstacles: list[dict[str, Any]]) -> float:
    """The volume (m^3) hidden behind an object from each sensor that saw it; with ``occluded="block"`` an
    obstacle ``NAME-shadow`` (per sensor: ``NAME-shadow-K``) holding it."""
    floor = _floor(points, planes)
    hidden = 0.0
    seen = np.unique(source)
    for k, cloud in enumerate(seen):
        region = shadow(points[source == cloud], sensors[int(cloud)], floor, params.reach)
        hidden += _volume(region)
        if params.occluded == "block":
            vertices, faces = hull_cover(region, 0.0)
            label = f"{name}-shadow" + (f"-{k + 1}" if len(seen) > 1 else "")
            if params.mesh_dir is None:
                obstacles.append({"name": label, **box_cover(region, 0.0)})
            else:
                obstacles += _obstacles(label, "hull", (vertices, faces), params)
    return hidden
