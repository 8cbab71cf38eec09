"""A stand-in depth camera over a simulated world: real depth images for users without a sensor and for
tests of "the scene from a scan".

Why rays, not PyBullet's image renderer: the world's bodies have collision shapes only (obstacles are
created with ``baseVisualShapeIndex=-1``), so the renderer would draw nothing. The camera casts one ray
per pixel with ``rayTestBatch`` against the collision geometry, the geometry the twin checks. A call
takes at most ``BATCH`` rays: PyBullet refuses more than ``MAX_RAY_INTERSECTION_BATCH_SIZE`` and, at
exactly that many, silently drops one result (a list input) or returns none at all (an array input).
Bullet's own threads cast them (``numThreads=0``: Bullet picks how many), with the results of one thread.

Camera model: a pinhole with square pixels, vertical field of view ``fov``; the optical frame is ROS's
(z forward along the view, x right, y down), its x axis ``view x up``. Depth is the optical z of the
hit point, so ``near`` and ``far`` are planes of constant depth: each ray ends where its depth is
``far`` (beyond: no return; removed obstacles parked thousands of metres away are never hit), and a
return nearer than ``near`` is dropped. A ray stops at the first body it meets: a hit on a body in
``ignore`` is no return, not a look through it.

Exact depths on primitives: Bullet casts a ray against a convex shape by conservative advancement and
stops once within a tolerance of the surface, so its hits fall short of boxes, spheres and convex hulls
(most on spheres at grazing incidence), and a ray passing a silhouette within that tolerance reports a
hit (plane and triangle-mesh hits are exact). A hit on a link whose collision shapes are all boxes,
spheres, cylinders or capsules is therefore recomputed exactly against those shapes. Where the ray
passes them by, or their exact entry lies behind Bullet's hit with another link's bounding box in
between, another body may be in front of it: then all the ray's hits are read and the nearest exact one
kept. What stays inexact: hits on meshes (Bullet's depth) and rays grazing a primitive's edge by a
fraction of a millimetre (Bullet's edges are rounded: no hit).

Sensor imperfections: ``noise`` adds Gaussian noise to each depth, moving the point along its pixel's
ray, with standard deviation ``noise * d**2`` at depth ``d`` (m), i.e. ``noise`` is the standard
deviation at 1 m, growing with the square of the distance as a stereo sensor's does; a noisy depth that
is not positive is no return. ``dropout`` is the probability, independent per pixel, that a pixel
returns nothing. Both draw one value per pixel from ``rng``, so a seed fixes the image.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np
import pybullet as pb

from robwot_sim.errors import InvalidParams
from robwot_sim.model.rotations import quat_matrix
from robwot_sim.sim.types import FloatArray

#: rays per rayTestBatch call: one fewer than PyBullet's maximum (see the module docstring)
BATCH = int(getattr(pb, "MAX_RAY_INTERSECTION_BATCH_SIZE", 16384)) - 1
THREADS = 0  # rayTestBatch's numThreads: Bullet picks the count
MAX_SIDE = 4096  # pixels, the largest width or height
MAX_FAR = 100.0  # m
#: m of depth: how far behind an exact entry Bullet's hit on that shape may lie (at an edge); an entry
#: farther in front of Bullet's hit is on a shape Bullet passed by, not the one it hit
REFINE_TOLERANCE = 0.002
MAX_HITS = 64  # most hits of one ray read back from Bullet
LINKS = 1 << 20  # above any body's number of links
PARALLEL = 1e-6  # the sine of the angle between view and up below which they count as parallel
_PRIMITIVES = (pb.GEOM_BOX, pb.GEOM_SPHERE, pb.GEOM_CYLINDER, pb.GEOM_CAPSULE)

UP: FloatArray = np.array([0.0, 0.0, 1.0])
UP.flags.writeable = False


class Camera(NamedTuple):
    """A depth camera's pose and pinhole model (world frame, metres, radians). The fields after ``up``
    have defaults because ``up`` has one: a VGA sensor of 45 degrees' vertical view, 0.1 to 10 m."""

    position: FloatArray  # [3] world, m
    target: FloatArray  # [3] a point the camera looks at
    up: FloatArray = UP  # [3] world up hint
    width: int = 640  # pixels
    height: int = 480
    fov: float = math.radians(45.0)  # vertical field of view, rad
    near: float = 0.1  # m of depth: nearer returns are dropped
    far: float = 10.0  # m of depth: rays end here (no return)


