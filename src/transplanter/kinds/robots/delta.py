"""The rotary delta of seed 002 (Zhao, Cheng, Dong, Ma, Xiong and Tong 2022): three
reducer-geared servo arms, pulse-train drives, the controller's B-spline transfers."""

from transplanter.kinds.interfaces import ALL

NAME = "delta"
SUMMARY = "rotary delta on pulse-train AC servos with quintic B-spline transfers (seed 002)"
KINEMATICS = "transplanter.machine.kinematics.delta:DeltaKinematics"
SCENE = "transplanter.scene.robots.delta"
MODEL = "delta"
CONTROLLER = "delta"
READS = {
    "delta": ALL,  # geometry, joint window, drives
    # the controller's planner and end-effector limit; its lines' grid, acceleration and
    # point time are the job's (the job section's segment_mm, path_accel_mm_s2, point_time_us)
    "motion": ("planner", "ee_accel_limit_mm_s2"),
}
