"""Seeded uniform random joint configurations within joint limits, drawn in fixed blocks.

Rows ``[k·BLOCK, (k+1)·BLOCK)`` come from their own generator, seeded by ``SeedSequence(seed,
spawn_key=(k,))`` (numpy's ``SeedSequence(seed).spawn(...)[k]``). Any range of rows can therefore be drawn
on its own, by any process (a local worker, a Ray task on another machine), and the rows are the same as in
one draw of all samples: the split of the work never changes the answer.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from robwot_sim.errors import InvalidParams

FloatArray = npt.NDArray[np.float64]


BLOCK = 1000


def sample_configurations(lower: npt.ArrayLike, upper: npt.ArrayLike, samples: int, seed: int,
                          start: int = 0) -> FloatArray:
    """Rows ``start .. start + samples - 1`` of the configurations for ``seed``, ``(samples, dof)``, drawn
    uniformly in ``[lower, upper]`` per joint.

    Limits are in rad (revolute/continuous) or m (prismatic), in the robot's ``controllable`` order.
    The same ``seed`` always gives the same rows (numpy ``PCG64`` per block of ``BLOCK`` rows, see the
    module docstring), whatever ``start`` and ``samples`` split them.
    """
    lo = np.asarray(lower, dtype=np.float64).reshape(-1)
    hi = np.asarray(upper, dtype=np.float64).reshape(-1)
    if lo.shape != hi.shape:
        raise InvalidParams("lower and upper limits differ in length", param="limits",
                            expected=len(lo), got=len(hi))
    for i, (a, b) in enumerate(zip(lo, hi, strict=True)):
        if not (math.isfinite(a) and math.isfinite(b)) or a > b:
            raise InvalidParams(f"joint {i}: limits [{a}, {b}] are not a finite interval",
                                param="limits", expected="finite lower <= upper", got=[float(a), float(b)])
    if isinstance(samples, bool) or not isinstance(samples, int) or samples < 1:
        raise InvalidParams("samples must be a positive integer", param="samples", expected="integer >= 1",
                            got=samples)
    if isinstance(start, bool) or not isinstance(start, int) or start < 0:
        raise InvalidParams("start must be an integer >= 0", param="start", expected="integer >= 0",
                            got=start)
    stop = start + samples
    first, last = start // BLOCK, (stop - 1) // BLOCK
    u = np.empty((samples, lo.size))
    for k in range(first, last + 1):
        r0, r1 = max(start, k * BLOCK), min(stop, (k + 1) * BLOCK)
        rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(k,)))
        block = rng.random((BLOCK, lo.size))
        u[r0 - start:r1 - start] = block[r0 - k * BLOCK:r1 - k * BLOCK]
    return lo + u * (hi - lo)
