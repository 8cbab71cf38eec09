"""Point cloud files read (and written) for the scene from a scan: PLY, PCD and XYZ text, parsed by our own
code, since clouds come from users and sensors and are hostile input.

`read_cloud` takes the format from the extension (``.ply``, ``.pcd``, ``.xyz``/``.txt``, any case) and
returns the points in metres in the file's own frame, as float64 ``[n, 3]``, with the sensor pose the
file states. Nothing in a header is trusted: every count, size and type is checked against the bytes the
file holds before anything is allocated for its points, and a file is refused whole (`ScanError`: file,
line where known, reason), never read in part:

* the file is read whole through `read_whole` (at most `MAX_CLOUD_BYTES`), at most `MAX_POINTS` points;
* binary data must be exactly as long as the header declares: fewer bytes is a truncated file, more is a
  lying header; text data must hold exactly the declared rows (blank lines aside);
* PLY: ``ascii``, ``binary_little_endian``, ``binary_big_endian``; ``x y z`` of the ``vertex`` element in
  any scalar type, other properties skipped by a structured dtype. Elements before ``vertex`` are
  skipped (one row each in ascii; by size in binary, where one with a list property is refused: its size
  is known only by walking it); elements after it are ignored (in binary, still checked for length when
  all of them have a fixed size). The pose is a ``comment robwot viewpoint x y z qx qy qz qw`` line.
* PCD v0.7: ``DATA ascii | binary | binary_compressed``, little-endian, fields other than ``x y z``
  skipped by SIZE/TYPE/COUNT; WIDTH x HEIGHT must equal POINTS. VIEWPOINT is ``tx ty tz qw qx qy qz``
  in the file, reordered to our ``x y z qx qy qz qw``; it is returned whenever the file states it.
  binary_compressed holds two uint32 (compressed, decompressed size) and LZF data of the fields one after
  the other (column-major; PCL leaves padding fields named ``_`` out). No LZF library is among our
  dependencies (PyPI's bindings are small C extensions we would have to add), so `_lzf_decompress` is
  ours: the declared decompressed size must equal POINTS x point size before anything is allocated, and
  the decoder never writes past it nor reads a back reference before the start of its output.
* text (any of the three) ends its lines with LF, CRLF or a lone CR (old Mac files: never one long line);
* XYZ text: a point a line, at least 3 numbers (further columns ignored) separated by spaces, tabs or
  commas (an empty field between commas is refused); blank lines and ``#`` or ``//`` comments skipped.

The NaN rule: an organised cloud (PCD HEIGHT > 1, a depth image) may hold non-finite points, the
sensor's "no return": they are skipped and counted in ``dropped``. In any other cloud (PCD HEIGHT 1, PLY,
XYZ) a non-finite coordinate is a broken file, refused naming the point's index (and line in text).

``units`` ``"mm"`` scales by 1e-3 (points and viewpoint position). After scaling, a coordinate beyond
`MAX_RANGE` is refused as wrong units. Text is parsed a chunk of rows at a time by string splitting and
C-level float conversion; a chunk that fails is walked again to name its first bad line.
"""

from __future__ import annotations

import os
import re
import struct
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import NamedTuple, NoReturn

import numpy as np
import numpy.typing as npt

from robwot_sim.errors import FileNotFound, InvalidParams, ScanError
from robwot_sim.wholefile import TooLarge, read_whole

F64 = npt.NDArray[np.float64]

MAX_POINTS = 10_000_000
MAX_RANGE = 100.0
MAX_CLOUD_BYTES = 1 << 30
MAX_HEADER_BYTES = 64 * 1024
MAX_HEADER_LINES = 1000
FORMATS = {".ply": "ply", ".pcd": "pcd", ".xyz": "xyz", ".txt": "xyz"}
_CHUNK_ROWS = 1 << 20  # text rows converted at a time: bounds the Python strings alive at once
_PLY_TYPES = {"char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2", "int16": "i2",
              "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
              "float": "f4", "float32": "f4", "double": "f8", "float64": "f8"}
_PLY_FORMATS = {"ascii": "", "binary_little_endian": "<", "binary_big_endian": ">"}
_PCD_KEYS = ("VERSION", "FIELDS", "SIZE", "TYPE", "COUNT", "WIDTH", "HEIGHT", "VIEWPOINT", "POINTS", "DATA")
_EMPTY_FIELD = re.compile(r"^[ \t]*,|,[ \t]*(?:,|$)", re.MULTILINE)
_COUNT = re.compile(r"[0-9]{1,19}")


