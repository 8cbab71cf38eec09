"""The twin's answers against the OpenAPI document `robwot openapi` writes, judged by Schemathesis (not by
RobWoT's code): a bounded fuzz run (`npm run bench:fuzz`) finds no 5xx and no contradiction; the answers a
random fuzzer seldom reaches (a calibration, a reachable Cartesian move, each error status) conform too;
and a document that contradicts the answers is caught, so the checks can fail. Real CLI, backend and
servient over HTTP."""

from __future__ import annotations

import copy
import json
import os
import subprocess
import time
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import pytest
import schemathesis
from schemathesis.checks import not_a_server_error
from schemathesis.core.failures import FailureGroup
from schemathesis.openapi.checks import JsonSchemaError, UndefinedStatusCode
from schemathesis.specs.openapi.checks import (
    content_type_conformance,
    response_schema_conformance,
    status_code_conformance,
)
from served_twin import NODE, REPO, robwot, served_twin

CHECKS = [not_a_server_error, status_code_conformance, content_type_conformance, response_schema_conformance]
HOME = {f"lbr_iiwa_joint_{i}": 0.0 for i in range(1, 8)}
REACHABLE = {"x": 0.4, "y": 0.1, "z": 0.6}


class Api:
    def __init__(self, folder: Path, doc: dict[str, Any], origin: str, slug: str) -> None:
        self.folder, self.doc, self.origin, self.slug = folder, doc, origin, slug

    def case(self, path: str, body: Any = None, method: str = "POST",
             doc: dict[str, Any] | None = None) -> Any:
        """A Schemathesis test case of the operation at `/<slug>/<path>`."""
        schema = schemathesis.openapi.from_dict(doc if doc is not None else self.doc)
        op = schema[f"/{self.slug}/{path}"][method]
        return op.Case(body=body) if body is not None else op.Case()

    def call(self, path: str, body: Any = None, method: str = "POST",
             doc: dict[str, Any] | None = None) -> Any:
        """Sends the case through Schemathesis and validates the answer with its checks; returns it."""
        case = self.case(path, body, method, doc)
        response = case.call(base_url=self.origin)
        case.validate_response(response, checks=CHECKS)
        return response


@pytest.fixture(scope="module")
def api(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Api]:
    work = tmp_path_factory.mktemp("openapi")
    folder = work / "kuka"
    with served_twin(folder) as td_url:  # realtime 1: a slow move lasts long enough to meet an obstacle
        origin, slug = td_url.rsplit("/", 1)
        doc = work / "openapi.json"
        robwot("openapi", str(folder), "--base", origin, "--out", str(doc))
        yield Api(folder, json.loads(doc.read_text()), origin, slug)


def test_bounded_fuzz_run_finds_no_5xx_and_no_contradiction(api: Api) -> None:
    env = {**os.environ, "ROBWOT_BENCH_TWIN": str(api.folder)}
    run = subprocess.run([NODE, str(REPO / "scripts" / "bench-fuzz.mjs"), "--examples", "3", "--json"],
                         capture_output=True, text=True, timeout=300, env=env)
    assert run.returncode in (0, 1), run.stderr
    figures = json.loads(run.stdout.strip().splitlines()[-1])
    assert figures["operations"] == 27  # every operation but the long-poll and stream routes
    assert figures["cases"] > 300
    assert figures["responses5xx"] == 0, figures
    assert figures["failures"] == [] and figures["errors"] == [], figures
    assert run.returncode == 0


def test_stateful_phase_follows_the_links_to_real_action_statuses(api: Api) -> None:
    """The document's links (an asynchronous move's 201 -> its queryaction / cancelaction) let
    Schemathesis's stateful phase chain calls: it queries and cancels ActionStatus resources a 201
    created (without links the phase has nothing to follow), and every answer conforms."""
    env = {**os.environ, "ROBWOT_BENCH_TWIN": str(api.folder)}
    run = subprocess.run([NODE, str(REPO / "scripts" / "bench-fuzz.mjs"), "--examples", "1",
                          "--stateful-examples", "50", "--json"],
                         capture_output=True, text=True, timeout=300, env=env)
    figures = json.loads(run.stdout.strip().splitlines()[-1])
    stateful = figures["stateful"]
    assert stateful["links"] == 6 and stateful["linksCovered"] > 0, stateful
    assert stateful["created"] > 0, stateful
    chained = stateful["chained"]
    assert chained.get("GET 200", 0) > 0, stateful
    # a cancel either stopped the move (204) or came after its end (409, nothing cancelled)
    assert chained.get("DELETE 204", 0) + chained.get("DELETE 409", 0) > 0, stateful
    assert figures["failures"] == [] and figures["errors"] == [], figures
    assert run.returncode == 0


def test_successes_the_fuzzer_seldom_reaches_conform(api: Api) -> None:
    assert api.call("actions/validateCartesianPosition", REACHABLE).json()["valid"] is True
    assert api.call("actions/moveToCartesianPosition", REACHABLE).json()["status"] == "reached"
    pairs = [{"real": {"x": x, "y": y, "z": z}, "virtual": {"x": x, "y": y, "z": z}}
             for x, y, z in ((0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1))]
    assert api.call("actions/calibrate", {"pairs": pairs, "withScale": False}).status_code == 200
    assert api.call("properties/calibration", method="GET").json()["active"] is True
    assert api.call("properties", method="GET").status_code == 200
    assert api.call("properties/motionStatus", method="GET").json()["lastResult"]["status"] == "reached"
    assert api.call("actions/moveToJointPosition", {"joints": HOME}).json()["status"] == "reached"
    assert api.call("actions/stop").json() == {"stopped": False, "simulation": {"ok": True}}


