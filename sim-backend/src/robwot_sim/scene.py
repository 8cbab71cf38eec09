"""Scene documents: versioned JSON checked against ``schemas/scene.schema.json``.

A scene is ``{"version": 1, "obstacles": [Obstacle], "objects": [Object], "conveyors": [Conveyor],
"sensors": [Sensor], "robots": [Robot]}``; an object is an obstacle's shape and pose with a mass (kg), a
conveyor a belt's box (an obstacle too) with its speed, one namespace holds the obstacles', objects',
conveyors' and robots' names (sensors': their own). Relative URDF and mesh paths are relative to the scene
file's folder (then ``pybullet_data`` for URDFs). Errors carry a JSON pointer.
"""

from __future__ import annotations

import json
import math
from functools import cache
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any

from robwot_sim.errors import FileNotFound, InvalidParams, SceneError
from robwot_sim.jsondepth import TooDeep, loads_bounded
from robwot_sim.limits import DEFAULT_MASS, MAX_OBJECTS
from robwot_sim.model.rotations import quat_from_rpy
from robwot_sim.model.urdf import pybullet_data_path
from robwot_sim.schemacheck import accepts, compiled
from robwot_sim.validate import MIN_QUATERNION_NORM, unit_quaternion
from robwot_sim.wholefile import TooLarge, read_whole

if TYPE_CHECKING:
    import jsonschema

MAX_SCENE_BYTES = 50 * 1024 * 1024


@cache
def schema() -> dict[str, Any]:
    text = resources.files("robwot_sim").joinpath("schemas/scene.schema.json").read_text(encoding="utf-8")
    data: dict[str, Any] = json.loads(text)
    return data


@cache
def _compiled() -> object:
    return compiled(schema())


@cache
def _validator() -> jsonschema.protocols.Validator:
    """The Python validator, for the message on a document refused (imported then: a valid scene, such as
    the one a labelling worker builds its world from, never needs it)."""
    import jsonschema

    cls = jsonschema.validators.validator_for(schema())
    v: jsonschema.protocols.Validator = cls(schema())
    return v


def _pointer(parts: Any) -> str:
    return "".join("/" + str(p).replace("~", "~0").replace("/", "~1") for p in parts)


def _nonfinite(value: Any, path: tuple[Any, ...] = ()) -> tuple[tuple[Any, ...], Any] | None:
    if isinstance(value, float) and not math.isfinite(value):
        return path, value
    if isinstance(value, dict):
        items: Any = value.items()
    elif isinstance(value, list):
        items = enumerate(value)
    else:
        return None
    for k, v in items:
        bad = _nonfinite(v, (*path, k))
        if bad is not None:
            return bad
    return None


def schema_errors(doc: Any) -> tuple[str, str] | None:
    """First problem of a scene document as (JSON pointer, message), or None when valid."""
    objects = doc.get("objects") if isinstance(doc, dict) else None
    if isinstance(objects, list) and len(objects) > MAX_OBJECTS:  # said before the schema quotes them all
        return "/objects", f"{len(objects)} objects, more than the limit of {MAX_OBJECTS}"
    bad = _nonfinite(doc)
    if bad is not None:
        return _pointer(bad[0]), f"{bad[1]} is not a finite number"
    if not accepts(_compiled(), doc):  # the Python validator only says why (``schemacheck.py``)
        from jsonschema.exceptions import best_match

        err = best_match(_validator().iter_errors(doc))
        if err is not None:
            return _pointer(err.absolute_path), err.message
    return _duplicate_name(doc) or _zero_quaternion(doc)


def _duplicate_name(doc: dict[str, Any]) -> tuple[str, str] | None:
    """The first name an obstacle, object, conveyor (its belt is an obstacle) or robot id repeats (one
    namespace), or a sensor repeats (among sensors)."""
    shared = "obstacles, objects, conveyors and robots share one namespace"
    spaces = [((("obstacles", "name"), ("objects", "name"), ("conveyors", "name"), ("robots", "id")), shared),
              ((("sensors", "name"),), "sensor names are unique among sensors")]
    for kinds, what in spaces:
        names: set[str] = set()
        for kind, key in kinds:
            for i, entry in enumerate(doc.get(kind, [])):
                if key not in entry:
                    continue
                if entry[key] in names:
                    return f"/{kind}/{i}/{key}", f"duplicate name {entry[key]!r} ({what})"
                names.add(entry[key])
    return None


