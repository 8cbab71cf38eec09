"""Mesh files checked by our own parsers before PyBullet sees them.

PyBullet's mesh readers trust their input: an ASCII STL, an empty binary STL (0 triangles) or a binary
STL whose triangle count exceeds what the file holds crash the whole process. Every mesh (URDF
``<mesh>``, scene and run-time obstacles) therefore goes through ``check_mesh`` first:

* binary STL: size exactly ``84 + 50 * n`` with ``0 < n <= MAX_TRIANGLES``, finite coordinates;
* ASCII STL: parsed (``vertex x y z`` triples), then converted to a binary STL in a backend-owned cache
  folder (PyBullet reads binary STL only), so the original never reaches PyBullet;
* OBJ: ``v`` lines finite, ``f`` lines with >= 3 in-range indices (1-based, negative = relative), at
  least one face;
* DAE (COLLADA): read with the same DTD-free XML reader as URDFs; ``float_array`` counts match their
  finite contents and every index of a ``<p>`` stays within them.

A refused file raises ``MeshError`` (``E_MESH``) naming the file and the reason; the caller adds where
it came from (URDF and line, obstacle name).
"""

from __future__ import annotations

import hashlib
import math
import os
import re
import struct
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from robwot_sim.errors import MeshError
from robwot_sim.model import xmlsafe

MAX_MESH_BYTES = 256 * 1024 * 1024
MAX_TRIANGLES = 5_000_000
_STL_DTYPE = np.dtype([("normal", "<f4", (3,)), ("v", "<f4", (3, 3)), ("attr", "<u2")])
_FLOAT = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_ASCII_VERTEX = re.compile(rb"^\s*vertex\s+(" + _FLOAT.encode() + rb")\s+(" + _FLOAT.encode() + rb")\s+("
                           + _FLOAT.encode() + rb")\s*$", re.MULTILINE)


@dataclass(frozen=True)
class MeshData:
    """Triangles of a mesh: ``vertices`` [n, 3] (file units) and ``faces`` [m, 3] (0-based indices)."""

    vertices: npt.NDArray[np.float64]
    faces: npt.NDArray[np.uint32]


def snippet(text: object, limit: int = 32, *, quote: bool = True) -> str:
    """A short quote of a file's own text for an error message: printable ASCII only, at most ``limit``
    characters (an error must not carry a file's content along)."""
    raw = str(text)
    clean = "".join(c if " " <= c <= "~" else "?" for c in raw[:limit])
    clean += "..." if len(raw) > limit else ""
    return repr(clean) if quote else clean


def _refuse(path: Path, reason: str, line: int | None = None) -> MeshError:
    if line is None:
        return MeshError(f"mesh {path}: {reason}", file=str(path), reason=reason)
    return MeshError(f"mesh {path}: line {line}: {reason}", file=str(path), reason=reason, line=line)


def _read(path: Path) -> bytes:
    size = path.stat().st_size
    if size > MAX_MESH_BYTES:
        raise _refuse(path, f"file of {size} bytes is larger than {MAX_MESH_BYTES}")
    return path.read_bytes()


def check_mesh(path: Path) -> Path:
    """Validate a mesh file; returns the file PyBullet may load (a converted copy for ASCII STL)."""
    suffix = path.suffix.lower()
    if suffix == ".stl":
        data = _read(path)
        if _binary_stl_triangles(data) is not None:
            _check_binary_stl(path, data)
            return path
        return _ascii_to_binary(path, data)
    if suffix == ".obj":
        _parse_obj(path, _read(path))
        return path
    if suffix == ".dae":
        _check_dae(path, _read(path))
        return path
    raise _refuse(path, f"unsupported mesh format {suffix or '(none)'!r}; use STL, OBJ or DAE")


def read_mesh(path: Path) -> MeshData | None:
    """The triangles of a checked STL or OBJ file (None for DAE, whose geometry PyBullet reads itself)."""
    suffix = path.suffix.lower()
    if suffix == ".stl":
        data = _read(path)
        if _binary_stl_triangles(data) is None:
            return _triangles(_parse_ascii_stl(path, data))
        return _triangles(_check_binary_stl(path, data).reshape(-1, 3))
    if suffix == ".obj":
        return _parse_obj(path, _read(path))
    return None


