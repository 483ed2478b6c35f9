"""The five-bar's measured MuJoCo joint speeds and arm motor torques against the limits its
``bspline5`` transfers are planned under (docs/planner.md, "The five-bar").

Runs one paper trial with an observer that reads the arm's and Z's joint speeds and the arm
motors' torques (the actuators' forces, N m at the motor shafts) every physics step, and
prints, per joint, the largest measured speed over the whole trial after homing, the largest
during the transfers (``to_drop`` lines) and the declared limit; per arm motor, the largest
torque after homing and during the transfers, raw and through the 5 ms lag of the trial's
motor meter (transplanter.twin.motors), against the torque limit and the lumped model's
peak over the planned transfers (FiveBarKinematics.inverse_dynamics).

    python scripts/fivebar_spline_speeds.py [--seed 31] [--seedlings 10] [--planner bspline5]
        [--timestep-ms 1]
"""

from __future__ import annotations

import argparse
import math

import numpy as np
from scipy.signal import lfilter

from transplanter.machine.pgf import LinePhase
from transplanter.machine.planner_via import plan_via_move
from transplanter.machine.spline_motion import spline_limits
from transplanter.scenario.assemble import assemble
from transplanter.scenario.schema import load_scenario
from transplanter.twin.motors import PEAK_TIME_CONSTANT_S
from transplanter.twin.trial import run_trial

JOINTS = ("theta1", "theta2", "z")
ARMS = ("theta1", "theta2")


class _Speeds:
    """Every physics step's joint speeds after homing, and whether a transfer runs."""

    def __init__(self) -> None:
        self.rows: list[tuple[float, bool, np.ndarray]] = []
        self.in_transfer = False
        self.homed = False

    def attach(self, twin, records) -> None:
        m = twin.model
        self.dofs = [int(m.jnt_dofadr[m.joint(n).id]) for n in JOINTS]
        self.actuators = [int(m.actuator(n).id) for n in ARMS]
        self.torques: list[np.ndarray] = []
        self.arm_qpos = [int(m.jnt_qposadr[m.joint(n).id]) for n in ARMS]
        self.angles: list[np.ndarray] = []
        self.phases: list[str] = []
        self.phase = ""
        twin.line_listeners.append(self.on_line)

    def on_line(self, event) -> None:
        line = event.line
        if line.phase == LinePhase.TO_START and line.reply is not None:
            self.homed = True
        if line.reply is None and line.phase not in (LinePhase.DROP_ELBOW, LinePhase.RETRACT):
            self.phase = str(line.phase)  # the move under way (the wrist's and M720 lines
            # are answered at once, the spline G0 after them)
        if line.phase == LinePhase.TO_DROP:
            self.in_transfer = line.reply is None  # sent: running; acknowledged: done

    def step(self, twin) -> None:
        if self.homed:
            self.rows.append((twin.time, self.in_transfer, twin.data.qvel[self.dofs].copy()))
            self.torques.append(twin.data.actuator_force[self.actuators].copy())
            self.angles.append(twin.data.qpos[self.arm_qpos].copy())
            self.phases.append(self.phase)

    def finish(self, twin, interrupted) -> None:
        pass

    def abort(self) -> None:
        pass


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=31)
    parser.add_argument("--seedlings", type=int, default=10)
    parser.add_argument("--planner", default="bspline5", choices=("lines", "bspline5"))
    parser.add_argument("--timestep-ms", type=float, default=1.0)
    args = parser.parse_args()
    overrides = {
        "motion.planner": args.planner,
        "scenario.seed": args.seed,
        "scenario.seedlings": args.seedlings,
        "physics.timestep_ms": args.timestep_ms,
    }
    scenario = load_scenario("paper", overrides)
    config = assemble(scenario)
    kin = config.machine.sgf.kinematics
    speeds = _Speeds()
    result = run_trial(config, observers=[speeds])
    t = np.array([r[0] for r in speeds.rows])
    transfer = np.array([r[1] for r in speeds.rows])
    qvel = np.array([r[2] for r in speeds.rows])
    cycle = float(np.mean(result.cycle_times))
    print(
        f"paper, seed {args.seed}, {args.seedlings} seedlings, {args.planner}, dt "
        f"{args.timestep_ms:g} ms: success {result.successes}/{result.seedlings}, cycle "
        f"{cycle:.3f} s, {t.size} steps after homing ({transfer.sum()} in transfers)"
    )
    scale = (math.degrees(1.0),) * 2 + (1e3,)
    units = ("deg/s", "deg/s", "mm/s")
    for j, name in enumerate(JOINTS):
        limit = kin.joint_speed_limits[j] * scale[j]
        whole = np.abs(qvel[:, j]).max() * scale[j]
        during = np.abs(qvel[transfer, j]).max(initial=0.0) * scale[j]
        print(
            f"{name}: measured peak {whole:.1f} {units[j]} (transfers {during:.1f}), "
            f"declared limit {limit:.1f} {units[j]} ({whole / limit:.0%})"
        )
    torque = np.array(speeds.torques)
    alpha = -math.expm1(-args.timestep_ms * 1e-3 / PEAK_TIME_CONSTANT_S)
    lagged = lfilter([alpha], [1.0, alpha - 1.0], torque, axis=0)
    planned = np.zeros(2)
    plans = []
    if args.planner == "bspline5":
        limits = spline_limits(kin, config.machine.sgf.motion)
        e = config.machine.eeprom
        for p in e.pickups:
            points = [[*p.grip_xy_m, e.z_up_m], [*p.approach_xy_m, e.z_up_m]]
            plan = plan_via_move(kin, np.array([*points, [*e.drop_xy_m, e.z_up_m]]), limits)
            plans.append(plan)
            planned = np.maximum(planned, plan.peaks["torque"].max(axis=0))
    for j, name in enumerate(ARMS):
        print(
            f"{name} motor: measured peak {np.abs(torque[:, j]).max():.4f} N m after homing "
            f"(t = {t[np.argmax(np.abs(torque[:, j]))]:.3f} s, "
            f"{speeds.phases[int(np.argmax(np.abs(torque[:, j])))]}) "
            f"({np.abs(lagged[:, j]).max():.4f} through the 5 ms lag), in the transfers "
            f"{np.abs(torque[transfer, j]).max(initial=0.0):.4f} "
            f"({np.abs(lagged[transfer, j]).max(initial=0.0):.4f}); planned transfers' "
            f"lumped peak {planned[j]:.4f} N m; limit {kin.arm_torque_limit_nm:g} N m"
        )
    if plans:
        _against_the_plans(kin, plans, t, transfer, np.array(speeds.angles), torque, args)