def _vector(camera: Camera, name: str) -> FloatArray:
    """One of the camera's 3-vectors as finite floats (InvalidParams otherwise)."""
    value = getattr(camera, name)
    try:
        v = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        v = np.full(0, np.nan)
    if v.shape != (3,) or not np.isfinite(v).all():
        raise InvalidParams(f"camera.{name} must be 3 finite numbers", param=f"camera.{name}",
                            expected="[x, y, z] finite", got=value if v.shape != (3,) else v.tolist())
    return v


def _number(camera: Camera, name: str, low: float, high: float, integer: bool = False) -> float:
    """One of the camera's scalars, checked to lie in [low, high] (InvalidParams otherwise)."""
    value = getattr(camera, name)
    kind = (int, np.integer) if integer else (int, float, np.integer, np.floating)
    ok = isinstance(value, kind) and not isinstance(value, bool) and math.isfinite(float(value))
    if not ok or not low <= float(value) <= high:
        what = "an integer" if integer else "a number"
        raise InvalidParams(f"camera.{name} must be {what} in [{low:g}, {high:g}]", param=f"camera.{name}",
                            expected=f"{what} in [{low:g}, {high:g}]", got=value)
    return float(value)


def validated(camera: Camera) -> Camera:
    """The camera with float arrays and plain numbers, or InvalidParams naming its first bad field:
    finite position, target and up, target away from position, up not parallel to the view, 1 <= width,
    height <= MAX_SIDE, 0 < fov < pi, 0 <= near < far <= MAX_FAR."""
    position, target, up = (_vector(camera, n) for n in ("position", "target", "up"))
    view = target - position
    if float(np.linalg.norm(view)) <= 1e-9:
        raise InvalidParams("camera.target must differ from camera.position", param="camera.target",
                            expected="a point other than camera.position", got=target.tolist())
    sine = float(np.linalg.norm(np.cross(view, up)) / (np.linalg.norm(view) * (np.linalg.norm(up) or 1.0)))
    if sine < PARALLEL:
        raise InvalidParams("camera.up must not be parallel to the view direction (target - position)",
                            param="camera.up", expected="a vector not parallel to the view", got=up.tolist())
    width = int(_number(camera, "width", 1, MAX_SIDE, integer=True))
    height = int(_number(camera, "height", 1, MAX_SIDE, integer=True))
    fov = _number(camera, "fov", 0.0, math.pi)
    if not 0.0 < fov < math.pi:
        raise InvalidParams("camera.fov must lie strictly between 0 and pi", param="camera.fov",
                            expected="0 < fov < pi", got=fov)
    near = _number(camera, "near", 0.0, MAX_FAR)
    far = _number(camera, "far", 0.0, MAX_FAR)
    if not near < far:
        raise InvalidParams("camera.near must be less than camera.far", param="camera.near",
                            expected=f"0 <= near < far ({far:g})", got=near)
    return Camera(position, target, up, width, height, fov, near, far)


def _frame(camera: Camera) -> FloatArray:
    """The optical frame's axes (x right, y down, z forward) as the columns of a world rotation."""
    z = camera.target - camera.position
    z = z / np.linalg.norm(z)
    x = np.cross(z, camera.up)
    x = x / np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


def orientation(camera: Camera) -> FloatArray:
    """The quaternion [x, y, z, w] of the camera's optical frame in the world (ROS optical convention:
    z forward along the view, x right, y down). ``model.rotations`` converts quaternions to matrices
    only; the other way is scipy's, as in ``model.chain_ik``."""
    from scipy.spatial.transform import Rotation

    return np.asarray(Rotation.from_matrix(_frame(validated(camera))).as_quat(), dtype=np.float64)


def intrinsics(camera: Camera) -> FloatArray:
    """The pinhole matrix K (3x3, pixels): square pixels of focal length ``(height / 2) / tan(fov / 2)``,
    principal point at the image centre; pixel (row v, column u) is the square [u, u + 1] x [v, v + 1]."""
    cam = validated(camera)
    f = cam.height / 2.0 / math.tan(cam.fov / 2.0)
    return np.array([[f, 0.0, cam.width / 2.0], [0.0, f, cam.height / 2.0], [0.0, 0.0, 1.0]])


