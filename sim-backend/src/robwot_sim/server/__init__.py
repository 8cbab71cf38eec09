"""The backend's WebSocket server, split as python-websockets splits its own: `peer` (a client's bounded
outbox), `services` (what the method handlers use: the world's thread, off-world threads, motions,
broadcast), `auth` (the upgrade check), `app` (the composition root: `run_server`)."""

from robwot_sim.server.app import run_server

__all__ = ["run_server"]