class Cloud(NamedTuple):
    """A cloud read: ``points`` [n, 3] in metres in the file's frame, ``viewpoint`` the sensor pose the file
    states (x y z qx qy qz qw) or None, ``dropped`` the no-return points skipped, ``file`` its path."""

    points: F64
    viewpoint: F64 | None
    dropped: int
    file: str


class _Raw(NamedTuple):
    """What a format's reader found: points in file units, pose, organised or not, text line of each point."""

    points: F64
    viewpoint: F64 | None
    organised: bool
    lines: list[int] | None


def read_cloud(path: str | Path, units: str = "m") -> Cloud:
    """The cloud in ``path`` (PLY, PCD or XYZ by extension) in metres, or `ScanError` naming file and why
    (`FileNotFound` when there is no such file; `InvalidParams` for ``units`` other than m or mm)."""
    if units not in ("m", "mm"):
        raise InvalidParams(f"units must be m or mm, not {units!r}", param="units", expected="m or mm",
                            got=units)
    file = str(path)
    kind = FORMATS.get(Path(file).suffix.lower())
    if kind is None:
        raise ScanError(f"unknown point cloud extension {Path(file).suffix!r}: known are "
                        f"{', '.join(FORMATS)}", file=file)
    try:
        data = read_whole(path, MAX_CLOUD_BYTES)
    except TooLarge as e:
        raise ScanError(f"file of {e.size} bytes is over the limit of {e.limit} bytes", file=file) from None
    except FileNotFoundError:
        raise FileNotFound(file, what="point cloud") from None
    except OSError as e:
        raise ScanError(f"cannot be read: {e.strerror or e}", file=file) from None
    reader = {"ply": _read_ply, "pcd": _read_pcd, "xyz": _read_xyz}[kind]
    return _finish(file, reader(file, data), 1e-3 if units == "mm" else 1.0, units)


def _finish(file: str, raw: _Raw, scale: float, units: str) -> Cloud:
    """The NaN rule and the range check applied, units scaled: the `Cloud` of a reader's `_Raw`."""
    pts = raw.points
    finite: npt.NDArray[np.bool_] = np.all(np.isfinite(pts), axis=1)
    if not finite.all() and not raw.organised:
        i = int(np.argmin(finite))
        raise ScanError(f"point {i} has a non-finite coordinate ({', '.join(f'{v:g}' for v in pts[i])}): "
                        "only an organised cloud (PCD HEIGHT > 1) may hold points without a return",
                        file=file, line=raw.lines[i] if raw.lines else None)
    if pts.size:
        mag = np.where(finite[:, None], np.abs(pts), 0.0)
        i, j = (int(v) for v in np.unravel_index(int(np.argmax(mag)), mag.shape))
        if mag[i, j] * scale > MAX_RANGE:
            hint = "; is the cloud in millimetres? read it with --units mm" if units == "m" else ""
            raise ScanError(f"point {i} has coordinate {'xyz'[j]} = {pts[i, j] * scale:.6g} m, farther than "
                            f"{MAX_RANGE:g} m from the sensor: wrong units{hint}", file=file,
                            line=raw.lines[i] if raw.lines else None)
    dropped = int(len(pts) - np.count_nonzero(finite))
    out = np.ascontiguousarray((pts[finite] if dropped else pts) * scale, dtype=np.float64)
    view = None if raw.viewpoint is None else np.concatenate([raw.viewpoint[:3] * scale, raw.viewpoint[3:]])
    return Cloud(out.reshape(-1, 3), view, dropped, file)


