"""COLLADA (DAE) meshes are read by our parser as PyBullet places them, so a concave DAE collision mesh
is decomposed like an STL or OBJ (and a convex one handed to PyBullet as our parsed hull)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pybullet as pb
import pytest

from robwot_bench.reference import example_robot_data
from robwot_sim.model.decompose import WHOLE_AS_PART
from robwot_sim.model.meshcheck import read_mesh
from robwot_sim.sim.world import World

#: PyBullet's AABB of a mesh link is the mesh's bounds grown by its collision margin and AABB slop
BULLET_AABB_GROWTH = 0.002

ROBOTS = example_robot_data() / "robots"


def bullet_reads_as_specified(dae: Path) -> bool:
    """PyBullet takes a node's first <matrix>, <translate>, <scale> and <rotate> in that order, not every
    transform in document order as COLLADA specifies (and three.js, the viewer, does): the same placement
    only where a node has at most one rotation and no non-uniform scale. Our reader follows the spec."""
    text = dae.read_text(errors="replace")
    nodes = text.split("<node")[1:]
    scales = [s.split("<")[0].split() for s in text.split("<scale")[1:]]
    return (all(n.split("</node>")[0].count("<rotate") <= 1 for n in nodes)
            and all(len(set(s[-3:])) == 1 for s in scales))


DAE_FILES = sorted(f for f in ROBOTS.glob("*/meshes/**/*.dae") if bullet_reads_as_specified(f))


def bullet_aabb(mesh: Path, tmp: Path) -> np.ndarray:
    """PyBullet's AABB of a one-link URDF whose collision is the mesh (it reads the DAE itself)."""
    urdf = tmp / f"{mesh.stem}.urdf"
    urdf.write_text(f'<robot name="r"><link name="a"><collision><geometry><mesh filename="{mesh}"/>'
                    "</geometry></collision></link></robot>")
    cid = pb.connect(pb.DIRECT)
    try:
        return np.array(pb.getAABB(pb.loadURDF(str(urdf), physicsClientId=cid), -1, physicsClientId=cid))
    finally:
        pb.disconnect(cid)


def test_the_robots_dae_files_are_many() -> None:
    assert len(DAE_FILES) >= 100, len(DAE_FILES)


@pytest.mark.parametrize("mesh", DAE_FILES[::4], ids=lambda p: f"{p.parent.parent.name}/{p.name}")
def test_our_dae_triangles_sit_where_pybullet_puts_them(mesh: Path, tmp_path: Path) -> None:
    """Bounds of the triangles we read = PyBullet's AABB of the same file (units, node transforms)."""
    ours = read_mesh(mesh)
    assert ours is not None and len(ours.faces) > 0
    lo, hi = bullet_aabb(mesh, tmp_path)
    assert np.allclose(lo + BULLET_AABB_GROWTH, ours.vertices.min(axis=0), atol=2e-4)
    assert np.allclose(hi - BULLET_AABB_GROWTH, ours.vertices.max(axis=0), atol=2e-4)


def square_dae(unit: float, translate: str, primitive: str) -> bytes:
    """A 1 x 1 x 1 (file units) cube's bottom and top faces as quads or triangles, placed by a node."""
    pos = "0 0 0 1 0 0 1 1 0 0 1 0 0 0 1 1 0 1 1 1 1 0 1 1"
    if primitive == "polylist":
        prim = ('<polylist count="2"><input semantic="VERTEX" source="#v" offset="0"/>'
                "<vcount>4 4</vcount><p>0 3 2 1 4 5 6 7</p></polylist>")
    else:
        prim = ('<triangles count="4"><input semantic="VERTEX" source="#v" offset="0"/>'
                "<p>0 2 1 0 3 2 4 5 6 4 6 7</p></triangles>")
    return (f'<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema"><asset><unit meter="{unit}"/>'
            f'</asset><library_geometries><geometry id="g"><mesh><source id="s">'
            f'<float_array id="a" count="24">{pos}</float_array><technique_common><accessor source="#a" '
            f'count="8" stride="3"/></technique_common></source><vertices id="v"><input semantic="POSITION" '
            f'source="#s"/></vertices>{prim}</mesh></geometry></library_geometries><library_visual_scenes>'
            f'<visual_scene id="vs"><node id="n"><translate>{translate}</translate><instance_geometry '
            f'url="#g"/></node></visual_scene></library_visual_scenes><scene><instance_visual_scene '
            f'url="#vs"/></scene></COLLADA>').encode()