def _rays(camera: Camera) -> FloatArray:
    """[height * width, 3] each pixel centre's ray in the optical frame, scaled to optical z = 1 (so a
    depth d puts the point at d times the ray), rows first."""
    k = intrinsics(camera)
    u = (np.arange(camera.width) + 0.5 - k[0, 2]) / k[0, 0]
    v = (np.arange(camera.height) + 0.5 - k[1, 2]) / k[1, 1]
    uu, vv = np.meshgrid(u, v)
    return np.column_stack([uu.ravel(), vv.ravel(), np.ones(uu.size)])


def _cast(cid: int, origin: FloatArray, ends: FloatArray,
          hit: int | None = None) -> tuple[FloatArray, Any, Any]:
    """Bullet's nearest hit along each segment from ``origin`` (``hit``: its hit number ``hit`` instead, in
    Bullet's order): (hit fraction, body, link); body -1 and fraction NaN where there is none."""
    n = len(ends)
    nth: dict[str, int] = {} if hit is None else {"reportHitNumber": hit}
    frac, body, link = np.full(n, np.nan), np.full(n, -1, dtype=np.int64), np.full(n, -1, dtype=np.int64)
    for i in range(0, n, BATCH):
        part = ends[i:i + BATCH]
        hits = pb.rayTestBatch(np.tile(origin, (len(part), 1)), part, numThreads=THREADS,
                               physicsClientId=cid, **nth)
        if len(hits) != len(part):
            raise RuntimeError(f"rayTestBatch returned {len(hits)} results for {len(part)} rays")
        body[i:i + len(part)] = np.fromiter((h[0] for h in hits), np.int64, len(part))
        link[i:i + len(part)] = np.fromiter((h[1] for h in hits), np.int64, len(part))
        frac[i:i + len(part)] = np.fromiter((h[2] for h in hits), np.float64, len(part))
    frac[body < 0] = np.nan
    return frac, body, link


def _primitives(cid: int, body: int, link: int) -> list[tuple[int, Any, FloatArray, FloatArray]] | None:
    """The collision shapes of a link as (kind, dimensions, world position, world rotation), or None
    when one of them is not a box, sphere, cylinder or capsule."""
    if link >= 0:
        state = pb.getLinkState(body, link, computeForwardKinematics=True, physicsClientId=cid)
        pos, orn = state[0], state[1]  # the link's inertial frame in the world
    else:  # Bullet's base frame is its inertial frame
        pos, orn = pb.getBasePositionAndOrientation(body, physicsClientId=cid)
    p, r = np.asarray(pos, dtype=np.float64), quat_matrix(orn)
    shapes = pb.getCollisionShapeData(body, link, physicsClientId=cid) or ()
    if not shapes or any(s[2] not in _PRIMITIVES for s in shapes):
        return None
    # each shape's frame is given in the link's inertial frame
    return [(s[2], s[3], p + r @ np.asarray(s[5], dtype=np.float64), r @ quat_matrix(s[6])) for s in shapes]


