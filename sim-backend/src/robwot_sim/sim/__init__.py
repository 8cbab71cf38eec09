"""PyBullet simulation core: world, robots, kinematics, collision, motion planning."""
