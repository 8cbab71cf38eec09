"""COLLADA (DAE) files read by our own code (``meshcheck.py`` calls it before PyBullet sees one): with the
DTD-free XML reader of URDFs, every ``float_array`` count and index checked, the triangles placed as the
scene instantiates them, in metres. A refused file raises ``MeshError`` naming the file and the reason."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from robwot_sim.errors import MeshError, snippet
from robwot_sim.model import xmlsafe

_refuse = MeshError.at  # a refusal naming the file, the reason and the line


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


def parse_dae(path: Path, data: bytes, most: int) -> npt.NDArray[np.float64]:
    """The triangles of a COLLADA file as placed by its scene, in metres ([m, 3, 3]), at most ``most``.

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
                if total > most:
                    raise _refuse(path, f"more than {most} triangles")
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