def _slab(o: FloatArray, d: FloatArray, half: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Where rays o + t d are inside |x_k| <= half_k for every axis k of ``half``: [t0, t1] per ray."""
    with np.errstate(divide="ignore", invalid="ignore"):
        a, b = (-half - o) / d, (half - o) / d
    lo, hi = np.fmin(a, b), np.fmax(a, b)
    # a ray parallel to a slab stays in it, or out of it, all along
    out = np.broadcast_to(np.abs(o) > half, d.shape)
    lo = np.where(d == 0, np.where(out, np.inf, -np.inf), lo)
    hi = np.where(d == 0, np.where(out, -np.inf, np.inf), hi)
    return lo.max(axis=1), hi.min(axis=1)


def _round(o: FloatArray, d: FloatArray, radius: float) -> tuple[FloatArray, FloatArray]:
    """Where rays o + t d are within ``radius`` of the origin (in the space of o's coordinates): [t0, t1]."""
    a = (d * d).sum(axis=1)
    b = d @ o
    c = float(o @ o) - radius * radius
    disc = b * b - a * c
    with np.errstate(divide="ignore", invalid="ignore"):
        root = np.sqrt(np.maximum(disc, 0.0))
        t0, t1 = (-b - root) / a, (-b + root) / a
    never = (disc < 0) | ((a == 0) & (c > 0))
    always = (a == 0) & (c <= 0)
    t0 = np.where(never, np.inf, np.where(always, -np.inf, t0))
    t1 = np.where(never, -np.inf, np.where(always, np.inf, t1))
    return t0, t1


def _entry(kind: int, dims: Any, o: FloatArray, d: FloatArray) -> FloatArray:
    """The t at which each ray o + t d (shape frame) enters a primitive; inf where it does not (a miss,
    or an origin inside it)."""
    spans: list[tuple[FloatArray, FloatArray]]
    if kind == pb.GEOM_BOX:
        spans = [_slab(o, d, np.asarray(dims[:3], dtype=np.float64) / 2)]
    elif kind == pb.GEOM_SPHERE:
        spans = [_round(o, d, float(dims[0]))]
    else:  # cylinder or capsule along z: length dims[0] of the cylinder, radius dims[1]
        half, radius = float(dims[0]) / 2, float(dims[1])
        z0, z1 = _slab(o[2:], d[:, 2:], np.array([half]))
        c0, c1 = _round(o[:2], d[:, :2], radius)
        spans = [(np.maximum(z0, c0), np.minimum(z1, c1))]
        if kind == pb.GEOM_CAPSULE:
            spans += [_round(o - np.array([0.0, 0.0, s * half]), d, radius) for s in (-1.0, 1.0)]
    out = np.full(len(d), np.inf)
    for t0, t1 in spans:
        out = np.where((t0 <= t1) & (t0 >= 0.0), np.minimum(out, t0), out)
    return out


def _exact(cid: int, origin: FloatArray, rays: FloatArray, depth: FloatArray, body: Any,
           link: Any) -> FloatArray:
    """Per ray (``rays``: world, depth-scaled) and Bullet's hit (``depth``, ``body``, ``link``): the exact
    depth at which the ray enters the hit link when its shapes are all primitives, inf when it passes
    them by (a silhouette's fringe); Bullet's depth for other links, or where the exact entry lies more
    than REFINE_TOLERANCE in front of it; NaN where nothing is hit."""
    out = depth.copy()
    hit = np.flatnonzero(body >= 0)
    key = body[hit] * LINKS + link[hit] + 1  # one number per (body, link), link -1 the base
    for k in np.unique(key).tolist():
        shapes = _primitives(cid, k // LINKS, k % LINKS - 1)
        if shapes is None:
            continue
        sel = hit[key == k]
        t = np.full(len(sel), np.inf)
        for kind, dims, p, r in shapes:
            t = np.minimum(t, _entry(kind, dims, (origin - p) @ r, rays[sel] @ r))
        keep = t < depth[sel] - REFINE_TOLERANCE
        out[sel] = np.where(keep, depth[sel], t)
    return out


def _fringe(cid: int, cam: Camera, rays: FloatArray, ends: FloatArray) -> tuple[FloatArray, Any]:
    """(depth, body) of the nearest exact hit of each ray, NaN and -1 where there is none, from all its
    hits: Bullet reports them one at a time and in no order of distance (up to MAX_HITS are read)."""
    best, best_body = np.full(len(ends), np.inf), np.full(len(ends), -1, dtype=np.int64)
    for k in range(MAX_HITS):
        frac, body, link = _cast(cid, cam.position, ends, hit=k)
        if (body < 0).all():
            break
        depth = _exact(cid, cam.position, rays, frac * cam.far, body, link)
        closer = depth < best  # never where NaN: no hit
        best[closer], best_body[closer] = depth[closer], body[closer]
    best[np.isinf(best)] = np.nan
    return best, best_body


def _crossed(cid: int, origin: FloatArray, rays: FloatArray, depth: FloatArray, exact: FloatArray,
             key: Any) -> Any:
    """Which rays of one link's exact hits lying behind Bullet's (``key``: the link, as in ``_exact``)
    meet another link's bounding box between Bullet's hit and the exact one: a body there may be hit
    first. A bool mask."""
    near, far = origin + rays * depth[:, None], origin + rays * exact[:, None]
    lo, hi = np.minimum(near, far).min(axis=0), np.maximum(near, far).max(axis=0)
    out = np.zeros(len(rays), dtype=bool)
    for b, li in pb.getOverlappingObjects(lo.tolist(), hi.tolist(), physicsClientId=cid) or ():
        if b * LINKS + li + 1 == key:
            continue
        box_lo, box_hi = (np.asarray(v, dtype=np.float64) for v in pb.getAABB(b, li, physicsClientId=cid))
        centre, half = (box_lo + box_hi) / 2, (box_hi - box_lo) / 2
        t0, t1 = _slab(origin - centre, rays, half)
        out |= (np.maximum(t0, depth) <= np.minimum(t1, exact))
    return out


def _trace(cid: int, cam: Camera, rays: FloatArray) -> tuple[FloatArray, Any]:
    """(depth, body) of each ray's first return (``rays``: world, depth-scaled), NaN and -1 where there is
    none: Bullet's nearest hit made exact (``_exact``). Where the ray passes the shapes by, or the exact
    entry lies behind Bullet's hit with another link's bounding box between them, another body may be
    in front, so all the ray's hits are compared (``_fringe``)."""
    ends = cam.position + rays * cam.far
    frac, body, link = _cast(cid, cam.position, ends)
    depth = frac * cam.far
    exact = _exact(cid, cam.position, rays, depth, body, link)
    doubt = np.isinf(exact)
    behind = np.flatnonzero(np.isfinite(exact) & (exact > depth))
    key = body[behind] * LINKS + link[behind] + 1
    for k in np.unique(key).tolist():
        sel = behind[key == k]
        doubt[sel] = _crossed(cid, cam.position, rays[sel], depth[sel], exact[sel], k)
    unsure = np.flatnonzero(doubt)
    if unsure.size:
        exact[unsure], body[unsure] = _fringe(cid, cam, rays[unsure], ends[unsure])
    return exact, body


def depth_image(cid: int, camera: Camera, noise: float = 0.0, dropout: float = 0.0,
                rng: np.random.Generator | None = None, ignore: Sequence[int] = ()) -> FloatArray:
    """[height, width] depth (m, optical z) the camera reads of the world of client ``cid``; NaN where no
    return: nothing hit before ``far``, a hit nearer than ``near`` or on a body in ``ignore``, a dropped
    pixel. ``noise``: standard deviation (m) at 1 m of the Gaussian depth noise, ``noise * d**2`` at
    depth d; ``dropout``: probability a pixel returns nothing; ``rng``: their random numbers (a fresh
    generator when None)."""
    cam = validated(camera)
    number = (int, float, np.integer, np.floating)
    if not (isinstance(noise, number) and math.isfinite(noise) and noise >= 0.0):
        raise InvalidParams("noise must be a finite number >= 0", param="noise", expected=">= 0", got=noise)
    if not (isinstance(dropout, number) and 0.0 <= dropout <= 1.0):
        raise InvalidParams("dropout must be a probability", param="dropout", expected="0 <= dropout <= 1",
                            got=dropout)
    depth, body = _trace(cid, cam, _rays(cam) @ _frame(cam).T)  # world rays, optical z = 1
    depth[np.isin(body, np.asarray(list(ignore), dtype=np.int64))] = np.nan
    depth[depth < cam.near] = np.nan
    if noise > 0.0 or dropout > 0.0:
        gen = rng if rng is not None else np.random.default_rng()
        depth = depth + gen.standard_normal(depth.shape) * (noise * depth * depth)
        depth[depth <= 0.0] = np.nan
        depth[gen.random(depth.shape) < dropout] = np.nan
    return depth.reshape(cam.height, cam.width)


def camera_points(depth: FloatArray, camera: Camera) -> FloatArray:
    """[n, 3] the points of the valid (finite) pixels of a depth image, rows first, in the camera's
    optical frame (x right, y down, z forward): pixel ray times depth. With ``orientation(camera)`` and
    ``camera.position`` as the viewpoint they are ``depth_points``."""
    cam = validated(camera)
    d = np.asarray(depth, dtype=np.float64)
    if d.shape != (cam.height, cam.width):
        raise InvalidParams("depth must be an image of the camera's size", param="depth",
                            expected=[cam.height, cam.width], got=list(d.shape))
    flat = d.ravel()
    valid = np.isfinite(flat)
    return np.asarray(_rays(cam)[valid] * flat[valid, None], dtype=np.float64)


def depth_points(depth: FloatArray, camera: Camera) -> FloatArray:
    """[n, 3] the points of the valid pixels of a depth image in the world frame: the camera's position
    plus each pixel's ray (from the camera model) to optical depth ``depth``."""
    cam = validated(camera)
    return np.asarray(cam.position + camera_points(depth, cam) @ _frame(cam).T, dtype=np.float64)
