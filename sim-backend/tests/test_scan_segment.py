"""The scene-from-scan geometry (scan/segment.py, scan/shapes.py) on synthetic clouds.

Clouds are sampled surfaces of boxes (some turned in yaw) and cylinders standing on a table top above a
floor, with Gaussian noise clipped to 3 sigma = 0.75 ``NOISE`` (so every point is within ``NOISE`` of its
surface, the bound the code is given). The covers are checked by independent checkers of the safety
guarantee (every point grown by the noise inside the cover), and the checkers themselves are shown to
catch a cover shrunk a little.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from scipy.spatial import ConvexHull, QhullError

from robwot_sim.model.rotations import quat_matrix
from robwot_sim.scan.segment import Plane, clusters, find_supports
from robwot_sim.scan.shapes import (
    Cover,
    box_cover,
    hull_candidates,
    hull_cover,
    shadow,
    tightest,
    volume_of,
    voxel_cover,
)

NOISE = 0.004
TABLE_Z = 0.75
DENSITY = 10_000.0   # points per square metre of surface
# (kind, size or (radius, height), centre xy, yaw) of the objects standing on the table
OBJECTS: list[tuple[str, tuple[float, ...], tuple[float, float], float]] = [
    ("box", (0.12, 0.08, 0.15), (-0.6, -0.3), 0.0),
    ("cyl", (0.05, 0.18), (-0.3, -0.3), 0.0),
    ("box", (0.15, 0.06, 0.1), (0.0, -0.3), 0.7),
    ("cyl", (0.04, 0.12), (0.3, -0.3), 0.0),
    ("box", (0.1, 0.1, 0.2), (0.6, -0.3), 0.3),
    ("cyl", (0.06, 0.1), (-0.6, 0.3), 0.0),
    ("box", (0.14, 0.09, 0.12), (-0.3, 0.3), -0.5),
    ("cyl", (0.03, 0.2), (0.0, 0.3), 0.0),
    ("box", (0.08, 0.13, 0.09), (0.3, 0.3), 1.2),
    ("box", (0.12, 0.12, 0.05), (0.6, 0.3), 0.0),
]


# ---------------------------------------------------------------- synthetic clouds

def noisy(rng: np.random.Generator, pts: np.ndarray, noise: float = NOISE) -> np.ndarray:
    """Points moved by Gaussian noise of sigma noise/4 per coordinate, each step's length clipped to
    0.75 noise (every point stays within ``noise`` of its surface)."""
    step = rng.normal(0.0, noise / 4.0, pts.shape)
    norm = np.linalg.norm(step, axis=1, keepdims=True)
    return np.asarray(pts + step * np.minimum(1.0, 0.75 * noise / np.maximum(norm, 1e-300)), dtype=float)


def patch(rng: np.random.Generator, x: tuple[float, float], y: tuple[float, float], z: float,
          density: float = DENSITY) -> np.ndarray:
    """A horizontal rectangle's surface points."""
    n = round(density * (x[1] - x[0]) * (y[1] - y[0]))
    return np.column_stack([rng.uniform(*x, n), rng.uniform(*y, n), np.full(n, z)])


def box_surface(rng: np.random.Generator, size: tuple[float, ...], xy: tuple[float, float], base: float,
                yaw: float, n: int | None = None, density: float = DENSITY) -> np.ndarray:
    """The 5 visible faces (not the bottom) of a box standing at ``base``, turned by ``yaw``."""
    sx, sy, sz = size
    faces = [(2, 1.0, sx * sy), (0, 1.0, sy * sz), (0, -1.0, sy * sz), (1, 1.0, sx * sz), (1, -1.0, sx * sz)]
    areas = np.array([f[2] for f in faces])
    n = round(density * areas.sum()) if n is None else n
    which = rng.choice(len(faces), size=n, p=areas / areas.sum())
    local = rng.uniform(-0.5, 0.5, (n, 3)) * np.array(size)
    for k, (axis, sign, _) in enumerate(faces):
        local[which == k, axis] = sign * np.array(size)[axis] / 2
    c, s = math.cos(yaw), math.sin(yaw)
    world = local @ np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
    return np.asarray(world + np.array([xy[0], xy[1], base + sz / 2]), dtype=float)