def write_ply(path: str | Path, points: F64, viewpoint: Sequence[float] | None = None) -> None:
    """Writes ``points`` [n, 3] (metres) as a binary little-endian PLY of float32 ``x y z``, ``viewpoint``
    (x y z qx qy qz qw) as a ``comment robwot viewpoint`` line; atomically (temp file + rename). ValueError
    for a wrong shape or a non-finite value."""
    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise ValueError(f"points must be [n, 3], not {list(pts.shape)}")
    with np.errstate(over="ignore", invalid="ignore"):  # beyond float32 becomes inf, refused below
        body = np.ascontiguousarray(pts, dtype="<f4")
    if not np.isfinite(body).all():
        raise ValueError("points hold a non-finite coordinate (or one beyond float32)")
    head = ["ply", "format binary_little_endian 1.0", "comment written by robwot"]
    if viewpoint is not None:
        view = [float(v) for v in viewpoint]
        if len(view) != 7 or not np.isfinite(view).all():
            raise ValueError(f"viewpoint must be 7 finite numbers (x y z qx qy qz qw), not {viewpoint!r}")
        head.append("comment robwot viewpoint " + " ".join(repr(v) for v in view))
    head += [f"element vertex {len(body)}", "property float x", "property float y", "property float z",
             "end_header", ""]
    fd, tmp = tempfile.mkstemp(prefix=f".{Path(path).name}.", suffix=".tmp", dir=Path(path).parent)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write("\n".join(head).encode("ascii"))
            f.write(body.tobytes())
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _header(file: str, data: bytes, last: str, what: str) -> tuple[list[str], int]:
    """The text lines of a header up to and including the first whose first word is ``last``, and the
    offset of the byte after it; refused when none is within `MAX_HEADER_BYTES` / `MAX_HEADER_LINES`."""
    head = data[:MAX_HEADER_BYTES]
    pieces = head.split(b"\n", MAX_HEADER_LINES)
    lines: list[str] = []
    pos = 0
    for raw in pieces[:MAX_HEADER_LINES]:
        end = pos + len(raw)
        if end == len(head) and end != len(data):
            break  # cut by the header window: not a whole line
        text = raw.decode("latin-1").rstrip("\r")
        lines.append(text)
        pos = end + 1
        if text.split()[:1] == [last]:
            return lines, min(pos, len(data))
    if len(data) <= MAX_HEADER_BYTES and len(pieces) <= MAX_HEADER_LINES:
        last_line = head.count(b"\n") + (1 if head and not head.endswith(b"\n") else 0)
        raise ScanError(f"the header ends without {what}: the file ends at line {last_line}", file=file,
                        line=last_line)
    raise ScanError(f"no {what} within the first {MAX_HEADER_LINES} lines or {MAX_HEADER_BYTES} bytes of "
                    "the header", file=file)


def _same_size(file: str, found: int, need: int, what: str, at_least: bool = False) -> None:
    """Refuses ``found`` bytes of ``what`` where the header declares ``need`` (or at least ``need``)."""
    if found < need or (found > need and not at_least):
        raise ScanError(f"{what} of {found} bytes where the header declares {'at least ' * at_least}{need}: "
                        f"{'truncated' if found < need else 'data past the declared end'}", file=file)


def _at_most(file: str, points: int, what: str, line: int | None) -> None:
    """Refuses a cloud of more than `MAX_POINTS` points, before anything is allocated for them."""
    if points > MAX_POINTS:
        raise ScanError(f"{what} {points} points, more than the {MAX_POINTS} a cloud may hold", file=file,
                        line=line)


def _same_rows(file: str, lines: list[int], need: int, first_line: int) -> None:
    """Refuses text data of other than ``need`` rows (at ``lines``), naming the first missing or extra."""
    if len(lines) != need:
        where = lines[need] if len(lines) > need else (lines[-1] + 1 if lines else first_line)
        raise ScanError(f"the header declares {need} data lines, the file holds "
                        f"{'more' if len(lines) > need else 'fewer'} ({len(lines)})", file=file, line=where)


def _count(file: str, line: int, word: str, what: str, least: int = 0) -> int:
    """A decimal integer of a header, at least ``least``, or refused."""
    if not _COUNT.fullmatch(word) or int(word) < least:
        raise ScanError(f"{what} {word[:40]!r} is not an integer of at least {least}", file=file, line=line)
    return int(word)


def _pose(file: str, line: int, words: Sequence[str], what: str, wxyz: bool) -> F64:
    """A stated sensor pose as x y z qx qy qz qw (from ``qw qx qy qz`` order when ``wxyz``), or refused."""
    try:
        v = np.array([float(w) for w in words], dtype=np.float64)
    except ValueError:
        v = np.empty(0)
    if len(v) != 7 or not np.isfinite(v).all() or not np.any(v[3:]):
        raise ScanError(f"{what} needs 7 finite numbers with a non-zero quaternion, not "
                        f"{' '.join(words)[:80]!r}", file=file, line=line)
    return v[[0, 1, 2, 4, 5, 6, 3]] if wxyz else v


