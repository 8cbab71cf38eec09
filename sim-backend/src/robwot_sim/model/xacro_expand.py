"""xacro files expanded into URDF with the ``xacro`` package (PyPI, no ROS install), as ROS users have them.

Expansion runs in a child process (``python -m robwot_sim.model.xacro_expand``, one JSON request on stdin, one
JSON answer on stdout): xacro keeps its state in module globals (not safe to share between requests) and
reads the environment (``$(env NAME)``, ``$(optenv NAME)``), so the child gets the backend's environment
without its ``ROBWOT_*`` variables (a backend token must not end up in a robot.urdf).

Inside the child, every file xacro opens (the file, ``xacro:include``, ``load_yaml``) must lie below an
allowed root (the xacro's folder or the ROS package holding it, ``packageRoots``, and packages found by
``$(find NAME)``) and declare no DTD or entities (xmlsafe's rule). ``$(find NAME)`` is the package NAME as
``package://NAME`` finds it (``packageRoots``, a package holding the xacro, ``ROS_PACKAGE_PATH``).

The expanded URDF is written into a fresh temporary folder, not next to the source, so mesh filenames are
made loadable from there: relative ones become absolute (they were relative to the xacro's folder), and
every package a mesh or ``$(find)`` used is returned as a package root; the caller loads the expanded file
with those roots. The temporary folder is the caller's to delete.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from robwot_sim.errors import FileNotFound, Forbidden, PathEscape, SimError, UnknownPackage, UrdfError
from robwot_sim.model import xmlsafe
from robwot_sim.model.confine import inside
from robwot_sim.model.ros_packages import enclosing_packages, find_on_ros_package_path, folder_named
from robwot_sim.model.urdf import MAX_URDF_BYTES, UrdfDoc, refuse_unexpanded, resolve_mesh
from robwot_sim.wholefile import TooLarge, read_whole

#: the package-root key under which the xacro's own folder is returned (a ROS package name cannot hold
#: a dot or a dash, so it never shadows a real package)
SOURCE_ROOT = "robwot.xacro-folder"
#: a xacro expansion that runs longer than this is stopped (xacro has loops only through recursion)
TIMEOUT_S = 120.0


class _XacroFailed(Exception):
    def __init__(self, message: str, file: str, line: int | None = None, column: int | None = None) -> None:
        super().__init__(message)
        self.message, self.file, self.line, self.column = message, file, line, column


def _first_line(file: Path, needle: str | None) -> int | None:
    """The first line of ``file`` holding ``needle`` (the expression xacro could not evaluate: xacro names
    it, not its line), or None."""
    if not needle:
        return None
    try:
        text = read_whole(file, MAX_URDF_BYTES).decode("utf-8", "replace")
    except (OSError, TooLarge):
        return None
    for n, line in enumerate(text.splitlines(), 1):
        if needle in line:
            return n
    return None


def _expand_in_child(xacro_file: Path, args: Mapping[str, str],
                     package_roots: Mapping[str, str]) -> dict[str, Any]:
    """The child's work: expand with xacro under the rules above. Returns ``{"xml", "packages"}``."""
    import xml.parsers.expat

    import xacro
    from xacro import substitution_args

    explicit = {k: Path(v).expanduser().resolve() for k, v in package_roots.items()}
    enclosing = enclosing_packages(xacro_file.parent)
    found: dict[str, Path] = {}
    roots = [xacro_file.parent, *enclosing.values(), *explicit.values()]

    def find(name: str) -> str:
        hit = explicit.get(name) or enclosing.get(name) or find_on_ros_package_path(name)
        if hit is None:
            raise UnknownPackage(f"$(find {name})", name, urdf=str(xacro_file))
        found[name] = hit
        roots.append(hit)
        return str(hit)

    orig_abs, orig_parse = xacro.abs_filename_spec, xacro.parse

    def confined(filename: str) -> str:
        path = Path(os.path.normpath(orig_abs(filename)))
        real = path.resolve()
        if not inside(path, roots) or not inside(real, roots):
            raise PathEscape(str(path), [str(r) for r in roots], urdf=str(xacro_file),
                             reason="a xacro may only read files below its folder, its ROS package, "
                             "--package-root folders and packages it finds")
        return str(path)

    def parse(inp: Any, filename: str | None = None) -> Any:
        if inp is None and filename is not None:
            path = Path(confined(filename))
            try:
                data = read_whole(path, MAX_URDF_BYTES)
            except OSError as e:
                raise xacro.XacroException(f"{e.strerror}: {path}", exc=e) from None
            except TooLarge as e:
                raise UrdfError(str(e), file=str(path), size=e.size, limit=e.limit) from None
            m = xmlsafe.FORBIDDEN.search(data)
            if m is not None:
                line = data.count(b"\n", 0, m.start()) + 1
                raise Forbidden(f"{path}:{line}: XML {m.group(1).decode().upper()} declarations are refused "
                                "(no DTD or entities in a xacro file)", file=str(path), line=line)
            return orig_parse(data.decode("utf-8"), filename)
        return orig_parse(inp, filename)

    substitution_args._eval_find = find
    substitution_args._eval_dict["find"] = find
    xacro.abs_filename_spec = confined
    xacro.parse = parse
    xacro.verbosity = 0
    try:
        doc = xacro.process_file(str(xacro_file), mappings=dict(args))
    except SimError:
        raise
    except xml.parsers.expat.ExpatError as e:
        where = (xacro.filestack or [None])[-1] or str(xacro_file)
        raise _XacroFailed(f"not well-formed XML: {xml.parsers.expat.ErrorString(e.code)}", str(where),
                           e.lineno, e.offset + 1) from None
    except Exception as e:  # xacro's own errors (XacroException, NameError, ArgException, ...)
        raise _xacro_failure(e, xacro_file) from None
    return {"xml": doc.toxml(), "packages": {k: str(v) for k, v in found.items()}}