def cylinder_surface(rng: np.random.Generator, radius: float, height: float, xy: tuple[float, float],
                     base: float, n: int | None = None, density: float = DENSITY) -> np.ndarray:
    """The side and top of an upright cylinder standing at ``base``."""
    side, top = 2 * math.pi * radius * height, math.pi * radius**2
    n = round(density * (side + top)) if n is None else n
    on_top = rng.random(n) < top / (side + top)
    a = rng.uniform(0, 2 * math.pi, n)
    r = np.where(on_top, radius * np.sqrt(rng.random(n)), radius)
    z = np.where(on_top, height, rng.uniform(0, height, n))
    return np.column_stack([xy[0] + r * np.cos(a), xy[1] + r * np.sin(a), base + z])


def table_scene(rng: np.random.Generator, density: float = DENSITY) -> tuple[np.ndarray, np.ndarray]:
    """Floor (label -1, z = 0), table top (-2, z = TABLE_Z) and OBJECTS (0..9) on it: points, labels."""
    parts = [patch(rng, (-2.0, 2.0), (-2.0, 2.0), 0.0, density),
             patch(rng, (-0.8, 0.8), (-0.6, 0.6), TABLE_Z, density)]
    labels = [np.full(len(parts[0]), -1), np.full(len(parts[1]), -2)]
    for k, (kind, dims, xy, yaw) in enumerate(OBJECTS):
        if kind == "box":
            pts = box_surface(rng, dims, xy, TABLE_Z, yaw, density=density)
        else:
            pts = cylinder_surface(rng, dims[0], dims[1], xy, TABLE_Z, density=density)
        parts.append(pts)
        labels.append(np.full(len(pts), k))
    return noisy(rng, np.vstack(parts)), np.concatenate(labels)


# ---------------------------------------------------------------- checkers of the guarantee

def box_holds(box: dict[str, Any], pts: np.ndarray, noise: float) -> bool:
    """Every point's ball of radius ``noise`` inside the oriented box."""
    rot = quat_matrix(box["orientation"])
    local = (pts - np.array(box["position"])) @ rot
    return bool((np.abs(local) <= np.array(box["shape"]["size"]) / 2 - noise + 1e-9).all())


