"""A link's outer shapes (``robot_shapes.LinkShapes``: spheres, boxes, slim hulls, corners, hull faces and
vertices, inner balls) kept on disk between processes, so a robot's shapes are fitted once per machine
instead of once per process (each labelling worker, each backend): the fits cost about as much as the rest
of a worker's start.

An entry is named by the digest of everything the fits read: Bullet's shape data of the link (kind,
scale, placement, its mesh files by their contents' digests and kinds, not their paths) and its inertial
frame (the base's in its root frame), which make the link's parts as points in its frame, and ``SALT``
(the fitting code's sources and the versions of numpy, scipy and pybullet): changed code, meshes or
libraries name other entries. The parts are read (their meshes parsed) only to fit an entry not found.
The folder is the user's own (``folder``, mode 0700, beside the user's collision
cache, never a twin's ``collision/`` folder): it is trusted as numba's cache of the kernels is. An entry
is still read with ``allow_pickle=False`` and checked for its arrays' kinds, shapes and finite values; one
that fails, or any failure to read or write, leaves the shapes to be fitted as if there were no cache.
Entries are a few kilobytes each and never removed: deleting the folder only costs the fits again.
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Callable
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np

from robwot_sim.wholefile import atomic_write

#: arrays of an entry: name -> (dtype kind, trailing shape)
_FIELDS = {"centres": ("f", (3,)), "radii": ("f", ()), "sphere_part": ("i", ()), "box_c": ("f", (3,)),
           "box_axes": ("f", (3, 3)), "box_half": ("f", (3,)), "verts": ("f", (3,)), "corners": ("f", (3,)),
           "counts": ("i", ()), "faces": ("f", (4,)), "face_counts": ("i", ()), "hull": ("f", (3,)),
           "hull_counts": ("i", ()), "inner_c": ("f", (3,)), "inner_r": ("f", ())}
_salt: str | None = None


def _salt_of() -> str:
    """The fitting code's sources and the libraries' versions (module docstring)."""
    global _salt
    if _salt is None:
        from robwot_sim.model import decompose
        from robwot_sim.sim import robot_shapes, surehit

        h = hashlib.sha256()
        for module in (robot_shapes, surehit, decompose):
            h.update(Path(str(module.__file__)).read_bytes())
        h.update(Path(__file__).read_bytes())
        for lib in ("numpy", "scipy", "pybullet"):
            h.update(f"{lib}={metadata.version(lib)};".encode())
        _salt = h.hexdigest()
    return _salt


def folder() -> Path:
    """The user's shapes cache: ``shapes/`` in ``ROBWOT_COLLISION_CACHE`` when set, else
    ``$XDG_CACHE_HOME/robwot/shapes`` (``~/.cache`` without it)."""
    if os.environ.get("ROBWOT_COLLISION_CACHE"):
        return Path(os.environ["ROBWOT_COLLISION_CACHE"]) / "shapes"
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "robwot" / "shapes"


def key(bullet: Any) -> str:
    """The entry of a link whose Bullet data (link index, whether it moves, shape data ``by_content``,
    inertial frame) is ``bullet`` (its ``repr`` is digested)."""
    h = hashlib.sha256(_salt_of().encode())
    h.update(repr(bullet).encode())
    return h.hexdigest()


def mesh_file(name: bytes | str) -> Path:
    """The file a row of Bullet's collision shape data names (its fifth field)."""
    return Path(name.decode(errors="replace") if isinstance(name, bytes) else str(name))


def by_content(shape: tuple[Any, ...]) -> tuple[Any, ...]:
    """One of Bullet's collision shape data rows with its mesh file named by the digest of its content and its
    kind (the reader its suffix picks): a robot loaded from a temporary folder (an expanded xacro, a tool
    attached) names the same entries each time, and a file changed in place names others."""
    name = shape[4]
    path = mesh_file(name)
    try:
        digest = (hashlib.sha256(path.read_bytes()).hexdigest() + path.suffix.lower() if path.is_file()
                  else repr(name))
    except OSError:
        digest = repr(name)
    return (*shape[:4], digest, *shape[5:])


