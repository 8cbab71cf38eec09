"""Writers for the workspace files: ``workspace.csv`` (labelled point cloud) and binary STL.

Both are written to a temporary file in the target folder and renamed, so a reader never sees a partial
file. Units: metres, world frame.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import BinaryIO

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
BoolArray = npt.NDArray[np.bool_]

CSV_HEADER = ("x", "y", "z", "collision_free")
_CSV_CHUNK = 20_000
_STL_DTYPE = np.dtype([("normal", "<f4", (3,)), ("vertices", "<f4", (3, 3)), ("attr", "<u2")])


def atomic_write(path: Path, write: Callable[[BinaryIO], None]) -> None:
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            write(f)
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def csv_layout(joint_count: int | None, joint_names: Sequence[str] = ()) -> tuple[list[str], str]:
    """Header and row format of ``workspace.csv``; ``joint_count`` joint columns (``None``: none)."""
    header = list(CSV_HEADER)
    fmt = "%.6f,%.6f,%.6f,%d"
    if joint_count is not None:
        names = list(joint_names) or [f"q{i}" for i in range(joint_count)]
        if len(names) != joint_count:
            raise ValueError(f"{len(names)} joint names for {joint_count} joint columns")
        header += names
        fmt += ",%.6f" * joint_count
    return header, fmt


def csv_table(positions: FloatArray, collision_free: BoolArray,
              joints: FloatArray | None = None) -> FloatArray:
    """The numbers of ``workspace.csv`` rows: ``x, y, z, flag[, joints...]`` per sample."""
    pos = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    cols = [pos, np.asarray(collision_free, dtype=np.float64).reshape(-1, 1)]
    if joints is not None:
        cols.append(np.asarray(joints, dtype=np.float64).reshape(len(pos), -1))
    return np.hstack(cols)


def write_csv(path: str | Path, positions: FloatArray, collision_free: BoolArray,
              joints: FloatArray | None = None, joint_names: Sequence[str] = ()) -> None:
    """``x,y,z,collision_free[,joint...]``: one row per sample, ``%.6f`` (m or rad), flag ``1``/``0``."""
    table = csv_table(positions, collision_free, joints)
    header, fmt = csv_layout(None if joints is None else table.shape[1] - 4, joint_names)
    write_table(Path(path), header, fmt, table)


def format_rows(row_format: str, table: FloatArray) -> bytes:
    """The CSV lines of ``table``, one per row, formatted by ``row_format`` (%-style)."""
    row = row_format + "\n"
    parts = []
    for a in range(0, len(table), _CSV_CHUNK):
        block = table[a:a + _CSV_CHUNK]
        parts.append(((row * len(block)) % tuple(block.ravel().tolist())).encode())
    return b"".join(parts)


def write_table(path: str | Path, header: Sequence[str], row_format: str, table: FloatArray) -> None:
    """A CSV file: ``header``, then one line per row of ``table`` formatted by ``row_format`` (%-style)."""

    def write(f: BinaryIO) -> None:
        f.write((",".join(header) + "\n").encode())
        for a in range(0, len(table), _CSV_CHUNK):
            f.write(format_rows(row_format, table[a:a + _CSV_CHUNK]))

    atomic_write(Path(path), write)


def triangle_normals(vertices: FloatArray, triangles: IntArray) -> FloatArray:
    """Unit normals (right-hand rule over the vertex order); zero for degenerate triangles."""
    v = vertices[triangles]
    n = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
    length = np.linalg.norm(n, axis=1, keepdims=True)
    unit: FloatArray = np.divide(n, length, out=np.zeros_like(n), where=length > 0)
    return unit


def write_stl(path: str | Path, vertices: FloatArray, triangles: IntArray,
              header: str = "robwot workspace alpha shape (binary STL, metres)") -> None:
    """Binary little-endian STL of ``triangles`` (indices into ``vertices``), normals from the winding."""
    v = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    t = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    rec = np.zeros(len(t), dtype=_STL_DTYPE)
    if len(t):
        rec["normal"] = triangle_normals(v, t)
        rec["vertices"] = v[t]
    head = header.encode("ascii", "replace")[:80].ljust(80, b" ")
    if head.lower().startswith(b"solid"):
        head = b"binary " + head[:73]

    def write(f: BinaryIO) -> None:
        f.write(head)
        f.write(np.array([len(t)], dtype="<u4").tobytes())
        f.write(rec.tobytes())

    atomic_write(Path(path), write)


def read_stl(path: str | Path) -> tuple[FloatArray, FloatArray]:
    """Triangles ``(f, 3, 3)`` and normals ``(f, 3)`` of a binary STL (for tests and checks)."""
    data = Path(path).read_bytes()
    count = int(np.frombuffer(data, dtype="<u4", count=1, offset=80)[0])
    if len(data) != 84 + 50 * count:
        raise ValueError(f"{path}: {len(data)} bytes, expected {84 + 50 * count} for {count} triangles")
    rec = np.frombuffer(data, dtype=_STL_DTYPE, count=count, offset=84)
    return rec["vertices"].astype(np.float64), rec["normal"].astype(np.float64)
