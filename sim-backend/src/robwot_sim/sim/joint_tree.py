"""A robot's joint tree as the compiled kernels take it (``sphere_kernel.py`` says what each array holds),
built from a parsed URDF once per robot body, and the frames it places at a configuration."""

from __future__ import annotations

from collections import deque
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt

from robwot_sim.model.couplings import Coupling
from robwot_sim.model.fk import chain_joint
from robwot_sim.model.joints import JointInfo
from robwot_sim.model.rotations import quat_matrix
from robwot_sim.sim.types import FloatArray

KINDS = {"fixed": 0, "revolute": 1, "continuous": 1, "prismatic": 2}

IntArray = npt.NDArray[np.int64]


class Tree(NamedTuple):
    parent: IntArray
    kind: IntArray
    origin_p: FloatArray
    origin_r: FloatArray
    axis: FloatArray
    coupling: FloatArray
    offset: FloatArray
    base_p: FloatArray
    base_r: FloatArray


def joint_tree(joints: list[JointInfo], controllable: list[str], couplings: list[Coupling],
               base_position: Any, base_orientation: Any) -> tuple[Tree, dict[str, int]] | None:
    """A parsed URDF's joint tree as the kernel takes it (``sphere_kernel.Tree``) and the joint whose child
    is each link; None when a joint is of a kind the kernel does not move."""
    if any(j.type not in KINDS for j in joints):
        return None
    children: dict[str, list[JointInfo]] = {}
    for j in joints:
        children.setdefault(j.parent, []).append(j)
    todo = deque(sorted({j.parent for j in joints} - {j.child for j in joints}))
    order: list[JointInfo] = []
    while todo:
        for j in children.get(todo.popleft(), []):
            order.append(j)
            todo.append(j.child)
    index = {n: i for i, n in enumerate(controllable)}
    rules = {c.follower: c for c in couplings}
    joint_of = {j.child: k for k, j in enumerate(order)}
    moved = [chain_joint(j, index, rules) for j in order]
    n = len(order)
    coupling = np.zeros((n, len(controllable)))
    for k, cj in enumerate(moved):
        for i, f in cj.terms:
            coupling[k, i] += f
    tree = Tree(np.array([joint_of.get(j.parent, -1) for j in order], dtype=np.int64),
                np.array([KINDS[j.type] for j in order], dtype=np.int64),
                np.array([j.origin_xyz for j in order], dtype=np.float64).reshape(n, 3),
                np.array([cj.origin_rot for cj in moved], dtype=np.float64).reshape(n, 3, 3),
                np.array([j.axis for j in order], dtype=np.float64).reshape(n, 3), coupling,
                np.array([cj.offset for cj in moved], dtype=np.float64),
                np.asarray(base_position, dtype=np.float64).reshape(3), quat_matrix(base_orientation))
    return tree, joint_of


def tree_frames(tree: Tree, q: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Every joint's frame (positions (n + 1, 3), rotations (n + 1, 3, 3); the last: the root's)."""
    n = len(tree.parent)
    from robwot_sim.sim.sphere_kernel import frames

    p, r = np.empty((n + 1, 3)), np.empty((n + 1, 3, 3))
    frames(tree, np.asarray(q, dtype=np.float64), p, r)
    return p, r


def ancestors(tree: Tree, frame: int) -> list[int]:
    """Joint ``frame`` and its ancestors, nearest first (the root's frame: none)."""
    out = []
    while 0 <= frame < len(tree.parent):
        out.append(frame)
        frame = int(tree.parent[frame])
    return out
