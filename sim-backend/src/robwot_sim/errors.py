"""Structured errors of the simulation backend.

Every error class declares a stable string ``code`` (``E_...``) and carries a ``data`` dict of structured
fields (joint, value, limits, file, line, ...). Its JSON-RPC number (``rpc_code``) is the contract's for
that code (``components.errors``): a class whose code the contract lacks fails at import. The RPC layer
maps an error to
``{"code": rpc_code, "message": message, "data": {"code": code, **data}}`` (see ARCHITECTURE.md, Contract 1).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from functools import cache
from pathlib import Path
from typing import Any

from robwot_sim.limits import contract_document


@cache
def rpc_code_of(code: str) -> int:
    """The JSON-RPC number the contract gives error ``code`` (LookupError when it has no such error)."""
    errors: dict[str, Any] = contract_document()["components"]["errors"]
    if code not in errors:
        raise LookupError(f"error code {code!r} is not in the contract's components.errors")
    return int(errors[code]["code"])


class SimError(Exception):
    """Base class of every backend error."""

    code: str = "E_INTERNAL"
    rpc_code: int = rpc_code_of(code)

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        cls.rpc_code = rpc_code_of(cls.code)

    def __init__(self, message: str, *, code: str | None = None, **data: Any) -> None:
        super().__init__(message)
        self.message = message
        if code is not None:
            self.code = code
            self.rpc_code = rpc_code_of(code)
        self.data: dict[str, Any] = data

    def to_json(self) -> dict[str, Any]:
        """JSON-RPC ``error`` object."""
        return {"code": self.rpc_code, "message": self.message, "data": {"code": self.code, **self.data}}

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.message!r}, code={self.code!r}, data={self.data!r})"


class InternalError(SimError):
    code = "E_INTERNAL"


class InvalidParams(SimError):
    """Wrong type/length, NaN/Infinity, missing parameter."""

    code = "E_INVALID_PARAMS"

    def __init__(
        self, message: str, *, param: str | None = None, expected: Any = None, got: Any = None, **data: Any
    ) -> None:
        super().__init__(message, param=param, expected=expected, got=_jsonable(got), **data)


class _UnknownName(SimError):
    kind = "name"

    def __init__(self, name: str, available: Iterable[str]) -> None:
        avail = sorted(str(a) for a in available)
        super().__init__(
            f"unknown {self.kind} {name!r}; available: {', '.join(avail) or '(none)'}",
            name=name,
            available=avail,
        )


class UnknownRobot(_UnknownName):
    code = "E_UNKNOWN_ROBOT"
    kind = "robot"


class UnknownObject(_UnknownName):
    code = "E_UNKNOWN_OBJECT"
    kind = "object"


class UnknownConveyor(UnknownObject):
    """A conveyor name the cell does not hold (``E_UNKNOWN_OBJECT``, naming the conveyors)."""

    kind = "conveyor"


class UnknownLink(_UnknownName):
    code = "E_UNKNOWN_LINK"
    kind = "link"


class OutOfLimits(SimError):
    """A joint value outside its limits (radians or metres)."""

    code = "E_OUT_OF_LIMITS"

    def __init__(self, joint: str, value: float, lower: float, upper: float) -> None:
        super().__init__(
            f"joint {joint!r} value {value:.6g} outside limits [{lower:.6g}, {upper:.6g}]",
            joint=joint,
            value=float(value),
            lower=float(lower),
            upper=float(upper),
        )


class UrdfError(SimError):
    """Malformed URDF (XML error with line/column, or a structural problem)."""

    code = "E_URDF"

    def __init__(
        self,
        message: str,
        *,
        file: str,
        line: int | None = None,
        column: int | None = None,
        code: str | None = None,
        **data: Any,
    ) -> None:
        where = (
            f"{file}"
            + (f":{line}" if line is not None else "")
            + (f":{column}" if column is not None and line is not None else "")
        )
        super().__init__(f"{where}: {message}", code=code, file=file, line=line, column=column, **data)


class SrdfError(UrdfError):
    """Malformed SRDF, or a ``<disable_collisions>`` pair naming a link the URDF does not have."""

    code = "E_SRDF"


class NoMovableJoint(UrdfError):
    code = "E_NO_MOVABLE_JOINT"

    def __init__(self, file: str) -> None:
        super().__init__("URDF has no movable (revolute, continuous or prismatic) joint", file=file)


class FileNotFound(SimError):
    """Missing URDF, mesh or scene file. ``urdf`` names the URDF that referenced a missing mesh."""

    code = "E_FILE_NOT_FOUND"

    def __init__(self, file: str, *, urdf: str | None = None, what: str = "file", **extra: Any) -> None:
        msg = f"{what} not found: {file}" + (f" (referenced by {urdf})" if urdf else "")
        data: dict[str, Any] = {"file": file, **extra}
        if urdf is not None:
            data["urdf"] = urdf
        super().__init__(msg, **data)


class UnknownPackage(FileNotFound):
    """A ``package://NAME/...`` path whose package NAME is found nowhere: says which option fixes it."""

    def __init__(self, reference: str, package: str, *, urdf: str | None = None, line: int | None = None,
                 searched: Sequence[str] = ()) -> None:
        where = f"{urdf}:{line}: " if urdf and line is not None else f"{urdf}: " if urdf else ""
        SimError.__init__(
            self,
            f"{where}{reference}: ROS package {package!r} not found (not a --package-root, not a package "
            f"holding the file, not on ROS_PACKAGE_PATH, not in an AMENT_PREFIX_PATH prefix, not in "
            f"pybullet_data; for package:// no folder of that name holds the file or stands beside one): "
            f"give --package-root {package}=DIR (the folder holding its package.xml) or add "
            "the folder it is in to ROS_PACKAGE_PATH",
            file=reference, package=package, reference=reference, searched=list(searched),
            urdf=urdf, line=line,
        )


