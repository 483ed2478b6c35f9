"""The 4-DOF hobby-servo arm of seed 004 (Dewi, Nurmaini, Risma, Oktarina and Roriz 2020):
analytic IK, four PWM servos, a host that reads two ultrasonic sensors."""

from transplanter.kinds.interfaces import ALL

NAME = "serial4"
SUMMARY = "4-DOF serial arm on hobby PWM servos, analytic IK (seed 004)"
KINEMATICS = "transplanter.machine.kinematics.serial4:Serial4Kinematics"
SCENE = "transplanter.scene.robots.serial4"
MODEL = "serial4"
CONTROLLER = "servo"
READS = {
    "serial4": ALL,  # links, servos, windows
    # its controller's motion and its host's grasp and release (in every job it does)
    "serial_arm": (
        "travel_speed_mm_s",
        "approach_speed_mm_s",
        "path_accel_mm_s2",
        "segment_mm",
        "point_time_us",
        "hover_mm",
        "grip_settle_ms",
        "release_settle_ms",
        "sensor_resolution_mm",
    ),
}
