"""Seeded uniform random joint configurations within joint limits."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from robwot_sim.errors import InvalidParams

FloatArray = npt.NDArray[np.float64]


def sample_configurations(lower: npt.ArrayLike, upper: npt.ArrayLike, samples: int, seed: int) -> FloatArray:
    """``samples`` configurations ``(samples, dof)`` drawn uniformly in ``[lower, upper]`` per joint.

    Limits are in rad (revolute/continuous) or m (prismatic), in the robot's ``controllable`` order.
    The same ``seed`` always gives the same array (numpy ``PCG64`` via ``default_rng``).
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
    rng = np.random.default_rng(seed)
    u = rng.random((samples, lo.size))
    return lo + u * (hi - lo)
