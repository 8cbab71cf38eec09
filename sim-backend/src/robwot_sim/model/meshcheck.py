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
  finite contents, every index of a ``<p>`` stays within its positions, the scene's triangles are read
  (``read_mesh``), so a DAE collision mesh is decomposed like an STL or OBJ.

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
import threading
import xml.etree.ElementTree as ET
from collections import OrderedDict
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from robwot_sim.errors import MeshError
from robwot_sim.model import xmlsafe
from robwot_sim.model.objmesh import parse_obj
from robwot_sim.wholefile import TooLarge, read_whole

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
    try:
        return read_whole(path, MAX_MESH_BYTES)
    except TooLarge as e:
        refused = _refuse(path, str(e))
        refused.data.update(size=e.size, limit=e.limit)
        raise refused from None


@dataclass(frozen=True)
class Parsed:
    """What a mesh file holds: its points (an OBJ's vertices, else its triangles' corners [3m, 3], an STL's
    read from ``ascii`` text when so), an OBJ's vertices and faces, and its content's digest."""

    points: npt.NDArray[np.float64]
    mesh: MeshData | None
    ascii: bool
    digest: str

    @property
    def nbytes(self) -> int:
        return int(self.points.nbytes) + (int(self.mesh.faces.nbytes) if self.mesh else 0)


#: bytes of parsed meshes a process keeps (by content): the robot's load, its collision mirrors and its
#: outer shapes each ask about the same files, which are then parsed once
MEMO_BYTES = 64 << 20
_memo: OrderedDict[tuple[str, str], Parsed] = OrderedDict()
_memo_bytes = 0
_memo_lock = threading.Lock()


def _parsed(path: Path) -> Parsed:
    """The file parsed by the reader of its kind (``E_MESH`` for a refused one), once per content
    (``MEMO_BYTES``): the arrays are shared, read-only."""
    global _memo_bytes
    suffix = path.suffix.lower()
    if suffix not in (".stl", ".obj", ".dae"):
        raise _refuse(path, f"unsupported mesh format {suffix or '(none)'!r}; use STL, OBJ or DAE")
    data = _read(path)
    key = (suffix, hashlib.sha256(data).hexdigest())
    with _memo_lock:
        hit = _memo.get(key)
        if hit is not None:
            _memo.move_to_end(key)
            return hit
    if suffix == ".obj":
        mesh = _parse_obj(path, data)
        parsed = Parsed(mesh.vertices, mesh, False, key[1])
        mesh.faces.setflags(write=False)
    elif suffix == ".dae":
        parsed = Parsed(_parse_dae(path, data).reshape(-1, 3), None, False, key[1])
    elif _binary_stl_triangles(data) is not None:
        parsed = Parsed(_check_binary_stl(path, data), None, False, key[1])
    else:
        parsed = Parsed(_parse_ascii_stl(path, data), None, True, key[1])
    parsed.points.setflags(write=False)  # shared by every caller
    with _memo_lock:
        if key not in _memo and parsed.nbytes <= MEMO_BYTES:
            _memo[key] = parsed
            _memo_bytes += parsed.nbytes
            while _memo_bytes > MEMO_BYTES:
                _memo_bytes -= _memo.popitem(last=False)[1].nbytes
    return parsed


def check_mesh(path: Path) -> Path:
    """Validate a mesh file; returns the file PyBullet may load (a converted copy for ASCII STL)."""
    parsed = _parsed(path)
    if parsed.ascii:
        return _ascii_to_binary(parsed.points, parsed.digest)
    return path


def read_mesh(path: Path) -> MeshData | None:
    """The triangles of a checked STL, OBJ or DAE file (a DAE's as its scene places them, in metres)."""
    if path.suffix.lower() not in (".stl", ".obj", ".dae"):
        return None
    parsed = _parsed(path)
    return parsed.mesh or _triangles(parsed.points)