def test_units_and_node_transforms_are_applied_as_pybullet_does(tmp_path: Path) -> None:
    f = tmp_path / "cube.dae"
    f.write_bytes(square_dae(0.01, "10 0 -5", "triangles"))
    ours = read_mesh(f)
    assert ours is not None
    assert np.allclose(ours.vertices.min(axis=0), [0.1, 0, -0.05]) and np.allclose(ours.vertices.max(axis=0),
                                                                                 [0.11, 0.01, -0.04])
    lo, hi = bullet_aabb(f, tmp_path)
    assert np.allclose(lo + BULLET_AABB_GROWTH, ours.vertices.min(axis=0), atol=2e-4)
    assert np.allclose(hi - BULLET_AABB_GROWTH, ours.vertices.max(axis=0), atol=2e-4)


def test_polylists_are_triangulated(tmp_path: Path) -> None:
    """PyBullet reads only <triangles>; a polylist's quads give the same triangles as the triangle file."""
    quads, tris = tmp_path / "q.dae", tmp_path / "t.dae"
    quads.write_bytes(square_dae(1, "0 0 0", "polylist"))
    tris.write_bytes(square_dae(1, "0 0 0", "triangles"))
    q, t = read_mesh(quads), read_mesh(tris)
    assert q is not None and t is not None and len(q.faces) == len(t.faces) == 4
    assert np.array_equal(q.vertices, t.vertices)


def test_a_kinova_s_concave_dae_collision_meshes_are_split_into_parts(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Every DAE collision mesh of the Jaco 2 gets a cache folder; the concave ones have several parts, and
    no DAE reaches PyBullet as a collision mesh (convex ones become their parsed hull)."""
    monkeypatch.setenv("ROBWOT_COLLISION_CACHE", str(tmp_path / "cache"))
    urdf = ROBOTS / "kinova_description/robots/kinova.urdf"
    with World() as world:
        model = world.load_robot(str(urdf), package_roots={"example-robot-data": str(example_robot_data())})
        assert len(model.links) > 8
    manifests = [(tmp_path / "cache" / k / "parts.json").read_text() for k in
                 sorted(p.name for p in (tmp_path / "cache").iterdir() if not p.name.startswith("."))]
    assert len(manifests) == 9  # the Jaco's 9 distinct collision meshes, all DAE
    assert all('"parts": []' not in m for m in manifests), ".dae" in WHOLE_AS_PART
    assert sum(m.count(".obj") > 1 for m in manifests) >= 5


def test_node_transforms_apply_in_document_order(tmp_path: Path) -> None:
    """translate, rotate Z 90°, rotate X 90° (COLLADA: in document order, T·Rz·Rx): the unit cube's far
    corner (1, 1, 1) lands at (1, 1, 1) -> Rx -> (1, -1, 1) -> Rz -> (1, 1, 1), then + (5, 0, 0)."""
    f = tmp_path / "r.dae"
    f.write_bytes(square_dae(1, "5 0 0", "triangles").replace(
        b"</translate>", b"</translate><rotate>0 0 1 90</rotate><rotate>1 0 0 90</rotate>"))
    ours = read_mesh(f)
    assert ours is not None
    corner = np.array([1.0, 1.0, 1.0])
    rx = np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]])
    rz = np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1]])
    expected = rz @ rx @ corner + [5, 0, 0]
    assert np.min(np.linalg.norm(ours.vertices - expected, axis=1)) < 1e-9
