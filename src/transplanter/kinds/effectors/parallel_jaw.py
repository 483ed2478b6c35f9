"""Servo parallel jaws with a wrist servo (seed 000's gripper)."""

from transplanter.kinds.interfaces import ALL

NAME = "parallel_jaw"
SUMMARY = "servo parallel jaws under a bridge, with a wrist servo (seed 000)"
SCENE = "transplanter.scene.effectors.parallel_jaw"
MODEL = "parallel_jaw"  # models/effectors/parallel_jaw/, at the robot's mount
READS = {"gripper": ALL}
