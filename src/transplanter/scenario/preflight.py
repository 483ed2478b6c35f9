"""Checks a machine's taught points before any simulation starts.

Every taught point must be reachable (kinematics limits, Z range), and every straight line
the PGF will ask for must be reachable at every interpolated point, so a trial never starts
on a program the SGF would reject halfway through. Errors name the scenario key.
"""

from __future__ import annotations

import numpy as np

from transplanter.machine.config import Machine
from transplanter.machine.kinematics import UnreachableError
from transplanter.machine.motion import plan_line
from transplanter.scenario.schema import ScenarioError
from transplanter.units import M_PER_MM

__all__ = [
    "check_program",
    "check_machine",
    "check_pickups_on_cells",
    "check_taught_speeds",
    "check_reply_timeout",
    "check_timestep",
    "longest_line_s",
    "MAX_OMEGA_DT",
    "REPLY_TIMEOUT_MARGIN_S",
]

# The PGF's reply timeout must exceed the longest line by this much (s): the line's and its
# reply's time on the wire and the SGF's planning before the first step.
REPLY_TIMEOUT_MARGIN_S = 1.0

# The steppers' torque laws are stiff springs the integrator takes explicitly (from each
# step's starting state; their damping is implicit): past omega x timestep = 2 the explicit
# (symplectic) Euler step diverges. The convergence study in docs/drives.md: Z, the stiffest
# (1716 rad/s with the paper's drives), has omega x dt = 1.72 at 1 ms, where every outcome
# agrees with 0.5 and 0.25 ms; at 2 ms (3.43) the Z drive rings itself out of step.
MAX_OMEGA_DT = 2.0


# Machines whose program passed in this process (a sweep's worker runs one setting over
# several seeds: the program is the same, the check about 0.1 s of a short trial).
PASSED_CACHE_SIZE = 64
_passed: dict[Machine, None] = {}


def check_program(machine: Machine) -> None:
    """Every check a trial makes of a machine's taught program before it starts (the teach
    pendant runs the same before it writes an image): the points and moves
    (:func:`check_machine`) and the reply timeout against its longest line
    (:func:`check_reply_timeout`). A machine equal to one that passed in this process (the
    last PASSED_CACHE_SIZE) is not checked again: the checks depend on the machine alone."""
    if machine in _passed:
        return
    check_machine(machine)
    check_reply_timeout(machine)
    if len(_passed) >= PASSED_CACHE_SIZE:
        del _passed[next(iter(_passed))]
    _passed[machine] = None


class TaughtRefused(ScenarioError):
    """A taught point or move the SGF would refuse, with what it is: the scenario ``key``, the
    pickup's index (None for the drop point), the ``point`` ('approach', 'grip', 'drop'; None
    for a move) and the kinematics' typed ``refusals``."""

    def __init__(self, message: str, key: str, pickup: int | None, point: str | None, refusals):
        super().__init__(message)
        self.key, self.pickup, self.point = key, pickup, point
        self.refusals = tuple(refusals)

    def short(self, width: int = 17) -> str:
        """The refusal in ``width`` characters (the teach pendant's LCD)."""
        if self.pickup is not None:
            what = f"{self.point[:4]} unreach." if self.point else "move unreach."
            text = f"P{self.pickup + 1} {what}"
        elif self.point is None:
            text = "home>drop unreach"
        else:
            text = "drop unreachable"
        return text[:width]