def mesh_points(path: Path) -> npt.NDArray[np.float64] | None:
    """Every vertex position of a checked STL or OBJ file, repeats kept ([n, 3]; None for DAE): enough for
    its convex hull, without the merging of shared vertices ``read_mesh`` does."""
    suffix = path.suffix.lower()
    if suffix == ".stl":
        data = _read(path)
        if _binary_stl_triangles(data) is None:
            return _parse_ascii_stl(path, data).astype(np.float64)
        return _check_binary_stl(path, data).reshape(-1, 3).astype(np.float64)
    if suffix == ".obj":
        return _parse_obj(path, _read(path)).vertices
    return None


def _triangles(corners: npt.NDArray[np.float64]) -> MeshData:
    """Triangle soup [3m, 3] -> shared vertices and faces."""
    vertices, inverse = np.unique(corners, axis=0, return_inverse=True)
    return MeshData(vertices.astype(np.float64), inverse.reshape(-1, 3).astype(np.uint32))


def _binary_stl_triangles(data: bytes) -> int | None:
    """The triangle count when ``data`` has the exact size of a binary STL, else None."""
    if len(data) < 84:
        return None
    n = int(struct.unpack_from("<I", data, 80)[0])
    return n if len(data) == 84 + 50 * n else None


def _check_binary_stl(path: Path, data: bytes) -> npt.NDArray[np.float64]:
    n = int(struct.unpack_from("<I", data, 80)[0])
    if n == 0:
        raise _refuse(path, "binary STL with 0 triangles")
    if n > MAX_TRIANGLES:
        raise _refuse(path, f"{n} triangles (at most {MAX_TRIANGLES})")
    tris = np.frombuffer(data, dtype=_STL_DTYPE, count=n, offset=84)["v"].astype(np.float64)
    if not np.all(np.isfinite(tris)):
        raise _refuse(path, "non-finite vertex coordinate (NaN or Infinity)")
    return tris.reshape(-1, 3)


def _parse_ascii_stl(path: Path, data: bytes) -> npt.NDArray[np.float64]:
    head = data.lstrip()[:5].lower()
    if head != b"solid":
        if len(data) >= 84:
            n = int(struct.unpack_from("<I", data, 80)[0])
            raise _refuse(path, f"binary STL header says {n} triangles ({84 + 50 * n} bytes) but the file "
                                f"has {len(data)} bytes")
        raise _refuse(path, f"truncated STL ({len(data)} bytes, a binary STL needs at least 84)")
    values = np.array([[float(x) for x in m.groups()] for m in _ASCII_VERTEX.finditer(data)],
                      dtype=np.float64).reshape(-1, 3)
    if len(values) == 0:
        raise _refuse(path, "ASCII STL without any facet")
    if len(values) % 3 != 0:
        raise _refuse(path, f"ASCII STL with {len(values)} vertices (not a multiple of 3)")
    if len(values) // 3 > MAX_TRIANGLES:
        raise _refuse(path, f"{len(values) // 3} triangles (at most {MAX_TRIANGLES})")
    if not np.all(np.isfinite(values)):
        raise _refuse(path, "non-finite vertex coordinate (NaN or Infinity)")
    return values


def _ascii_to_binary(path: Path, data: bytes) -> Path:
    """Converts a checked ASCII STL into a cached binary STL (PyBullet reads binary STL only)."""
    corners = _parse_ascii_stl(path, data)
    cache = Path(tempfile.gettempdir()) / f"robwot-meshes-{os.getuid()}"
    cache.mkdir(mode=0o700, exist_ok=True)
    out = cache / f"{hashlib.sha256(data).hexdigest()[:32]}.stl"
    if not out.is_file():
        tris = corners.reshape(-1, 3, 3)
        normals = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
        lengths = np.linalg.norm(normals, axis=1, keepdims=True)
        normals = np.divide(normals, lengths, out=np.zeros_like(normals), where=lengths > 0)
        rec = np.zeros(len(tris), dtype=_STL_DTYPE)
        rec["normal"], rec["v"] = normals, tris
        tmp = out.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_bytes(b"robwot: converted from ASCII STL".ljust(80, b" ") + struct.pack("<I", len(tris))
                        + rec.tobytes())
        os.replace(tmp, out)
    return out