def _xacro_failure(e: Exception, xacro_file: Path) -> Exception:
    """The error to raise for an exception out of xacro: ours when xacro wrapped one of ours, else a
    ``_XacroFailed`` naming the file, the line and, for an undefined argument, the option that gives it."""
    import xacro
    from xacro import substitution_args

    inner = getattr(e, "exc", None)
    if isinstance(inner, SimError):
        return inner  # ours, raised inside an expression ($(find) of an unknown package)
    where = str((xacro.filestack or [None])[-1] or xacro_file)
    message = " ".join((str(e) or type(e).__name__).split())
    arg = re.search(r"Undefined substitution argument (\S+)", message)
    needle: str | None
    if isinstance(e, substitution_args.ArgException) or arg:
        name = arg.group(1) if arg else message
        message = f"undefined argument {name!r}: give it with --xacro-arg {name}:=VALUE"
        needle = f"$(arg {name})"
    else:
        expr = re.search(r"when evaluating expression '(.*)'$", message)
        needle = f"${{{expr.group(1)}}}" if expr else None
    stack = [m.body.getAttribute("name") for m in (xacro.macrostack or [])]
    return _XacroFailed(message + (f" (in macro {' <- '.join(reversed(stack))})" if stack else ""),
                       where, _first_line(Path(where), needle))


def _child_main() -> int:
    req = json.loads(sys.stdin.read())
    try:
        out = _expand_in_child(Path(req["xacro"]), req["args"], req["packageRoots"])
        answer: dict[str, Any] = {"ok": True, **out}
    except SimError as e:
        answer = {"ok": False, "sim": e.to_json()}
    except _XacroFailed as e:
        answer = {"ok": False,
                  "xacro": {"message": e.message, "file": e.file, "line": e.line, "column": e.column}}
    sys.stdout.write(json.dumps(answer))
    return 0


def _run_child(xacro_file: Path, args: Mapping[str, str], package_roots: Mapping[str, str]) -> dict[str, Any]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("ROBWOT_")}
    request = json.dumps({"xacro": str(xacro_file), "args": dict(args), "packageRoots": dict(package_roots)})
    try:
        proc = subprocess.run([sys.executable, "-m", "robwot_sim.model.xacro_expand"], input=request, env=env,
                              capture_output=True, text=True, timeout=TIMEOUT_S, check=False)
    except subprocess.TimeoutExpired:
        raise UrdfError(f"xacro expansion did not end within {TIMEOUT_S:g} s", file=str(xacro_file)) from None
    try:
        answer: dict[str, Any] = json.loads(proc.stdout)
    except json.JSONDecodeError:
        tail = proc.stderr.strip().splitlines()[-1:] or ["no output"]
        raise UrdfError(f"xacro expansion failed: {tail[0][:300]}", file=str(xacro_file)) from None
    if answer["ok"]:
        return answer
    if "xacro" in answer:
        x = answer["xacro"]
        raise UrdfError(f"xacro: {x['message']}", file=x["file"], line=x["line"], column=x["column"],
                        source=str(xacro_file))
    err = answer["sim"]
    data = dict(err["data"])
    code = data.pop("code")
    # the child's error raised again as the class it was (the classes its refusals use)
    cls: type[SimError] = {"E_PATH_ESCAPE": PathEscape, "E_FORBIDDEN": Forbidden, "E_URDF": UrdfError,
                           "E_FILE_NOT_FOUND": UnknownPackage if "package" in data else FileNotFound,
                           }.get(code, SimError)
    failure = cls.__new__(cls)
    SimError.__init__(failure, err["message"], code=code, **data)
    raise failure


