"""A twin folder's collision cache is not trusted: ``parts.json`` entries stay in their folder after
symlinks, every convex part passes our mesh parser before PyBullet sees it, a missing part is refused at
once (never decomposed again), and ``decompose: false`` (how ``robwot serve`` loads) never decomposes.
Over the real RPC server, which keeps serving after every refusal."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from rpc_backend import RpcClient
from test_sim_decompose import to_obj, u_shape

from robwot_sim.errors import MeshError
from robwot_sim.model.decompose import MANIFEST, cache_key, decompose
from robwot_sim.model.meshcheck import check_mesh

URDF = """<robot name="arm">
  <link name="base"/>
  <link name="l1"><collision><geometry><mesh filename="meshes/u.obj"/></geometry></collision></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" velocity="1" effort="1"/></joint>
</robot>"""
TETRA = "v 0 0 0\nv 0.01 0 0\nv 0 0.01 0\nv 0 0 0.01\nf 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n"


@pytest.fixture(scope="module")
def generated(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A twin-like folder as generate leaves it: robot.urdf, a concave mesh and its parts in collision/."""
    folder = tmp_path_factory.mktemp("generated") / "twin"
    (folder / "meshes").mkdir(parents=True)
    v, f = u_shape()
    mesh = folder / "meshes" / "u.obj"
    mesh.write_text(to_obj(v, f))
    (folder / "robot.urdf").write_text(URDF)
    key = cache_key(mesh.read_bytes(), (1.0, 1.0, 1.0))
    assert not decompose(v, f, key, folder / "collision").convex
    return folder


@pytest.fixture
def twin(generated: Path, tmp_path: Path) -> Path:
    """A private copy of the generated folder, to plant hostile files in."""
    copy = tmp_path / "twin"
    shutil.copytree(generated, copy, symlinks=True)
    return copy


def parts_folder(twin: Path) -> Path:
    (folder,) = (twin / "collision").iterdir()
    return folder


def manifest(twin: Path) -> dict[str, object]:
    doc = json.loads((parts_folder(twin) / MANIFEST).read_text())
    assert isinstance(doc, dict)
    return doc


def write_manifest(twin: Path, parts: list[str]) -> None:
    (parts_folder(twin) / MANIFEST).write_text(json.dumps({"convex": False, "parts": parts}))


def load(client: RpcClient, twin: Path, **extra: object) -> dict[str, object]:
    return client.call("robot.load", {"urdf": str(twin / "robot.urdf"), "id": "arm", **extra})


def refused(client: RpcClient, twin: Path, **extra: object) -> dict[str, object]:
    err = client.error("robot.load", {"urdf": str(twin / "robot.urdf"), "id": "arm", **extra})
    assert client.call("ping")["version"]  # the server lives
    assert "arm" not in [r["id"] for r in client.call("world.list")["robots"]]
    return err.data


def test_a_twin_loads_from_its_own_parts_without_decomposing(client: RpcClient, twin: Path) -> None:
    """decompose: false loads a folder whose parts generate wrote, and nothing is written into it."""
    before = sorted(p.relative_to(twin) for p in twin.rglob("*"))
    model = load(client, twin, decompose=False)
    assert model["id"] == "arm"
    assert sorted(p.relative_to(twin) for p in twin.rglob("*")) == before


def hostile_entries(twin: Path, outside: Path) -> dict[str, str]:
    part = str(manifest(twin)["parts"][0])  # type: ignore[index]
    (outside / "secret.obj").write_text(TETRA)
    link = parts_folder(twin) / "link.obj"
    link.symlink_to(outside / "secret.obj")
    return {
        "absolute": str(outside / "secret.obj"),
        "climbing": f"../../../{outside.name}/secret.obj",
        "symlink out": link.name,
        "a sub-folder": f"sub/{part}",
    }


@pytest.mark.parametrize("kind", ["absolute", "climbing", "symlink out", "a sub-folder"])
def test_parts_json_entries_leaving_their_folder_are_refused(client: RpcClient, twin: Path, tmp_path: Path,
                                                             kind: str) -> None:
    """A parts.json entry that is absolute, climbs with ../, is a symlink out of the folder or names a
    path instead of a file of the folder is refused (E_PATH_ESCAPE naming parts.json), never loaded."""
    outside = tmp_path / "outside"
    outside.mkdir()
    (parts_folder(twin) / "sub").mkdir()
    entry = hostile_entries(twin, outside)[kind]
    shutil.copy(parts_folder(twin) / str(manifest(twin)["parts"][0]), parts_folder(twin) / "sub")  # type: ignore[index]
    write_manifest(twin, [entry])
    data = refused(client, twin)
    assert data["code"] == "E_PATH_ESCAPE", data
    assert str(data["file"]).endswith(MANIFEST)