def facets(mesh: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Unit outward normals and offsets of a mesh's triangles (as wound)."""
    v, t = mesh
    n = np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    return n, np.einsum("ij,ij->i", n, v[t[:, 0]])


def hull_holds(mesh: tuple[np.ndarray, np.ndarray], pts: np.ndarray, noise: float) -> bool:
    """Every point at least ``noise`` inside every facet of the (convex) mesh."""
    n, d = facets(mesh)
    return bool((pts @ n.T - d <= -noise + 1e-9).all())


def voxels_hold(boxes: list[dict[str, Any]], pts: np.ndarray, noise: float) -> bool:
    """Every point's cube of half-side ``noise`` (which holds its ball) inside the union of the axis-aligned
    boxes: the cube is cut at every box face crossing it, and each piece's centre must be in some box."""
    lo = np.array([np.array(b["position"]) - np.array(b["shape"]["size"]) / 2 for b in boxes]) - 1e-9
    hi = np.array([np.array(b["position"]) + np.array(b["shape"]["size"]) / 2 for b in boxes]) + 1e-9
    for p in pts:
        a, b = p - noise, p + noise
        near = np.flatnonzero((lo <= b).all(axis=1) & (hi >= a).all(axis=1))
        if len(near) == 0:
            return False
        cuts = []
        for axis in range(3):
            inner = np.concatenate([lo[near, axis], hi[near, axis]])
            crossing = inner[(inner > a[axis]) & (inner < b[axis])]
            cuts.append(np.unique(np.concatenate([[a[axis], b[axis]], crossing])))
        mids = [(c[1:] + c[:-1]) / 2 for c in cuts]
        centres = np.stack(np.meshgrid(*mids, indexing="ij"), -1).reshape(-1, 3)
        inside = (centres[:, None] >= lo[near]) & (centres[:, None] <= hi[near])
        if not np.all(np.any(np.all(inside, axis=2), axis=1)):
            return False
    return True


def check_mesh(mesh: tuple[np.ndarray, np.ndarray]) -> None:
    """A closed, outward-wound, non-degenerate convex mesh whose volume_of matches qhull's."""
    v, t = mesh
    assert v.shape[1] == 3 and t.shape[1] == 3 and len(t) >= 4
    edges = np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert (counts == 2).all()                      # closed: every edge in two triangles
    n, d = facets(mesh)
    assert (v @ n.T - d <= 1e-9).all()              # convex and wound outward
    assert volume_of(mesh) > 0.0
    assert volume_of(mesh) == pytest.approx(ConvexHull(v).volume, rel=1e-9)


def all_hold(pts: np.ndarray, noise: float, side: float) -> None:
    """The three covers of ``pts`` each hold every point grown by ``noise``."""
    assert box_holds(box_cover(pts, noise), pts, noise)
    mesh = hull_cover(pts, noise)
    check_mesh(mesh)
    assert hull_holds(mesh, pts, noise)
    assert voxels_hold(voxel_cover(pts, noise, side), pts, noise)


# ---------------------------------------------------------------- supports

def test_floor_and_table_found_at_their_heights() -> None:
    """The floor and the table top, at their heights within the noise, each holding its own points only; the
    same planes again with the default generator."""
    rng = np.random.default_rng(1)
    pts, labels = table_scene(rng, density=4000.0)
    planes = find_supports(pts, NOISE)
    assert len(planes) == 2
    floor, table = planes                            # largest first
    for plane, z, label in ((floor, 0.0, -1), (table, TABLE_Z, -2)):
        assert plane.normal[2] > math.cos(0.01) and plane.normal[2] > 0
        assert plane.offset / plane.normal[2] == pytest.approx(z, abs=NOISE)
        assert (np.abs(pts[plane.inliers, 2] - z) <= NOISE).all()      # table and floor kept apart
        own = labels == label
        assert own[plane.inliers].mean() > 0.95 and own[plane.inliers].sum() > 0.99 * own.sum()
    again = find_supports(pts, NOISE)                 # deterministic with the default generator
    assert all(np.array_equal(a.inliers, b.inliers) for a, b in zip(planes, again, strict=True))


def test_two_tables_at_one_height_are_two_supports() -> None:
    """Two tables at one height, apart, are two supports (split in the plane); ``most`` bounds the count."""
    rng = np.random.default_rng(2)
    pts = noisy(rng, np.vstack([patch(rng, (-2, 2), (-1, 1), 0.0),
                                patch(rng, (-1.2, -0.2), (-0.5, 0.5), TABLE_Z),
                                patch(rng, (0.2, 1.0), (-0.5, 0.5), TABLE_Z)]))
    planes = find_supports(pts, NOISE)
    assert len(planes) == 3
    tops = [p for p in planes if abs(p.offset / p.normal[2] - TABLE_Z) <= NOISE]
    assert len(tops) == 2
    xs = sorted((pts[p.inliers, 0].min(), pts[p.inliers, 0].max()) for p in tops)
    assert xs[0][1] < -0.19 and xs[1][0] > 0.19     # one table each
    assert [len(p.inliers) for p in planes] == sorted((len(p.inliers) for p in planes), reverse=True)
    assert len(find_supports(pts, NOISE, most=1)) == 1


def test_tilt_bound() -> None:
    """A plane tilted within ``max_tilt`` is found with its tilt; a steeper one (a ramp) is no support at all,
    not even as horizontal bands across it."""
    rng = np.random.default_rng(3)
    flat = patch(rng, (-1, 1), (-1, 1), 0.0)
    for tilt, found in ((0.1, True), (0.3, False)):
        c, s = math.cos(tilt), math.sin(tilt)
        pts = noisy(rng, flat @ np.array([[c, 0, -s], [0, 1, 0], [s, 0, c]]))
        planes = find_supports(pts, NOISE)
        assert bool(planes) == found
        if found:
            assert math.acos(planes[0].normal[2]) == pytest.approx(tilt, abs=0.01)
            assert len(planes[0].inliers) > 0.99 * len(pts)


def test_small_patches_stay_with_the_objects() -> None:
    """A coplanar patch of fewer than ``min_points`` points, apart from the floor, is in no Plane."""
    rng = np.random.default_rng(4)
    big = patch(rng, (-1, 1), (-1, 1), 0.0)
    small = patch(rng, (2.0, 2.1), (0, 0.1), 0.0)    # coplanar, apart, fewer than min_points
    planes = find_supports(noisy(rng, np.vstack([big, small])), NOISE)
    assert len(planes) == 1 and planes[0].inliers.max() < len(big)


# ---------------------------------------------------------------- clusters

def same_partition(found: np.ndarray, truth: np.ndarray) -> bool:
    """Whether two labellings group the points alike (a bijection between labels)."""
    pairs = np.unique(np.column_stack([found, truth]), axis=0)
    return len(pairs) == len(np.unique(found)) == len(np.unique(truth))


def test_clusters_are_the_objects() -> None:
    """With the supports removed, the clusters are exactly the objects on the table."""
    rng = np.random.default_rng(5)
    pts, labels = table_scene(rng, density=4000.0)
    rest = np.ones(len(pts), dtype=bool)
    for plane in find_supports(pts, NOISE):
        rest[plane.inliers] = False
    assert (labels[rest] >= 0).all()
    found = clusters(pts[rest], 0.02)
    assert found.min() == 0 and found.max() == len(OBJECTS) - 1
    assert same_partition(found, labels[rest])


def test_200k_points_clustered_dense_and_sparse_alike() -> None:
    """200,000 points in 20 blobs: the dense grid path, and the sparse path (blobs moved far apart), both find
    the blobs."""
    rng = np.random.default_rng(6)
    centres = np.array([(x, y, z) for x in range(5) for y in range(2) for z in range(2)]) * 0.5
    truth = np.repeat(np.arange(len(centres)), 10_000)
    pts = centres[truth] + rng.uniform(-0.15, 0.15, (len(truth), 3))
    dense = clusters(pts, 0.02)
    assert same_partition(dense, truth)
    far = pts + (truth[:, None] % 3) * np.array([[40.0, 0.0, 0.0]])   # grid too large: the sparse path
    assert same_partition(clusters(far, 0.02), truth)


def test_cluster_gap_is_never_split_and_far_apart_never_joined() -> None:
    """Points closer than ``gap`` always share a cluster, points beyond ``2 sqrt(3) gap`` never do; a chain of
    steps below ``gap`` is one cluster."""
    rng = np.random.default_rng(7)
    gap = 0.05
    for _ in range(200):
        a = rng.uniform(-1, 1, 3)
        step = rng.normal(size=3)
        near = a + step / np.linalg.norm(step) * gap * 0.999
        far = a + step / np.linalg.norm(step) * gap * 2 * math.sqrt(3) * 1.001
        assert clusters(np.vstack([a, near]), gap).tolist() == [0, 0]
        assert sorted(clusters(np.vstack([a, far]), gap).tolist()) == [0, 1]
    chain = np.column_stack([np.arange(100) * 0.049, np.zeros(100), np.zeros(100)])
    assert (clusters(chain, 0.05) == 0).all()
    assert clusters(np.zeros((0, 3)), 0.05).shape == (0,)
    with pytest.raises(ValueError):
        clusters(chain, 0.0)


# ---------------------------------------------------------------- covers

def test_covers_hold_object_clusters() -> None:
    """Box, hull and voxel covers of every object (boxes turned in yaw, cylinders) hold each point grown by
    the noise."""
    rng = np.random.default_rng(8)
    for kind, dims, xy, yaw in OBJECTS:
        if kind == "box":
            pts = box_surface(rng, dims, xy, TABLE_Z, yaw, n=600)
        else:
            pts = cylinder_surface(rng, dims[0], dims[1], xy, TABLE_Z, n=600)
        all_hold(noisy(rng, pts), NOISE, 0.02)


@pytest.mark.parametrize("pts", [
    np.array([[0.1, 0.2, 0.3]]),
    np.array([[0.0, 0.0, 0.0], [0.1, 0.05, 0.02]]),
    np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]),
    np.outer(np.linspace(0, 1, 10), [0.1, -0.2, 0.3]),
    np.array([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0]], dtype=float),
    np.column_stack([np.random.default_rng(9).uniform(-0.1, 0.1, (50, 2)), np.full(50, 0.5)]),
    np.column_stack([np.random.default_rng(10).uniform(-0.1, 0.1, 50), np.zeros(50),
                     np.random.default_rng(11).uniform(0, 0.2, 50)]),
], ids=["1 point", "2 points", "2 equal", "collinear", "3 points", "horizontal", "vertical"])
def test_covers_hold_degenerate_clusters(pts: np.ndarray) -> None:
    """Degenerate clusters still get safe covers and a solid hull, with noise and without."""
    all_hold(pts, NOISE, 0.02)
    mesh = hull_cover(pts, 0.0)                     # no noise: still a solid hull
    check_mesh(mesh)
    assert hull_holds(mesh, pts, 0.0)


