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
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from robwot_sim.model.fk import ChainFK

if TYPE_CHECKING:
    from scipy.spatial.transform import Rotation

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
    from scipy.spatial.transform import Rotation

    turn = (rotation * Rotation.from_matrix(rot).inv()).as_rotvec()
    return np.hstack([err, turn]), rot


def _jacobian(fk: ChainFK, q: FloatArray, err: FloatArray, position: FloatArray,
              rotation: Rotation | None) -> FloatArray:
    """d(pose)/dq of every row of ``q`` (its errors ``err``) by finite differences: n x dof x m."""
    n, dof = q.shape
    probe = (q[:, None, :] + STEP * np.eye(dof)[None, :, :]).reshape(n * dof, dof)
    moved, _ = _errors(fk, probe, position, rotation)
    out: FloatArray = (err[:, None, :] - moved.reshape(n, dof, -1)) / STEP
    return out


def solve_chain_ik(fk: ChainFK, position: FloatArray, rotation: Rotation | None, starts: FloatArray,
                   lower: FloatArray, upper: FloatArray,
                   stop: Callable[[FloatArray, FloatArray], bool] | None = None) -> ChainIkResult:
    """Damped least squares from every row of ``starts`` at once, within ``[lower, upper]``. ``stop``
    (position and orientation errors of every row) ends the iterations early when it answers True."""
    q = np.clip(np.array(starts, dtype=np.float64), lower, upper)
    for _ in range(ITERATIONS):
        err, _ = _errors(fk, q, position, rotation)
        pe, oe = _norms(err)
        if stop is not None and stop(pe, oe):
            break
        jac = _jacobian(fk, q, err, position, rotation)
        jjt = np.einsum("ndm,ndk->nmk", jac, jac) + DAMPING ** 2 * np.eye(err.shape[1])[None]
        dq = np.einsum("ndm,nm->nd", jac, np.linalg.solve(jjt, err[:, :, None])[:, :, 0])
        scale = np.maximum(np.abs(dq).max(axis=1, keepdims=True) / MAX_STEP, 1.0)
        q = np.clip(q + dq / scale, lower, upper)
    err, _ = _errors(fk, q, position, rotation)
    pe, oe = _norms(err)
    return ChainIkResult(q, pe, oe)


#: weight of the distance from the previous joints in a tracked solve (``track_chain_ik``)
TRACK_PRIOR = 1e-6
#: largest change of one joint in one iteration of a tracked solve (rad or m)
TRACK_STEP = 0.05
#: iterations of a tracked solve
TRACK_ITERATIONS = 40


def track_chain_ik(fk: ChainFK, position: FloatArray, rotation: Rotation | None, seed: FloatArray,
                   lower: FloatArray, upper: FloatArray, tolerance: tuple[float, float]) -> ChainIkResult:
    """The joints nearest ``seed`` that put the end link at the pose: Levenberg-Marquardt on the pose
    error plus ``TRACK_PRIOR`` x the squared distance from ``seed`` (a redundant arm takes the solution
    nearest the previous one, not any point of its self-motion), small steps, within ``[lower, upper]``;
    stops once the position and orientation errors are within ``tolerance`` (m, rad)."""
    start = np.clip(np.asarray(seed, dtype=np.float64), lower, upper)[None, :]
    q = start.copy()
    dof = q.shape[1]
    for _ in range(TRACK_ITERATIONS):
        err, _ = _errors(fk, q, position, rotation)
        pe, oe = _norms(err)
        if pe[0] <= tolerance[0] and oe[0] <= tolerance[1]:
            break
        jac = _jacobian(fk, q, err, position, rotation)[0]  # dof x m
        lhs = jac @ jac.T + (TRACK_PRIOR + DAMPING**2) * np.eye(dof)
        dq = np.linalg.solve(lhs, jac @ err[0] - TRACK_PRIOR * (q[0] - start[0]))
        dq /= max(1.0, float(np.abs(dq).max()) / TRACK_STEP)
        q = np.clip(q + dq, lower, upper)
    err, _ = _errors(fk, q, position, rotation)
    pe, oe = _norms(err)
    return ChainIkResult(q, pe, oe)


def smallest_singular_value(fk: ChainFK, q: FloatArray, orientation: bool = True) -> float:
    """The smallest singular value of the end link's Jacobian at ``q`` (position rows, m/rad, and with
    ``orientation`` the rotation rows, rad/rad): near 0 at a singularity, where some direction of the end
    link's motion needs joint speeds without bound."""
    row = np.asarray(q, dtype=np.float64)[None, :]
    position, rot = fk.poses(row)
    from scipy.spatial.transform import Rotation

    rotation = Rotation.from_matrix(rot[0]) if orientation else None
    err, _ = _errors(fk, row, position[0], rotation)
    jac = _jacobian(fk, row, err, position[0], rotation)[0]
    return float(np.linalg.svd(jac, compute_uv=False).min())


def _norms(err: FloatArray) -> tuple[FloatArray, FloatArray]:
    pe = np.linalg.norm(err[:, :3], axis=1)
    oe = np.linalg.norm(err[:, 3:], axis=1) if err.shape[1] > 3 else np.zeros(len(err))
    return pe, oe
