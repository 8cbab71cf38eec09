"""Point cloud files (``scan/clouds.py``): every format and encoding read back as written, and every hostile
file refused with ScanError naming the file, the reason and (text, where known) the line."""

from __future__ import annotations

import struct
import tracemalloc
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest

from robwot_sim.errors import FileNotFound, InvalidParams, ScanError
from robwot_sim.scan import clouds
from robwot_sim.scan.clouds import MAX_POINTS, read_cloud, write_ply

F64 = npt.NDArray[np.float64]
XYZ_PROPS = ["float x", "float y", "float z"]
PLY_NP = {"char": "i1", "uchar": "u1", "short": "i2", "ushort": "u2", "int": "i4", "uint": "u4",
          "float": "f4", "double": "f8", "int8": "i1", "uint8": "u1", "int16": "i2", "uint16": "u2",
          "int32": "i4", "uint32": "u4", "float32": "f4", "float64": "f8"}
# An organised-free cloud of 8 points (x, y = 0, z) and a uint16 intensity as PCL's binary_compressed holds
# it (x block, y block, z block, intensity block), compressed by liblzf itself (python-lzf 0.2.6): a
# known-good sample with literal runs and overlapping back references.
LIBLZF_SAMPLE = bytes.fromhex(
    "010000400001803e2005033f00004020030080200300a0200300c0200300e02003e0180000402021e002030020200be003030d"
    "0100020003000400050006000700")
LIBLZF_POINTS = np.array([[0.25 * i, 0.0, 2.0 if i < 4 else 2.5] for i in range(8)])


def grid(n: int = 24, seed: int = 0) -> F64:
    """Points exactly representable in every PLY/PCD scalar type used below: multiples of 0.25 within +-8."""
    return np.random.default_rng(seed).integers(-32, 32, size=(n, 3)).astype(np.float64) * 0.25


def lzf_compress(data: bytes) -> bytes:
    """A greedy LZF compressor (liblzf's format): literal runs of 1..32 bytes, back references of 3..264
    bytes from at most 8192 back (overlapping ones included)."""
    out, lit, i = bytearray(), bytearray(), 0
    table: dict[bytes, int] = {}

    def flush() -> None:
        for k in range(0, len(lit), 32):
            out.append(len(lit[k:k + 32]) - 1)
            out.extend(lit[k:k + 32])
        lit.clear()

    while i < len(data):
        key = data[i:i + 3]
        ref = table.get(key) if len(key) == 3 else None
        table[key] = i
        if ref is not None and i - ref <= 8192:
            length = 3
            while length < min(264, len(data) - i) and data[ref + length] == data[i + length]:
                length += 1
            flush()
            off, code = i - ref - 1, length - 2
            out.extend([(min(code, 7) << 5) | (off >> 8), *([code - 7] if code >= 7 else []), off & 0xFF])
            i += length
        else:
            lit.append(data[i])
            i += 1
    flush()
    return bytes(out)


def ply_file(fmt: str, elements: Sequence[tuple[str, list[str], Sequence[Sequence[float]]]],
             comments: tuple[str, ...] = ()) -> bytes:
    """A PLY file: ``elements`` as (name, property declarations such as ``"float x"`` or
    ``"list uchar int idx"``, rows of values; a list's row part is its length, then its items)."""
    head = ["ply", f"format {fmt} 1.0", *(f"comment {c}" for c in comments)]
    for name, props, rows in elements:
        head += [f"element {name} {len(rows)}", *(f"property {p}" for p in props)]
    out = bytearray(("\n".join([*head, "end_header"]) + "\n").encode())
    endian = ">" if fmt == "binary_big_endian" else "<"
    for _, props, rows in elements:
        for row in rows:
            if fmt == "ascii":
                out += (" ".join(f"{v:g}" for v in row) + "\n").encode()
                continue
            values = iter(row)
            for p in props:
                w = p.split()
                if w[0] == "list":
                    k = int(next(values))
                    out += np.array(k, endian + PLY_NP[w[1]]).tobytes()
                    out += np.array([next(values) for _ in range(k)], endian + PLY_NP[w[2]]).tobytes()
                else:
                    out += np.array(next(values), endian + PLY_NP[w[0]]).tobytes()
    return bytes(out)