def check_machine(machine: Machine) -> None:
    """Raise ScenarioError naming the scenario key of the first taught point (as stored in
    the EEPROM image), speed or move that fails."""
    taught = machine.eeprom
    check_taught_speeds(machine)
    z_low, z_up = taught.z_low_m, taught.z_up_m
    points: list[tuple[str, int | None, str, tuple[float, float], float]] = [
        ("taught.drop_mm", None, "drop", taught.drop_xy_m, z_up)
    ]
    for i, p in enumerate(taught.pickups):
        points.append((f"taught.pickup[{i}].approach_mm", i, "approach", p.approach_xy_m, z_low))
        points.append((f"taught.pickup[{i}].grip_mm", i, "grip", p.grip_xy_m, z_low))
    xyz = np.array([(*p[3], p[4]) for p in points])
    report = machine.kinematics.check(xyz)
    for (key, pickup, point, p, _), ok, reason, refusals in zip(
        points, report.ok, report.reasons, report.refusals, strict=True
    ):
        if not ok:
            raise TaughtRefused(
                f"{key} = [{p[0] / M_PER_MM:g}, {p[1] / M_PER_MM:g}] mm cannot be reached: "
                f"{reason}. "
                "Teach a point inside the workspace.",
                key, pickup, point, refusals,
            )  # fmt: skip
    drop = (*taught.drop_xy_m, z_up)
    homed = _homed_xyz(machine)
    _require_line(
        machine,
        homed,
        drop,
        "taught.drop_mm: the first move, from the homed position",
        "Move the drop point or the limit switches (drives.home_*).",
        ("taught.drop_mm", None),
    )
    for i, p in enumerate(taught.pickups):
        approach_low, grip_low = (*p.approach_xy_m, z_low), (*p.grip_xy_m, z_low)
        grip_up, approach_up = (*p.grip_xy_m, z_up), (*p.approach_xy_m, z_up)
        path = [drop, approach_low, grip_low, grip_up, approach_up, drop]
        for a, b in zip(path[:-1], path[1:], strict=True):
            _require_line(
                machine,
                a,
                b,
                f"taught.pickup[{i}]: the move from",
                "Move the approach or grip point.",
                (f"taught.pickup[{i}]", i),
            )
    if machine.pgf.spline_transfer:
        _check_transfers(machine)


def _check_transfers(machine: Machine) -> None:
    """TaughtRefused naming the pickup whose ``bspline5`` transfer (lifted grip point,
    retract point, drop point: ``PGFConfig.spline_transfer``) the SGF would refuse: a limit
    no timing meets, the spline leaving an axis's window or a sampled point the arm's check
    refuses between the taught points (the plans are kept for the trial)."""
    from transplanter.machine.planner_bspline import MoveRefused
    from transplanter.machine.spline_motion import plan_via_transfer

    taught, kinematics = machine.eeprom, machine.kinematics
    z_up = taught.z_up_m
    drop = (*taught.drop_xy_m, z_up)
    for i, p in enumerate(taught.pickups):
        points = np.array([(*p.grip_xy_m, z_up), (*p.approach_xy_m, z_up), drop])
        keep = np.append(True, np.linalg.norm(np.diff(points, axis=0), axis=1) >= 1e-6)
        points = points[keep]
        if len(points) < 2:
            continue
        steps = kinematics.steps_of_point(points[0])
        refusals: tuple = ()
        try:
            plan_via_transfer(steps, points, kinematics, machine.motion)
            continue
        except MoveRefused as exc:
            why = f"({exc.limit}) {exc}"
        except UnreachableError as exc:
            why, refusals = str(exc), exc.refusals
        raise TaughtRefused(
            f"taught.pickup[{i}]: the bspline5 transfer {_mm(points[0])} via "
            f"{_mm(points[1])} to {_mm(drop)} mm is refused: {why}. Move the approach or "
            "grip point, or use motion.planner = 'lines'.",
            f"taught.pickup[{i}]", i, None, refusals,
        )  # fmt: skip


def check_pickups_on_cells(machine: Machine, scene_config) -> None:
    """The taught pickups are the pickup row's cells: one pickup per cell of the row
    (conveyor.cols of them), each grip point over its own cell's centre to within half the
    play a pot has between its cell's walls (beyond it the jaws come down on the cell's rib
    or a neighbour's wall, not around the pot). A conveyor of 6 columns under the paper's 5
    pickups passed every other check and then knocked pots over; ScenarioError naming the
    keys otherwise."""
    from transplanter.scene.geometry import cell_columns_x

    pickups = machine.eeprom.pickups
    cols = int(scene_config.cols)
    xs = cell_columns_x(scene_config)
    y_row = float(scene_config.pickup_row_y_m)
    tol = max((scene_config.cell_pitch_m - scene_config.pot_diameter_m) / 2, 1e-3)
    cells = ", ".join(f"{x / M_PER_MM:g}" for x in xs)
    where = (
        f"the pickup row's {cols} cells at x = {cells} mm, y = {y_row / M_PER_MM:g} mm "
        "(conveyor.cols, cell_pitch_mm, pickup_row_y_mm)"
    )
    if len(pickups) != cols:
        raise ScenarioError(
            f"{len(pickups)} pickups are taught ([[taught.pickup]]) for {where}: the PGF picks "
            "its pickups in turn, one per cell of the row, so a cell without a pickup is "
            "never picked and a pickup without a cell closes on air or on the ribs; teach "
            f"one pickup per cell or set conveyor.cols = {len(pickups)}"
        )
    used: dict[int, int] = {}
    for k, pickup in enumerate(pickups):
        x, y = pickup.grip_xy_m
        col = int(np.argmin(np.abs(xs - x)))
        off = float(np.hypot(xs[col] - x, y_row - y))
        if off > tol:
            raise ScenarioError(
                f"taught.pickup[{k}].grip_mm = [{x / M_PER_MM:g}, {y / M_PER_MM:g}] is "
                f"{off / M_PER_MM:.1f} mm from the nearest cell's centre, more than the "
                f"{tol / M_PER_MM:.1f} mm a pot has to its cell's walls ({where}): the jaws "
                "would come down beside the pot; teach it over its cell"
            )
        if col in used:
            raise ScenarioError(
                f"taught.pickup[{used[col]}] and taught.pickup[{k}] both grip at the cell "
                f"x = {xs[col] / M_PER_MM:g} mm ({where}): each pickup its own cell"
            )
        used[col] = k