class Forbidden(SimError):
    """XML DTD/entities, or other refused input."""

    code = "E_FORBIDDEN"

    def __init__(
        self, message: str, *, file: str, roots: Sequence[str] = (), code: str | None = None, **data: Any
    ) -> None:
        super().__init__(message, code=code, file=file, roots=[str(r) for r in roots], **data)


class PathEscape(Forbidden):
    """A mesh path resolving outside the allowed roots."""

    code = "E_PATH_ESCAPE"

    def __init__(self, file: str, roots: Sequence[str], *, urdf: str | None = None,
                 reason: str | None = None) -> None:
        why = reason or f"outside the allowed roots: {', '.join(str(r) for r in roots)}"
        super().__init__(
            f"path {file} is refused: {why}",
            file=file,
            roots=roots,
            reason=why,
            **({"urdf": urdf} if urdf else {}),
        )


class SceneError(SimError):
    """Scene document violating the schema; ``path`` is a JSON pointer."""

    code = "E_SCENE"

    def __init__(self, message: str, *, file: str | None, path: str) -> None:
        super().__init__(f"scene {file or '(inline)'} at {path or '/'}: {message}", file=file, path=path)
        self.data["message"] = message


class Unreachable(SimError):
    """IK found no solution within tolerance; ``best`` is the best configuration found."""

    code = "E_UNREACHABLE"

    def __init__(self, position_error: float, orientation_error: float, best: Sequence[float],
                 beyond_reach: bool = False) -> None:
        """``beyond_reach``: refused without solving, ``position_error`` is the distance (m) beyond the
        robot's reach sphere, a lower bound of the error (``beyondReach`` in the data)."""
        extra: dict[str, Any] = {"beyondReach": True} if beyond_reach else {}
        super().__init__(
            f"target unreachable: {position_error:.4g} m beyond the robot's reach" if beyond_reach else
            f"target unreachable: best position error {position_error:.4g} m, "
            f"orientation error {orientation_error:.4g} rad",
            positionError=float(position_error),
            orientationError=float(orientation_error),
            best=[float(b) for b in best],
            **extra,
        )


class Busy(SimError):
    code = "E_BUSY"

    def __init__(self, robot: str) -> None:
        super().__init__(
            f"a motion is already running for robot {robot!r}; call robot.stop first", robot=robot
        )