PCD_FIELDS = [("x", "F", 4, 1), ("normal", "F", 4, 3), ("y", "F", 8, 1), ("z", "I", 2, 1),
              ("intensity", "U", 1, 1)]


def pcd_file(pts: F64, data: str, fields: list[tuple[str, str, int, int]] = PCD_FIELDS,
             width: int | None = None, height: int = 1, viewpoint: str | None = "0 0 0 1 0 0 0",
             points: int | None = None) -> bytes:
    """A PCD v0.7 file of ``pts`` in encoding ``data`` (fields other than x y z hold small constants);
    ``width`` and ``points`` default to the number of points."""
    n = len(pts)
    cols: list[F64] = []
    for name, _, _, count in fields:
        cols += [pts[:, "xyz".index(name)]] if name in "xyz" else [np.full(n, 7.0 + k) for k in range(count)]
    head = ["# .PCD v0.7 - Point Cloud Data file format", "VERSION 0.7",
            "FIELDS " + " ".join(f[0] for f in fields), "SIZE " + " ".join(str(f[2]) for f in fields),
            "TYPE " + " ".join(f[1] for f in fields), "COUNT " + " ".join(str(f[3]) for f in fields),
            f"WIDTH {n if width is None else width}", f"HEIGHT {height}",
            *([f"VIEWPOINT {viewpoint}"] if viewpoint else []), f"POINTS {n if points is None else points}",
            f"DATA {data}"]
    out = ("\n".join(head) + "\n").encode()
    if data == "ascii":
        return out + "".join(" ".join(f"{v:g}" for v in row) + "\n" for row in np.column_stack(cols)).encode()
    dtype = np.dtype([(f"f{i}", f"<{t.lower()}{s}", (c,)) for i, (_, t, s, c) in enumerate(fields)])
    rec = np.zeros(n, dtype)
    k = 0
    for i, (_, _, _, count) in enumerate(fields):
        rec[f"f{i}"] = np.column_stack(cols[k:k + count])
        k += count
    if data == "binary":
        return out + rec.tobytes()
    raw = b"".join(rec[f"f{i}"].tobytes() for i, f in enumerate(fields) if f[0] != "_")
    packed = lzf_compress(raw)
    return out + struct.pack("<II", len(packed), len(raw)) + packed


def put(tmp_path: Path, name: str, data: bytes | str) -> Path:
    """``data`` written to ``tmp_path / name``."""
    path = tmp_path / name
    path.write_bytes(data.encode() if isinstance(data, str) else data)
    return path


def refused(path: Path, *words: str, line: int | None = None, units: str = "m") -> ScanError:
    """read_cloud refuses ``path`` with a ScanError whose message starts with the file (and line) and
    names each of ``words``."""
    with pytest.raises(ScanError) as err:
        read_cloud(path, units=units)
    message = str(err.value)
    assert message.startswith(f"{path}:{line}: " if line is not None else f"{path}: "), message
    for w in words:
        assert w in message, message
    assert err.value.data["file"] == str(path) and err.value.data["line"] == line
    assert err.value.code == "E_SCAN"
    return err.value


# --- round trips ---------------------------------------------------------------------------------------

def test_write_ply_reads_back_points_at_float32_and_the_viewpoint(tmp_path: Path) -> None:
    """write_ply -> read_cloud keeps the points (float32 precision) and the stated pose exactly."""
    pts = np.random.default_rng(1).uniform(-3, 3, (500, 3))
    view = [0.1, -0.2, 1.5, 0.0, 0.0, 0.3826834323650898, 0.9238795325112867]
    path = tmp_path / "scan.ply"
    write_ply(path, pts, view)
    cloud = read_cloud(path)
    assert cloud.points.dtype == np.float64 and cloud.points.shape == (500, 3)
    assert np.array_equal(cloud.points, pts.astype(np.float32).astype(np.float64))
    assert cloud.viewpoint is not None and cloud.viewpoint.tolist() == view
    assert cloud.dropped == 0 and cloud.file == str(path)
    assert not [p for p in tmp_path.iterdir() if p.name != "scan.ply"], "no temp file left"


