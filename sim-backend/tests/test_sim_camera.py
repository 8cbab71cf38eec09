"""The stand-in depth camera (robwot_sim.sim.camera): depths against an independent ray caster of boxes
and spheres, points on the true surfaces of every primitive (compound bodies and moved links included),
the optical frame, ``ignore``, ``near`` and ``far``, the statistics of noise and dropout, refused cameras,
and a real robot's meshes."""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np
import pybullet as pb
import pybullet_data
import pytest

from robwot_sim.errors import InvalidParams
from robwot_sim.model.rotations import quat_matrix
from robwot_sim.sim.camera import Camera, camera_points, depth_image, depth_points, orientation, validated
from robwot_sim.sim.types import FloatArray

EXACT = 1e-6  # m
GROW = 1e-3  # m: shapes grown and shrunk by this mark the pixels at a silhouette or a contact

DOWN = {"position": (0.0, 0.0, 2.0), "target": (0.0, 0.0, 0.0), "up": (0.0, 1.0, 0.0)}
OBLIQUE = {"position": (1.6, 1.1, 1.4), "target": (0.0, 0.0, 0.3), "up": (0.0, 0.0, 1.0)}


@pytest.fixture
def cid() -> Iterator[int]:
    """A PyBullet DIRECT client of its own."""
    c = pb.connect(pb.DIRECT)
    yield c
    pb.disconnect(c)


def camera(pose: dict[str, Any], width: int = 120, height: int = 90, fov: float = math.radians(60),
           near: float = 0.1, far: float = 10.0) -> Camera:
    """A camera at a pose of ``DOWN`` / ``OBLIQUE`` form."""
    return Camera(np.array(pose["position"], dtype=float), np.array(pose["target"], dtype=float),
                  np.array(pose["up"], dtype=float), width, height, fov, near, far)


def add_box(cid: int, half: Sequence[float], pos: Sequence[float],
            quat: Sequence[float] = (0.0, 0.0, 0.0, 1.0)) -> int:
    """A static box of half extents ``half``, without a visual shape."""
    col = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=list(half), physicsClientId=cid)
    return int(pb.createMultiBody(baseMass=0, baseCollisionShapeIndex=col, baseVisualShapeIndex=-1,
                                  basePosition=list(pos), baseOrientation=list(quat), physicsClientId=cid))


def add_sphere(cid: int, radius: float, pos: Sequence[float]) -> int:
    """A static sphere, without a visual shape."""
    col = pb.createCollisionShape(pb.GEOM_SPHERE, radius=radius, physicsClientId=cid)
    return int(pb.createMultiBody(baseMass=0, baseCollisionShapeIndex=col, baseVisualShapeIndex=-1,
                                  basePosition=list(pos), physicsClientId=cid))


def world_rays(cam: Camera) -> FloatArray:
    """[height * width, 3] each pixel centre's ray in the world, scaled to unit depth: the pinhole of
    the camera's definition, rebuilt here."""
    f = cam.height / 2 / math.tan(cam.fov / 2)
    u, v = np.meshgrid((np.arange(cam.width) + 0.5 - cam.width / 2) / f,
                       (np.arange(cam.height) + 0.5 - cam.height / 2) / f)
    z = (cam.target - cam.position) / np.linalg.norm(cam.target - cam.position)
    x = np.cross(z, cam.up) / np.linalg.norm(np.cross(z, cam.up))
    y = np.cross(z, x)
    return np.asarray(u.reshape(-1, 1) * x + v.reshape(-1, 1) * y + z, dtype=np.float64)


# a shape of the independent caster: ("box", centre, rotation, half extents) or ("sphere", centre, r)
Shape = tuple[Any, ...]