def mesh_points(path: Path) -> npt.NDArray[np.float64] | None:
    """Every vertex position of a checked STL, OBJ or DAE file, repeats kept ([n, 3], read-only): enough for
    its convex hull, without the merging of shared vertices ``read_mesh`` does."""
    if path.suffix.lower() not in (".stl", ".obj", ".dae"):
        return None
    return _parsed(path).points


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


def _ascii_to_binary(corners: npt.NDArray[np.float64], digest: str) -> Path:
    """A checked ASCII STL's triangles as a cached binary STL (PyBullet reads binary STL only)."""
    cache = Path(tempfile.gettempdir()) / f"robwot-meshes-{os.getuid()}"
    cache.mkdir(mode=0o700, exist_ok=True)
    out = cache / f"{digest[:32]}.stl"
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


def _parse_obj(path: Path, data: bytes) -> MeshData:
    vertices, faces = parse_obj(path, data, _refuse, MAX_TRIANGLES)
    return MeshData(vertices, faces)


def _local(tag: str) -> str:
    """An element's name without its XML namespace (COLLADA 1.4 and 1.5 files carry one)."""
    return tag.rsplit("}", 1)[-1]


def _children(el: ET.Element, name: str) -> list[ET.Element]:
    return [c for c in el if _local(c.tag) == name]


def _numbers(path: Path, el: ET.Element, dtype: type, what: str) -> npt.NDArray[Any]:
    try:
        values: npt.NDArray[Any] = np.array((el.text or "").split(), dtype=dtype)
    except (ValueError, OverflowError):
        raise _refuse(path, f"{what} {snippet(el.get('id') or _local(el.tag))} holds a value that is not "
                            f"{'a number' if dtype is np.float64 else 'an integer'}") from None
    if dtype is np.float64 and not np.all(np.isfinite(values)):
        raise _refuse(path, f"{what} {snippet(el.get('id') or _local(el.tag))} holds a non-finite value")
    return values


#: COLLADA node transforms, in the order a node lists them (spec 1.4.1, "Transform elements")
_TRANSFORMS = ("matrix", "translate", "rotate", "scale")
#: nested <node>/<instance_node> levels followed at most (instance_node may refer to itself)
_MAX_NODE_DEPTH = 64


def _node_transform(path: Path, node: ET.Element) -> npt.NDArray[np.float64]:
    """A node's own 4x4 transform: its transform elements multiplied in document order."""
    out = np.eye(4)
    for el in node:
        kind = _local(el.tag)
        if kind not in _TRANSFORMS:
            if kind in ("lookat", "skew"):
                raise _refuse(path, f"node {snippet(node.get('id'))}: <{kind}> transforms are not supported")
            continue
        v = _numbers(path, el, np.float64, kind)
        need = {"matrix": 16, "translate": 3, "rotate": 4, "scale": 3}[kind]
        if len(v) != need:
            raise _refuse(path, f"node {snippet(node.get('id'))}: <{kind}> holds {len(v)} numbers, "
                                f"expected {need}")
        t = np.eye(4)
        if kind == "matrix":
            t = v.reshape(4, 4)
        elif kind == "translate":
            t[:3, 3] = v
        elif kind == "scale":
            t[:3, :3] = np.diag(v)
        else:
            axis, angle = v[:3], np.radians(v[3])
            norm = float(np.linalg.norm(axis))
            if norm == 0.0:
                raise _refuse(path, f"node {snippet(node.get('id'))}: <rotate> about a zero axis")
            x, y, z = axis / norm
            c, s_, k = np.cos(angle), np.sin(angle), 1 - np.cos(angle)
            t[:3, :3] = [[c + x * x * k, x * y * k - z * s_, x * z * k + y * s_],
                         [y * x * k + z * s_, c + y * y * k, y * z * k - x * s_],
                         [z * x * k - y * s_, z * y * k + x * s_, c + z * z * k]]
        out = out @ t
    return out


