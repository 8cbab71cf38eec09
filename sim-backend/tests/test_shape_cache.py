"""The outer shapes kept on disk (``sim/shape_cache.py``): what a later process reads is exactly what the
fits make, on real robots; an entry that is damaged, or made for other parts, is never used."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from robwot_sim.sim import robot_shapes, shape_cache
from robwot_sim.sim.robot_shapes import RobotShapes
from robwot_sim.sim.world import World

FIELDS = ("centres", "radii", "sphere_part", "box_c", "box_axes", "box_half", "own", "inner_c", "inner_r")


def shapes_of(w: World, rid: str) -> RobotShapes:
    e = w.queries._scene.entries()[rid]
    made = robot_shapes.robot_shapes(e.bound, e.checker.filtered, e.model)
    assert made is not None
    return made


def same(a: RobotShapes, b: RobotShapes) -> None:
    assert len(a.links) == len(b.links)
    for x, y in zip(a.links, b.links, strict=True):
        assert (x.link, x.moving) == (y.link, y.moving)
        for f in FIELDS:
            assert np.array_equal(getattr(x, f), getattr(y, f)), f
        for f in ("verts", "corners", "faces"):
            assert all(np.array_equal(u, v) for u, v in zip(getattr(x, f), getattr(y, f), strict=True)), f


@pytest.mark.parametrize("urdf", ["kuka_iiwa/model.urdf", "franka_panda/panda.urdf"])
def test_shapes_read_back_are_the_fitted_ones(urdf: str, tmp_path: Path,
                                              monkeypatch: pytest.MonkeyPatch) -> None:
    with World() as w:
        rid = w.load_robot(urdf, robot_id="r").id
        monkeypatch.setenv("ROBWOT_COLLISION_CACHE", str(tmp_path))
        fitted = []
        original = robot_shapes.fit_link
        monkeypatch.setattr(robot_shapes, "fit_link", lambda p, i: fitted.append(1) or original(p, i))
        first = shapes_of(w, rid)
        entries = sorted((tmp_path / "shapes").glob("*.npz"))
        assert len(fitted) == len(first.links) == len(entries)
        second = shapes_of(w, rid)
        assert len(fitted) == len(first.links)  # nothing fitted again
        same(first, second)


def test_a_damaged_or_foreign_entry_is_fitted_again(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    with World() as w:
        rid = w.load_robot("kuka_iiwa/model.urdf", robot_id="r").id
        monkeypatch.setenv("ROBWOT_COLLISION_CACHE", str(tmp_path))
        truth = shapes_of(w, rid)
        entries = sorted((tmp_path / "shapes").glob("*.npz"))
        with np.load(entries[0]) as z:
            good = {k: z[k] for k in z.files}
        damaged = [
            b"not a zip",  # unreadable
            {**good, "radii": np.full_like(good["radii"], np.nan)},  # not finite
            {**good, "radii": -good["radii"]},  # not a radius
            {**good, "counts": good["counts"][:-1]},  # another number of parts
            {**good, "box_axes": good["box_axes"][:, :2]},  # not a rotation's shape
            {k: v for k, v in good.items() if k != "corners"},  # an array missing
            {**good, "face_counts": good["face_counts"] + 1},  # faces that do not add up
            {**good, "centres": np.array(["x"] * len(good["centres"]))},  # not numbers
        ]
        for bad in damaged:
            if isinstance(bad, bytes):
                entries[0].write_bytes(bad)
            else:
                np.savez(entries[0], **bad)
            assert shape_cache.load(entries[0].stem, len(good["box_c"])) is None
            same(truth, shapes_of(w, rid))  # fitted again, and stored again whole
            assert shape_cache.load(entries[0].stem, len(good["box_c"])) is not None


def test_other_bullet_data_name_another_entry() -> None:
    row = (0, -1, 5, (1.0, 1.0, 1.0), "ab12.obj", (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
    moved = (*row[:5], (0.0, 0.0, 1e-9), row[6])
    assert shape_cache.key((1, True, [row], None)) != shape_cache.key((1, True, [moved], None))
    assert shape_cache.key((1, True, [row], None)) != shape_cache.key((2, True, [row], None))
    assert shape_cache.key((1, True, [row], None)) == shape_cache.key((1, True, [tuple(row)], None))


@pytest.mark.parametrize("urdf", ["kuka_iiwa/model.urdf", "franka_panda/panda.urdf"])
def test_an_entry_found_reads_no_part(urdf: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A robot whose shapes are in the cache never reads its links' parts (parsing a robot's convex parts cost
    a labelling worker as much as the rest of its start); with an empty cache every link's are read."""
    monkeypatch.setenv("ROBWOT_COLLISION_CACHE", str(tmp_path))
    read: list[int] = []
    original = robot_shapes.link_parts
    monkeypatch.setattr(robot_shapes, "link_parts", lambda c, b, ln: read.append(ln) or original(c, b, ln))
    with World() as w:
        rid = w.load_robot(urdf, robot_id="r").id
        first = shapes_of(w, rid)
    assert len(read) == len(first.links)
    with World() as w:
        rid = w.load_robot(urdf, robot_id="r").id
        same(first, shapes_of(w, rid))
    assert len(read) == len(first.links)