def oracle(cam: Camera, shapes: list[Shape], grow: float = 0.0) -> tuple[FloatArray, FloatArray]:
    """[height, width] the depth of each ray's first entry into the shapes (grown by ``grow``), NaN
    where none lies before ``far``, and the index of that shape (-1: none)."""
    d = world_rays(cam)
    best, which = np.full(len(d), np.inf), np.full(len(d), -1)
    for i, shape in enumerate(shapes):
        if shape[0] == "box":
            _, c, rot, half = shape
            o, dl = rot.T @ (cam.position - c), d @ rot
            with np.errstate(divide="ignore", invalid="ignore"):
                a, b = (-np.asarray(half) - grow - o) / dl, (np.asarray(half) + grow - o) / dl
            t0, t1 = np.fmin(a, b).max(axis=1), np.fmax(a, b).min(axis=1)
        else:
            _, c, r = shape
            o = cam.position - c
            qa, qb, qc = (d * d).sum(axis=1), d @ o, o @ o - (r + grow) ** 2
            disc = qb * qb - qa * qc
            root = np.sqrt(np.where(disc >= 0, disc, np.nan))
            t0, t1 = (-qb - root) / qa, (-qb + root) / qa
        first = (t0 <= t1) & (t0 > 0) & (t0 < best)
        best, which = np.where(first, t0, best), np.where(first, i, which)
    which[best > cam.far] = -1
    best[best > cam.far] = np.inf
    shape = (cam.height, cam.width)
    return np.where(np.isinf(best), np.nan, best).reshape(shape), which.reshape(shape)


def agrees(image: FloatArray, cam: Camera, shapes: list[Shape]) -> FloatArray:
    """Assert the image is the independent caster's away from silhouettes and contacts (to ``EXACT``):
    returns the mask of pixels where a shape grown or shrunk by ``GROW`` changes which is seen first,
    which must be few."""
    (_, grown), (_, shrunk) = oracle(cam, shapes, GROW), oracle(cam, shapes, -GROW)
    band = grown != shrunk
    truth = oracle(cam, shapes)[0]
    assert np.array_equal(np.isnan(image[~band]), np.isnan(truth[~band]))
    assert np.nanmax(np.abs(image[~band] - truth[~band])) < EXACT
    assert band.mean() < 0.05
    return np.asarray(band)


def floor(cid: int) -> tuple[int, Shape]:
    """A floor: a box whose top is z = 0."""
    return add_box(cid, (3.0, 3.0, 0.5), (0.0, 0.0, -0.5)), ("box", np.array([0, 0, -0.5]), np.eye(3),
                                                              (3.0, 3.0, 0.5))


def tower(cid: int, x: float = 0.0, y: float = 0.0) -> tuple[int, Shape]:
    """A 0.2 m box 0.5 high standing on the floor at (x, y)."""
    c = np.array([x, y, 0.25])
    return add_box(cid, (0.1, 0.1, 0.25), c), ("box", c, np.eye(3), (0.1, 0.1, 0.25))


def test_floor_and_box_seen_straight_down(cid: int) -> None:
    """Straight down from 2 m: the floor reads 2.0 in every pixel, a 0.5 m box on it 1.5, in the pixels
    the independent caster says (an image of more rays than one batch of PyBullet's)."""
    cam = camera(DOWN, 161, 121)
    _, ground = floor(cid)
    image = depth_image(cid, cam)
    assert image.shape == (121, 161) and np.abs(image - 2.0).max() < EXACT
    _, box = tower(cid)
    image = depth_image(cid, cam)
    assert abs(image[60, 80] - 1.5) < EXACT
    agrees(image, cam, [ground, box])
    on_box = np.abs(image - 1.5) < EXACT
    assert on_box.sum() > 100 and (on_box | (np.abs(image - 2.0) < EXACT)).all()


def test_optical_frame(cid: int) -> None:
    """x right, y down, z along the view: from above with +y world up the image, a box at +x is right
    of the centre, a box at +y above it; the quaternion rotates the optical axes onto those."""
    cam = camera(DOWN, 61, 61)
    floor(cid)
    tower(cid, x=0.5)
    tower(cid, y=0.5)
    image = depth_image(cid, cam)
    rows, cols = np.nonzero(np.abs(image - 1.5) < EXACT)
    right, up = cols > 35, rows < 25
    assert right.any() and up.any() and not (right & up).any()
    assert (np.abs(rows[right] - 30) <= 5).all() and (np.abs(cols[up] - 30) <= 5).all()
    assert np.allclose(quat_matrix(orientation(cam)), [[1, 0, 0], [0, -1, 0], [0, 0, -1]], atol=1e-12)
    oblique = camera(OBLIQUE)
    rot = quat_matrix(orientation(oblique))
    view = (oblique.target - oblique.position) / np.linalg.norm(oblique.target - oblique.position)
    assert np.allclose(rot[:, 2], view) and abs(rot[:, 0] @ oblique.up) < 1e-12
    assert rot[:, 1] @ oblique.up < 0 and np.isclose(np.linalg.det(rot), 1.0)