def test_write_ply_of_an_empty_cloud_and_no_viewpoint(tmp_path: Path) -> None:
    """An empty cloud is valid: written and read back as a [0, 3] array without a pose."""
    path = tmp_path / "empty.ply"
    write_ply(path, np.zeros((0, 3)))
    cloud = read_cloud(path)
    assert cloud.points.shape == (0, 3) and cloud.viewpoint is None and cloud.dropped == 0


def test_write_ply_refuses_what_it_could_not_read_back(tmp_path: Path) -> None:
    """A wrong shape or a non-finite point is a caller's error (ValueError), and no file is written."""
    for bad in (np.zeros((4, 2)), np.array([[0.0, np.nan, 0.0]]), np.array([[1e39, 0.0, 0.0]])):
        with pytest.raises(ValueError):
            write_ply(tmp_path / "bad.ply", bad)
    with pytest.raises(ValueError):
        write_ply(tmp_path / "bad.ply", np.zeros((1, 3)), [0, 0, 0, 1])
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("fmt", ["ascii", "binary_little_endian", "binary_big_endian"])
def test_ply_with_extra_properties_and_elements_around_the_vertices(tmp_path: Path, fmt: str) -> None:
    """x y z of mixed types among other properties; a fixed-size element before the vertices is skipped
    by its size, a face element with a list property after them is ignored; the pose comment is read."""
    pts = grid()
    camera = ("camera", ["float fx", "uchar id", "double k"], [[500.0, 1, 0.5], [600.0, 2, 0.25]])
    vertex = ("vertex", ["uchar red", "double x", "float nx", "float y", "short z", "int32 label"],
              [[200, x, 0.5, y, z * 4, 7] for x, y, z in pts])
    faces = ("face", ["list uchar int vertex_indices"], [[3, 0, 1, 2], [4, 0, 1, 2, 3]])
    path = put(tmp_path, "cloud.PLY", ply_file(fmt, [camera, vertex, faces],
                                               ("made by hand", "robwot viewpoint 1 2 3 0 0 0 1")))
    cloud = read_cloud(path)
    assert np.array_equal(cloud.points, pts * [1, 1, 4])
    assert cloud.viewpoint is not None and cloud.viewpoint.tolist() == [1, 2, 3, 0, 0, 0, 1]


@pytest.mark.parametrize("ptype", sorted(PLY_NP))
@pytest.mark.parametrize("fmt", ["ascii", "binary_big_endian"])
def test_ply_coordinates_of_every_scalar_type(tmp_path: Path, ptype: str, fmt: str) -> None:
    """x y z declared in any PLY scalar type (and alias) are read as float64."""
    pts = np.abs(grid(10) * 4)  # small non-negative integers: fit every type
    path = put(tmp_path, "t.ply", ply_file(fmt, [("vertex", [f"{ptype} {a}" for a in "xyz"], pts.tolist())]))
    assert np.array_equal(read_cloud(path).points, pts)


def test_ascii_ply_with_a_list_element_before_the_vertices(tmp_path: Path) -> None:
    """In ascii an element with a list property before the vertices is skipped a line an instance."""
    pts = grid(5)
    faces = ("face", ["list uchar int vertex_indices"], [[3, 0, 1, 2], [4, 0, 1, 2, 3], [0]])
    path = put(tmp_path, "f.ply", ply_file("ascii", [faces, ("vertex", XYZ_PROPS,
                                                              pts.tolist())]))
    assert np.array_equal(read_cloud(path).points, pts)


@pytest.mark.parametrize("data", ["ascii", "binary", "binary_compressed"])
def test_pcd_round_trip_skips_the_other_fields(tmp_path: Path, data: str) -> None:
    """x (F4), y (F8), z (I2) among a 3-count normal and a U1 intensity, in every encoding; VIEWPOINT's
    qw qx qy qz becomes our qx qy qz qw."""
    pts = grid(300)
    pts[:, 2] = np.round(pts[:, 2])  # z is an integer field
    path = put(tmp_path, "c.pcd", pcd_file(pts, data, viewpoint="1 2 3 0.5 0.1 0.2 0.3"))
    cloud = read_cloud(path)
    assert np.array_equal(cloud.points, pts) and cloud.dropped == 0
    assert cloud.viewpoint is not None and cloud.viewpoint.tolist() == [1, 2, 3, 0.1, 0.2, 0.3, 0.5]


