"""RobWoT simulation backend: PyBullet in DIRECT mode behind a WebSocket JSON-RPC 2.0 server."""

__version__ = "0.1.0"