def test_checkers_catch_a_shrunk_cover() -> None:
    """The checkers are not vacuous: a cover shrunk a little, or missing a box, or asked to hold more noise,
    fails them."""
    rng = np.random.default_rng(12)
    pts = noisy(rng, box_surface(rng, (0.2, 0.1, 0.15), (0.3, 0.1), 0.0, 0.4, n=800))
    box = box_cover(pts, NOISE)
    shrunk = {**box, "shape": {"type": "box", "size": [s - NOISE / 2 for s in box["shape"]["size"]]}}
    assert box_holds(box, pts, NOISE) and not box_holds(shrunk, pts, NOISE)
    v, t = hull_cover(pts, NOISE)
    centre = v.mean(axis=0)
    assert hull_holds((v, t), pts, NOISE) and not hull_holds((centre + (v - centre) * 0.99, t), pts, NOISE)
    boxes = voxel_cover(pts, NOISE, 0.02)
    assert voxels_hold(boxes, pts, NOISE)
    assert not voxels_hold(boxes[1:], pts, NOISE)
    assert not voxels_hold(boxes, pts, NOISE * 1.6)


def test_box_cover_of_a_turned_box_is_tight() -> None:
    """The box cover of a turned box's surface finds its yaw and is within 1.5x of its volume (ratio
    printed)."""
    rng = np.random.default_rng(13)
    size, yaw = (0.3, 0.2, 0.15), 0.6
    pts = noisy(rng, box_surface(rng, size, (0.4, -0.2), 0.75, yaw, n=3000))
    box = box_cover(pts, NOISE)
    ratio = volume_of(box) / math.prod(size)
    print(f"box_cover / true box volume: {ratio:.3f}")
    assert 1.0 < ratio < 1.5
    assert box_holds(box, pts, NOISE)
    turned = 2 * math.atan2(box["orientation"][2], box["orientation"][3])
    assert min(abs((turned - yaw + math.pi / 4) % (math.pi / 2) - math.pi / 4), 1.0) < 0.02
    assert box["position"][2] == pytest.approx(0.75 + 0.075, abs=NOISE)


