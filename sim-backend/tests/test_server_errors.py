"""Every error of the Contract 1 error table over the real WebSocket; the server answers afterwards and the
world is unchanged by the failed request."""

from __future__ import annotations

import json
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from rpc_backend import BackendProcess, RpcClient
from websockets.exceptions import ConnectionClosed

LIMIT = 200_000
KUKA = "kuka_iiwa/model.urdf"


@pytest.fixture(scope="module")
def backend() -> Iterator[BackendProcess]:
    proc = BackendProcess("--max-message", str(LIMIT))
    yield proc
    assert proc.stop() == 0


@pytest.fixture
def client(backend: BackendProcess) -> Iterator[RpcClient]:
    c = backend.client()
    c.call("world.reset")
    c.call("robot.load", {"urdf": KUKA, "id": "kuka"})
    c.call("obstacle.add", {"name": "box", "shape": {"type": "box", "size": [0.1, 0.1, 0.1]},
                            "position": [0.6, 0.0, 0.3]})
    c.call("robot.setJointPositions", {"robot": "kuka", "positions": [0.1] * 7})
    yield c
    c.close()


def _snapshot(c: RpcClient) -> dict[str, Any]:
    return {"list": c.call("world.list"), "q": c.call("robot.getJointPositions", {"robot": "kuka"})}


def _write(tmp: Path, name: str, text: str) -> str:
    path = tmp / name
    path.write_text(text)
    return str(path)


LINK = '<link name="{n}"><collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link>'
ONE_DOF = ('<robot name="one">' + LINK.format(n="base") + LINK.format(n="tip") +
           '<joint name="j" type="revolute"><parent link="base"/><child link="tip"/>'
           '<limit lower="-1" upper="1" velocity="1" effort="1"/></joint></robot>')


def _mesh_robot(filename: str) -> str:
    return ('<robot name="m"><link name="base"/><link name="tip"><visual><geometry>'
            f'<mesh filename="{filename}"/></geometry></visual></link>'
            '<joint name="j" type="revolute"><parent link="base"/><child link="tip"/>'
            '<limit lower="-1" upper="1" velocity="1" effort="1"/></joint></robot>')


Case = Callable[[RpcClient, Path], Any]

CASES: list[tuple[str, int, str, Case, dict[str, Any]]] = [
    ("parse", -32700, "E_PARSE", lambda c, t: c.raw("{not json"), {}),
    ("batch", -32600, "E_INVALID_REQUEST",
     lambda c, t: c.raw('[{"jsonrpc":"2.0","id":1,"method":"ping"}]'), {}),
    ("not a request", -32600, "E_INVALID_REQUEST", lambda c, t: c.raw('{"id":1,"method":"ping"}'), {}),
    ("binary frame", -32600, "E_INVALID_REQUEST",
     lambda c, t: c.raw(b'{"jsonrpc":"2.0","id":1,"method":"ping"}'), {}),
    ("too large", -32600, "E_TOO_LARGE",
     lambda c, t: c.raw(json.dumps({"jsonrpc": "2.0", "id": 9, "method": "ping", "x": "a" * (LIMIT + 10)})),
     {"limit": LIMIT}),
    ("unknown method", -32601, "E_METHOD_NOT_FOUND", lambda c, t: c.error("robot.fly"),
     {"method": "robot.fly"}),
    ("NaN", -32602, "E_INVALID_PARAMS", lambda c, t: c.raw(
        '{"jsonrpc":"2.0","id":2,"method":"robot.setJointPositions",'
        '"params":{"robot":"kuka","positions":[0,0,NaN,0,0,0,0]}}'), {"param": "positions[2]", "got": "NaN"}),
    ("Infinity", -32602, "E_INVALID_PARAMS", lambda c, t: c.raw(
        '{"jsonrpc":"2.0","id":2,"method":"obstacle.move","params":{"name":"box","position":[0,1e999,0]}}'),
     {"param": "position[1]", "got": "Infinity"}),
    ("wrong length", -32602, "E_INVALID_PARAMS",
     lambda c, t: c.error("robot.setJointPositions", {"robot": "kuka", "positions": [0] * 6}),
     {"param": "positions"}),
    ("wrong type", -32602, "E_INVALID_PARAMS",
     lambda c, t: c.error("robot.move", {"robot": "kuka", "target": [0] * 7, "speed": "fast"}),
     {"param": "speed"}),
    ("missing", -32602, "E_INVALID_PARAMS", lambda c, t: c.error("obstacle.add", {"name": "b2"}),
     {"param": "shape"}),
    ("unknown param", -32602, "E_INVALID_PARAMS", lambda c, t: c.error("robot.model", {"robto": "kuka"}),
     {"param": "robto"}),
    ("unknown robot", -32001, "E_UNKNOWN_ROBOT", lambda c, t: c.error("robot.fk", {"robot": "nope"}),
     {"name": "nope", "available": ["kuka"]}),
    ("unknown object", -32001, "E_UNKNOWN_OBJECT", lambda c, t: c.error("obstacle.remove", {"name": "nope"}),
     {"name": "nope", "available": ["box"]}),
    ("unknown link", -32001, "E_UNKNOWN_LINK",
     lambda c, t: c.error("robot.load", {"urdf": KUKA, "id": "k2", "eeLink": "hand"}), {"name": "hand"}),
    ("out of limits", -32002, "E_OUT_OF_LIMITS",
     lambda c, t: c.error("robot.setJointPositions", {"robot": "kuka", "positions": [0, 3.0, 0, 0, 0, 0, 0]}),
     {"joint": "lbr_iiwa_joint_2", "value": 3.0}),
    ("malformed urdf", -32003, "E_URDF",
     lambda c, t: c.error("robot.load", {"urdf": _write(t, "bad.urdf", "<robot>\n<link>\n</robot>")}),
     {"line": 3}),
    ("no movable joint", -32003, "E_NO_MOVABLE_JOINT",
     lambda c, t: c.error("robot.load", {"urdf": _write(t, "fixed.urdf",
                                                        ONE_DOF.replace("revolute", "fixed"))}),
     {}),
    ("missing urdf", -32004, "E_FILE_NOT_FOUND",
     lambda c, t: c.error("robot.load", {"urdf": str(t / "absent.urdf")}), {}),
    ("missing mesh", -32004, "E_FILE_NOT_FOUND",
     lambda c, t: c.error("robot.load", {"urdf": _write(t, "mesh.urdf", _mesh_robot("meshes/absent.stl"))}),
     {}),
    ("xml entity", -32005, "E_FORBIDDEN", lambda c, t: c.error("robot.load", {"urdf": _write(
        t, "xxe.urdf", '<?xml version="1.0"?><!DOCTYPE r [<!ENTITY x SYSTEM "file:///etc/passwd">]>'
        + ONE_DOF.replace('name="one"', 'name="&x;"'))}), {}),
    ("path escape", -32005, "E_PATH_ESCAPE", lambda c, t: c.error("robot.load", {"urdf": _write(
        t, "escape.urdf", _mesh_robot("../../../../../../../etc/hostname"))}), {}),
    ("scene schema", -32006, "E_SCENE", lambda c, t: c.error("world.loadScene", {"scene": {
        "version": 1, "obstacles": [{"name": "s", "shape": {"type": "sphere", "radius": "big"},
                                     "position": [0, 0, 0]}]}}), {}),
    ("unreachable", -32007, "E_UNREACHABLE",
     lambda c, t: c.error("robot.ik", {"robot": "kuka", "position": [5.0, 5.0, 5.0]}), {}),
    ("name taken", -32010, "E_NAME_TAKEN", lambda c, t: c.error("obstacle.add", {
        "name": "box", "shape": {"type": "sphere", "radius": 0.1}, "position": [2, 2, 2]}), {"name": "box"}),
]