def check_taught_speeds(machine: Machine) -> None:
    """ScenarioError for a taught speed the SGF can never move at: it solves the kinematics
    of one Bresenham point at a time (motion.compute_time_per_point_us), so no move is
    faster than resolution / compute time (505 mm/s for the paper's ESP32). The firmware
    would run such a program at its own top speed, not the taught one."""
    motion = machine.motion
    cap = motion.point_rate_speed_cap_m_s
    taught = machine.eeprom
    for key, speed in (
        ("taught.s_low_mm_s", taught.s_low_m_s),
        ("taught.s_high_mm_s", taught.s_high_m_s),
    ):
        if speed > cap:
            raise ScenarioError(
                f"{key} = {speed / M_PER_MM:g} is faster than the SGF can move: it solves the "
                f"kinematics of each {motion.resolution_m / M_PER_MM:g} mm point in "
                f"{motion.compute_time_per_point_s * 1e6:g} us "
                "(motion.resolution_mm, motion.compute_time_per_point_us), so no move exceeds "
                f"{cap / M_PER_MM:.0f} mm/s. Teach at most that, or change those two keys "
                "(a faster controller, a coarser grid)."
            )


def _require_line(machine, a, b, what: str, hint: str, where: tuple[str, int | None]) -> None:
    """TaughtRefused '<what> a to b mm leaves the workspace: <reason>. <hint>' if the SGF
    would refuse the straight line from a to b (``where``: the key and pickup index)."""
    try:
        _check_line(machine, a, b)
    except UnreachableError as exc:
        raise TaughtRefused(
            f"{what} {_mm(a)} to {_mm(b)} mm leaves the workspace: {exc.reason}. {hint}",
            where[0], where[1], None, exc.refusals,
        ) from None  # fmt: skip


def _homed_xyz(machine) -> tuple[float, float, float]:
    """Where G28 leaves the machine: the SGF's homed step counters, through its kinematics."""
    sgf = machine.sgf
    x, y, z = sgf.kinematics.point_of_steps(sgf.homed_steps)
    return (float(x), float(y), float(z))


def _check_line(machine, a, b) -> None:
    start = np.asarray(a, dtype=float)
    steps = machine.kinematics.steps_of_point(start)
    speed = machine.eeprom.s_high_m_s
    plan_line(steps, start, np.asarray(b, dtype=float), speed, machine.kinematics, machine.motion)