def _obj_index(token: str, count: int, path: Path, line: int) -> int:
    raw = token.split("/")[0]
    try:
        i = int(raw)
    except ValueError:
        raise _refuse(path, f"face index {snippet(token)} is not an integer", line) from None
    k = i - 1 if i > 0 else count + i
    if i == 0 or not 0 <= k < count:
        raise _refuse(path, f"face index {i} outside the {count} vertices defined so far", line)
    return k


def _parse_obj(path: Path, data: bytes) -> MeshData:
    vertices: list[tuple[float, float, float]] = []
    faces: list[tuple[int, int, int]] = []
    for n, raw in enumerate(data.decode("utf-8", errors="replace").splitlines(), start=1):
        parts = raw.split("#", 1)[0].split()
        if not parts:
            continue
        if parts[0] == "v":
            try:
                xyz = tuple(float(p) for p in parts[1:4])
            except ValueError:
                raise _refuse(path, "vertex coordinates are not numbers", n) from None
            if len(xyz) != 3 or not all(math.isfinite(c) for c in xyz):
                raise _refuse(path, "a vertex needs 3 finite coordinates", n)
            vertices.append((xyz[0], xyz[1], xyz[2]))
        elif parts[0] == "f":
            if len(parts) < 4:
                raise _refuse(path, "a face needs at least 3 vertices", n)
            idx = [_obj_index(p, len(vertices), path, n) for p in parts[1:]]
            faces += [(idx[0], idx[k], idx[k + 1]) for k in range(1, len(idx) - 1)]
        if len(faces) > MAX_TRIANGLES:
            raise _refuse(path, f"more than {MAX_TRIANGLES} triangles", n)
    if not faces:
        raise _refuse(path, "OBJ without any face")
    return MeshData(np.array(vertices, dtype=np.float64), np.array(faces, dtype=np.uint32))


def _check_dae(path: Path, data: bytes) -> None:
    try:
        root, _ = xmlsafe.parse(data)
    except (xmlsafe.XmlRefused, xmlsafe.XmlMalformed) as e:
        raise _refuse(path, str(e)) from None
    if not root.tag.endswith("COLLADA"):
        raise _refuse(path, f"root element is {snippet(root.tag)}, expected <COLLADA>")
    largest = 0
    for arr in root.iter():
        if not arr.tag.endswith("float_array"):
            continue
        try:
            values = np.array((arr.text or "").split(), dtype=np.float64)
        except ValueError:
            raise _refuse(path, f"float_array {snippet(arr.get('id'))} holds a value that is not a "
                                "number") from None
        if arr.get("count") is not None and str(len(values)) != arr.get("count"):
            raise _refuse(path, f"float_array {snippet(arr.get('id'))} says "
                                f"count={snippet(arr.get('count'), quote=False)} but holds "
                                f"{len(values)} values")
        if not np.all(np.isfinite(values)):
            raise _refuse(path, f"float_array {snippet(arr.get('id'))} holds a non-finite value")
        largest = max(largest, len(values))
    primitives = [el for el in root.iter() if el.tag.split("}")[-1] == "p"]
    if largest == 0 or not primitives:
        raise _refuse(path, "COLLADA file without geometry (no float_array or no <p> indices)")
    for p in primitives:
        try:
            idx = np.array((p.text or "").split(), dtype=np.int64)
        except ValueError:
            raise _refuse(path, "a <p> index is not an integer") from None
        if len(idx) and (idx.min() < 0 or idx.max() >= largest):
            raise _refuse(path, f"a <p> index ({int(idx.max())}) points outside the arrays "
                                f"({largest} values)")
