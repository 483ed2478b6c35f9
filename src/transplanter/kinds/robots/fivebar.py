"""The five-bar of seed 000 (Rahul, Raheman and Paradkar 2020): a planar 5R arm on a
lead-screw Z slide, three NEMA17 steppers, the paper's PGF/SGF firmware."""

from transplanter.kinds.interfaces import ALL

NAME = "fivebar"
SUMMARY = "closed-chain five-bar on a lead-screw Z slide, stepper-driven (seed 000)"
KINEMATICS = "transplanter.machine.kinematics.fivebar:FiveBarKinematics"
SCENE = "transplanter.scene.robots.fivebar"
MODEL = "fivebar"
CONTROLLER = "sgf"
READS = {
    "arm": ALL,  # its links and working mode
    "limits": ALL,  # the reach check at every interpolated point
    "drives": ALL,  # the steppers, their torque law, switches and homing
    "motion": ALL,  # the SGF's lines (Bresenham grid, profile, IK time) and the planner
    "recovery": ALL,  # the drivers' stall detection, the PGF's re-homes
    "faults": ALL,  # faults injected into its switches, motors and bus
}