def _geometry_triangles(path: Path, geometry: ET.Element,
                        floats: dict[int, npt.NDArray[np.float64]]) -> npt.NDArray[np.float64]:
    """The triangles of a <geometry>'s <mesh> in its own frame, [m, 3, 3]: <triangles>, <polylist> and
    <polygons> (polygons as fans); lines and points carry no volume and are skipped. ``floats``: every
    float_array's checked values by element."""
    gid = snippet(geometry.get("id"))
    out = []
    for mesh in _children(geometry, "mesh"):
        sources: dict[str, npt.NDArray[np.float64]] = {}
        for src in _children(mesh, "source"):
            arrays = _children(src, "float_array")
            if not arrays:
                continue
            values = floats[id(arrays[0])]
            stride = 3
            for acc in src.iter():
                if _local(acc.tag) == "accessor" and (acc.get("stride") or "").isdigit():
                    stride = max(1, int(acc.get("stride") or 3))
                    break
            if stride >= 3:
                whole = values[: len(values) // stride * stride]
                sources[src.get("id", "")] = whole.reshape(-1, stride)[:, :3]
        positions: dict[str, npt.NDArray[np.float64]] = {}
        for vertices in _children(mesh, "vertices"):
            for inp in _children(vertices, "input"):
                if inp.get("semantic") == "POSITION" and inp.get("source", "")[1:] in sources:
                    positions[vertices.get("id", "")] = sources[inp.get("source", "")[1:]]
        for prim in mesh:
            kind = _local(prim.tag)
            if kind not in ("triangles", "polylist", "polygons"):
                continue
            stride, pos, offset = 1, None, 0
            for inp in _children(prim, "input"):
                try:
                    offset = int(inp.get("offset", "0"))
                except ValueError:
                    raise _refuse(path, f"geometry {gid}: an <input> offset is not an integer") from None
                if not 0 <= offset < 64:
                    raise _refuse(path, f"geometry {gid}: an <input> offset of {offset} is out of range")
                stride = max(stride, offset + 1)
                if inp.get("semantic") == "VERTEX":
                    pos = positions.get(inp.get("source", "")[1:])
                    vertex_offset = offset
            if pos is None:
                raise _refuse(path, f"geometry {gid}: <{kind}> has no VERTEX input with POSITION data")
            if kind == "polygons":
                polys = [_numbers(path, p, np.int64, "<p>")[vertex_offset::stride]
                         for p in _children(prim, "p")]
            else:
                ps = _children(prim, "p")
                flat = (_numbers(path, ps[0], np.int64, "<p>")[vertex_offset::stride] if ps
                        else np.empty(0, np.int64))
                if kind == "triangles":
                    polys = [flat[: len(flat) // 3 * 3].reshape(-1, 3)]
                else:
                    vc = _children(prim, "vcount")
                    counts = _numbers(path, vc[0], np.int64, "<vcount>") if vc else np.empty(0, np.int64)
                    if counts.size and (counts.min() < 0 or counts.sum() != len(flat)):
                        raise _refuse(path, f"geometry {gid}: <polylist> vcount sums to {int(counts.sum())} "
                                            f"but <p> holds {len(flat)} vertices")
                    polys = list(np.split(flat, np.cumsum(counts)[:-1])) if counts.size else []
            for poly in polys:
                if poly.size and (poly.min() < 0 or poly.max() >= len(pos)):
                    raise _refuse(path, f"geometry {gid}: a <p> index ({int(poly.max())}) points outside "
                                        f"its {len(pos)} positions")
                if poly.ndim == 2:
                    out.append(pos[poly])
                elif len(poly) >= 3:
                    fan = np.stack([np.full(len(poly) - 2, poly[0]), poly[1:-1], poly[2:]], axis=1)
                    out.append(pos[fan])
    return np.concatenate(out) if out else np.empty((0, 3, 3))


def _parse_dae(path: Path, data: bytes) -> npt.NDArray[np.float64]:
    """The triangles of a COLLADA file as placed by its scene, in metres ([m, 3, 3]).

    Read with the DTD-free XML reader; every float_array count and index checked. Geometry is taken as
    the scene instantiates it (``<scene><instance_visual_scene>``, else the first visual scene; node
    transforms in document order, ``<instance_node>`` followed) and scaled by ``<asset><unit meter>``.
    The up axis is not applied: PyBullet ignores it for collision meshes, and URDF tools take the file's
    coordinates as the link's."""
    try:
        root, _ = xmlsafe.parse(data)
    except (xmlsafe.XmlRefused, xmlsafe.XmlMalformed) as e:
        raise _refuse(path, str(e)) from None
    if _local(root.tag) != "COLLADA":
        raise _refuse(path, f"root element is {snippet(root.tag)}, expected <COLLADA>")
    unit = 1.0
    for asset in _children(root, "asset"):
        for el in _children(asset, "unit"):
            try:
                unit = float(el.get("meter", "1"))
            except ValueError:
                raise _refuse(path, "<unit meter> is not a number") from None
            if not (math.isfinite(unit) and unit > 0):
                raise _refuse(path, f"<unit meter> must be a positive number, got {snippet(el.get('meter'))}")
    floats = {}
    for arr in root.iter():
        if _local(arr.tag) != "float_array":
            continue
        values = _numbers(path, arr, np.float64, "float_array")
        if arr.get("count") is not None and str(len(values)) != arr.get("count"):
            raise _refuse(path, f"float_array {snippet(arr.get('id'))} says "
                                f"count={snippet(arr.get('count'), quote=False)} but holds "
                                f"{len(values)} values")
        floats[id(arr)] = values
    by_id = {el.get("id"): el for el in root.iter() if el.get("id")}
    geometries = {g.get("id", ""): g for g in root.iter() if _local(g.tag) == "geometry"}
    cache: dict[str, npt.NDArray[np.float64]] = {}

    def triangles_of(gid: str) -> npt.NDArray[np.float64]:
        if gid not in cache:
            cache[gid] = _geometry_triangles(path, geometries[gid], floats)
        return cache[gid]

    placed: list[npt.NDArray[np.float64]] = []
    total = 0

    def walk(node: ET.Element, parent: npt.NDArray[np.float64], depth: int) -> None:
        nonlocal total
        if depth > _MAX_NODE_DEPTH:
            raise _refuse(path, f"nodes nested deeper than {_MAX_NODE_DEPTH} levels "
                                "(an <instance_node> loop?)")
        frame = parent @ _node_transform(path, node)
        for el in node:
            kind, url = _local(el.tag), el.get("url", "")[1:]
            if kind == "instance_geometry" and url in geometries:
                tris = triangles_of(url)
                total += len(tris)
                if total > MAX_TRIANGLES:
                    raise _refuse(path, f"more than {MAX_TRIANGLES} triangles")
                placed.append(tris @ frame[:3, :3].T + frame[:3, 3])
            elif kind == "node":
                walk(el, frame, depth + 1)
            elif kind == "instance_node" and url in by_id:
                walk(by_id[url], frame, depth + 1)

    scenes = [el for el in root.iter() if _local(el.tag) == "visual_scene"]
    chosen = None
    for inst in (el for el in root.iter() if _local(el.tag) == "instance_visual_scene"):
        chosen = by_id.get(inst.get("url", "")[1:])
        break
    chosen = chosen if chosen is not None else (scenes[0] if scenes else None)
    if chosen is None:  # geometry without a scene: each geometry as it is
        for gid in geometries:
            placed.append(triangles_of(gid))
    else:
        for node in _children(chosen, "node"):
            walk(node, np.eye(4), 0)
    tris = np.concatenate(placed) if placed else np.empty((0, 3, 3))
    if not len(tris):
        raise _refuse(path, "COLLADA file without triangles in its scene")
    return tris * unit