def scene(cid: int) -> list[Shape]:
    """Floor, a box, a turned box, a sphere and a compound body of two boxes and a sphere; their shapes
    for the independent caster."""
    shapes = [floor(cid)[1], tower(cid, 0.3, -0.2)[1]]
    q = pb.getQuaternionFromEuler([0.3, -0.2, 0.8])
    add_box(cid, (0.15, 0.1, 0.08), (-0.3, 0.35, 0.25), q)
    shapes.append(("box", np.array([-0.3, 0.35, 0.25]), quat_matrix(q), (0.15, 0.1, 0.08)))
    add_sphere(cid, 0.15, (-0.2, -0.4, 0.15))
    shapes.append(("sphere", np.array([-0.2, -0.4, 0.15]), 0.15))
    base = np.array([0.5, 0.4, 0.0])
    offsets = [(0.0, 0.0, 0.1), (0.2, 0.0, 0.05), (0.0, 0.25, 0.12)]
    col = pb.createCollisionShapeArray(
        shapeTypes=[pb.GEOM_BOX, pb.GEOM_BOX, pb.GEOM_SPHERE], radii=[0.0, 0.0, 0.12],
        halfExtents=[[0.1, 0.1, 0.1], [0.05, 0.08, 0.05], [0.0, 0.0, 0.0]], lengths=[0.0, 0.0, 0.0],
        collisionFramePositions=[list(o) for o in offsets], physicsClientId=cid)
    pb.createMultiBody(baseMass=0, baseCollisionShapeIndex=col, baseVisualShapeIndex=-1,
                       basePosition=list(base), physicsClientId=cid)
    shapes += [("box", base + offsets[0], np.eye(3), (0.1, 0.1, 0.1)),
               ("box", base + offsets[1], np.eye(3), (0.05, 0.08, 0.05)),
               ("sphere", base + offsets[2], 0.12)]
    return shapes


def test_oblique_scene_matches_an_independent_caster(cid: int) -> None:
    """Seen at an angle, boxes (turned, in a compound) and spheres read the exact depths of an
    independent ray caster, and cover the same pixels away from silhouettes; every shape is seen."""
    cam = camera(OBLIQUE, 160, 120)
    shapes = scene(cid)
    image = depth_image(cid, cam)
    agrees(image, cam, shapes)
    for shape in shapes:
        assert np.isfinite(oracle(cam, [shape])[0]).any()


def box_distance(p: FloatArray, c: FloatArray, rot: FloatArray, half: Sequence[float]) -> FloatArray:
    """Signed distance of points to a turned box."""
    q = np.abs((p - c) @ rot) - np.asarray(half)
    return np.asarray(np.linalg.norm(np.maximum(q, 0), axis=1) + np.minimum(q.max(axis=1), 0))