def _against_the_plans(kin, plans, t, transfer, angles, torque, args) -> None:
    """Each transfer's measured motor torques, averaged over 20 ms (the rotors ring on their
    fields at a few hundred Hz), against the lumped model along its plan (the plan whose start
    is nearest the arms' angles, aligned in time by least squares within 40 ms)."""
    dt = args.timestep_ms * 1e-3
    window = max(int(round(0.020 / dt)), 1)
    kernel = np.ones(window) / window
    edges = np.flatnonzero(np.diff(np.concatenate([[0], transfer.astype(int), [0]])))
    worst, peaks_avg, rms = 0.0, np.zeros(2), []
    for start, stop in zip(edges[::2], edges[1::2], strict=True):
        starts = np.array([p.nodes[0][:2] for p in plans])
        plan = plans[int(np.argmin(np.abs(starts - angles[start]).sum(axis=1)))]
        spline = plan.spline()
        best = None
        for lag in range(int(0.040 / dt)):
            tau = t[start + lag : stop] - t[start + lag]
            inside = tau <= plan.total_s
            if inside.sum() < window:
                break
            tt = tau[inside]
            q, qd, qdd = (spline(tt, nu=k)[:, :2] for k in range(3))
            lumped = kin.inverse_dynamics(q, qd, qdd)
            seg = torque[start + lag : stop][inside]
            smooth = np.column_stack(
                [np.convolve(seg[:, j], kernel, mode="same") for j in range(2)]
            )
            err = float(np.sqrt(np.mean((smooth - lumped) ** 2)))
            if best is None or err < best[0]:
                best = (err, np.abs(smooth - lumped).max(), np.abs(smooth).max(axis=0))
        rms.append(best[0])
        worst = max(worst, best[1])
        peaks_avg = np.maximum(peaks_avg, best[2])
    print(
        f"{len(rms)} transfers: measured torque averaged over 20 ms peaks at "
        f"{peaks_avg[0]:.4f} / {peaks_avg[1]:.4f} N m; against the lumped model along the "
        f"plan: rms difference {np.mean(rms):.4f} N m (worst transfer {max(rms):.4f}), "
        f"largest {worst:.4f} N m"
    )


if __name__ == "__main__":
    main()