def _text(file: str, data: bytes, start: int, first_line: int, comments: bool) -> tuple[list[str], list[int]]:
    """The non-blank lines of ``data[start:]`` (and not ``#``/``//`` comments when ``comments``) with their
    line numbers (``first_line`` is the number of the line at ``start``)."""
    try:
        text = str(memoryview(data)[start:], "utf-8")
    except UnicodeDecodeError as e:
        raise ScanError(f"byte {data[start + e.start]:#04x} is not text (UTF-8)", file=file,
                        line=first_line + data.count(b"\n", start, start + e.start)) from None
    text = text.replace("\r\n", "\n").replace("\r", "\n") if "\r" in text else text
    lines = text.split("\n")
    if comments and ("#" in text or "//" in text):
        keep = [i for i, ln in enumerate(lines) if ln.strip() and not ln.lstrip().startswith(("#", "//"))]
    else:
        keep = [i for i, ln in enumerate(lines) if ln and not ln.isspace()]
    return [lines[i] for i in keep], [first_line + i for i in keep]


def _table(file: str, rows: list[str], lines: list[int], cols: Sequence[int], ncols: int | None) -> F64:
    """x y z of text rows, a point a row: the numbers in columns ``cols`` of rows holding exactly ``ncols``
    values (``None``: at least 3, whose first 3 are taken), converted `_CHUNK_ROWS` rows at a time."""
    out = np.empty((len(rows), 3))
    for start in range(0, len(rows), _CHUNK_ROWS):
        part = rows[start:start + _CHUNK_ROWS]
        counts = [len(ln.split()) for ln in part]
        if (k := next((k for k, c in enumerate(counts) if c < 3 or c != (ncols or c)), None)) is not None:
            want = "at least 3 (x y z)" if ncols is None else f"{ncols} as the header declares"
            raise ScanError(f"the line holds {counts[k]} values, a point needs {want}", file=file,
                            line=lines[start + k])
        width = ncols if ncols is not None else counts[0] if counts.count(counts[0]) == len(counts) else None
        if width is not None:
            flat = " ".join(part).split()
            picked, used = [flat[c::width] for c in cols], cols
        else:
            flat = [t for ln in part for t in ln.split()[:3]]
            picked, used = [flat[c::3] for c in range(3)], range(3)
        try:
            for j, vals in enumerate(picked):
                out[start:start + len(part), j] = np.fromiter(map(float, vals), np.float64, len(vals))
        except ValueError:
            _bad_number(file, part, lines[start:], used)
    return out


def _bad_number(file: str, rows: list[str], lines: list[int], cols: Sequence[int]) -> NoReturn:
    """Refuses the first of ``rows`` with a non-number in ``cols``, naming its line."""
    for row, line in zip(rows, lines, strict=False):
        for word in [row.split()[c] for c in cols]:
            try:
                float(word)
            except ValueError:
                raise ScanError(f"{word[:40]!r} is not a number", file=file, line=line) from None
    raise ScanError("a value is not a number", file=file)


def _read_xyz(file: str, data: bytes) -> _Raw:
    """An XYZ text cloud: a point a line, at least 3 numbers separated by blanks or commas."""
    rows, lines = _text(file, data, 0, 1, comments=True)
    _at_most(file, len(rows), "the file holds", None)
    joined = "\n".join(rows)
    if "," in joined:  # an empty field is two commas, or a comma and a line's end, with only blanks between
        squeezed = "\n" + joined.replace(" ", "").replace("\t", "") + "\n"
        if any(p in squeezed for p in (",,", ",\n", "\n,")) and (m := _EMPTY_FIELD.search(joined)):
            raise ScanError("an empty field between commas", file=file,
                            line=lines[joined.count("\n", 0, m.start())])
        rows = [r.replace(",", " ") for r in rows]
    return _Raw(_table(file, rows, lines, (0, 1, 2), None), None, False, lines)


class _PlyElement(NamedTuple):
    """A PLY element: ``props`` (name, numpy type, or None for a list property), header ``line``."""

    name: str
    number: int
    props: list[tuple[str, str | None]]
    line: int


