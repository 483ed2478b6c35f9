"""Steps per second of the full 40-pot scene: all resting, while the arm works on row 0
(joint targets from the five-bar kinematics), and during a 0.6 s conveyor index; then the
floor under them: the arm swinging (one tree awake, no contact) in the robot model alone and
in the scene built with 1, 4 and 8 rows of pots, best of three runs each.

Run: .venv/bin/python benchmarks/bench_scene.py
     .venv/bin/python benchmarks/bench_scene.py --feet 8 --drive stepper   (pots on feet)
"""

import argparse
import math
import sys
import time
from pathlib import Path

import mujoco
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "src"))
from transplanter.machine.kinematics import fivebar as kinematics  # noqa: E402
from transplanter.scene import (  # noqa: E402
    ConveyorDrive,
    SceneConfig,
    build_scene,
)


def ik(cfg, x, y):
    """Paper working mode (elbows out) IK for a scene config."""
    return kinematics.ik(cfg.geometry(), x, y)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--feet", type=int, default=0, help="SceneConfig.pot_feet")
    parser.add_argument("--drive", default="pd", help="SceneConfig.conveyor_index_drive")
    args = parser.parse_args()
    cfg = SceneConfig(pot_feet=args.feet, conveyor_index_drive=args.drive)
    scene = build_scene(cfg, seed=0)
    model, data = scene.model, scene.make_data()
    conveyor = ConveyorDrive(scene)
    print(f"nq={model.nq} nv={model.nv} ngeom={model.ngeom} nbody={model.nbody}")
    for _ in range(300):
        mujoco.mj_step(model, data)

    n = 5000
    start = time.perf_counter()
    for _ in range(n):
        conveyor.apply(data, data.time)
        mujoco.mj_step(model, data)
    print(
        f"resting: {n / (time.perf_counter() - start):,.0f} steps/s, "
        f"awake trees {data.ntree_awake}/{model.ntree}"
    )

    # Working on row 0: pick the centre pot, lift, move over the neighbours and back.
    y0, z_low = cfg.pickup_row_y_m, 0.032
    t1, t2 = ik(cfg, 0.0, y0 - 0.03)
    scene.set_wrist_angle(data, math.pi / 2 - (t1 + cfg.kinematics().passive_angles(t1, t2)[0]))
    scene.set_gripper_opening(data, 0.041)
    waypoints = [
        (0.0, y0 - 0.03, 0.10),
        (0.0, y0 - 0.03, z_low),
        (0.0, y0, z_low),
        "close",
        (0.0, y0, z_low + 0.05),
        (0.0, 0.14, z_low + 0.05),
        "open",
        (0.0, y0 - 0.03, 0.10),
    ]
    # Joint targets precomputed (the firmware does that per move, not per physics step).
    p = data.site_xpos[scene.grip_site].copy()
    plan, gripper_events = [], {}
    for wp in waypoints:
        if isinstance(wp, str):
            gripper_events[len(plan)] = 0.0 if wp == "close" else 0.041
            plan += [plan[-1]] * 300
            continue
        target = np.array(wp)
        k = max(int(np.linalg.norm(target - p) / 0.05 / model.opt.timestep), 50)
        for i in range(1, k + 1):
            q = p + (target - p) * (i / k)
            plan.append((*ik(cfg, q[0], q[1]), q[2]))
        p = target
    targets = np.array(plan)
    speeds = np.gradient(targets, model.opt.timestep, axis=0)
    awake = np.zeros(len(targets))
    start = time.perf_counter()
    for i, target in enumerate(targets):
        if i in gripper_events:
            scene.set_gripper_opening(data, gripper_events[i])
        scene.hold_motors(data, target, speeds[i])  # the steppers' torque laws
        conveyor.apply(data, data.time)
        mujoco.mj_step(model, data)
        awake[i] = data.ntree_awake
    elapsed = time.perf_counter() - start
    print(
        f"working on row 0: {len(targets) / elapsed:,.0f} steps/s over {len(targets)} steps, "
        f"mean awake trees {awake.mean():.1f}; centre pot in tube: "
        f"{scene.pot_in_tube(data)[2]}; warnings {data.warning.number.sum()}"
    )

    # Conveyor index with the pickup row emptied: every pot of rows 1-7 is pushed (awake).
    for c in range(cfg.cols):
        adr = scene.pot_qpos_adr[c]
        data.qpos[adr : adr + 3] = [0.4 + 0.05 * c, 0.0, -0.13]
    index_s = 0.6
    n = int(round(index_s / model.opt.timestep))
    conveyor.start(data, data.time, index_s)
    awake = np.zeros(n)
    start = time.perf_counter()
    for i in range(n):
        conveyor.apply(data, data.time)
        mujoco.mj_step(model, data)
        awake[i] = data.ntree_awake
    elapsed = time.perf_counter() - start
    print(
        f"conveyor index: {n / elapsed:,.0f} steps/s over {n} steps, "
        f"mean awake trees {awake.mean():.1f}; done: {not conveyor.indexing(data, data.time)}, "
        f"conveyor at {conveyor.position(data) * 1000:.2f} mm; "
        f"warnings {data.warning.number.sum()}"
    )

    print("floor, the arm swinging (theta1 +-0.3 rad at the motor), best of 3:")
    robot = mujoco.MjModel.from_xml_path(str(MODELS / "fivebar" / "fivebar.xml"))
    print(f"  robot alone (models/fivebar/fivebar.xml): {swinging_rate(robot, None):,.0f} steps/s")
    for rows in (1, 4, 8):
        scene = build_scene(SceneConfig(rows=rows, pot_feet=cfg.pot_feet), seed=0)
        ConveyorDrive(scene)  # as a trial: rows past the front drum leave the broadphase
        rate = swinging_rate(scene.model, scene)
        print(f"  scene with {rows} row(s) of pots: {rate:,.0f} steps/s")


MODELS = Path(__file__).resolve().parent.parent / "models"


def swinging_rate(model: mujoco.MjModel, scene, n: int = 20000) -> float:
    """Steps/s with motor 1 swinging its arm (a torque to and fro) and nothing else moving
    (the rest asleep): bare mj_step, no torque law."""
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    motor = 0 if scene is None else int(scene.motor_actuators[0])
    for _ in range(1500):  # the pots settle and fall asleep
        mujoco.mj_step(model, data)
    ctrl0 = data.ctrl.copy()
    swing = 0.05 * np.sin(0.002 * np.arange(n))  # N m at the motor
    best = 0.0
    for _ in range(3):
        start = time.perf_counter()
        for k in range(n):
            data.ctrl[motor] = ctrl0[motor] + swing[k]
            mujoco.mj_step(model, data)
        best = max(best, n / (time.perf_counter() - start))
    return best


if __name__ == "__main__":
    main()