def test_pcd_binary_compressed_known_good_liblzf_sample(tmp_path: Path) -> None:
    """Data compressed by liblzf itself decodes to the points it was made of."""
    head = (b"VERSION .7\nFIELDS x y z intensity\nSIZE 4 4 4 2\nTYPE F F F U\nCOUNT 1 1 1 1\nWIDTH 8\n"
            b"HEIGHT 1\nPOINTS 8\nDATA binary_compressed\n")
    path = put(tmp_path, "s.pcd", head + struct.pack("<II", len(LIBLZF_SAMPLE), 112) + LIBLZF_SAMPLE)
    cloud = read_cloud(path)
    assert np.array_equal(cloud.points, LIBLZF_POINTS) and cloud.viewpoint is None


def test_pcd_padding_fields_are_left_out_of_compressed_data(tmp_path: Path) -> None:
    """PCL's padding fields named ``_`` are in binary data but not in binary_compressed data."""
    fields = [("x", "F", 4, 1), ("_", "U", 1, 4), ("y", "F", 4, 1), ("z", "F", 4, 1)]
    pts = grid(50)
    for data in ("binary", "binary_compressed"):
        path = put(tmp_path, f"{data}.pcd", pcd_file(pts, data, fields))
        assert np.array_equal(read_cloud(path).points, pts)


@pytest.mark.parametrize("data", ["ascii", "binary", "binary_compressed"])
def test_organised_pcd_drops_and_counts_points_without_a_return(tmp_path: Path, data: str) -> None:
    """HEIGHT > 1 (a depth image): NaN points are the sensor's no return, skipped and counted."""
    pts = grid(12)
    pts[[1, 5, 6], 0] = np.nan
    pts[9] = np.nan
    path = put(tmp_path, "d.pcd", pcd_file(pts, data, [("x", "F", 4, 1), ("y", "F", 4, 1), ("z", "F", 4, 1)],
                                           width=4, height=3))
    cloud = read_cloud(path)
    assert cloud.dropped == 4
    assert np.array_equal(cloud.points, pts[np.isfinite(pts).all(axis=1)])


def test_xyz_text_with_comments_commas_tabs_and_extra_columns(tmp_path: Path) -> None:
    """Blank lines and # or // comments skipped; spaces, tabs or commas; further columns ignored; CRLF."""
    text = ("# x y z r g b\r\n1 2 3 255 0 0\r\n\r\n  // a comment\n4,5,6\n7.5\t-8e-1\t9\n"
            "10, 11 ,12, extra, words\n\n# end\n")
    for name in ("a.xyz", "b.TXT"):
        cloud = read_cloud(put(tmp_path, name, text))
        assert cloud.points.tolist() == [[1, 2, 3], [4, 5, 6], [7.5, -0.8, 9], [10, 11, 12]]
        assert cloud.viewpoint is None and cloud.dropped == 0
    cloud = read_cloud(put(tmp_path, "mac.xyz", "1 2 3\r4 5 6\r"))
    assert cloud.points.tolist() == [[1, 2, 3], [4, 5, 6]], "a lone CR ends a line: not one row of 6 columns"


def test_empty_clouds_are_valid(tmp_path: Path) -> None:
    """0 points in any format is an empty [0, 3] array."""
    files = {"e.xyz": b"# nothing\n", "e.ply": ply_file("ascii", [("vertex", XYZ_PROPS, [])]),
             "e.pcd": pcd_file(np.zeros((0, 3)), "binary"), "f.pcd": pcd_file(np.zeros((0, 3)), "ascii")}
    for name, data in files.items():
        assert read_cloud(put(tmp_path, name, data)).points.shape == (0, 3)


def test_millimetres(tmp_path: Path) -> None:
    """A cloud in millimetres read as metres is refused with the hint; read with units="mm" it is scaled,
    the viewpoint's position too."""
    pts = grid(20) * 400  # up to 3.2 m in mm
    path = tmp_path / "mm.ply"
    write_ply(path, pts, [100, 200, 300, 0, 0, 0, 1])
    err = refused(path, "farther than 100 m", "--units mm")
    assert "point " in err.message
    cloud = read_cloud(path, units="mm")
    assert np.allclose(cloud.points, pts * 1e-3)
    assert cloud.viewpoint is not None and np.allclose(cloud.viewpoint, [0.1, 0.2, 0.3, 0, 0, 0, 1])
    with pytest.raises(InvalidParams) as bad:
        read_cloud(path, units="cm")
    assert bad.value.data["param"] == "units"


