"""Drive the robwot_sim backend with a plain WebSocket client: no project code, only `websockets`.

    python plain_client.py                      # starts `python -m robwot_sim serve --port 0` itself
    ROBWOT_BACKEND_TOKEN=... python plain_client.py ws://127.0.0.1:8765  # uses a running server (its token)

Loads the KUKA iiwa from pybullet_data, computes forward kinematics, moves joint 1 while printing the
streamed `robot.state` notifications, and shows a structured error reply.
"""

from __future__ import annotations

import asyncio
import itertools
import json
import os
import subprocess
import sys
from typing import Any

from websockets.asyncio.client import ClientConnection, connect

_ids = itertools.count(1)


async def call(ws: ClientConnection, method: str, params: dict[str, Any] | None = None) -> dict[str, Any]:
    """Send one request; print notifications until its reply arrives; return the reply object."""
    request: dict[str, Any] = {"jsonrpc": "2.0", "id": next(_ids), "method": method}
    if params is not None:
        request["params"] = params
    await ws.send(json.dumps(request))
    while True:
        message = json.loads(await ws.recv())
        if "id" not in message:  # a notification, e.g. robot.state
            p = message["params"]
            print(f"  {message['method']}: t={p.get('time', 0):.3f} s q1={p['positions'][0]:.3f} "
                  f"moving={p.get('moving')}")
            continue
        if message["id"] == request["id"]:
            return dict(message)


async def session(url: str, token: str) -> None:
    # the backend serves only clients presenting its token
    async with connect(url, additional_headers={"Authorization": f"Bearer {token}"}) as ws:
        ping = await call(ws, "ping")
        print("ping:", ping["result"])
        await call(ws, "world.reset")
        model = (await call(ws, "robot.load", {"urdf": "kuka_iiwa/model.urdf", "id": "kuka"}))["result"]
        print("loaded", model["id"], "joints:", model["controllable"], "end effector:", model["eeLink"])
        pose = (await call(ws, "robot.fk", {"robot": "kuka"}))["result"]
        print("end effector at", [round(v, 4) for v in pose["position"]], "m")
        target = [0.5, 0, 0, 0, 0, 0, 0]
        result = (await call(ws, "robot.move", {"robot": "kuka", "target": target, "speed": 0.2}))["result"]
        print("move:", result["status"],
              f"in {result['duration']:.3f} s simulated, {result['wallTime']:.3f} s wall")
        too_far = [0, 3, 0, 0, 0, 0, 0]  # joint 2 beyond its limit
        error = await call(ws, "robot.setJointPositions", {"robot": "kuka", "positions": too_far})
        print("error:", error["error"]["code"], error["error"]["data"])


def main() -> int:
    if len(sys.argv) > 1:  # a running backend: its token comes from the environment
        token = os.environ.get("ROBWOT_BACKEND_TOKEN")
        if not token:
            print(f"plain_client.py: connecting to {sys.argv[1]} needs the server's token: set "
                  "ROBWOT_BACKEND_TOKEN to the token the server was started with (or printed in its ready line)",
                  file=sys.stderr)
            return 2
        asyncio.run(session(sys.argv[1], token))
        return 0
    server = subprocess.Popen([sys.executable, "-m", "robwot_sim", "serve", "--port", "0"],
                              stdout=subprocess.PIPE, text=True)
    try:
        assert server.stdout is not None
        # started without ROBWOT_BACKEND_TOKEN, the server makes a token and names it in its ready line
        ready = json.loads(server.stdout.readline())  # {"event":"ready","port":N,"token":"..."}
        asyncio.run(session(f"ws://127.0.0.1:{ready['port']}", ready["token"]))
    finally:
        server.terminate()
        server.wait(10)
    return 0


if __name__ == "__main__":
    sys.exit(main())
