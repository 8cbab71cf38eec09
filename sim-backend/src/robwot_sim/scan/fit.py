"""Objects fitted to the user's models (``scene.fromScan`` ``models``, ``scene from-scan --model``).

A model is a mesh file of a thing that may stand in the cell (a fixture, a conveyor, a crate), in its own
frame with Z up, resting on its lowest point. A cluster of the scan is that thing when the model, standing
on the support below the cluster (or at the cluster's bottom) and turned about Z only, lies along the
points: a 2-D rigid ICP (x, y and yaw; from ``YAWS`` starting turns) against points sampled on the model's
surface, accepted when the points' distances to that surface are at most ``noise / 2`` at the median and
``noise`` at the 95th percentile (plus half the samples' spacing) and the model is no smaller than the
cluster. The placed model adds what the sensor could not see of the thing (its back, its underside);
the cluster's own cover stays, so every point grown by the noise is still held.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import NamedTuple

import numpy as np
import numpy.typing as npt
from scipy.spatial import ConvexHull, QhullError, cKDTree

from robwot_sim.errors import FileNotFound, MeshError
from robwot_sim.model.meshcheck import check_mesh, read_mesh

FloatArray = npt.NDArray[np.float64]

SAMPLES = 20_000  # points sampled on a model's surface (area-weighted, fixed seed)
YAWS = 8  # starting turns of the ICP
ITERATIONS = 30


class Model(NamedTuple):
    """A user's model: its file, points on its surface (its frame), their tree, its lowest z, its extent,
    the samples' spacing."""

    name: str
    file: str
    surface: FloatArray
    tree: cKDTree
    low: float
    extent: FloatArray
    spacing: float


class Fit(NamedTuple):
    """Where a model stands: position (of its frame), yaw (rad), the points' median and 95th percentile
    distance to its surface (m)."""

    position: FloatArray
    yaw: float
    median: float
    p95: float


def load_model(name: str, file: str) -> Model:
    """A model read by our mesh parser (``E_MESH`` naming the file for one it refuses; a missing file:
    ``E_FILE_NOT_FOUND``)."""
    path = Path(file).expanduser()
    if not path.is_file():
        raise FileNotFound(str(path), what="model mesh")
    check_mesh(path)
    mesh = read_mesh(path)
    if mesh is None or not len(mesh.faces):
        raise MeshError(f"{path}: the model has no triangles", file=str(path), reason="no triangles")
    tri = mesh.vertices[mesh.faces.astype(np.intp)]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    total = float(area.sum())
    if not total > 0:
        raise MeshError(f"{path}: the model has no area", file=str(path), reason="no area")
    rng = np.random.default_rng(0)
    pick = rng.choice(len(tri), size=SAMPLES, p=area / total)
    u, v = rng.random(SAMPLES), rng.random(SAMPLES)
    flip = u + v > 1
    u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
    t = tri[pick]
    surface = t[:, 0] + u[:, None] * (t[:, 1] - t[:, 0]) + v[:, None] * (t[:, 2] - t[:, 0])
    surface = np.concatenate([surface, mesh.vertices])
    extent = mesh.vertices.max(axis=0) - mesh.vertices.min(axis=0)
    low = float(mesh.vertices[:, 2].min())
    spacing = math.sqrt(total / SAMPLES)
    return Model(name, str(path.resolve()), surface, cKDTree(surface), low, extent, spacing)


def _turn(yaw: float) -> FloatArray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _icp(model: Model, points: FloatArray, yaw: float, xy: FloatArray, z: float) -> tuple[float, FloatArray]:
    """x, y and yaw refined from a start so the points lie on the model's surface."""
    for _ in range(ITERATIONS):
        rot = _turn(yaw)
        local = (points - np.array([xy[0], xy[1], z])) @ rot  # into the model's frame
        _, idx = model.tree.query(local)
        target = model.surface[idx] @ rot.T + np.array([xy[0], xy[1], z])  # matched surface points, world
        a, b = points[:, :2] - points[:, :2].mean(axis=0), target[:, :2] - target[:, :2].mean(axis=0)
        # the turn taking the points onto their targets about the centroids; the model goes the other way:
        # x -> R(-turn) (x - target centroid) + points' centroid
        turn = math.atan2(float(np.sum(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])), float(np.sum(a * b)))
        c_p, c_t = points[:, :2].mean(axis=0), target[:, :2].mean(axis=0)
        c, s = math.cos(-turn), math.sin(-turn)
        rel = xy - c_t
        moved = c_p + np.array([c * rel[0] - s * rel[1], s * rel[0] + c * rel[1]])
        step = float(np.linalg.norm(moved - xy))
        yaw, xy = yaw - turn, moved
        if abs(turn) < 1e-6 and step < 1e-6:
            break
    return yaw, xy


def fit(model: Model, points: FloatArray, noise: float, floor: float | None) -> Fit | None:
    """The model where it lies along ``points`` (a cluster, world frame), standing on ``floor`` (a support's
    height) or at the points' bottom; None when it does not fit."""
    if _diameter(points) > float(np.linalg.norm(model.extent)) + 4 * noise:
        return None  # the cluster is larger than the model
    z = (floor if floor is not None else float(points[:, 2].min())) - model.low
    centre = points[:, :2].mean(axis=0)
    best: Fit | None = None
    for k in range(YAWS):
        yaw0 = 2 * math.pi * k / YAWS
        start = centre - (_turn(yaw0) @ model.surface.mean(axis=0))[:2]
        yaw, xy = _icp(model, points, yaw0, start, z)
        local = (points - np.array([xy[0], xy[1], z])) @ _turn(yaw)
        d, _ = model.tree.query(local)
        found = Fit(np.array([xy[0], xy[1], z]), math.remainder(yaw, 2 * math.pi), float(np.median(d)),
                    float(np.percentile(d, 95)))
        if best is None or found.p95 < best.p95:
            best = found
    assert best is not None
    if best.median <= (noise + model.spacing) / 2 and best.p95 <= noise + model.spacing / 2:
        return best
    return None


def _diameter(points: FloatArray) -> float:
    """The largest distance between two of ``points`` (over their hull's vertices)."""
    try:
        ends = points[ConvexHull(points).vertices]
    except (QhullError, ValueError):
        ends = points
    if len(ends) > 2000:
        ends = ends[:: len(ends) // 2000 + 1]
    return float(np.sqrt(((ends[:, None, :] - ends[None, :, :]) ** 2).sum(axis=2).max()))