def _ply_header(file: str, lines: list[str]) -> tuple[str, list[_PlyElement], F64 | None]:
    """The format (``""``, ``"<"`` or ``">"``), elements and stated pose of a PLY header."""
    fmt: str | None = None
    elements: list[_PlyElement] = []
    view = None
    for n, text in enumerate(lines[1:-1], start=2):
        w = text.split()
        if not w or w[0] == "obj_info" or (w[0] == "comment" and w[1:3] != ["robwot", "viewpoint"]):
            continue
        if w[0] == "comment":
            view = _pose(file, n, w[3:], "comment robwot viewpoint", wxyz=False)
        elif w[0] == "format" and len(w) == 3 and w[1] in _PLY_FORMATS and w[2] == "1.0" and fmt is None:
            fmt = _PLY_FORMATS[w[1]]
        elif w[0] == "element" and len(w) == 3:
            elements.append(_PlyElement(w[1], _count(file, n, w[2], f"element {w[1]} count"), [], n))
        elif w[0] == "property" and elements and len(w) == 3 and w[1] in _PLY_TYPES:
            elements[-1].props.append((w[2], _PLY_TYPES[w[1]]))
        elif (w[0] == "property" and elements and len(w) == 5 and w[1] == "list" and w[3] in _PLY_TYPES
              and _PLY_TYPES.get(w[2], "f")[0] in "iu"):
            elements[-1].props.append((w[4], None))
        else:
            raise ScanError(f"header line {text[:80]!r} is not understood (or out of place)", file=file,
                            line=n)
    if fmt is None:
        raise ScanError("the header has no format line (ascii, binary_little_endian, binary_big_endian 1.0)",
                        file=file, line=2)
    return fmt, elements, view


def _read_ply(file: str, data: bytes) -> _Raw:
    """A PLY cloud: the x y z of its vertex element."""
    if not data.startswith((b"ply\n", b"ply\r\n")):
        raise ScanError("not a PLY file: the first line is not 'ply'", file=file, line=1)
    lines, body = _header(file, data, "end_header", "an end_header line")
    fmt, elements, view = _ply_header(file, lines)
    vi = next((i for i, e in enumerate(elements) if e.name == "vertex"), None)
    if vi is None:
        raise ScanError("the header declares no vertex element", file=file)
    vertex = elements[vi]
    names = [p for p, _ in vertex.props]
    cols = [names.index(a) if names.count(a) == 1 else -1 for a in "xyz"]
    if -1 in cols or any(t is None for _, t in vertex.props):
        raise ScanError("the vertex element needs one scalar property each of x, y and z and no list "
                        "property", file=file, line=vertex.line)
    _at_most(file, vertex.number, "the header declares", vertex.line)
    if fmt:
        return _Raw(_ply_binary(file, data, body, elements, vi, fmt, cols), view, False, None)
    rows, rlines = _text(file, data, body, len(lines) + 1, comments=False)
    _same_rows(file, rlines, sum(e.number for e in elements), len(lines) + 1)
    skip = sum(e.number for e in elements[:vi])
    end = skip + vertex.number
    return _Raw(_table(file, rows[skip:end], rlines[skip:end], cols, len(names)), view, False,
                rlines[skip:end])


def _ply_binary(file: str, data: bytes, body: int, elements: list[_PlyElement], vi: int, endian: str,
                cols: list[int]) -> F64:
    """x y z of the vertex element ``elements[vi]`` of a binary PLY whose data starts at ``body``."""
    dtypes: list[np.dtype[np.void] | None] = [
        None if any(t is None for _, t in e.props)
        else np.dtype([(f"p{k}", endian + str(t)) for k, (_, t) in enumerate(e.props)]) for e in elements]
    offset = body
    for e, dt in zip(elements[:vi], dtypes, strict=False):
        if dt is None:
            raise ScanError(f"element {e.name!r} before the vertex element has a list property: its size is "
                            "only known by walking it, not supported in binary (write the vertex element "
                            "first)", file=file, line=e.line)
        offset += e.number * dt.itemsize
    vdt, n = dtypes[vi], elements[vi].number
    assert vdt is not None
    fixed = None not in dtypes[vi + 1:]
    rest = zip(elements[vi + 1:], dtypes[vi + 1:], strict=True)
    need = offset + n * vdt.itemsize + sum(e.number * dt.itemsize for e, dt in rest if dt is not None)
    _same_size(file, len(data) - body, need - body, "binary data", at_least=not fixed)
    rec = np.frombuffer(data, dtype=vdt, count=n, offset=offset)
    return np.column_stack([rec[f"p{c}"] for c in cols]).astype(np.float64)