@pytest.mark.parametrize("what", ["parts.json", "the parts folder", "collision/"])
def test_a_cache_symlinked_out_of_the_folder_is_refused(client: RpcClient, twin: Path, tmp_path: Path,
                                                        what: str) -> None:
    """parts.json, the key folder or collision/ itself symlinked to a copy outside the twin folder: refused
    (E_PATH_ESCAPE), the outside copy is not read."""
    outside = tmp_path / "outside"
    folder = parts_folder(twin)
    target = {"parts.json": folder / MANIFEST, "the parts folder": folder,
              "collision/": twin / "collision"}[what]
    shutil.move(target, outside)
    target.symlink_to(outside)
    data = refused(client, twin)
    assert data["code"] == "E_PATH_ESCAPE", data


@pytest.mark.parametrize(("name", "text", "reason"), [
    ("a face index of 1,000,000", "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nf 1 2 1000000\n", "face index 1000000"),
    ("a face without vertices", "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nf 1 2 3\nf\n", "at least 3 vertices"),
])
def test_a_hostile_part_is_refused_by_our_parser_before_pybullet(client: RpcClient, twin: Path, name: str,
                                                                  text: str, reason: str) -> None:
    """A convex part PyBullet would crash on (segfault) answers E_MESH naming the part, the line and why;
    the server keeps serving (with or without decompose)."""
    part = parts_folder(twin) / str(manifest(twin)["parts"][0])  # type: ignore[index]
    part.write_text(text)
    for extra in ({}, {"decompose": False}):
        data = refused(client, twin, **extra)
        assert data["code"] == "E_MESH", data
        assert data["file"] == str(part.resolve()) and reason in str(data["reason"])
        assert data["line"] == text.count("\n")


@pytest.mark.parametrize("extra", [{}, {"decompose": False}])
def test_a_missing_part_is_refused_at_once_and_nothing_is_decomposed(client: RpcClient, twin: Path,
                                                                     extra: dict[str, object]) -> None:
    """parts.json naming a part that is not there: E_MESH naming it (re-run generate), the cache is left
    as it was (no decomposition into it)."""
    folder = parts_folder(twin)
    write_manifest(twin, [*manifest(twin)["parts"], "part999.obj"])  # type: ignore[misc]
    before = sorted(p.name for p in folder.parent.iterdir())
    data = refused(client, twin, **extra)
    assert data["code"] == "E_MESH", data
    assert data["file"] == str(folder / "part999.obj") and data["reason"] == "missing convex part"
    assert sorted(p.name for p in folder.parent.iterdir()) == before


def test_decompose_false_refuses_a_concave_mesh_without_parts(client: RpcClient, twin: Path) -> None:
    """Without its collision/ folder, a twin's concave mesh is refused (E_MESH, re-run generate) by a load
    that may not decompose, instead of minutes of decomposition."""
    shutil.rmtree(twin / "collision")
    (twin / "collision").mkdir()  # the twin's (empty) cache, not the user's
    data = refused(client, twin, decompose=False)
    assert data["code"] == "E_MESH", data
    assert data["file"] == str(twin / "meshes" / "u.obj") and data["reason"] == "no cached convex parts"
    assert list((twin / "collision").iterdir()) == []


def test_mesh_errors_carry_the_line_and_quote_only_a_short_sanitised_snippet(tmp_path: Path) -> None:
    """E_MESH of an OBJ names the line; a hostile token is quoted at most a few dozen printable chars."""
    f = tmp_path / "x.obj"
    f.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 " + "\x1b[2Jroot:x:0:0" * 100 + "\n")
    with pytest.raises(MeshError) as e:
        check_mesh(f)
    assert e.value.data["line"] == 4
    assert "\x1b" not in e.value.message and e.value.message.count("root:") <= 3
    assert len(e.value.message) < len(str(f)) + 120
