"""Imported by the labelling pool's forkserver only (``pool.py``): the outer bounds' compiled kernels loaded
there, once, before it forks a worker. Every worker then labels with them from its first row instead of
after ``kernels.WARM_AFTER`` rows of its own, and none pays numba's import and the kernels' load: the
forkserver pays it while the backend loads the robot, before any chunk is sent. ``ROBWOT_OUTER_BOUNDS=off``
leaves them unloaded, as everywhere.

Every worker waits for this load, so it skips what the kernels do not use: numba probes for a BLAS as it
loads its NumPy support, by importing scipy's linear algebra package (longer than loading every kernel)
only to know whether ``np.dot`` may call it. No kernel calls a BLAS, so the probe is answered "none" here
(the import refused for its duration; ``test_layers.py`` checks that the kernels load without the package
and that it imports afterwards): ``np.dot`` in numba code of this process would loop instead, and scipy
itself still imports wherever it is used.
"""

import sys

from robwot_sim.sim.kernels import load_kernels

_PROBED = "scipy.linalg.cython_blas"
_refused = _PROBED not in sys.modules
if _refused:
    sys.modules[_PROBED] = None  # type: ignore[assignment]  # an import of it raises ImportError
try:
    load_kernels(here=True)
finally:
    if _refused:
        del sys.modules[_PROBED]
