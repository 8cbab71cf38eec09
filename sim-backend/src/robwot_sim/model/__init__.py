"""The robot model layer: what a robot and its geometry are, read from files, below the simulation.

URDF/SRDF/mesh reading and checking, convex decomposition of collision meshes, the joint tree, rotations
and the vectorised forward kinematics. Nothing here imports the simulation (`sim/`), the workspace
generation (`workspace/`) or the RPC layer: they import this.
"""