def test_long_poll_answers_conform(api: Api) -> None:
    """The long-poll routes (left out of the fuzz run: they answer on the next change) answer the
    property's schema once a move changes it."""
    poses = [dict(HOME, lbr_iiwa_joint_2=0.5, lbr_iiwa_joint_4=-0.5), HOME]  # the twin is at HOME
    for i, name in enumerate(("getJointPosition", "getCartesianPosition", "motionStatus")):
        case = api.case(f"properties/{name}/observable", method="GET")
        with ThreadPoolExecutor(1) as pool:
            answer = pool.submit(case.call, base_url=api.origin)
            time.sleep(0.5)  # the long poll is waiting
            assert api.call("actions/moveToJointPosition", {"joints": poses[i % 2]}).status_code == 200
            response = answer.result(timeout=30)
        case.validate_response(response, checks=CHECKS)
        assert response.status_code == 200


def test_every_error_status_conforms(api: Api) -> None:
    box = {"type": "box", "size": [0.3, 0.3, 0.3]}
    wall = {"name": "wall", "shape": box, "position": [0.4, -0.4, 0.4]}
    assert api.call("actions/addObstacle", wall).status_code == 200
    taken = api.call("actions/addObstacle", {"name": "wall", "shape": box, "position": [2, 2, 0]})
    assert (taken.status_code, taken.json()["code"]) == (409, "E_NAME_TAKEN")
    inside = api.call("actions/moveToCartesianPosition", {"x": 0.4, "y": -0.4, "z": 0.4})
    assert (inside.status_code, inside.json()["code"]) == (422, "E_REJECTED")
    assert api.call("actions/removeObstacle", {"name": "nope"}).status_code == 404
    assert api.call("actions/moveToJointPosition", {"joints": {"elbow": 1}}).status_code == 400
    same = [{"real": {"x": 0, "y": 0, "z": 0}, "virtual": {"x": 0, "y": 0, "z": 0}}] * 3
    assert api.call("actions/calibrate", {"pairs": same}).status_code == 400
    assert api.call("actions/removeObstacle", {"name": "wall"}).status_code == 200


def test_a_document_that_contradicts_the_answers_is_caught(api: Api) -> None:
    """The checks can fail: a success schema requiring a field the twin never sends, and a document
    without the 422 the twin answers, are both reported."""
    op = f"/{api.slug}/actions/validateJointPosition"
    wrong = copy.deepcopy(api.doc)
    wrong["paths"][op]["post"]["responses"]["200"]["content"]["application/json"]["schema"]["required"].append("x")
    with pytest.raises(FailureGroup) as schema_failure:
        api.call("actions/validateJointPosition", {"joints": HOME}, doc=wrong)
    assert [type(e) for e in schema_failure.value.exceptions] == [JsonSchemaError]
    no422 = copy.deepcopy(api.doc)
    del no422["paths"][f"/{api.slug}/actions/moveToCartesianPosition"]["post"]["responses"]["422"]
    ball = {"name": "w2", "shape": {"type": "sphere", "radius": 0.2}, "position": [0.4, -0.4, 0.4]}
    api.call("actions/addObstacle", ball)
    try:
        with pytest.raises(FailureGroup) as status_failure:
            api.call("actions/moveToCartesianPosition", {"x": 0.4, "y": -0.4, "z": 0.4}, doc=no422)
        assert [type(e) for e in status_failure.value.exceptions] == [UndefinedStatusCode]
    finally:
        api.call("actions/removeObstacle", {"name": "w2"})


def test_collision_event_and_busy_answers_conform(api: Api) -> None:
    """The collision event's long poll answers its data schema; a move while moving answers 409."""
    event = api.case("events/collision", method="GET")
    target = dict(HOME, lbr_iiwa_joint_2=1.2, lbr_iiwa_joint_4=-0.4, lbr_iiwa_joint_6=0.4)
    box = {"type": "box", "size": [0.2, 0.6, 0.2]}
    intruder = {"name": "intruder", "shape": box, "position": [0.55, 0, 0.75]}
    with ThreadPoolExecutor(2) as pool:
        collision = pool.submit(event.call, base_url=api.origin)
        time.sleep(0.5)  # the long poll is waiting
        move = pool.submit(api.call, "actions/moveToJointPosition", {"joints": target, "speed": 0.05})
        deadline = time.monotonic() + 20
        while api.call("properties/motionStatus", method="GET").json()["state"] != "moving":
            assert time.monotonic() < deadline and not move.done(), move.result().json()
            time.sleep(0.05)
        busy = api.call("actions/moveToJointPosition", {"joints": HOME})
        assert (busy.status_code, busy.json().get("code")) == (409, "E_BUSY"), busy.json()
        assert api.call("actions/addObstacle", intruder).status_code == 200
        assert move.result(timeout=60).json()["status"] == "collision"
        answer = collision.result(timeout=30)
    event.validate_response(answer, checks=CHECKS)
    assert answer.status_code == 200 and answer.json()["pair"]["b"]["body"] == "intruder"
    api.call("actions/removeObstacle", {"name": "intruder"})