def test_the_same_bytes_as_another_kind_of_mesh_name_another_entry(tmp_path: Path) -> None:
    """An entry names a mesh by its content and the reader its suffix picks: the same bytes as OBJ and as
    STL are read differently."""
    (tmp_path / "m.obj").write_bytes(b"x")
    (tmp_path / "m.stl").write_bytes(b"x")
    rows = [shape_cache.by_content((0, -1, 5, (1, 1, 1), str(tmp_path / f"m.{k}").encode(), (0, 0, 0),
                                    (0, 0, 0, 1))) for k in ("obj", "stl")]
    assert rows[0][4] != rows[1][4] and rows[0][4][:64] == rows[1][4][:64]


CUBE = "".join(f"v {x} {y} {z}\n" for x in (-0.05, 0.05) for y in (-0.05, 0.05) for z in (0.0, 0.3)) + (
    "f 1 2 4 3\nf 5 7 8 6\nf 1 5 6 2\nf 3 4 8 7\nf 1 3 7 5\nf 2 6 8 4\n")
ARM = """<robot name="cubes">
  <link name="base"><collision><geometry><mesh filename="cube.obj"/></geometry></collision>
    <inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
  <link name="arm"><collision><origin xyz="0 0 0.05"/><geometry><mesh filename="cube.obj"/></geometry>
    </collision>
    <inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
  <joint name="j" type="revolute"><parent link="base"/><child link="arm"/><origin xyz="0 0 0.4"/>
    <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>
"""


def test_entries_name_mesh_files_by_content_not_path(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The same robot from another folder (an expanded xacro's temporary one) reads the entries back; the
    same vertices in a file that differs elsewhere are fitted again."""
    monkeypatch.setenv("ROBWOT_COLLISION_CACHE", str(tmp_path / "cache"))
    fitted = []
    original = robot_shapes.fit_link
    monkeypatch.setattr(robot_shapes, "fit_link", lambda p, i: fitted.append(1) or original(p, i))
    counts = []
    for folder, extra in (("a", ""), ("b", ""), ("c", "o second\n")):
        (tmp_path / folder).mkdir()
        (tmp_path / folder / "cube.obj").write_text(CUBE + extra)
        (tmp_path / folder / "arm.urdf").write_text(ARM)
        with World() as w:
            rid = w.load_robot(str(tmp_path / folder / "arm.urdf"), robot_id="r").id
            shapes_of(w, rid)
        counts.append(len(fitted))
    assert counts[0] == 2 and counts[1] == 2 and counts[2] == 4, counts