def test_voxel_cover_merges_and_fills() -> None:
    """Voxels merge into few disjoint boxes; filled columns hold the solid, the shell only the surface."""
    rng = np.random.default_rng(14)
    pts = noisy(rng, box_surface(rng, (0.2, 0.1, 0.15), (0.0, 0.0), 0.0, 0.0, n=2000))
    side = 0.02
    filled, shell = voxel_cover(pts, NOISE, side), voxel_cover(pts, NOISE, side, fill=False)
    assert voxels_hold(shell, pts, NOISE)
    assert len(filled) <= 4                           # a solid box's columns: merged into a few boxes
    assert len(shell) < volume_of(shell) / side**3 / 5  # far fewer boxes than voxels
    assert volume_of(filled) >= math.prod((0.2, 0.1, 0.15))
    assert volume_of(shell) < volume_of(filled)
    lo = np.array([np.array(b["position"]) - np.array(b["shape"]["size"]) / 2 for b in shell])
    hi = np.array([np.array(b["position"]) + np.array(b["shape"]["size"]) / 2 for b in shell])
    common = np.minimum(hi[:, None], hi[None]) - np.maximum(lo[:, None], lo[None])
    overlap = np.clip(common, 0, None).prod(axis=2)
    assert overlap.sum() - np.trace(overlap) < 1e-12  # disjoint boxes
    assert all(b["orientation"] == [0.0, 0.0, 0.0, 1.0] for b in filled)


