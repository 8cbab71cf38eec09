"""Workspace generation: sample configurations, vectorised FK, parallel collision labelling, alpha shape.

``generate_workspace`` (``generate.py``) writes ``workspace.csv`` and ``workspace.stl`` into ``out_dir``
and returns the WorkspaceSummary of ARCHITECTURE.md (Contract 2). Units: metres, radians, seconds; world
frame.
"""

from __future__ import annotations

from robwot_sim.model.fk import ChainFK
from robwot_sim.workspace.generate import ALPHA_MAX_POINTS, chain_fk, generate_workspace, versions
from robwot_sim.workspace.labelling import warm_up

# scipy (alpha shape) is imported on first use: worker processes import this package and need only
# the labelling, and they start faster without it.
__all__ = ["ALPHA_MAX_POINTS", "ChainFK", "chain_fk", "generate_workspace", "versions", "warm_up"]
