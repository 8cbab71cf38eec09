"""Hostile mesh files are refused by our parser (E_MESH, file and reason) before PyBullet sees them, over
the real RPC server, which keeps serving; valid ASCII STL is converted and loads."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest
from rpc_backend import RpcClient

TRI = struct.pack("<12fH", 0, 0, 1, 0, 0, 0, 0.1, 0, 0, 0, 0.1, 0, 0)
NAN_TRI = struct.pack("<12fH", 0, 0, 1, float("nan"), 0, 0, 0.1, 0, 0, 0, 0.1, 0, 0)
BROKEN_FACET = (b"solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n"
                b"endloop\nendfacet\nendsolid x\n")
DOCTYPE = b'<?xml version="1.0"?>\n<!DOCTYPE x [<!ENTITY a "b">]>\n<COLLADA/>'


def dae(positions: str, indices: str, count: int | None = None, node: str = "") -> bytes:
    """A COLLADA file with one triangle mesh instantiated by a node of its scene."""
    n = len(positions.split()) if count is None else count
    return (f'<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema"><library_geometries>'
            f'<geometry id="g"><mesh><source id="s"><float_array id="a" count="{n}">{positions}</float_array>'
            f'</source><vertices id="v"><input semantic="POSITION" source="#s"/></vertices>'
            f'<triangles count="1"><input semantic="VERTEX" source="#v" offset="0"/>'
            f'<p>{indices}</p></triangles>'
            f'</mesh></geometry></library_geometries><library_visual_scenes><visual_scene id="vs">'
            f'<node id="n"><instance_geometry url="#g"/>{node}</node></visual_scene></library_visual_scenes>'
            f'<scene><instance_visual_scene url="#vs"/></scene></COLLADA>').encode()


def binary_stl(n_claimed: int, triangles: bytes) -> bytes:
    return b"\0" * 80 + struct.pack("<I", n_claimed) + triangles


HOSTILE: dict[str, tuple[str, bytes, str]] = {
    "empty binary STL": ("stl", binary_stl(0, b""), "0 triangles"),
    "lying triangle count": ("stl", binary_stl(1000, TRI * 3), "says 1000 triangles"),
    "truncated STL": ("stl", b"\0" * 40, "truncated"),
    "NaN vertex": ("stl", binary_stl(1, NAN_TRI), "non-finite"),
    "ASCII STL without facets": ("stl", b"solid x\nendsolid x\n", "without any facet"),
    "ASCII STL with a broken facet": ("stl", BROKEN_FACET, "not a multiple of 3"),
    "OBJ without faces": ("obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\n", "without any face"),
    "OBJ index out of range": ("obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n", "face index 9"),
    "OBJ non-finite vertex": ("obj", b"v 0 0 inf\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "3 finite coordinates"),
    "DAE with DOCTYPE": ("dae", DOCTYPE, "DOCTYPE"),
    "DAE index out of range": ("dae", dae("0 0 0 1 0 0 0 1 0", "0 1 7"), "points outside its 3 positions"),
    "DAE count lies": ("dae", dae("0 0 0 1 0 0 0 1 0", "0 1 2", count=12), "count=12"),
    "DAE without triangles": ("dae", b"<COLLADA><library_geometries/></COLLADA>", "without triangles"),
    "DAE nodes in a loop": ("dae", dae("0 0 0 1 0 0 0 1 0", "0 1 2", node='<instance_node url="#n"/>'),
                            "nested deeper"),
}


@pytest.mark.parametrize("kind", sorted(HOSTILE))
def test_hostile_mesh_obstacle_is_refused_and_the_server_lives(client: RpcClient, tmp_path: Path,
                                                               kind: str) -> None:
    """obstacle.add of each hostile mesh answers E_MESH naming the file and why; ping still answers."""
    suffix, data, reason = HOSTILE[kind]
    f = tmp_path / f"bad.{suffix}"
    f.write_bytes(data)
    err = client.error("obstacle.add", {"name": "bad", "shape": {"type": "mesh", "file": str(f)},
                                        "position": [1, 1, 0]})
    assert err.data["code"] == "E_MESH", err.data
    assert err.data["file"] == str(f) and reason in err.data["reason"]
    assert client.call("ping")["version"]
    assert client.call("world.list")["obstacles"] == []


@pytest.mark.parametrize("kind", ["empty binary STL", "lying triangle count", "ASCII STL without facets"])
def test_hostile_mesh_in_a_urdf_is_refused_with_urdf_and_line(client: RpcClient, tmp_path: Path,
                                                               kind: str) -> None:
    """robot.load of a URDF whose collision mesh is hostile answers E_MESH with the URDF file and line."""
    suffix, data, reason = HOSTILE[kind]
    (tmp_path / f"link.{suffix}").write_bytes(data)
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(f"""<robot name="arm">
  <link name="base"/>
  <link name="l1"><collision><geometry><mesh filename="link.{suffix}"/></geometry></collision></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" velocity="1" effort="1"/></joint>