class _PcdLayout(NamedTuple):
    """A checked PCD header: fields (name, numpy type, count), x y z field indices, shape and encoding."""

    fields: list[tuple[str, str, int]]
    xyz: list[int]
    width: int
    height: int
    data: str
    viewpoint: F64 | None


def _pcd_header(file: str, lines: list[str]) -> _PcdLayout:
    """The layout a PCD header declares, every entry checked against the others."""
    keys: dict[str, tuple[int, list[str]]] = {}
    for n, text in enumerate(lines, start=1):
        w = text.split()
        if not w or w[0].startswith("#"):
            continue
        if w[0] not in _PCD_KEYS or w[0] in keys:
            raise ScanError(f"header line {text[:80]!r} is not understood (or repeated)", file=file, line=n)
        keys[w[0]] = (n, w[1:])
    if missing := [k for k in ("FIELDS", "SIZE", "TYPE", "WIDTH", "HEIGHT", "POINTS") if k not in keys]:
        raise ScanError(f"the header has no {' or '.join(missing)} line", file=file, line=len(lines))
    names = keys["FIELDS"][1]
    nf = len(names)
    counts = keys.get("COUNT", (keys["FIELDS"][0], ["1"] * nf))
    for k, (n, w) in (("SIZE", keys["SIZE"]), ("TYPE", keys["TYPE"]), ("COUNT", counts)):
        if len(w) != nf:
            raise ScanError(f"{k} has {len(w)} entries for {nf} FIELDS", file=file, line=n)
    types = []
    for size, kind, count in zip(keys["SIZE"][1], keys["TYPE"][1], counts[1], strict=True):
        if size not in ("1", "2", "4", "8"):
            raise ScanError(f"SIZE {size[:20]!r} is not 1, 2, 4 or 8", file=file, line=keys["SIZE"][0])
        if kind not in ("I", "U", "F") or (kind == "F" and size in "12"):
            raise ScanError(f"TYPE {kind[:20]!r} of SIZE {size} is not I or U, or F of SIZE 4 or 8",
                            file=file, line=keys["TYPE"][0])
        types.append(("<" + kind.lower() + size, _count(file, counts[0], count, "COUNT", least=1)))
    point_size = sum(int(t[2:]) * c for t, c in types)
    if point_size > MAX_CLOUD_BYTES:
        raise ScanError(f"a point of {point_size} bytes (SIZE x COUNT)", file=file, line=counts[0])
    xyz = [names.index(a) if names.count(a) == 1 else -1 for a in "xyz"]
    if -1 in xyz or any(types[i][1] != 1 for i in xyz):
        raise ScanError("FIELDS needs one each of x, y and z, of COUNT 1", file=file, line=keys["FIELDS"][0])
    width, height, points = (_count(file, keys[k][0], " ".join(keys[k][1]), k)
                             for k in ("WIDTH", "HEIGHT", "POINTS"))
    pl = keys["POINTS"][0]
    _at_most(file, points, "the header declares", pl)
    if width * height != points:
        raise ScanError(f"WIDTH {width} x HEIGHT {height} is not POINTS {points}", file=file, line=pl)
    dl, dw = keys["DATA"]
    if dw not in (["ascii"], ["binary"], ["binary_compressed"]):
        raise ScanError(f"DATA {' '.join(dw)[:40]!r} is not ascii, binary or binary_compressed", file=file,
                        line=dl)
    view = _pose(file, *keys["VIEWPOINT"], "VIEWPOINT", wxyz=True) if "VIEWPOINT" in keys else None
    fields = [(name, t, c) for name, (t, c) in zip(names, types, strict=True)]
    return _PcdLayout(fields, xyz, width, height, dw[0], view)


