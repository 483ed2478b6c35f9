"""Servo parallel jaws with a wrist servo (seed 000's gripper)."""

from transplanter.kinds.interfaces import ALL

NAME = "parallel_jaw"
SUMMARY = "servo parallel jaws under a bridge, with a wrist servo (seed 000)"
SCENE = "transplanter.scene.effectors.parallel_jaw"
MODEL = ""  # drawn in models/fivebar/fivebar.xml
READS = {"gripper": ALL}