def test_tightest_picks_by_volume() -> None:
    """The hull for a can, the box for a brick (within the slack), voxels for an L; ``slack=0`` is the strict
    least."""
    rng = np.random.default_rng(15)
    can = noisy(rng, cylinder_surface(rng, 0.08, 0.2, (0.0, 0.0), 0.0, n=4000))
    assert tightest(can, NOISE, 0.02)[0] == "hull"
    brick = noisy(rng, box_surface(rng, (0.2, 0.1, 0.15), (0.0, 0.0), 0.0, 0.5, n=4000))
    kind, cover = tightest(brick, NOISE, 0.02)
    assert kind == "box" and volume_of(cover) < 1.3 * 0.2 * 0.1 * 0.15
    ell = noisy(rng, np.vstack([box_surface(rng, (0.4, 0.06, 0.1), (0.0, 0.0), 0.0, 0.0, n=3000),
                                box_surface(rng, (0.06, 0.4, 0.1), (0.17, 0.17), 0.0, 0.0, n=3000)]))
    kind, cover = tightest(ell, NOISE, 0.01)
    assert kind == "voxels" and isinstance(cover, list) and voxels_hold(cover, ell[::10], NOISE)
    assert tightest(can, NOISE, 0.02, hull=False)[0] != "hull"  # a hull that cannot be written is no choice
    strict = tightest(brick, NOISE, 0.02, slack=0.0)
    covers: dict[str, Cover] = {"box": box_cover(brick, NOISE), "hull": hull_cover(brick, NOISE),
              "voxels": voxel_cover(brick, NOISE, 0.02)}
    assert volume_of(strict[1]) == pytest.approx(min(volume_of(c) for c in covers.values()))


@pytest.mark.parametrize("dim", [2, 3])
def test_hull_candidates_keep_every_hull_vertex(dim: int) -> None:
    """The filtered points' hull is the points' hull (same vertices) on a ball, a box's sampled surface with
    many coplanar points, and a flat set it cannot filter; without the boundary points the volume agrees."""
    rng = np.random.default_rng(21)
    flat = np.column_stack([rng.random((500, dim - 1)), np.zeros(500)])
    box = box_surface(rng, (0.2, 0.1, 0.15), (0.0, 0.0), 0.3, 0.0, n=5000)[:, :dim]
    for pts in (rng.normal(size=(20_000, dim)), box, np.round(box, 2), flat):
        kept = hull_candidates(pts)
        assert len(kept) <= len(pts)
        try:
            truth = ConvexHull(pts)
        except QhullError:  # a flat set: qhull refuses it, and it is returned whole
            assert len(kept) == len(pts)
            continue
        assert {tuple(v) for v in pts[truth.vertices]} == {tuple(v) for v in kept[ConvexHull(kept).vertices]}
        loose = ConvexHull(hull_candidates(pts, boundary=False))
        assert loose.volume == pytest.approx(truth.volume, rel=1e-9)
    big = rng.normal(size=(20_000, dim))
    assert len(hull_candidates(big)) < len(big) / 10  # it filters


