"""Workspace generation: sample configurations, vectorised FK, parallel collision labelling, alpha shape.

``generate.generate_workspace`` writes ``workspace.csv`` and ``workspace.stl`` into ``out_dir`` and returns
the WorkspaceSummary of ARCHITECTURE.md (Contract 2). Units: metres, radians, seconds; world frame.

Nothing is imported here: the backend starts the labelling pool (``pool.warm_up``) before anything else,
and the pool's forkserver imports ``pool``; neither should wait for FK, meshes or scipy. Import the
submodules.
"""
