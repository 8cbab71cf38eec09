"""Convex decomposition of concave collision meshes, cached by content.

PyBullet turns every ``<collision><mesh>`` of a moving link into ONE convex hull: a UR forearm's hull
then touches the wrist's hull in a third of all configurations where the real meshes are apart. A link
with several ``<collision>`` elements becomes a compound shape instead, so a concave mesh is replaced by
its approximate convex decomposition (CoACD, the ``coacd`` package: collision-aware concavity, seeded,
so deterministic), one ``<collision>`` per part. CoACD replaced V-HACD (voxel-based): V-HACD's parts
stuck out of the meshes further, so more of the configurations the exact-mesh reference calls free were
labelled "colliding" (the measurements are in README "Fidelity"). A mesh that is already convex (every
vertex and triangle centroid within ``CONVEX_TOLERANCE`` of its hull's surface) is kept as it is: its hull
is exact.

Parts are OBJ files under ``cache_dir/<key>/`` where the key is a digest of the mesh bytes, the scale
and the decomposition parameters, so a cache (the twin folder's ``collision/``) is reused only for the
same input and written atomically (temp folder + rename).
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import tempfile
import threading
import time
import xml.etree.ElementTree as ET
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from importlib.metadata import version
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from robwot_sim.errors import MeshError, PathEscape, snippet
from robwot_sim.model.hull_merge import NEAR, merge_parts
from robwot_sim.model.mesh_eta import MeshEta
from robwot_sim.model.meshcheck import check_mesh
from robwot_sim.model.objfile import write_obj
from robwot_sim.twin_layout import COLLISION_DIR
from robwot_sim.wholefile import TooLarge, read_whole

FloatArray = npt.NDArray[np.float64]
IndexArray = npt.NDArray[np.uint32]
MeshReader = Callable[[Path], "tuple[FloatArray, IndexArray] | None"]

#: CoACD parameters (``coacd.run_coacd`` keyword names): concavity threshold 0.05 (of the mesh's size);
#: a shallow tree search, one cut deep (deeper searches cost a robot's first use much more time for labels
#: as close to the exact-mesh reference's). CoACD's own merge is off: its pieces are merged by
#: ``hull_merge`` to ``MAX_MESH_PARTS``, or to at most ``MOST_MESH_PARTS`` where merging costs volume
#: (README "Fidelity", "First use of your own robot" and "The paper's robots" have the measurements).
COACD_PARAMS: dict[str, Any] = {"threshold": 0.05, "preprocess_mode": "auto",
                                "resolution": 1000, "mcts_nodes": 10, "mcts_iterations": 30,
                                "mcts_max_depth": 1, "merge": False, "max_ch_vertex": 64, "seed": 0}
#: Parts per mesh where merging them is cheap: Bullet's cost per check grows with the parts.
MAX_MESH_PARTS = 8
#: Parts per mesh at most: below this, pieces are merged on down to ``MAX_MESH_PARTS`` only while the
#: cheapest merge adds less than ``MERGE_BUDGET`` of the mesh's total part volume, so a concave mesh (a
#: hollow base, a bracket) keeps the parts that stop its hulls from filling the space it encloses.
MOST_MESH_PARTS = 16
MERGE_BUDGET = 0.02
#: Concavity (metres) CoACD may leave in a piece whatever the mesh's size: the threshold is a fraction of
#: the mesh's size, so a small link's engravings and screw holes were cut out piece by piece (hundreds of
#: pieces) only to be merged into ``MAX_MESH_PARTS`` again. The same as ``REMESH_VOXEL``, the detail a
#: remeshed mesh keeps; meshes larger than 1/threshold of it are cut as before.
CONCAVITY_FLOOR = 0.005
#: Non-manifold meshes (the UR and KUKA ones) are remeshed on a voxel grid first, which fattens them: the
#: coarser, the fatter. Voxels of at most this side (m), between ``REMESH_RESOLUTION`` voxels per side:
#: a fixed count per side fattens large meshes, a finer grid costs decomposition time for no fewer false
#: "colliding" labels (README "Fidelity" has the comparison).
REMESH_VOXEL = 0.005
REMESH_RESOLUTION = (50, 100)
#: A mesh whose vertices all lie within this fraction of its size from its hull's surface is convex.
CONVEX_TOLERANCE = 1e-3
#: A mesh vertex farther than this fraction of the mesh's size outside every part is added to a part.
COVER_TOLERANCE = 1e-4
#: How far (metres) a part's slimmed hull may lie outside the points it covers (see ``slim``).
SLIM_MARGIN = 1e-4
MANIFEST = "parts.json"
#: mesh formats whose convex meshes become one part too, so PyBullet never reads them for collision
WHOLE_AS_PART = (".dae",)
#: The convex parts of the bundled robots' meshes, shipped with the package so that their first use does
#: not decompose (``npm run ship:parts`` writes them). A folder is named by its cache key, which digests
#: the mesh's content and every parameter: a changed mesh or parameter finds nothing here and is
#: decomposed as any other; ``tests/shipped-parts.test.ts`` fails when a bundled robot's parts are stale.
SHIPPED_PARTS = Path(__file__).resolve().parent.parent / "data" / COLLISION_DIR
#: bounds of a manifest read from a cache (a twin folder's may be hostile); ours hold a few names
MAX_MANIFEST_BYTES = 1024 * 1024
MAX_PARTS = 4096


@dataclass(frozen=True)
class MeshDone:
    """A mesh of a robot's first load decomposed: its file name, how many of the load's new meshes are done
    (convex ones count at once), the mesh's own time and parts, the load's elapsed time and an estimate
    of the time left (seconds; None until a concave mesh is done: from the triangles still to do at the
    rate of those done, ``mesh_eta.py``: None while unknown). The first report, before any work, has
    ``done`` 0 and no mesh name. ``cache``: the collision cache folder the parts are written to."""

    mesh: str
    done: int
    total: int
    seconds: float
    parts: int
    elapsed: float
    eta: float | None
    cache: str


OnMesh = Callable[[MeshDone], None]


@dataclass(frozen=True)
class Decomposition:
    """The convex parts of one mesh (OBJ files, in the mesh's own units), or none when it is convex."""

    convex: bool
    parts: tuple[Path, ...]


def cache_key(mesh_bytes: bytes, scale: tuple[float, float, float], whole_as_part: bool = False) -> str:
    """Digest of what determines the parts: mesh content, scale, the library, its version and parameters
    (and whether a convex mesh becomes one part: ``decompose``)."""
    h = hashlib.sha256(mesh_bytes)
    h.update(json.dumps({"scale": scale, "coacd": [version("coacd"), COACD_PARAMS],
                         **({"whole_as_part": True} if whole_as_part else {}),
                         "remesh": [REMESH_VOXEL, REMESH_RESOLUTION],
                         "merge": [MAX_MESH_PARTS, MOST_MESH_PARTS, MERGE_BUDGET, NEAR],
                         "floor": CONCAVITY_FLOOR,
                         "cover": [COVER_TOLERANCE, 2], "slim": SLIM_MARGIN}, sort_keys=True).encode())
    return h.hexdigest()[:24]


def is_convex(vertices: FloatArray, faces: IndexArray) -> bool:
    """True when every vertex and triangle centroid lies on (within tolerance of) the hull's surface."""
    size = float(np.ptp(vertices, axis=0).max()) if len(vertices) else 0.0
    if size == 0.0:
        return True
    from scipy.spatial import ConvexHull, QhullError

    try:
        hull = ConvexHull(vertices)
    except QhullError:
        return True  # flat or degenerate: PyBullet's hull of it is the shape itself
    probes = np.vstack([vertices, vertices[faces].mean(axis=1)])
    # hull.equations: n·x + d <= 0 inside; the distance to the surface is -max over facets. In blocks of
    # probes (a probes x facets matrix of a detailed mesh is gigabytes); a concave mesh stops at its first
    # deep probe.
    for block in _blocks(len(probes), len(hull.equations)):
        depth = -np.max(probes[block] @ hull.equations[:, :3].T + hull.equations[:, 3], axis=1)
        if np.any(depth > CONVEX_TOLERANCE * size):
            return False
    return True


def _blocks(rows: int, columns: int, cells: int = 1 << 20) -> list[slice]:
    """Row slices of a rows x columns computation holding at most about ``cells`` values at a time."""
    step = max(1, cells // max(1, columns))
    return [slice(i, i + step) for i in range(0, rows, step)]


def _outside(points: FloatArray, equations: FloatArray) -> FloatArray:
    """Signed distance of each point outside a convex hull (its facet planes ``equations``): the largest
    plane distance, <= 0 inside. Computed in blocks of points."""
    out = np.empty(len(points))
    for block in _blocks(len(points), len(equations)):
        out[block] = np.max(points[block] @ equations[:, :3].T + equations[:, 3], axis=1)
    return out


def decompose(vertices: FloatArray, faces: IndexArray, key: str, cache_dir: Path,
              whole_as_part: bool = False, convex: bool | None = None) -> Decomposition:
    """The cached decomposition of a mesh (``vertices`` [n, 3] already scaled, ``faces`` [m, 3]). A convex
    mesh has no parts (PyBullet's hull of the file is exact), unless ``whole_as_part``: then its hull is
    the one part, so PyBullet never reads the file for collision (a DAE: PyBullet reads only its
    ``<triangles>``; ours reads polylists and polygons too). ``convex``: ``is_convex`` already known."""
    folder = cache_dir / key
    cached = _read_manifest(folder)
    if cached is not None:
        return cached
    if convex if convex is not None else is_convex(vertices, faces):
        from scipy.spatial import ConvexHull

        _write(folder, [_compact(vertices, ConvexHull(vertices, qhull_options="QJ").simplices)]
               if whole_as_part else [])
    else:
        _write(folder, cover(surface_points(vertices, faces), convex_parts(vertices, faces)))
    written = _read_manifest(folder)
    if written is None:
        raise OSError(f"convex decomposition cache {folder} could not be read back")
    return written


_quiet_lock = threading.Lock()
_quiet = False


def _quiet_coacd(coacd: Any) -> None:
    """CoACD's log level set to errors, once per process and before any decomposition of it runs: its
    logger is not thread-safe, and setting the level while another thread decomposes aborted the process
    (meshes are decomposed on threads, one per core)."""
    global _quiet
    with _quiet_lock:
        if not _quiet:
            coacd.set_log_level("error")
            _quiet = True


def convex_parts(vertices: FloatArray, faces: IndexArray) -> list[FloatArray]:
    """CoACD's convex pieces of a mesh merged to ``MAX_MESH_PARTS`` parts, or to at most ``MOST_MESH_PARTS``
    where merging would add more than ``MERGE_BUDGET`` of their volume (``hull_merge``; their vertices)."""
    import coacd  # imported here: most robots have only convex meshes

    _quiet_coacd(coacd)
    mesh = coacd.Mesh(np.ascontiguousarray(vertices, dtype=np.float64),
                      np.ascontiguousarray(faces, dtype=np.int32))
    size = float(np.ptp(vertices, axis=0).max()) if len(vertices) else 0.0
    params = {**COACD_PARAMS, "threshold": max(COACD_PARAMS["threshold"], CONCAVITY_FLOOR / (size or 1.0))}
    pieces = coacd.run_coacd(mesh, preprocess_resolution=remesh_resolution(vertices), **params)
    return merge_parts([np.asarray(v, dtype=np.float64) for v, _ in pieces], MAX_MESH_PARTS,
                       MOST_MESH_PARTS, MERGE_BUDGET)


def remesh_resolution(vertices: FloatArray) -> int:
    """Voxels per side for CoACD's remesh of a non-manifold mesh (``REMESH_VOXEL``)."""
    lo, hi = REMESH_RESOLUTION
    size = float(np.ptp(vertices, axis=0).max()) if len(vertices) else 0.0
    return int(np.clip(np.ceil(size / REMESH_VOXEL), lo, hi))


def surface_points(vertices: FloatArray, faces: IndexArray, spacing: float = 1 / 40) -> FloatArray:
    """The vertices plus points spread over every triangle (at most ``spacing`` x the mesh size apart), so
    that covering them covers the surface, not only its corners (a flat link's large triangles)."""
    size = float(np.ptp(vertices, axis=0).max()) or 1.0
    tris = vertices[faces]
    edges = np.max(np.linalg.norm(tris - np.roll(tris, 1, axis=1), axis=2), axis=1)
    out = [vertices]
    for n in range(2, 9):
        pick = np.ceil(edges / (spacing * size)).clip(1, 8) == n
        if not pick.any():
            continue
        grid = np.array([(i, j, n - i - j) for i in range(n + 1) for j in range(n + 1 - i)], float) / n
        out.append(np.einsum("gk,tkd->tgd", grid, tris[pick]).reshape(-1, 3))
    return np.vstack(out)


def cover(vertices: FloatArray, parts: list[FloatArray]) -> list[tuple[FloatArray, npt.NDArray[Any]]]:
    """Grows the parts until every mesh vertex lies inside one of them (within ``COVER_TOLERANCE``).

    A decomposition may leave parts of the surface out (V-HACD left whole regions of a forearm outside
    every part; CoACD's hulls of its pieces leave out thin slivers, e.g. where a non-manifold mesh is
    remeshed), which would let real contacts through. Each
    uncovered vertex joins the part it is closest to, whose hull is then recomputed: the twin's shape then
    contains the mesh (up to triangle interiors spanning two parts), never less.
    """
    from scipy.spatial import ConvexHull

    pts = [p for p in parts if len(p) >= 4]
    size = float(np.ptp(vertices, axis=0).max())
    tolerance = COVER_TOLERANCE * size
    for _ in range(4):
        eqs = [ConvexHull(p, qhull_options="QJ").equations for p in pts]
        # a point is covered by a part it lies in (within the tolerance); only points in a part's bounding
        # ball, grown by the tolerance, can be, so only those are measured against its facet planes
        covered = np.zeros(len(vertices), dtype=bool)
        for p, e in zip(pts, eqs, strict=True):
            centre = p.mean(axis=0)
            radius = float(np.max(np.linalg.norm(p - centre, axis=1)))
            in_ball = np.linalg.norm(vertices - centre, axis=1) <= radius + tolerance
            near = np.flatnonzero(~covered & in_ball)
            covered[near[_outside(vertices[near], e) <= tolerance]] = True
        lost = np.flatnonzero(~covered)
        if not len(lost):
            break
        # each lost point joins the part it lies least outside of
        best = np.argmin(np.stack([_outside(vertices[lost], e) for e in eqs], axis=1), axis=1)
        for k in np.unique(best):
            pts[k] = np.vstack([pts[k], vertices[lost[best == k]]])
    return [slim(p, SLIM_MARGIN) for p in pts]


def slim(points: FloatArray, margin: float) -> tuple[FloatArray, npt.NDArray[Any]]:
    """A convex hull of ``points`` with few vertices that contains them all and is slightly larger.

    The exact hull of finely spread surface points has hundreds of vertices (KUKA parts: median 353, up
    to 7,522), and Bullet's narrow phase pays per vertex. Qhull merges facets whose centrums lie within
    ``margin`` of their neighbours ("C" option); each merged facet's plane is moved out by ``margin`` and
    the planes are intersected. Faces lie ``margin`` out, corners where shallow faces meet somewhat
    more (a 5 cm sphere at 0.1 mm: 0.47 mm at most, 2,266 instead of 5,000 vertices). The result is
    checked to contain every point; when it does not, or has no fewer vertices (nothing to merge), the
    exact hull is returned. Returns (vertices, triangles).
    """
    from scipy.spatial import ConvexHull, HalfspaceIntersection, QhullError

    exact = ConvexHull(points, qhull_options="QJ")
    vertices, triangles = _compact(points, exact.simplices)
    try:
        merged = ConvexHull(points, qhull_options=f"C{margin:.9g}")
        planes = np.unique(np.round(merged.equations, 12), axis=0)
        planes[:, 3] -= margin
        inner = points[merged.vertices].mean(axis=0)
        corners = HalfspaceIntersection(planes, inner).intersections
        slimmed = ConvexHull(corners)
    except (QhullError, ValueError):
        return vertices, triangles
    outside = np.max(points @ slimmed.equations[:, :3].T + slimmed.equations[:, 3], axis=1)
    if len(slimmed.vertices) >= len(vertices) or outside.max() > 1e-9:
        return vertices, triangles
    return _compact(corners, slimmed.simplices)


def _compact(points: FloatArray, simplices: npt.NDArray[Any]) -> tuple[FloatArray, npt.NDArray[Any]]:
    """The points a triangulation uses, and the triangles renumbered over them."""
    used = np.unique(simplices)
    remap = np.full(len(points), -1)
    remap[used] = np.arange(len(used))
    return points[used], remap[simplices]


def _write(folder: Path, hulls: list[tuple[FloatArray, npt.NDArray[Any]]]) -> None:
    """Writes the parts and the manifest into a temp folder, then renames it into place."""
    folder.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{folder.name}-", dir=folder.parent))
    try:
        names = []
        for i, (v, f) in enumerate(hulls):
            name = f"part{i:03d}.obj"
            write_obj(tmp / name, v, f)
            names.append(name)
        (tmp / MANIFEST).write_text(json.dumps({"convex": not hulls, "parts": names}))
        try:
            os.rename(tmp, folder)
        except OSError:
            if not (folder / MANIFEST).is_file():  # another process wrote the same key first: keep theirs
                raise
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def _read_manifest(folder: Path) -> Decomposition | None:
    """The cached parts in ``folder`` (``cache_dir/<key>``), or None when it holds no manifest.

    A cache may come with a twin folder (its ``collision/``), so nothing in it is trusted: the key folder,
    ``parts.json`` and every part must resolve inside the cache after symlinks, every entry must be a
    plain file name of its folder, and every part must exist and pass our mesh parser (PyBullet crashes
    on a face index beyond the vertices). A manifest that breaks any of this refuses the load (PathEscape,
    MeshError): it is never taken as missing, which would decompose again."""
    manifest = folder / MANIFEST
    if not os.path.lexists(manifest):
        return None
    real_folder = folder.resolve()
    if real_folder.parent != folder.parent.resolve():
        raise PathEscape(str(folder), [str(folder.parent)], reason="the convex parts folder resolves "
                         "outside its collision cache")
    if manifest.resolve().parent != real_folder:
        raise PathEscape(str(manifest), [str(folder)], reason=f"{MANIFEST} resolves outside its folder")
    where = f"{manifest} (delete {folder} or re-run robwot generate)"
    try:
        doc = json.loads(read_whole(manifest, MAX_MANIFEST_BYTES))
    except TooLarge as e:
        raise MeshError(f"{where}: {e}", file=str(manifest), reason="manifest too large", size=e.size,
                        limit=e.limit) from None
    except (OSError, ValueError):
        raise MeshError(f"{where}: not a readable JSON manifest", file=str(manifest),
                        reason="invalid manifest") from None
    names = doc.get("parts") if isinstance(doc, dict) else None
    if not isinstance(names, list) or len(names) > MAX_PARTS or not all(isinstance(n, str) for n in names):
        raise MeshError(f"{where}: 'parts' must be a list of at most {MAX_PARTS} file names",
                        file=str(manifest), reason="invalid manifest")
    return Decomposition(convex=bool(doc.get("convex")),
                         parts=tuple(_checked_part(folder, real_folder, name) for name in names))


def _checked_part(folder: Path, real_folder: Path, name: str) -> Path:
    """A part named by a manifest: a file of the folder itself (no path, no symlink out), parsed by our
    mesh parser. Returns its real path (what PyBullet loads)."""
    manifest = folder / MANIFEST
    entry = snippet(name)
    if name in ("", ".", "..") or Path(name).name != name or "\\" in name or "\0" in name:
        raise PathEscape(str(manifest), [str(folder)],
                         reason=f"{MANIFEST} entry {entry} is not a file name of its folder")
    part = folder / name
    if not part.is_file():
        raise MeshError(f"convex part {part} named by {manifest} is missing (the collision cache is "
                        f"incomplete: re-run robwot generate, or delete {folder} to decompose again)",
                        file=str(part), reason="missing convex part", manifest=str(manifest))
    real = part.resolve()
    if real.parent != real_folder:
        raise PathEscape(str(manifest), [str(folder)],
                         reason=f"{MANIFEST} entry {entry} resolves outside its folder")
    if real.suffix.lower() != ".obj":
        raise MeshError(f"convex part {part}: parts are OBJ files", file=str(part), reason="not an OBJ file")
    check_mesh(real)
    return real


def collision_cache(urdf_dir: Path) -> Path:
    """Where decompositions are cached: the ``collision/`` folder next to a twin's robot.urdf (export
    writes it; it must resolve inside the URDF's folder), else ``ROBWOT_COLLISION_CACHE``, else
    ``$XDG_CACHE_HOME/robwot/collision``."""
    local = urdf_dir / COLLISION_DIR
    if local.is_dir():
        real, udir = local.resolve(), urdf_dir.resolve()
        if udir not in real.parents:
            raise PathEscape(str(local), [str(udir)], reason="the collision cache resolves outside the "
                             "URDF's folder")
        return real
    if os.environ.get("ROBWOT_COLLISION_CACHE"):
        return Path(os.environ["ROBWOT_COLLISION_CACHE"])
    base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    return base / "robwot" / "collision"


def split_collisions(root: ET.Element, cache_dir: Path, read_mesh: MeshReader, *,
                     allow_decompose: bool = True, on_mesh: OnMesh | None = None) -> tuple[Path, ...]:
    """Replaces, in a URDF tree whose mesh filenames are absolute, every ``<collision>`` holding a concave
    mesh by one ``<collision>`` per convex part (same origin and name). ``read_mesh`` gives a mesh's
    vertices and triangles, or None for a format that is kept as it is. Meshes not yet in the cache are
    decomposed first, in parallel (``decompose_all``); with ``allow_decompose`` False (serving a twin
    folder, whose parts generate wrote) a concave mesh without cached parts is refused instead
    (MeshError): only ``robwot generate`` decomposes. ``on_mesh`` hears of each new mesh done. Returns the
    cache folders used."""
    found: list[tuple[ET.Element, ET.Element, str]] = []
    known: dict[str, Decomposition] = {}
    folders: dict[str, Path] = {}  # key -> the cache folder its parts come from
    todo: dict[str, tuple[FloatArray, IndexArray, bool, str]] = {}
    for link in root.iter("link"):
        for col in list(link.findall("collision")):
            mesh = col.find("geometry/mesh")
            if mesh is None:
                continue
            path = Path(mesh.get("filename", ""))
            scale = _scale(mesh.get("scale"))
            whole = path.suffix.lower() in WHOLE_AS_PART
            key = cache_key(path.read_bytes(), scale, whole)
            if key in known or key in todo:
                found.append((link, col, key))
                continue
            cached = _cached(key, cache_dir)
            if cached is not None:  # its triangles are not read: the parts are known by its content
                known[key], folders[key] = cached
                found.append((link, col, key))
                continue
            read = read_mesh(path)
            if read is None:
                continue
            found.append((link, col, key))
            if allow_decompose:
                todo[key] = (read[0] * np.asarray(scale), read[1], whole, path.name)
            elif is_convex(read[0] * np.asarray(scale), read[1]):
                known[key] = Decomposition(convex=True, parts=())  # kept whole: nothing to decompose
            else:
                raise MeshError(
                    f"collision mesh {path} is concave and has no convex parts in {cache_dir / key}: this "
                    "load may not decompose meshes (robwot serve never does): re-run robwot generate",
                    file=str(path), reason="no cached convex parts", cache=str(cache_dir / key))
    decompose_all(todo, cache_dir, on_mesh)
    for link, col, key in found:
        folders.setdefault(key, cache_dir / key)
        parts = known.get(key) or _read_manifest(folders[key])
        if parts is None:
            raise OSError(f"convex decomposition cache {cache_dir / key} could not be read back")
        if parts.convex:
            continue
        at = list(link).index(col)
        link.remove(col)
        for i, part in enumerate(parts.parts):
            piece = ET.Element("collision", {k: v for k, v in col.attrib.items() if k != "name"})
            if col.get("name"):
                piece.set("name", f"{col.get('name')}_{i}")
            origin = col.find("origin")
            if origin is not None:
                piece.append(ET.Element("origin", dict(origin.attrib)))
            geometry = ET.SubElement(piece, "geometry")
            ET.SubElement(geometry, "mesh", {"filename": str(part)})
            link.insert(at + i, piece)
    return tuple(dict.fromkeys(folders[key] for _, _, key in found if folders[key].is_dir()))


def _cached(key: str, cache_dir: Path) -> tuple[Decomposition, Path] | None:
    """The parts of a key and their folder: from the cache, else from the shipped parts."""
    for folder in (cache_dir / key, SHIPPED_PARTS / key):
        cached = _read_manifest(folder)
        if cached is not None:
            return cached, folder
    return None


def decompose_all(meshes: dict[str, tuple[FloatArray, IndexArray, bool, str]], cache_dir: Path,
                  on_mesh: OnMesh | None = None) -> None:
    """Decomposes meshes (key -> scaled vertices, triangles, whole_as_part, file name) into the cache:
    convex ones at once, concave ones on one thread per core, largest first, each reported to ``on_mesh``
    (from the thread that did it). A robot's first load decomposes all its meshes; CoACD releases the GIL,
    so the threads run side by side, and its parts do not depend on what runs beside it (seeded)."""
    start = time.perf_counter()
    convex = {key for key, (v, f, _, _) in meshes.items() if is_convex(v, f)}
    concave = sorted((key for key in meshes if key not in convex), key=lambda k: -len(meshes[k][1]))
    workers = max(1, min(len(concave), os.cpu_count() or 1))
    eta = MeshEta({key: len(meshes[key][1]) for key in concave}, workers)
    lock = threading.Lock()
    done = {"meshes": 0}
    where = str(cache_dir)

    def one(key: str) -> None:
        vertices, faces, whole, name = meshes[key]
        t = time.perf_counter()
        eta.start(key, t)
        parts = decompose(vertices, faces, key, cache_dir, whole, key in convex)
        left = eta.done(key, time.perf_counter()) if key not in convex else None
        if on_mesh is None:
            return
        with lock:
            now = time.perf_counter()
            done["meshes"] += 1
            on_mesh(MeshDone(name, done["meshes"], len(meshes), now - t, len(parts.parts), now - start, left,
                             where))

    if on_mesh is not None and meshes:
        on_mesh(MeshDone("", 0, len(meshes), 0.0, 0, 0.0, None, where))
    for key in convex:
        one(key)
    with ThreadPoolExecutor(workers) as pool:
        for job in [pool.submit(one, key) for key in concave]:
            job.result()


def _scale(text: str | None) -> tuple[float, float, float]:
    values = [float(v) for v in (text or "1 1 1").split()]
    if len(values) == 1:
        values *= 3
    return (values[0], values[1], values[2])