def _set_limits(root: ET.Element, src: Path, velocities: Mapping[str, float],
                positions: Mapping[str, tuple[float, float]]) -> None:
    """A joint_limits.yaml's velocities and positions written into the joints' ``<limit>``; a continuous
    joint given positions becomes revolute (a URDF's continuous joint has no position limits)."""
    joints = {j.get("name"): j for j in root.findall("joint")}

    def limit_of(name: str) -> ET.Element:
        joint = joints.get(name)
        if joint is None:
            raise UrdfError(f"joint_limits.yaml names joint {name!r}, which the robot does not have (joints: "
                            f"{', '.join(sorted(str(j) for j in joints))})", file=str(src), joint=name)
        if joint.get("type") == "fixed":
            raise UrdfError(f"joint_limits.yaml gives limits to the fixed joint {name!r}", file=str(src),
                            joint=name)
        limit = joint.find("limit")
        return limit if limit is not None else ET.SubElement(joint, "limit", {"effort": "0", "velocity": "0"})

    for name, velocity in velocities.items():
        limit_of(name).set("velocity", repr(float(velocity)))
    for name, (lower, upper) in positions.items():
        limit = limit_of(name)
        limit.set("lower", repr(float(lower)))
        limit.set("upper", repr(float(upper)))
        if joints[name].get("type") == "continuous":
            joints[name].set("type", "revolute")


def expand_xacro(xacro: str | Path, args: Mapping[str, str] | None = None,
                 package_roots: Mapping[str, str] | None = None,
                 velocity_limits: Mapping[str, float] | None = None,
                 position_limits: Mapping[str, tuple[float, float]] | None = None,
                 ) -> tuple[Path, dict[str, str]]:
    """Expand ``xacro`` (with ``args``, xacro's ``NAME:=VALUE`` arguments) into a URDF file in a new
    temporary folder. Returns (that file, package roots to load it with: ``package_roots`` plus every
    package the expansion or its meshes used, and the xacro's folder under SOURCE_ROOT).

    Raises FileNotFound, Forbidden / PathEscape (a file outside the allowed roots, DTD/entities),
    UnknownPackage (``$(find)`` or ``package://`` naming a package found nowhere: says which option fixes
    it) or UrdfError (xacro's own error, with the file and, for XML errors, the line; an expansion that
    still holds ``${...}``/``$(...)``). ``velocity_limits`` (joint -> max velocity, a MoveIt config's
    joint_limits.yaml) replace the URDF's ``<limit velocity>``, ``position_limits`` (joint -> (lower, upper))
    its ``lower``/``upper`` (``_set_limits``); a joint the URDF lacks is refused."""
    src = Path(xacro).expanduser()
    if not src.is_file():
        raise FileNotFound(str(src), what="xacro file")
    src = src.resolve()
    roots = dict(package_roots or {})
    for name, folder in roots.items():
        if not Path(folder).expanduser().is_dir():
            raise FileNotFound(str(folder), what=f"package root {name!r} folder")
    answer = _run_child(src, args or {}, roots)
    try:
        root, _ = xmlsafe.parse(answer["xml"].encode("utf-8"))
    except (xmlsafe.XmlRefused, xmlsafe.XmlMalformed) as e:
        raise UrdfError(f"the URDF expanded from it is not valid XML: {e}", file=str(src)) from None
    if root.tag != "robot":
        raise UrdfError(f"expands to <{root.tag}>, expected <robot>", file=str(src))
    refuse_unexpanded(UrdfDoc(root, src, {}))  # names the xacro file: its expansion's lines are not its own
    _set_limits(root, src, velocity_limits or {}, position_limits or {})
    out_roots = {**roots, **answer["packages"], SOURCE_ROOT: str(src.parent)}
    enclosing = enclosing_packages(src.parent)
    for el in root.iter("mesh"):
        fn = el.get("filename", "")
        real = resolve_mesh(fn, src.parent, out_roots, urdf=str(src))  # refusals name the xacro file
        if fn.startswith("package://"):
            name = fn[len("package://"):].partition("/")[0]
            # found as resolve_mesh found it (a folder taken by its name last), so the copy finds it too
            pkg = (roots.get(name) or enclosing.get(name) or find_on_ros_package_path(name)
                   or folder_named(src.parent, name))
            if pkg is not None:
                out_roots[name] = str(pkg)
        elif not fn.startswith("file://") and not Path(fn).is_absolute():
            el.set("filename", str(real))  # was relative to the xacro's folder
    name = src.name.removesuffix(".xacro") if src.name.endswith(".urdf.xacro") else f"{src.stem}.urdf"
    out = Path(tempfile.mkdtemp(prefix="robwot-xacro-")) / name
    ET.indent(root)
    ET.ElementTree(root).write(out, encoding="utf-8", xml_declaration=True)
    return out, {k: str(v) for k, v in out_roots.items()}


if __name__ == "__main__":
    sys.exit(_child_main())