def load(name: str, parts: int) -> dict[str, Any] | None:
    """The arrays of entry ``name`` for a link of ``parts`` parts (``verts``, ``corners``, ``faces`` and
    ``hull`` as one list per part), or None when there is none or it is not sound in kind, shape and
    values."""
    path = folder() / f"{name}.npz"
    try:
        with np.load(path, allow_pickle=False) as z:
            arrays: dict[str, Any] = {k: np.asarray(z[k]) for k in _FIELDS}
    except (OSError, ValueError, KeyError, EOFError):
        return None
    for k, (kind, tail) in _FIELDS.items():
        a = arrays[k]
        if a.dtype.kind != kind or a.shape[1:] != tail or (kind == "f" and not np.isfinite(a).all()):
            return None
    counts, spheres = arrays["counts"], len(arrays["radii"])
    if (len(counts) != parts or (counts < 1).any() or counts.sum() != len(arrays["verts"])
            or len(arrays["corners"]) != len(arrays["verts"]) or len(arrays["centres"]) != spheres
            or len(arrays["face_counts"]) != parts or (arrays["face_counts"] < 0).any()
            or arrays["face_counts"].sum() != len(arrays["faces"])
            or len(arrays["hull_counts"]) != parts or (arrays["hull_counts"] < 1).any()
            or arrays["hull_counts"].sum() != len(arrays["hull"])
            or len(arrays["sphere_part"]) != spheres or (arrays["radii"] <= 0).any()
            or ((arrays["sphere_part"] < 0) | (arrays["sphere_part"] >= parts)).any()
            or not len(arrays["box_c"]) == len(arrays["box_axes"]) == len(arrays["box_half"]) == parts
            or len(arrays["inner_c"]) != len(arrays["inner_r"]) or (arrays["inner_r"] < 0).any()):
        return None
    cut = np.cumsum(counts)[:-1]
    arrays["verts"] = [np.ascontiguousarray(v) for v in np.split(arrays["verts"], cut)]
    arrays["corners"] = [np.ascontiguousarray(c) for c in np.split(arrays["corners"], cut)]
    cut = np.cumsum(arrays["face_counts"])[:-1]
    arrays["faces"] = [np.ascontiguousarray(f) for f in np.split(arrays["faces"], cut)]
    cut = np.cumsum(arrays["hull_counts"])[:-1]
    arrays["hull"] = [np.ascontiguousarray(h) for h in np.split(arrays["hull"], cut)]
    return arrays


def store(name: str, arrays: dict[str, Any]) -> None:
    """Writes entry ``name`` (whole or not at all: a temporary file renamed); a failure is ignored."""
    out = folder()
    data = dict(arrays)
    data["counts"] = np.array([len(v) for v in arrays["verts"]], dtype=np.int64)
    data["verts"] = np.concatenate(arrays["verts"]).reshape(-1, 3)
    data["corners"] = np.concatenate(arrays["corners"]).reshape(-1, 3)
    data["face_counts"] = np.array([len(f) for f in arrays["faces"]], dtype=np.int64)
    data["faces"] = np.concatenate(arrays["faces"]).reshape(-1, 4)
    data["hull_counts"] = np.array([len(h) for h in arrays["hull"]], dtype=np.int64)
    data["hull"] = np.concatenate(arrays["hull"]).reshape(-1, 3)
    try:
        out.mkdir(parents=True, mode=0o700, exist_ok=True)
        atomic_write(out / f"{name}.npz", lambda f: np.savez(f, **{k: data[k] for k in _FIELDS}))
    except OSError:
        pass


def cached(parts: int, bullet: Any, fit: Callable[[], dict[str, Any]]) -> dict[str, Any]:
    """The arrays of the shapes of a link of ``parts`` parts: its entry when sound, else ``fit()``'s, then
    stored."""
    name = key(bullet)
    found = load(name, parts)
    if found is not None:
        return found
    made = fit()
    store(name, made)
    return made
