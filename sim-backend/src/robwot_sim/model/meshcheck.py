"""Mesh files checked by our own parsers before PyBullet sees them.

PyBullet's mesh readers trust their input: an ASCII STL, an empty binary STL (0 triangles) or a binary
STL whose triangle count exceeds what the file holds crash the whole process. Every mesh (URDF
``<mesh>``, scene and run-time obstacles) therefore goes through ``check_mesh`` first:

* binary STL: size exactly ``84 + 50 * n`` with ``0 < n <= MAX_TRIANGLES``, finite coordinates;
* ASCII STL: parsed (``vertex x y z`` triples), then converted to a binary STL in a backend-owned cache
  folder (PyBullet reads binary STL only), so the original never reaches PyBullet;
* OBJ (``objmesh.py``): ``v`` lines finite, ``f`` lines with >= 3 in-range indices (1-based, negative =
  relative), at least one face;
* DAE (COLLADA, ``daemesh.py``): read with the same DTD-free XML reader as URDFs; ``float_array`` counts
  match their finite contents, every index of a ``<p>`` stays within its positions, the scene's triangles
  are read (``read_mesh``), so a DAE collision mesh is decomposed like an STL or OBJ.

A refused file raises ``MeshError`` (``E_MESH``) naming the file and the reason; the caller adds where
it came from (URDF and line, obstacle name).

A file passed is remembered by its stamp (path, size, modification and status change times in ns, inode,
device): asked about again with the same stamp, it is not read again. A process may take another's passed
files as its own (``checked_meshes`` there, ``vouch`` here: a labelling pool's workers take the backend's);
a file changed since has another stamp and is parsed again. The status change time is the kernel's own:
every write sets it, and so does setting the modification time back (``touch -d``). The kernel stamps with
a clock of a few milliseconds' resolution, so a file written again within that time could keep its stamp:
only a file whose status last changed ``SETTLED_NS`` or longer before it is read is remembered (as git does
with its index), and any later write stamps it anew.
"""

from __future__ import annotations

import hashlib
import os
import re
import struct
import tempfile
import threading
import time
from collections import OrderedDict
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from robwot_sim.errors import MeshError
from robwot_sim.model.daemesh import parse_dae
from robwot_sim.model.objmesh import parse_obj
from robwot_sim.wholefile import TooLarge, read_whole

MAX_MESH_BYTES = 256 * 1024 * 1024
MAX_TRIANGLES = 5_000_000
_STL_DTYPE = np.dtype([("normal", "<f4", (3,)), ("v", "<f4", (3, 3)), ("attr", "<u2")])
_FLOAT = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_ASCII_VERTEX = re.compile(rb"^\s*vertex\s+(" + _FLOAT.encode() + rb")\s+(" + _FLOAT.encode() + rb")\s+("
                           + _FLOAT.encode() + rb")\s*$", re.MULTILINE)


_refuse = MeshError.at  # a refusal naming the file, the reason and the line

@dataclass(frozen=True)
class MeshData:
    """Triangles of a mesh: ``vertices`` [n, 3] (file units) and ``faces`` [m, 3] (0-based indices)."""

    vertices: npt.NDArray[np.float64]
    faces: npt.NDArray[np.uint32]


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
        parsed = Parsed(parse_dae(path, data, MAX_TRIANGLES).reshape(-1, 3), None, False, key[1])
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


#: a file's stamp: (path, size, modification time in ns, status change time in ns, inode, device)
FileStamp = tuple[str, int, int, int, int, int]
#: stamps of the files this process (or one vouching for it) parsed and passed as PyBullet may load them;
#: emptied when it holds more than ``MAX_PASSED`` (a servient loading robots for months)
_passed: set[FileStamp] = set()
MAX_PASSED = 10_000
#: how long before it is read a file's status must have changed last for it to be remembered (module
#: docstring)
SETTLED_NS = 1_000_000_000


def _stamp(path: Path) -> FileStamp | None:
    try:
        st = os.stat(path)
    except OSError:
        return None
    return (str(path), st.st_size, st.st_mtime_ns, st.st_ctime_ns, st.st_ino, st.st_dev)


def check_mesh(path: Path) -> Path:
    """Validate a mesh file; returns the file PyBullet may load (a converted copy for ASCII STL). A file
    passed before with the same stamp (module docstring) is not read again. The stamp is taken before the
    file is read: a file changed while or after it is read has another stamp at the next check."""
    stamp = _stamp(path)
    if stamp is not None and stamp in _passed:
        return path
    parsed = _parsed(path)
    if parsed.ascii:
        return _ascii_to_binary(parsed.points, parsed.digest)
    if stamp is not None and time.time_ns() - stamp[3] >= SETTLED_NS:
        with _memo_lock:
            if len(_passed) >= MAX_PASSED:
                _passed.clear()
            _passed.add(stamp)
    return path


def checked_meshes() -> frozenset[FileStamp]:
    """The stamps of the files this process passed (``check_mesh``) and PyBullet may load as they are."""
    with _memo_lock:
        return frozenset(_passed)


def vouch(stamps: frozenset[FileStamp]) -> None:
    """Take files another process of this machine passed (``checked_meshes`` there) as passed here: each
    counts while the file keeps that stamp. Never for another machine's: a stamp names a file of one."""
    with _memo_lock:
        if len(_passed) + len(stamps) > MAX_PASSED:
            _passed.clear()
        _passed.update(stamps)


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