@pytest.mark.parametrize(("label", "code", "data_code", "case", "fields"), CASES, ids=[c[0] for c in CASES])
def test_error_then_server_still_answers(client: RpcClient, tmp_path: Path, label: str, code: int,
                                         data_code: str, case: Case, fields: dict[str, Any]) -> None:
    """The error has its JSON-RPC code, data.code and fields; the world is unchanged; ping still answers."""
    before = _snapshot(client)
    outcome = case(client, tmp_path)
    error = outcome["error"] if isinstance(outcome, dict) else outcome.error
    assert error["code"] == code, error
    assert error["data"]["code"] == data_code, error
    for key, value in fields.items():
        assert error["data"][key] == value, error
    assert isinstance(error["message"], str) and error["message"]
    assert _snapshot(client) == before
    assert client.call("ping")["pybullet"] == "3.2.7"


def test_error_data_fields_name_files(client: RpcClient, tmp_path: Path) -> None:
    """File errors carry the file (and the URDF naming a missing mesh); URDF errors the line."""
    urdf = _write(tmp_path, "mesh.urdf", _mesh_robot("meshes/absent.stl"))
    err = client.error("robot.load", {"urdf": urdf})
    assert err.data["file"].endswith("absent.stl")
    assert err.data["urdf"].endswith("mesh.urdf")
    err = client.error("robot.load", {"urdf": _write(tmp_path, "bad.urdf", "<robot>\n<link>\n</robot>")})
    assert err.data["file"].endswith("bad.urdf") and err.data["line"] == 3


def test_busy_error(client: RpcClient) -> None:
    """A second robot.move while one runs is E_BUSY naming the robot; the first motion is unaffected."""
    first = client.send("robot.move", {"robot": "kuka", "target": [-1.0] + [0.1] * 6, "speed": 0.2})
    client.wait_notification("robot.state")
    err = client.error("robot.move", {"robot": "kuka", "target": [0.0] * 7})
    assert (err.code, err.data) == (-32008, {"code": "E_BUSY", "robot": "kuka"})
    assert client.error("robot.setJointPositions", {"robot": "kuka", "positions": [0.0] * 7}).code == -32008
    assert client.call("robot.stop", {"robot": "kuka"}) == {"stopped": True}
    assert client.wait(first)["status"] == "stopped"
    assert client.call("ping")["version"]


def test_frame_above_hard_cap_closes_only_that_connection(backend: BackendProcess, client: RpcClient) -> None:
    """A frame far above the limit closes that connection (1009); the server keeps serving others."""
    big = backend.client()
    with pytest.raises(ConnectionClosed):
        big.raw(json.dumps({"jsonrpc": "2.0", "id": 1, "method": "ping", "x": "a" * (LIMIT * 8)}))
    assert client.call("ping")["version"]
    again = backend.client()
    assert again.call("ping")["version"]
    again.close()
