"""Wavefront OBJ files read by our own code (``meshcheck.py`` calls it before PyBullet sees one).

Two readers of the same grammar. ``parse_obj_lines`` reads line by line and refuses a bad file naming its
line: it is the definition. ``parse_obj`` first tries ``_parse_regular``, which reads the common shape of a
file (every ``v`` line three or more numbers, every ``f`` line the same number of positive indices, each
defined before the face, no comment after a statement) with numpy in one pass per kind of line. Whatever it
does not recognise (relative indices, mixed face sizes, a comment after a statement, a bad number) sends
the file to the line reader, which then accepts it the same way or names the line it refuses. The two give
equal vertices and faces on every file the regular reader accepts (``tests/test_objmesh.py`` compares them
on every mesh and part the repository holds and on altered copies).
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from pathlib import Path

import numpy as np
import numpy.typing as npt

from robwot_sim.errors import MeshError

_SLASHED = re.compile(r"(?<=\d)/\S*")  # the texture and normal indices after a face's vertex index

Refuse = Callable[[Path, str, int | None], MeshError]
Faces = npt.NDArray[np.uint32]
Vertices = npt.NDArray[np.float64]


def parse_obj(path: Path, data: bytes, refuse: Refuse, most: int) -> tuple[Vertices, Faces]:
    """The vertices [n, 3] and triangles [m, 3] (0-based; polygons as fans from their first vertex) of an
    OBJ file's bytes, at most ``most`` triangles, or ``refuse(path, reason, line)`` raised."""
    text = data.decode("utf-8", errors="replace")
    regular = _parse_regular(text, most)
    if regular is not None:
        return regular
    return parse_obj_lines(path, text, refuse, most)


def _parse_regular(text: str, most: int) -> tuple[Vertices, Faces] | None:
    """The file read with numpy when it has the regular shape (module docstring), else None."""
    lines = text.splitlines()
    is_v = np.fromiter((ln.startswith("v ") for ln in lines), dtype=np.bool_, count=len(lines))
    is_f = np.fromiter((ln.startswith("f ") for ln in lines), dtype=np.bool_, count=len(lines))
    vs = [lines[i][2:] for i in np.flatnonzero(is_v)]
    fs = [lines[i][2:] for i in np.flatnonzero(is_f)]
    if not fs or any("#" in s for s in vs) or any("#" in s for s in fs):
        return None
    for i in np.flatnonzero(~(is_v | is_f)):  # any other line must be one the line reader skips too
        head = lines[i].split("#", 1)[0].split(None, 1)
        if head and head[0] in ("v", "f"):
            return None
    try:
        v_rows = [s.split() for s in vs]
        width = len(v_rows[0]) if v_rows else 3
        if width < 3 or any(len(r) != width for r in v_rows):
            return None
        vertices = np.array(v_rows, dtype=np.float64).reshape(-1, width)[:, :3]
        f_rows = [s.split() for s in _SLASHED.sub("", "\n".join(fs)).split("\n")]
        corners = len(f_rows[0])
        if corners < 3 or any(len(r) != corners for r in f_rows):
            return None
        index = np.array(f_rows, dtype=np.int64).reshape(-1, corners)
    except (ValueError, OverflowError):
        return None
    if not np.isfinite(vertices).all() or (index < 1).any():
        return None
    defined = np.cumsum(is_v)[is_f]  # vertices defined before each face line
    if (index.max(axis=1) > defined).any():
        return None
    if len(index) * (corners - 2) > most:
        return None
    index -= 1
    fans = [np.stack([index[:, 0], index[:, k], index[:, k + 1]], axis=1) for k in range(1, corners - 1)]
    faces = np.stack(fans, axis=1).reshape(-1, 3)  # a polygon's triangles together, in the file's order
    return np.ascontiguousarray(vertices), faces.astype(np.uint32)


def _obj_index(token: str, count: int, path: Path, line: int, refuse: Refuse) -> int:
    raw = token.split("/")[0]
    try:
        i = int(raw)
    except ValueError:
        raise refuse(path, f"face index {_quote(token)} is not an integer", line) from None
    k = i - 1 if i > 0 else count + i
    if i == 0 or not 0 <= k < count:
        raise refuse(path, f"face index {i} outside the {count} vertices defined so far", line)
    return k


def _quote(text: str, limit: int = 32) -> str:
    clean = "".join(c if " " <= c <= "~" else "?" for c in text[:limit])
    return repr(clean + ("..." if len(text) > limit else ""))


def parse_obj_lines(path: Path, text: str, refuse: Refuse, most: int) -> tuple[Vertices, Faces]:
    """The line reader (module docstring): what an OBJ file holds, or the first line refused and why."""
    vertices: list[tuple[float, float, float]] = []
    faces: list[tuple[int, int, int]] = []
    for n, raw in enumerate(text.splitlines(), start=1):
        parts = raw.split("#", 1)[0].split()
        if not parts:
            continue
        if parts[0] == "v":
            try:
                xyz = tuple(float(p) for p in parts[1:4])
            except ValueError:
                raise refuse(path, "vertex coordinates are not numbers", n) from None
            if len(xyz) != 3 or not all(math.isfinite(c) for c in xyz):
                raise refuse(path, "a vertex needs 3 finite coordinates", n)
            vertices.append((xyz[0], xyz[1], xyz[2]))
        elif parts[0] == "f":
            if len(parts) < 4:
                raise refuse(path, "a face needs at least 3 vertices", n)
            idx = [_obj_index(p, len(vertices), path, n, refuse) for p in parts[1:]]
            faces += [(idx[0], idx[k], idx[k + 1]) for k in range(1, len(idx) - 1)]
        if len(faces) > most:
            raise refuse(path, f"more than {most} triangles", n)
    if not faces:
        raise refuse(path, "OBJ without any face", None)
    return (np.array(vertices, dtype=np.float64).reshape(-1, 3),
            np.array(faces, dtype=np.uint32).reshape(-1, 3))
