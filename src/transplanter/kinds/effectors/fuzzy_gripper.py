"""Seed 004's two-finger gripper on a hobby servo, set by its fuzzy controller."""

from transplanter.kinds.interfaces import ALL

NAME = "fuzzy_gripper"
SUMMARY = "two-finger servo gripper with an ultrasonic sensor (seed 004)"
SCENE = "transplanter.scene.effectors.fuzzy_gripper"
MODEL = "fuzzy_gripper"
READS = {
    "fuzzy_gripper": ALL,
    "serial4": ("gripper_servo",),  # its servo's class, kept with the arm's servos
}
