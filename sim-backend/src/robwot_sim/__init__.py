"""RobWoT simulation backend: PyBullet in DIRECT mode behind a WebSocket JSON-RPC 2.0 server."""

import os

# Our numpy products are small (4x4 link frames, 3x3 fits) and workspace labelling runs one process per
# core: OpenBLAS threads in every process would only compete with those workers (local labelling of
# 300,000 kuka samples on 2 cores: 8.3-8.6 s with them, 6.2-7.8 s without). Set before numpy loads
# OpenBLAS here and in the worker processes started from here; an explicit setting is kept.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

__version__ = "0.1.0"