def longest_line_s(machine: Machine) -> tuple[float, str]:
    """The longest time (s) the SGF may take over one line of the PGF's program, and what
    that line is: a homing that finds each switch at the end of its seek and locate, the
    longest taught move at its speed, a dwell or a conveyor index."""
    sgf, pgf, taught = machine.sgf, machine.pgf, machine.eeprom
    homing = sgf.homing
    seek, locate = np.asarray(homing.rate_hz), np.asarray(homing.locate_rate_hz)
    pulloff, longest = np.asarray(homing.pulloff_steps), np.asarray(homing.max_steps)
    per_motor = (
        longest / seek + 2 * pulloff / seek + np.ceil(homing.locate_scalar * pulloff) / locate
    )
    cycles = homing.cycles
    candidates = [(float(sum(per_motor[c].max() for c in cycles)), "G28 (homing, worst case)")]
    z_low, z_up = taught.z_low_m, taught.z_up_m
    drop = (*taught.drop_xy_m, z_up)
    s_low, s_high = taught.s_low_m_s, taught.s_high_m_s
    moves = [(_homed_xyz(machine), drop, s_high)]
    for p in taught.pickups:
        approach_low, grip_low = (*p.approach_xy_m, z_low), (*p.grip_xy_m, z_low)
        grip_up, approach_up = (*p.grip_xy_m, z_up), (*p.approach_xy_m, z_up)
        moves += [
            (drop, approach_low, s_high), (approach_low, grip_low, s_low),
            (grip_low, grip_up, s_low), (grip_up, approach_up, s_high),
            (approach_up, drop, s_high),
        ]  # fmt: skip
    for a, b, speed in moves:
        start = np.asarray(a, dtype=float)
        steps = sgf.kinematics.steps_of_point(start)
        move = plan_line(
            steps, start, np.asarray(b, dtype=float), speed, machine.kinematics, machine.motion
        )
        candidates.append((move.duration_s, f"the move {_mm(a)} to {_mm(b)} mm"))
    candidates += [
        (pgf.open_dwell_s, "the open dwell (gripper.open_dwell_ms)"),
        (pgf.close_dwell_s, "the close dwell (gripper.close_dwell_ms)"),
        (pgf.release_dwell_s, "the release dwell (gripper.release_dwell_ms)"),
        (sgf.conveyor_index_s, "M710 (conveyor.index_time_s)"),
    ]
    if pgf.stall_recovery:
        candidates.append((pgf.stall_settle_s, "the dwell after a stall (stall_settle_ms)"))
    return max(candidates)


def check_reply_timeout(machine: Machine) -> None:
    """ScenarioError when bus.reply_timeout_s is not longer than the longest line the PGF
    sends (plus REPLY_TIMEOUT_MARGIN_S): the PGF would stop a healthy run with a timeout."""
    timeout = machine.pgf.reply_timeout_s
    duration, what = longest_line_s(machine)
    if timeout < duration + REPLY_TIMEOUT_MARGIN_S:
        raise ScenarioError(
            f"bus.reply_timeout_s = {timeout:g} s is too short: {what} can take {duration:.2f} "
            f"s, and the PGF would stop a healthy run with a bus timeout; use at least "
            f"{duration + REPLY_TIMEOUT_MARGIN_S:.1f} s."
        )


def _mm(p) -> str:
    return "(" + ", ".join(f"{v / M_PER_MM:g}" for v in p) + ")"


def check_timestep(scene_config) -> None:
    """Raise ScenarioError when physics.timestep_ms is too coarse for a stepper's torque law.

    Builds the machine (one conveyor cell is enough: the pots do not load the motors) and
    takes each motor's natural frequency from its small-signal stiffness and its joint's inertia
    (mass matrix at the home keyframe, rotor armature included)."""
    import dataclasses
    import math

    import mujoco

    from transplanter.scene import build_scene

    scene = build_scene(dataclasses.replace(scene_config, rows=1, cols=1), seed=0)
    m = scene.model
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("home").id)
    mujoco.mj_forward(m, d)
    inertia = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, inertia)
    dt = m.opt.timestep
    worst = (0.0, "")
    for a, params in zip(scene.motor_actuators, scene.drives.params, strict=True):
        dof = m.jnt_dofadr[m.actuator_trnid[a, 0]]
        stiffness = params.stiffness_nm_rad * m.actuator_gear[a, 0] ** 2
        omega = math.sqrt(stiffness / inertia[dof, dof])
        worst = max(worst, (omega, m.actuator(a).name))
    omega, name = worst
    if omega * dt >= MAX_OMEGA_DT:
        raise ScenarioError(
            f"physics.timestep_ms = {dt * 1e3:g} is too coarse for the {name} stepper "
            f"(its rotor rings on its field at {omega:.0f} rad/s: omega x timestep = "
            f"{omega * dt:.2f} >= {MAX_OMEGA_DT:g}, where the explicit step of its torque law "
            "diverges and the motor would lose steps the machine does not). Use less than "
            f"{MAX_OMEGA_DT / omega * 1e3:.2f} ms (docs/drives.md, the convergence table)."
        )
