"""Imported by the labelling pool's forkserver only (``pool.py``): the outer bounds' compiled kernels loaded
there, once, before it forks a worker. Every worker then labels with them from its first row instead of
after ``kernels.WARM_AFTER`` rows of its own, and none pays numba's import and the kernels' load: the
forkserver pays it while the backend loads the robot, before any chunk is sent. ``ROBWOT_OUTER_BOUNDS=off``
leaves them unloaded, as everywhere."""

from robwot_sim.sim.kernels import load_kernels

load_kernels(here=True)