def _zero_quaternion(doc: dict[str, Any]) -> tuple[str, str] | None:
    quaternions = (("obstacles", "orientation"), ("objects", "orientation"), ("conveyors", "orientation"),
                   ("sensors", "orientation"), ("robots", "baseOrientation"))
    for kind, key in quaternions:
        for i, ob in enumerate(doc.get(kind, [])):
            if key in ob and unit_quaternion(ob[key]) is None:
                return f"/{kind}/{i}/{key}", f"quaternion has zero norm (< {MIN_QUATERNION_NORM:g})"
    return None


def read_scene(scene: dict[str, Any] | str | Path) -> tuple[dict[str, Any], Path, str | None]:
    """Read and validate a scene (dict or file). Returns (document, base folder, file name or None)."""
    if isinstance(scene, dict):
        doc, base, file = scene, Path.cwd(), None
    else:
        p = Path(scene).expanduser()
        if not p.is_file():
            raise FileNotFound(str(p), what="scene file")
        file = str(p.resolve())
        try:
            text = read_whole(p, MAX_SCENE_BYTES)
        except TooLarge as e:
            refused = SceneError(str(e), file=file, path="")
            refused.data.update(size=e.size, limit=e.limit)
            raise refused from None

        def refuse(c: str) -> Any:
            raise ValueError(f"{c} is not valid JSON")

        try:
            doc = loads_bounded(text.decode("utf-8"), parse_constant=refuse)
        except TooDeep as e:
            raise SceneError(str(e), file=file, path="") from None
        except (ValueError, UnicodeDecodeError) as e:
            raise SceneError(f"not valid JSON: {e}", file=file, path="") from None
        base = p.resolve().parent
    problem = schema_errors(doc)
    if problem is not None:
        raise SceneError(problem[1], file=file, path=problem[0])
    return doc, base, file


def normalise_obstacle(spec: Any, base: Path | None = None, *, checked: bool = False,
                       kind: str = "obstacles") -> dict[str, Any]:
    """Validate one obstacle spec (InvalidParams with a JSON pointer) and return it normalised:
    ``{name, shape, position, orientation}`` with a unit quaternion; mesh files made absolute.
    ``kind="objects"``: an object's spec, normalised with its ``mass`` (kg; the contract's default).
    ``checked=True`` skips the schema check for specs of a document ``read_scene`` already validated
    (with 239 obstacles the second check cost ~0.3 s of every scene load)."""
    what = "obstacle" if kind == "obstacles" else "object"
    problem = None if checked else schema_errors({"version": 1, kind: [spec]})
    if problem is not None:
        ptr = problem[0].removeprefix(f"/{kind}/0")
        raise InvalidParams(
            f"{what}{ptr or ''}: {problem[1]}", param=ptr or "/", expected=what.capitalize(), got=None
        )
    shape = dict(spec["shape"])
    if shape["type"] == "mesh":
        shape["file"] = str(resolve_file(shape["file"], base or Path.cwd(), what="mesh file"))
        if isinstance(shape.get("scale"), int | float):  # a uniform scale, stored per axis
            shape["scale"] = [float(shape["scale"])] * 3
    if "orientation" in spec:
        quat = unit_quaternion([float(v) for v in spec["orientation"]])
        if quat is None:  # schema_errors refuses it; reached only with checked=True on a bad document
            raise InvalidParams(f"{what}/orientation: quaternion has zero norm", param="/orientation",
                                expected=what.capitalize(), got=None)
    elif "rpy" in spec:
        quat = list(quat_from_rpy(spec["rpy"]))
    else:
        quat = [0.0, 0.0, 0.0, 1.0]
    out: dict[str, Any] = {
        "name": spec["name"],
        "shape": shape,
        "position": [float(v) for v in spec["position"]],
        "orientation": quat,
    }
    if "color" in spec:
        out["color"] = list(spec["color"])
    if kind == "objects":
        out["mass"] = float(spec.get("mass", DEFAULT_MASS))
    return out


def resolve_file(name: str, base: Path, *, what: str, data_fallback: bool = False) -> Path:
    """An existing file: absolute, or relative to ``base`` (then to ``pybullet_data`` if allowed)."""
    p = Path(name).expanduser()
    cands = [p] if p.is_absolute() else [base / p] + ([pybullet_data_path() / p] if data_fallback else [])
    for c in cands:
        if c.is_file():
            return c.resolve()
    raise FileNotFound(str(cands[0]), what=what)