def test_range_refusal_names_the_line_of_a_text_point(tmp_path: Path) -> None:
    """The refusal of a far point in text names its line, and in millimetres no units hint."""
    path = put(tmp_path, "far.xyz", "0 0 0\n1 2 3\n# far\n0 -250000 0\n")
    refused(path, "-250000", "--units mm", line=4)
    err = refused(path, "-250 m", line=4, units="mm")
    assert "--units" not in err.message


# --- refusals ------------------------------------------------------------------------------------------

def test_unknown_extension_names_the_known_ones(tmp_path: Path) -> None:
    """A .las file is refused naming .ply, .pcd, .xyz and .txt."""
    refused(put(tmp_path, "scan.las", b"LASF"), "'.las'", ".ply", ".pcd", ".xyz", ".txt")


def test_missing_file(tmp_path: Path) -> None:
    """No such file: FileNotFound naming it."""
    with pytest.raises(FileNotFound, match=r"missing\.ply"):
        read_cloud(tmp_path / "missing.ply")


def test_file_over_the_size_limit(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A file over MAX_CLOUD_BYTES is refused whole with both sizes."""
    monkeypatch.setattr(clouds, "MAX_CLOUD_BYTES", 100)
    path = tmp_path / "big.ply"
    write_ply(path, grid(20))
    refused(path, f"{path.stat().st_size} bytes", "limit of 100 bytes")


@pytest.mark.parametrize("fmt", ["binary_little_endian", "binary_big_endian"])
def test_truncated_and_overlong_binary_ply(tmp_path: Path, fmt: str) -> None:
    """Fewer bytes than the header declares: truncated, with expected vs found; more: refused too."""
    data = ply_file(fmt, [("vertex", XYZ_PROPS, grid(10).tolist())])
    refused(put(tmp_path, "t.ply", data[:-5]), "115 bytes", "declares 120", "truncated")
    refused(put(tmp_path, "o.ply", data + b"\0\0\0\0"), "124 bytes", "declares 120", "data past")


def test_binary_ply_trailing_elements_are_checked_when_fixed_size(tmp_path: Path) -> None:
    """A fixed-size element after the vertices still has to be whole; a list one is ignored."""
    vertex = ("vertex", XYZ_PROPS, grid(4).tolist())
    data = ply_file("binary_little_endian", [vertex, ("edge", ["int a", "int b"], [[0, 1], [1, 2]])])
    refused(put(tmp_path, "e.ply", data[:-1]), "declares 64", "truncated")
    faces = ("face", ["list uchar int idx"], [[3, 0, 1, 2]])
    data = ply_file("binary_little_endian", [vertex, faces])
    assert np.array_equal(read_cloud(put(tmp_path, "f.ply", data[:-3])).points, grid(4))


def test_binary_ply_with_a_list_element_before_the_vertices(tmp_path: Path) -> None:
    """Its size is known only by walking it: refused, saying so, at its header line."""
    faces = ("face", ["list uchar int vertex_indices"], [[3, 0, 1, 2]])
    data = ply_file("binary_little_endian", [faces, ("vertex", XYZ_PROPS, [[0, 0, 0]])])
    refused(put(tmp_path, "l.ply", data), "'face'", "list property", "vertex element first", line=3)


def test_truncated_and_overlong_ascii_ply(tmp_path: Path) -> None:
    """Fewer rows than declared names the line where a row is missing; more names the first extra."""
    text = ply_file("ascii", [("vertex", XYZ_PROPS, grid(3).tolist())]).decode()
    refused(put(tmp_path, "t.ply", text.rsplit("\n", 2)[0] + "\n"), "declares 3", "fewer (2)", line=10)
    refused(put(tmp_path, "o.ply", text + "1 2 3\n"), "declares 3", "more (4)", line=11)
    refused(put(tmp_path, "s.ply", text[:-1] + " 9\n"), "holds 4 values", "3 as the header declares", line=10)


def test_ply_header_refusals(tmp_path: Path) -> None:
    """Missing end_header, garbage lines, no vertex x y z, a format other than PLY, a header without end."""
    good = ply_file("ascii", [("vertex", XYZ_PROPS, [[0, 0, 0]])]).decode()
    refused(put(tmp_path, "a.ply", good.replace("end_header\n", "")), "without an end_header", line=7)
    refused(put(tmp_path, "b.ply", good.replace("vertex 1", "vertex many")), "'many'", "integer", line=3)
    refused(put(tmp_path, "c.ply", good.replace("property float z", "property quad z")), "'property quad z'",
            "not understood", line=6)
    refused(put(tmp_path, "d.ply", good.replace("float z", "float w")), "x, y and z", line=3)
    refused(put(tmp_path, "e.ply", good.replace("ascii 1.0", "ascii 2.0")), "not understood", line=2)
    refused(put(tmp_path, "f.ply", b"\x89PNG\r\n\x1a\n" + bytes(range(256)) * 4), "not a PLY file", line=1)
    refused(put(tmp_path, "g.ply", "ply\nformat ascii 1.0\n" + "comment x\n" * 1200 + "end_header\n"),
            "no an end_header line within the first 1000 lines")
    zero_quaternion = good.replace("ascii 1.0\n", "ascii 1.0\ncomment robwot viewpoint 1 2 3 0 0 0 0\n")
    refused(put(tmp_path, "h.ply", zero_quaternion), "non-zero quaternion", line=3)


def test_too_many_points_are_refused_before_any_allocation(tmp_path: Path) -> None:
    """A header declaring 10^8 points is refused from the header alone: nothing near its size allocated."""
    ply = ply_file("binary_little_endian", [("vertex", XYZ_PROPS, [[0, 0, 0]])])
    ply = ply.replace(b"vertex 1\n", f"vertex {10 ** 8}\n".encode())
    pcd = pcd_file(grid(1), "binary", width=10 ** 8, points=10 ** 8)
    for path, line, reader in ((put(tmp_path, "h.ply", ply), 3, clouds._read_ply),
                               (put(tmp_path, "h.pcd", pcd), 10, clouds._read_pcd)):
        refused(path, f"{10 ** 8} points", f"more than the {MAX_POINTS}", line=line)
        data = path.read_bytes()
        tracemalloc.start()  # the parse alone: read_whole's buffer is sized by the file size limit
        try:
            with pytest.raises(ScanError):
                reader(str(path), data)
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
        assert peak < 1 << 20, peak


def test_non_finite_points_in_unorganised_clouds_are_refused(tmp_path: Path) -> None:
    """PLY, XYZ and PCD of HEIGHT 1: a NaN or infinite coordinate names the point (and its line)."""
    pts = grid(6)
    pts[4, 1] = np.nan
    ply = ply_file("binary_little_endian", [("vertex", XYZ_PROPS, pts.tolist())])
    refused(put(tmp_path, "n.ply", ply), "point 4", "non-finite", "organised")
    refused(put(tmp_path, "n.xyz", "# head\n1 2 3\n4 inf 6\n"), "point 1", "non-finite", line=3)
    xyz3 = [("x", "F", 4, 1), ("y", "F", 4, 1), ("z", "F", 4, 1)]
    refused(put(tmp_path, "n.pcd", pcd_file(pts, "ascii", xyz3)), "point 4", "non-finite", line=16)
    refused(put(tmp_path, "m.pcd", pcd_file(pts, "binary", xyz3)), "point 4", "non-finite")


def test_pcd_refusals(tmp_path: Path) -> None:
    """Lying POINTS, truncated or overlong data in each encoding, a garbage header."""
    pts = grid(10)
    xyz3 = [("x", "F", 4, 1), ("y", "F", 4, 1), ("z", "F", 4, 1)]
    refused(put(tmp_path, "a.pcd", pcd_file(pts, "binary", xyz3, points=12)), "WIDTH 10 x HEIGHT 1",
            "POINTS 12", line=10)
    binary = pcd_file(pts, "binary", xyz3)
    refused(put(tmp_path, "b.pcd", binary[:-1]), "119 bytes", "declares 120", "truncated")
    refused(put(tmp_path, "c.pcd", binary + b"\n"), "121 bytes", "declares 120", "data past")
    text = pcd_file(pts, "ascii", xyz3).decode()
    refused(put(tmp_path, "d.pcd", text.rsplit("\n", 3)[0] + "\n"), "declares 10", "fewer (8)", line=20)
    refused(put(tmp_path, "e.pcd", text + "\n1 2 3\n"), "declares 10", "more (11)", line=23)
    bad = text.split("\n")
    bad[14] = "1 2 three"
    refused(put(tmp_path, "g.pcd", "\n".join(bad)), "'three'", "not a number", line=15)
    refused(put(tmp_path, "h.pcd", text.replace("SIZE 4 4 4", "SIZE 4 4 x")), "SIZE 'x'", line=4)
    refused(put(tmp_path, "n.pcd", text.replace("TYPE F F F", "TYPE F F D")), "TYPE 'D'", line=5)
    refused(put(tmp_path, "i.pcd", text.replace("HEIGHT 1", "HEIGHT 1\nCOLOR red")), "'COLOR red'", line=9)
    refused(put(tmp_path, "j.pcd", text.replace("DATA ascii", "DATA zip")), "'zip'", line=11)
    refused(put(tmp_path, "k.pcd", text.replace("FIELDS x y z", "FIELDS x y w")), "x, y and z", line=3)
    refused(put(tmp_path, "l.pcd", bytes(range(256)) * 8), "without a DATA line", line=9)
    refused(put(tmp_path, "m.pcd", text.replace("VIEWPOINT 0 0 0 1 0 0 0", "VIEWPOINT 0 0 0 1")),
            "VIEWPOINT needs 7 finite numbers", line=9)


def test_pcd_binary_compressed_refusals(tmp_path: Path) -> None:
    """Sizes that disagree with POINTS or with the bytes present, and corrupt LZF data."""
    head = (b"FIELDS x y z intensity\nSIZE 4 4 4 2\nTYPE F F F U\nCOUNT 1 1 1 1\nWIDTH 8\nHEIGHT 1\n"
            b"POINTS 8\nDATA binary_compressed\n")
    sizes = struct.pack("<II", len(LIBLZF_SAMPLE), 112)
    refused(put(tmp_path, "a.pcd", head + sizes + LIBLZF_SAMPLE[:-1]), f"declares {len(LIBLZF_SAMPLE)}",
            "truncated")
    refused(put(tmp_path, "b.pcd", head + sizes + LIBLZF_SAMPLE + b"\0"), "data past")
    refused(put(tmp_path, "c.pcd", head + struct.pack("<II", len(LIBLZF_SAMPLE), 10 ** 9) + LIBLZF_SAMPLE),
            "declares 1000000000 bytes decompressed", "make 112")
    refused(put(tmp_path, "d.pcd", head + b"\1\0"), "2 bytes", "at least 8", "truncated")
    corrupt = b"\x00A\x20\x05" + LIBLZF_SAMPLE[4:]  # a back reference 6 bytes back after 1 byte of output
    refused(put(tmp_path, "e.pcd", head + struct.pack("<II", len(corrupt), 112) + corrupt), "corrupt",
            "before the start")
    short = LIBLZF_SAMPLE[:-15] + b"\x01\x01\x00"  # its last run of 14 literals now one of 2
    refused(put(tmp_path, "f.pcd", head + struct.pack("<II", len(short), 112) + short), "corrupt",
            "not the declared 112")


def test_xyz_refusals(tmp_path: Path) -> None:
    """A word that is not a number, too few numbers, an empty comma field, bytes that are not text."""
    refused(put(tmp_path, "a.xyz", "1 2 3\n# c\n4 5 x6\n"), "'x6'", "not a number", line=3)
    refused(put(tmp_path, "b.xyz", "1 2 3\n4 5\n"), "holds 2 values", "at least 3", line=2)
    refused(put(tmp_path, "c.xyz", "1,2,3\n4,,5,6\n"), "empty field", line=2)
    refused(put(tmp_path, "d.xyz", "1 2 3\n1 2 3 4\n\n7 8 9 x\n1 2 q 4 5\n"), "'q'", line=5)
    refused(put(tmp_path, "e.xyz", b"1 2 3\n4 5 \xff\n"), "0xff", "not text", line=2)