def test_voxel_rows_far_from_the_origin() -> None:
    """Voxel covers of a cluster far from the world origin (large voxel indices) hold its points."""
    rng = np.random.default_rng(22)
    pts = noisy(rng, box_surface(rng, (0.2, 0.1, 0.15), (-40.0, 35.0), 7.0, 0.4, n=2000))
    for fill in (True, False):
        assert voxels_hold(voxel_cover(pts, NOISE, 0.01, fill=fill), pts, NOISE)


# ---------------------------------------------------------------- shadow

def test_shadow_reaches_the_floor() -> None:
    """A box's shadow from a sensor above and aside ends on the floor, as far as similar triangles say, and
    holds a point hidden behind the box."""
    rng = np.random.default_rng(16)
    pts = noisy(rng, box_surface(rng, (0.2, 0.2, 0.3), (0.0, 0.0), 0.0, 0.0, n=2000))
    floor = Plane(np.array([0.0, 0.0, 1.0]), 0.0, np.zeros(0, dtype=np.intp))
    sensor = np.array([2.0, 0.0, 1.5])
    region = shadow(pts, sensor, floor, 10.0)
    assert len(region) == 2 * len(pts)
    ends = region[len(pts):]
    assert ends[:, 2].max() < 1e-9 and ends[:, 2].min() >= -NOISE          # every ray ends on the floor
    assert (np.abs(ends[:, 2]) < 1e-9)[pts[:, 2] >= 0].all()                # (a point below ends its own)
    # the top far edge's ray lands at x = -0.1 - 0.3 * (2.1 / 1.2) (similar triangles), y spread
    assert ends[:, 0].min() == pytest.approx(-0.1 - 0.3 * 2.1 / 1.2, abs=0.02)
    assert (np.linalg.norm(ends - sensor, axis=1) >= np.linalg.norm(pts - sensor, axis=1) - 1e-12).all()
    hidden = np.array([[-0.3, 0.0, 0.05]])          # behind the box on the floor, seen from the sensor
    assert hull_holds(hull_cover(region, 0.0), hidden, 0.0)


def test_shadow_without_floor_or_upward_goes_to_reach() -> None:
    """Rays that never meet the floor from above (level, upward, or the sensor below it) end at ``reach``; a
    downward ray ends on the floor."""
    pts = np.array([[1.0, 0.0, 1.0], [1.0, 0.0, 2.0]])
    sensor = np.array([0.0, 0.0, 1.0])
    floor = Plane(np.array([0.0, 0.0, 1.0]), 0.0, np.zeros(0, dtype=np.intp))
    for plane in (None, floor):                     # level and upward rays never meet the floor
        ends = shadow(pts, sensor, plane, 5.0)[2:]
        assert np.linalg.norm(ends - sensor, axis=1) == pytest.approx([5.0, 5.0])
    low = shadow(np.array([[1.0, 0.0, 0.5]]), sensor, floor, 5.0)[1]
    assert low == pytest.approx([2.0, 0.0, 0.0])
    behind = shadow(np.array([[1.0, 0.0, 0.5]]), np.array([0.0, 0.0, -1.0]), floor, 5.0)[1]
    assert np.linalg.norm(behind - [0.0, 0.0, -1.0]) == pytest.approx(5.0)
