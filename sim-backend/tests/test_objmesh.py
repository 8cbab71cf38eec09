"""The OBJ readers (``model/objmesh.py``): the regular reader gives the line reader's vertices and faces on
every OBJ file the repository and the installed packages hold (the robots' meshes, the shipped convex
parts, pybullet_data's) and on altered copies of them, or leaves the file to the line reader; a mesh is
parsed once per content in a process, its arrays shared read-only."""

from __future__ import annotations

import random
from pathlib import Path

import numpy as np
import pytest

from robwot_sim.errors import MeshError
from robwot_sim.model import meshcheck
from robwot_sim.model.objmesh import _parse_regular, parse_obj, parse_obj_lines

ROOT = Path(__file__).resolve().parents[2]
MOST = meshcheck.MAX_TRIANGLES


def _refuse(path: Path, reason: str, line: int | None) -> MeshError:
    return MeshError(f"{path}:{line}: {reason}", file=str(path), reason=reason)


def _files() -> list[Path]:
    import pybullet_data

    found = [p for p in ROOT.rglob("*.obj") if "node_modules" not in p.parts and ".venv" not in p.parts]
    found += sorted(Path(pybullet_data.getDataPath()).rglob("*.obj"))
    small = [p for p in found if p.stat().st_size < 2_000_000]
    return sorted(set(small))


def _lines(text: str) -> tuple[np.ndarray, np.ndarray] | str:
    try:
        return parse_obj_lines(Path("x.obj"), text, _refuse, MOST)
    except MeshError as e:
        return str(e)


def _same(text: str) -> bool | None:
    """Whether the regular reader agrees with the line reader on ``text`` (None: it left the file to it)."""
    fast = _parse_regular(text, MOST)
    if fast is None:
        return None
    slow = _lines(text)
    assert not isinstance(slow, str), f"the regular reader accepted what the line reader refuses: {slow}"
    assert fast[0].shape == slow[0].shape and np.array_equal(fast[0], slow[0])
    assert fast[1].dtype == slow[1].dtype and np.array_equal(fast[1], slow[1])
    return True


def test_the_regular_reader_reads_every_obj_file_here_as_the_line_reader_does() -> None:
    files = _files()
    assert len(files) > 100
    read = [_same(p.read_bytes().decode("utf-8", errors="replace")) for p in files]
    # the repository's own meshes and convex parts all have the regular shape
    assert sum(r is True for r in read) >= 0.9 * len(files)


def _altered(text: str, rng: random.Random) -> str:
    lines = text.splitlines()
    i = rng.randrange(len(lines))
    edits = [
        lambda ln: ln + " # note",
        lambda ln: "  " + ln,
        lambda ln: ln.replace(" ", "\t", 1),
        lambda ln: ln.replace("1", "-1", 1),
        lambda ln: ln.replace("2", "99999", 1),
        lambda ln: ln.replace("3", "x", 1),
        lambda ln: ln.replace(".", "", 1),
        lambda ln: ln + " 7",
        lambda ln: ln + " /5",
        lambda ln: ln.replace(" ", "/2 ", 1),
        lambda ln: "v",
        lambda ln: "f 1 2",
        lambda ln: ln.replace("0", "inf", 1),
        lambda ln: "v#" + ln,
        lambda ln: "",
    ]
    lines[i] = rng.choice(edits)(lines[i])
    return "\n".join(lines) + "\n"


def test_altered_files_are_read_alike_or_left_to_the_line_reader() -> None:
    rng = random.Random(7)
    files = [p for p in _files() if p.stat().st_size < 200_000]
    agreed = left = 0
    for k in range(600):
        text = _altered(files[k % len(files)].read_bytes().decode("utf-8", errors="replace"), rng)
        if _same(text) is None:
            left += 1
        else:
            agreed += 1
    assert agreed > 100 and left > 100  # both ways were taken


def test_quads_and_slashed_indices_are_fans_of_the_vertex_indices() -> None:
    text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1 4//1\n"
    vertices, faces = parse_obj(Path("q.obj"), text.encode(), _refuse, MOST)
    assert faces.tolist() == [[0, 1, 2], [0, 2, 3]] and vertices.shape == (4, 3)
    assert _same(text)


def test_a_face_before_its_vertex_is_refused_naming_the_line() -> None:
    text = "v 0 0 0\nv 1 0 0\nf 1 2 3\nv 0 1 0\n"
    assert _parse_regular(text, MOST) is None
    with pytest.raises(MeshError, match=":3: face index 3 outside the 2 vertices"):
        parse_obj(Path("x.obj"), text.encode(), _refuse, MOST)


def test_a_mesh_is_parsed_once_per_content_and_shared_read_only(tmp_path: Path,
                                                                monkeypatch: pytest.MonkeyPatch) -> None:
    calls = []
    original = meshcheck._parse_obj
    monkeypatch.setattr(meshcheck, "_parse_obj", lambda p, d: calls.append(p) or original(p, d))
    body = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n# %d\n"
    a, b = tmp_path / "a.obj", tmp_path / "b.obj"
    a.write_bytes(body % rng_token())
    b.write_bytes(a.read_bytes())
    meshcheck.check_mesh(a)
    points = meshcheck.mesh_points(b)
    mesh = meshcheck.read_mesh(a)
    assert len(calls) == 1 and points is not None and mesh is not None
    assert not points.flags.writeable and not mesh.faces.flags.writeable
    a.write_bytes(body % (rng_token() + 1))  # new content: parsed again
    meshcheck.check_mesh(a)
    assert len(calls) == 2


def rng_token() -> int:
    """A number no other test's mesh holds, so the process-wide memo has not seen the file."""
    return random.SystemRandom().randrange(1 << 60)
