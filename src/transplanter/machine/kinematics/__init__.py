"""Arm kinematics, one module per arm."""
