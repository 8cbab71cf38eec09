"""Inverse kinematics in the controllable joints' coordinates, for robots whose followers (coupled joints)
lie on the chain to the end link.

PyBullet's IK solves for every movable joint as if each were free, so on a parallel-linkage arm it answers
configurations the linkage cannot take (a passive joint turned on its own). This solver works on the
vectorised FK (``fk.py``), where followers are functions of the controllable joints: damped least squares
with a finite-difference Jacobian, every start solved at once as one batch, each step clipped to the
joint limits. Rotation errors are rotation vectors (``scipy.spatial.transform.Rotation``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.spatial.transform import Rotation

from robwot_sim.model.fk import ChainFK

FloatArray = npt.NDArray[np.float64]

#: finite-difference step of the Jacobian (rad or m)
STEP = 1e-7
#: damping of the least-squares step
DAMPING = 1e-3
#: largest change of one joint in one iteration (rad or m)
MAX_STEP = 0.3
#: iterations per batch of starts
ITERATIONS = 60


@dataclass(frozen=True)
class ChainIkResult:
    """Per start: the joint vector reached, its position error (m) and orientation error (rad)."""

    q: FloatArray
    position_error: FloatArray
    orientation_error: FloatArray


def _errors(fk: ChainFK, q: FloatArray, position: FloatArray,
            rotation: Rotation | None) -> tuple[FloatArray, FloatArray]:
    """Per row: the 3 (position only) or 6 error components and the end poses' rotations."""
    pos, rot = fk.poses(q)
    err = position[None, :] - pos
    if rotation is None:
        return err, rot
    turn = (rotation * Rotation.from_matrix(rot).inv()).as_rotvec()
    return np.hstack([err, turn]), rot


def solve_chain_ik(fk: ChainFK, position: FloatArray, rotation: Rotation | None, starts: FloatArray,
                   lower: FloatArray, upper: FloatArray,
                   stop: Callable[[FloatArray, FloatArray], bool] | None = None) -> ChainIkResult:
    """Damped least squares from every row of ``starts`` at once, within ``[lower, upper]``. ``stop``
    (position and orientation errors of every row) ends the iterations early when it answers True."""
    q = np.clip(np.array(starts, dtype=np.float64), lower, upper)
    n, dof = q.shape
    eye = np.eye(dof)
    for _ in range(ITERATIONS):
        err, _ = _errors(fk, q, position, rotation)
        pe, oe = _norms(err)
        if stop is not None and stop(pe, oe):
            break
        probe = (q[:, None, :] + STEP * eye[None, :, :]).reshape(n * dof, dof)
        moved, _ = _errors(fk, probe, position, rotation)
        jac = (err[:, None, :] - moved.reshape(n, dof, -1)) / STEP  # d(pose)/dq: n x dof x m
        jjt = np.einsum("ndm,ndk->nmk", jac, jac) + DAMPING ** 2 * np.eye(err.shape[1])[None]
        dq = np.einsum("ndm,nm->nd", jac, np.linalg.solve(jjt, err[:, :, None])[:, :, 0])
        scale = np.maximum(np.abs(dq).max(axis=1, keepdims=True) / MAX_STEP, 1.0)
        q = np.clip(q + dq / scale, lower, upper)
    err, _ = _errors(fk, q, position, rotation)
    pe, oe = _norms(err)
    return ChainIkResult(q, pe, oe)


def _norms(err: FloatArray) -> tuple[FloatArray, FloatArray]:
    pe = np.linalg.norm(err[:, :3], axis=1)
    oe = np.linalg.norm(err[:, 3:], axis=1) if err.shape[1] > 3 else np.zeros(len(err))
    return pe, oe