def test_points_lie_on_the_surfaces(cid: int) -> None:
    """The world points of a noise-free image lie on the surfaces (to ``EXACT``): the scene's boxes and
    spheres, an upright cylinder, and a capsule on a link turned by its joint, placed from the link's
    own frame; each of them gets points."""
    shapes = scene(cid)
    col = pb.createCollisionShape(pb.GEOM_CYLINDER, radius=0.1, height=0.4, physicsClientId=cid)
    pb.createMultiBody(0, col, -1, [0.6, -0.5, 0.2], physicsClientId=cid)
    cap = pb.createCollisionShape(pb.GEOM_CAPSULE, radius=0.06, height=0.3,
                                  collisionFramePosition=[0, 0.05, 0], physicsClientId=cid)
    foot = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[0.05, 0.05, 0.05], physicsClientId=cid)
    arm = pb.createMultiBody(
        0, foot, -1, [-0.6, -0.1, 0.05], linkMasses=[1.0], linkCollisionShapeIndices=[cap],
        linkVisualShapeIndices=[-1], linkPositions=[[0, 0, 0.3]], linkOrientations=[[0, 0, 0, 1]],
        linkInertialFramePositions=[[0.01, 0.02, 0.03]],
        linkInertialFrameOrientations=[list(pb.getQuaternionFromEuler([0, 0.3, 0]))],
        linkParentIndices=[0], linkJointTypes=[pb.JOINT_REVOLUTE], linkJointAxis=[[1, 0, 0]],
        physicsClientId=cid)
    pb.resetJointState(arm, 0, 0.7, physicsClientId=cid)
    cam = camera(OBLIQUE, 200, 150)
    points = depth_points(depth_image(cid, cam), cam)
    dist = []
    for shape in shapes:
        if shape[0] == "box":
            dist.append(box_distance(points, shape[1], shape[2], shape[3]))
        else:
            dist.append(np.linalg.norm(points - shape[1], axis=1) - shape[2])
    dist.append(box_distance(points, np.array([-0.6, -0.1, 0.05]), np.eye(3), (0.05, 0.05, 0.05)))
    rel = points - np.array([0.6, -0.5, 0.2])
    radial = np.hypot(rel[:, 0], rel[:, 1]) - 0.1
    dist.append(np.minimum(np.maximum(radial, np.abs(rel[:, 2]) - 0.2), 0)
                + np.hypot(np.maximum(radial, 0), np.maximum(np.abs(rel[:, 2]) - 0.2, 0)))
    state = pb.getLinkState(arm, 0, computeForwardKinematics=True, physicsClientId=cid)
    frame, turn = np.asarray(state[4]), quat_matrix(state[5])  # the link's own frame in the world
    axis = turn[:, 2]
    centre = frame + turn @ np.array([0, 0.05, 0])
    along = np.clip((points - centre) @ axis, -0.15, 0.15)
    dist.append(np.linalg.norm(points - centre - along[:, None] * axis, axis=1) - 0.06)
    table = np.abs(np.array(dist))
    assert table.min(axis=0).max() < EXACT
    assert ((table < EXACT).sum(axis=1) > 20).all()


def test_camera_points_are_depth_points_in_the_optical_frame(cid: int) -> None:
    """Placed at the camera's position and orientation, its optical-frame points are the world points;
    their z is the depth."""
    scene(cid)
    cam = camera(OBLIQUE)
    image = depth_image(cid, cam)
    local, world = camera_points(image, cam), depth_points(image, cam)
    assert len(local) == np.isfinite(image).sum() > 1000
    assert np.allclose(cam.position + local @ quat_matrix(orientation(cam)).T, world, rtol=0, atol=1e-9)
    assert np.array_equal(local[:, 2], image[np.isfinite(image)])


def test_ignore_drops_a_body(cid: int) -> None:
    """A body in ``ignore`` returns nothing where it is seen (it is not looked through); the other
    pixels are unchanged."""
    cam = camera(DOWN)
    floor(cid)
    box, _ = tower(cid)
    image, without = depth_image(cid, cam), depth_image(cid, cam, ignore=[box])
    on_box = np.abs(image - 1.5) < EXACT
    assert on_box.sum() > 50 and np.isnan(without[on_box]).all()
    assert np.array_equal(without[~on_box], image[~on_box])


def test_near_and_far(cid: int) -> None:
    """Returns beyond ``far`` or nearer than ``near`` (depths) are dropped; a body parked thousands of
    metres away is never hit."""
    floor(cid)
    tower(cid)
    on_box = np.abs(depth_image(cid, camera(DOWN)) - 1.5) < EXACT
    cut = depth_image(cid, camera(DOWN, far=1.9))
    assert np.isnan(cut[~on_box]).all() and np.isfinite(cut[on_box]).all()
    assert np.isnan(depth_image(cid, camera(DOWN, far=1.4))).all()
    close = depth_image(cid, camera(DOWN, near=1.6))
    assert np.isnan(close[on_box]).all() and np.isfinite(close[~on_box]).all()
    ahead = {"position": (0.0, 0.0, 10.0), "target": (1.0, 0.0, 10.0), "up": (0.0, 0.0, 1.0)}
    wall = add_box(cid, (10.0, 50.0, 50.0), (60.0, 0.0, 10.0))
    assert np.isfinite(depth_image(cid, camera(ahead, far=100.0))).all()
    pb.resetBasePositionAndOrientation(wall, [5000.0, 0.0, 10.0], [0, 0, 0, 1], physicsClientId=cid)
    assert np.isnan(depth_image(cid, camera(ahead, far=100.0))).all()