</robot>""")
    err = client.error("robot.load", {"urdf": str(urdf), "id": "arm"})
    assert err.data["code"] == "E_MESH" and err.data["urdf"] == str(urdf) and err.data["line"] == 3
    assert reason in err.data["reason"]
    assert client.call("ping")["version"]


def test_ascii_stl_is_converted_and_loads(client: RpcClient, tmp_path: Path) -> None:
    """A valid ASCII STL obstacle loads (converted to binary for PyBullet) and collides like the shape."""
    corners = np.array([[x, y, z] for x in (0, 0.2) for y in (0, 0.2) for z in (0, 0.2)])
    from scipy.spatial import ConvexHull

    hull = ConvexHull(corners)
    loops = ["".join(f"vertex {a} {b} {c}\n" for a, b, c in corners[s]) for s in hull.simplices]
    facets = "".join(f"facet normal 0 0 0\nouter loop\n{loop}endloop\nendfacet\n" for loop in loops)
    f = tmp_path / "cube.stl"
    f.write_text(f"solid cube\n{facets}endsolid cube\n")
    out = client.call("obstacle.add", {"name": "cube", "shape": {"type": "mesh", "file": str(f)},
                                       "position": [2, 2, 0]})
    assert out["shape"]["file"] == str(f)
    assert client.call("ping")["version"]


def test_a_passed_file_is_not_read_again_while_its_stamp_holds(tmp_path: Path,
                                                                monkeypatch: pytest.MonkeyPatch) -> None:
    """A file passed once is not read again; one vouched for by another process (a labelling worker taking
    the backend's) is not read at all; a file changed since, its modification time set back, is read again
    and refused when it is hostile now; a file changed just before it is read (its stamp not settled) is
    read every time."""
    import os

    from robwot_sim.errors import MeshError
    from robwot_sim.model import meshcheck

    mesh = tmp_path / "m.stl"
    mesh.write_bytes(binary_stl(1, TRI))
    reads: list[Path] = []
    original = meshcheck._read
    monkeypatch.setattr(meshcheck, "_read", lambda p: reads.append(p) or original(p))
    monkeypatch.setattr(meshcheck, "_passed", set())
    meshcheck.check_mesh(mesh)
    meshcheck.check_mesh(mesh)
    assert reads == [mesh, mesh]  # written just now: not settled
    reads.clear()
    monkeypatch.setattr(meshcheck, "SETTLED_NS", 0)  # as if a while had passed since it was written
    assert meshcheck.check_mesh(mesh) == mesh and meshcheck.check_mesh(mesh) == mesh
    assert reads == [mesh]
    stamps = meshcheck.checked_meshes()
    monkeypatch.setattr(meshcheck, "_passed", set())  # another process: nothing passed there
    meshcheck.vouch(stamps)
    assert meshcheck.check_mesh(mesh) == mesh and reads == [mesh]
    before = mesh.stat()
    mesh.write_bytes(binary_stl(1000, TRI))  # changed in place: a lying triangle count, same size,
    os.utime(mesh, ns=(before.st_atime_ns, before.st_mtime_ns))  # its modification time set back
    with pytest.raises(MeshError, match="1000 triangles"):
        meshcheck.check_mesh(mesh)
    assert reads == [mesh, mesh]