class Rejected(SimError):
    """A move whose plan is not valid (limits, no IK solution, every path collides): nothing moved.
    ``reasons`` in words, ``checks`` as `robot.plan` reports them; a program's (``program.run``) also its
    ``program`` report."""

    code = "E_REJECTED"

    def __init__(self, reasons: Sequence[str], checks: dict[str, Any],
                 program: dict[str, Any] | None = None) -> None:
        extra: dict[str, Any] = {} if program is None else {"program": program}
        super().__init__(f"target rejected: {'; '.join(reasons)}", reasons=list(reasons), checks=checks,
                         **extra)


class PlanBudget(SimError):
    """A plan (robot.plan, a move's or a program's planning) still running when its budget of the world's
    thread ran out (``budget`` s): refused, nothing moved. ``step``: the program's step it was planning."""

    code = "E_PLAN_BUDGET"

    def __init__(self, budget: float, step: int | None = None, steps: int | None = None) -> None:
        where = "" if step is None else f" while planning step {step} of {steps}"
        super().__init__(f"planning took longer than its budget of {budget:g} s{where}; nothing moved: plan "
                         "fewer steps at a time, or targets that need no detour", budget=budget, step=step,
                         steps=steps)

    def at_step(self, step: int, steps: int) -> PlanBudget:
        """The same refusal naming a program's step."""
        return PlanBudget(float(self.data["budget"]), step, steps)


class MeshError(SimError):
    """A mesh file our parser refuses (PyBullet would crash or silently drop it): ``file``, ``reason``
    (``line`` where it has one)."""

    code = "E_MESH"

    @classmethod
    def at(cls, path: Path, reason: str, line: int | None = None) -> MeshError:
        """The refusal of mesh file ``path`` for ``reason``, at ``line`` when given."""
        if line is None:
            return cls(f"mesh {path}: {reason}", file=str(path), reason=reason)
        return cls(f"mesh {path}: line {line}: {reason}", file=str(path), reason=reason, line=line)


class ClusterError(SimError):
    """``workspace.generate`` with ``cluster``: the Ray cluster cannot be reached (``address``)."""

    code = "E_CLUSTER"


class NameTaken(SimError):
    code = "E_NAME_TAKEN"

    def __init__(self, name: str) -> None:
        super().__init__(f"name {name!r} is already used", name=name)


class Overlap(SimError):
    """An object placed into (or coming to rest in) another body: ``object`` and ``body`` name both,
    ``depth`` (m) how deep."""

    code = "E_OVERLAP"

    def __init__(self, obj: str, body: str, depth: float, *, at_rest: bool = False) -> None:
        how = "comes to rest touching" if at_rest else f"is placed {depth * 1000:.1f} mm deep into"
        super().__init__(f"object {obj!r} {how} {body!r}; nothing added or moved", object=obj, body=body,
                         depth=depth)


def _jsonable(value: Any) -> Any:
    """Best-effort JSON-safe echo of a bad value (NaN/Infinity become strings)."""
    if isinstance(value, float) and (value != value or value in (float("inf"), float("-inf"))):
        return str(value)
    if isinstance(value, (str, int, float, bool)) or value is None:
        return value
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value][:64]
    return repr(value)[:200]


class ScanError(SimError):
    """A point cloud our reader refuses (``scan/clouds.py``): ``file``, ``line`` (text formats, where
    known), ``reason``; the message names all three."""

    code = "E_SCAN"

    def __init__(self, reason: str, *, file: str, line: int | None = None) -> None:
        where = file + (f":{line}" if line is not None else "")
        super().__init__(f"{where}: {reason}", file=file, line=line, reason=reason)


def snippet(text: object, limit: int = 32, *, quote: bool = True) -> str:
    """A short quote of a file's own text for an error message: printable ASCII only, at most ``limit``
    characters (an error must not carry a file's content along)."""
    raw = str(text)
    clean = "".join(c if " " <= c <= "~" else "?" for c in raw[:limit])
    clean += "..." if len(raw) > limit else ""
    return repr(clean) if quote else clean