def test_dropout_drops_its_share(cid: int) -> None:
    """Dropout 0.3 drops 30 % of 10,800 pixels within six binomial standard deviations (fixed seed);
    0 drops none, 1 all."""
    cam = camera(DOWN)
    floor(cid)
    n = cam.width * cam.height
    dropped = np.isnan(depth_image(cid, cam, dropout=0.3, rng=np.random.default_rng(7))).sum()
    assert abs(dropped - 0.3 * n) < 6 * math.sqrt(n * 0.3 * 0.7)
    assert np.isfinite(depth_image(cid, cam, dropout=0.0, rng=np.random.default_rng(7))).all()
    assert np.isnan(depth_image(cid, cam, dropout=1.0, rng=np.random.default_rng(7))).all()


def test_noise_has_its_stated_deviation(cid: int) -> None:
    """Noise of 5 mm has a standard deviation of 5 mm at 1 m and 20 mm at 2 m (quadratic growth; fixed
    seed, within 5 %, ten standard errors), no bias, and moves each point along its pixel's ray."""
    floor(cid)
    for height in (1.0, 2.0):
        pose = {**DOWN, "position": (0.0, 0.0, height)}
        cam = camera(pose, 160, 120)
        noisy = depth_image(cid, cam, noise=0.005, rng=np.random.default_rng(11))
        sigma = 0.005 * height**2
        assert np.isfinite(noisy).all()
        assert abs(noisy.std() / sigma - 1) < 0.05
        assert abs(noisy.mean() - height) < 6 * sigma / math.sqrt(noisy.size)
        clean, moved = camera_points(depth_image(cid, cam), cam), camera_points(noisy, cam)
        assert np.allclose(moved[:, :2] / moved[:, 2:], clean[:, :2] / clean[:, 2:], rtol=0, atol=1e-12)


BAD: list[tuple[dict[str, Any], str]] = [
    ({"position": np.array([0.0, np.nan, 2.0])}, "camera.position"),
    ({"position": np.array([0.0, 2.0])}, "camera.position"),
    ({"target": np.array([0.0, 0.0, np.inf])}, "camera.target"),
    ({"target": np.array([0.0, 0.0, 2.0])}, "camera.target"),
    ({"up": np.array([0.0, 0.0, 1.0])}, "camera.up"),
    ({"up": np.array([0.0, 0.0, 0.0])}, "camera.up"),
    ({"width": 0}, "camera.width"),
    ({"width": 4097}, "camera.width"),
    ({"width": 64.0}, "camera.width"),
    ({"height": 0}, "camera.height"),
    ({"fov": 0.0}, "camera.fov"),
    ({"fov": math.pi}, "camera.fov"),
    ({"fov": math.nan}, "camera.fov"),
    ({"near": -0.1}, "camera.near"),
    ({"near": 10.0}, "camera.near"),
    ({"far": 101.0}, "camera.far"),
    ({"far": math.inf}, "camera.far"),
]


@pytest.mark.parametrize(("change", "param"), BAD)
def test_invalid_cameras_are_refused(cid: int, change: dict[str, Any], param: str) -> None:
    """A camera with a bad field is refused with InvalidParams naming that field."""
    bad = camera(DOWN)._replace(**change)
    with pytest.raises(InvalidParams) as err:
        validated(bad)
    assert err.value.data["param"] == param
    with pytest.raises(InvalidParams):
        depth_image(cid, bad)