def _read_pcd(file: str, data: bytes) -> _Raw:
    """A PCD v0.7 cloud: x y z of its ascii, binary or binary_compressed data."""
    lines, body = _header(file, data, "DATA", "a DATA line")
    lay = _pcd_header(file, lines)
    n, organised = lay.width * lay.height, lay.height > 1
    if lay.data == "ascii":
        rows, rlines = _text(file, data, body, len(lines) + 1, comments=False)
        _same_rows(file, rlines, n, len(lines) + 1)
        starts = np.cumsum([0] + [c for _, _, c in lay.fields])
        cols = [int(starts[i]) for i in lay.xyz]
        return _Raw(_table(file, rows, rlines, cols, int(starts[-1])), lay.viewpoint, organised, rlines)
    if lay.data == "binary_compressed":
        return _Raw(_pcd_compressed(file, data, body, lay), lay.viewpoint, organised, None)
    dt = np.dtype([(f"p{k}", t, (c,)) if c > 1 else (f"p{k}", t) for k, (_, t, c) in enumerate(lay.fields)])
    _same_size(file, len(data) - body, n * dt.itemsize, f"binary data ({n} points of {dt.itemsize} bytes)")
    rec = np.frombuffer(data, dtype=dt, count=n, offset=body)
    return _Raw(np.column_stack([rec[f"p{i}"] for i in lay.xyz]).astype(np.float64), lay.viewpoint, organised,
                None)


def _pcd_compressed(file: str, data: bytes, body: int, lay: _PcdLayout) -> F64:
    """x y z of binary_compressed PCD data: sizes checked, LZF decoded, fields read one after the other."""
    n = lay.width * lay.height
    fields = [(k, t, c) for k, (name, t, c) in enumerate(lay.fields) if name != "_"]
    size = n * sum(np.dtype(t).itemsize * c for _, t, c in fields)
    _same_size(file, len(data) - body, 8, "binary_compressed data (two sizes first)", at_least=True)
    csize, usize = struct.unpack_from("<II", data, body)
    if usize != size or size > MAX_CLOUD_BYTES:
        raise ScanError(f"binary_compressed data declares {usize} bytes decompressed where POINTS and the "
                        f"fields make {size} (at most {MAX_CLOUD_BYTES})", file=file)
    _same_size(file, len(data) - body - 8, csize, "LZF data")
    try:
        raw = _lzf_decompress(memoryview(data)[body + 8:], usize)
    except ValueError as e:
        raise ScanError(f"binary_compressed data is corrupt: {e}", file=file) from None
    out, offset = np.empty((n, 3)), 0
    for k, t, c in fields:
        if k in lay.xyz:
            out[:, lay.xyz.index(k)] = np.frombuffer(raw, dtype=t, count=n, offset=offset)
        offset += n * np.dtype(t).itemsize * c
    return out


def _lzf_decompress(src: bytes | memoryview, size: int) -> bytearray:
    """LZF data (liblzf's format) decoded into exactly ``size`` bytes, or ValueError. A control byte below
    32 starts a run of that many plus one literal bytes; any other holds in its top 3 bits a length minus 2
    (7: plus the next byte) and in its low 5 bits, with the byte after, a distance minus 1: a copy from
    the output written so far, which may overlap what it writes. Invariants: the output never grows past
    ``size``, no copy starts before the output's start, no read passes the input's end."""
    out = bytearray()
    i, n = 0, len(src)
    while i < n:
        at, ctrl = i, src[i]
        i += 1
        if ctrl < 32:
            run = ctrl + 1
            if i + run > n or len(out) + run > size:
                raise ValueError(f"a literal run at input byte {at} passes the end of the "
                                 f"{'input' if i + run > n else 'declared output'}")
            out += src[i:i + run]
            i += run
            continue
        length = ctrl >> 5
        if i + (length == 7) >= n:
            raise ValueError(f"a back reference at input byte {at} is cut by the end of the input")
        if length == 7:
            length += src[i]
            i += 1
        dist = ((ctrl & 31) << 8) + src[i] + 1
        i += 1
        length += 2
        start = len(out) - dist
        if start < 0 or len(out) + length > size:
            raise ValueError(f"a back reference at input byte {at} points "
                             f"{'before the start' if start < 0 else 'past the end'} of the output")
        if dist >= length:
            out += out[start:start + length]
        else:
            out += (out[start:] * (length // dist + 1))[:length]
    if len(out) != size:
        raise ValueError(f"it decodes to {len(out)} bytes, not the declared {size}")
    return out
