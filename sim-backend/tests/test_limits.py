"""The backend's checks below the RPC layer take their ranges from the contract (`robwot_sim.limits`)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from simhelp import KUKA

from robwot_sim import limits, validate
from robwot_sim.errors import InvalidParams
from robwot_sim.sim.world import World

CONTRACT = Path(__file__).parents[1] / "src" / "robwot_sim" / "schemas" / "protocol.openrpc.json"
SCHEMAS = json.loads(CONTRACT.read_text())["components"]["schemas"]


def test_limits_are_the_contracts_numbers() -> None:
    """Each range of `limits` is the contract component of the same name, read from the file itself."""
    for name, bounds in (("Speed", limits.SPEED), ("Dt", limits.DT), ("Clearance", limits.CLEARANCE),
                         ("ReachVoxel", limits.REACH_VOXEL)):
        assert (bounds.minimum, bounds.maximum) == (SCHEMAS[name]["minimum"], SCHEMAS[name]["maximum"])
    assert SCHEMAS["Clearance"]["default"] == limits.DEFAULT_CLEARANCE
    assert SCHEMAS["Position"]["items"]["maximum"] == limits.MAX_COORDINATE
    assert SCHEMAS["Name"]["maxLength"] == limits.MAX_NAME_LENGTH
    assert SCHEMAS["QuatXyzw"]["x-minNorm"] == limits.MIN_QUATERNION_NORM


def test_positions_names_and_clearance_follow_the_contract() -> None:
    """Positions, names and a robot's clearance are refused just beyond the contract's bounds."""
    edge = limits.MAX_COORDINATE
    assert validate.position("p", [edge, -edge, 0]) == [edge, -edge, 0.0]
    with pytest.raises(InvalidParams):
        validate.position("p", [edge * 1.001, 0, 0])
    assert validate.name("n", "x" * limits.MAX_NAME_LENGTH)
    with pytest.raises(InvalidParams, match=f"at most {limits.MAX_NAME_LENGTH} characters"):
        validate.name("n", "x" * (limits.MAX_NAME_LENGTH + 1))
    with World() as w:
        assert w.load_robot(KUKA, clearance=limits.CLEARANCE.maximum).clearance == limits.CLEARANCE.maximum
        with pytest.raises(InvalidParams):
            w.load_robot(KUKA, robot_id="other", clearance=limits.CLEARANCE.maximum * 1.5)