def test_invalid_noise_dropout_and_image_are_refused(cid: int) -> None:
    """Negative or non-finite noise, a dropout outside [0, 1], and an image of the wrong size are
    refused with InvalidParams."""
    cam = camera(DOWN)
    for kwargs, param in (({"noise": -0.01}, "noise"), ({"noise": math.nan}, "noise"),
                          ({"dropout": 1.5}, "dropout")):
        with pytest.raises(InvalidParams) as err:
            depth_image(cid, cam, **kwargs)
        assert err.value.data["param"] == param
    with pytest.raises(InvalidParams) as err:
        depth_points(np.zeros((3, 4)), cam)
    assert err.value.data["param"] == "depth"


def test_rays_see_a_robot(cid: int) -> None:
    """The KUKA iiwa's links (meshes, Bullet's own depths) are seen: every point lies in a link's
    bounding box, many links are seen, and sampled points lie within Bullet's ray tolerance of the
    robot's collision geometry."""
    pb.setAdditionalSearchPath(pybullet_data.getDataPath(), physicsClientId=cid)
    robot = pb.loadURDF("kuka_iiwa/model.urdf", [0, 0, 0], useFixedBase=True, physicsClientId=cid)
    for joint, angle in enumerate([0.4, 0.7, 0.0, -1.2, 0.3, 0.9, 0.0]):
        pb.resetJointState(robot, joint, angle, physicsClientId=cid)
    cam = camera({"position": (1.2, 0.8, 1.0), "target": (0.2, 0.1, 0.5), "up": (0.0, 0.0, 1.0)}, 160, 120,
                 fov=math.radians(55))
    points = depth_points(depth_image(cid, cam), cam)
    assert len(points) > 0.04 * cam.width * cam.height
    links = range(-1, pb.getNumJoints(robot, physicsClientId=cid))
    inside = np.zeros((len(links), len(points)), dtype=bool)
    for i, link in enumerate(links):
        lo, hi = (np.asarray(v) for v in pb.getAABB(robot, link, physicsClientId=cid))
        inside[i] = ((points >= lo - 1e-3) & (points <= hi + 1e-3)).all(axis=1)
    assert inside.any(axis=0).all() and (inside.sum(axis=1) > 10).sum() >= 5
    probe = add_sphere(cid, 1e-3, (10.0, 10.0, 10.0))
    for p in points[np.random.default_rng(3).choice(len(points), 60, replace=False)]:
        pb.resetBasePositionAndOrientation(probe, p.tolist(), [0, 0, 0, 1], physicsClientId=cid)
        near = pb.getClosestPoints(probe, robot, 0.05, physicsClientId=cid)
        assert near and min(c[8] for c in near) + 1e-3 < 3e-3


def test_random_overlapping_scenes_match_an_independent_caster() -> None:
    """Fifteen seeded scenes of 3 to 8 turned boxes and spheres, overlapping and touching, seen from
    seeded viewpoints: the independent caster's depths away from silhouettes (surfaces less than Bullet's
    ray tolerance apart along a ray included)."""
    rng = np.random.default_rng(123)
    for _ in range(15):
        cid = pb.connect(pb.DIRECT)
        try:
            shapes = [floor(cid)[1]]
            for _ in range(rng.integers(3, 9)):
                c = rng.uniform([-0.8, -0.8, 0.0], [0.8, 0.8, 0.6])
                if rng.random() < 0.5:
                    half = rng.uniform(0.03, 0.25, 3)
                    q = pb.getQuaternionFromEuler(rng.uniform(-3, 3, 3).tolist())
                    add_box(cid, half, c, q)
                    shapes.append(("box", c, quat_matrix(q), tuple(half)))
                else:
                    r = rng.uniform(0.03, 0.3)
                    add_sphere(cid, r, c)
                    shapes.append(("sphere", c, r))
            d, az, el = rng.uniform(1.0, 3.0), rng.uniform(0, 2 * math.pi), rng.uniform(0.2, 1.4)
            pose = {"position": (d * math.cos(el) * math.cos(az), d * math.cos(el) * math.sin(az),
                                 d * math.sin(el) + 0.2),
                    "target": tuple(rng.uniform(-0.3, 0.3, 3) * [1, 1, 0] + [0, 0, 0.2]),
                    "up": (0.0, 0.0, 1.0)}
            cam = camera(pose, 160, 120, fov=math.radians(rng.uniform(30, 90)))
            agrees(depth_image(cid, cam), cam, shapes)
        finally:
            pb.disconnect(cid)
