"""Write models/delta/delta.xml: the rotary delta of Zhao et al. 2022 drawn in its `home`
pose, every number from DeltaKinematics() (the [delta] scenario defaults) and the pure
kinematics (transplanter.machine.kinematics.delta).

Run: .venv/bin/python scripts/make_delta_model.py          (rewrites the file)
     .venv/bin/python scripts/make_delta_model.py --check  (exit status 1 if it is stale)

The model is drawn at the home pose (the platform centre HOME_POINT_M below the base): each
arm's hinge has ref = its home angle, so a hinge's qpos is the paper's q_i (below the base plane
positive) and qpos0 is the home keyframe, whose chains close by construction. Each follower is
a parallelogram of two rods, each hung from its elbow on a universal joint (two hinges, the
first along the arm's hinge axis) and tied to the platform by a site-to-site `connect`
equality (a ball joint); the platform is a free body held only by the six rods. The meshes
(assets/) are written by scripts/make_meshes.py. tests/test_delta_model.py checks that the
file is what this script writes (`same_model`: the numbers to their last bits, which numpy's
matrix products leave to the CPU's BLAS kernel).
"""

from __future__ import annotations

import math
import re
import sys
from pathlib import Path

import numpy as np

from transplanter.machine.kinematics.delta import ARM_ANGLES_RAD, DeltaKinematics

MODEL = Path(__file__).resolve().parent.parent / "models" / "delta" / "delta.xml"

HOME_POINT_M = (0.0, 0.0, -0.800)
"""Platform centre at the home keyframe: on the axis, at the paper's working height."""
ROD_SPACING_M = 0.080
"""Distance between the two rods of a parallelogram (an estimate)."""
ROD_RADIUS_M = 0.006
UPPER_ARM_RADIUS_M = 0.015
PLATFORM_RADIUS_M = 0.075
"""The platform disc (collision cylinder); the followers end at the kinematic radius r."""
PLATFORM_HALF_HEIGHT_M = 0.010
SERVO_STIFFNESS_NM_PER_DEG = 120.0
"""Position-loop stiffness at the joint (the default 12 N m torque limit at 0.1 deg of error)."""
SERVO_RADIUS_M = 0.045
SERVO_HALF_LENGTH_M = 0.060


def fmt(*values) -> str:
    """Numbers as MJCF text: the shortest repr that parses back to the same double."""
    out = []
    for v in values:
        v = float(v)
        if v == 0.0:
            v = 0.0  # no "-0"
        text = repr(v)
        out.append(text[:-2] if text.endswith(".0") else text)
    return " ".join(out)


def rot_z(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def rot_y(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def quat(m: np.ndarray) -> np.ndarray:
    """Unit quaternion (w, x, y, z) of a rotation matrix."""
    w = math.sqrt(max(0.0, 1.0 + m[0, 0] + m[1, 1] + m[2, 2])) / 2.0
    x = math.copysign(
        math.sqrt(max(0.0, 1.0 + m[0, 0] - m[1, 1] - m[2, 2])) / 2.0, m[2, 1] - m[1, 2]
    )
    y = math.copysign(
        math.sqrt(max(0.0, 1.0 - m[0, 0] + m[1, 1] - m[2, 2])) / 2.0, m[0, 2] - m[2, 0]
    )
    z = math.copysign(
        math.sqrt(max(0.0, 1.0 - m[0, 0] - m[1, 1] + m[2, 2])) / 2.0, m[1, 0] - m[0, 1]
    )
    return np.array([w, x, y, z])


CLOSEUP_M = ((0.0, -0.26, -0.05), (0.0, 0.0, -0.11), 40)
"""The camera `claws_closeup` on the platform (platform frame: position, the point looked at,
vertical field of view deg): the effector under it, from the side, for `transplanter render`.
The world's cameras are the scene's (transplanter.scene.delta_scene.add_cameras)."""


def look_at(pos, target) -> np.ndarray:
    """A camera's xyaxes looking from `pos` at `target`, its x axis level."""
    forward = np.asarray(target, float) - np.asarray(pos, float)
    forward /= np.linalg.norm(forward)
    x = np.cross(forward, [0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    y = np.cross(x, forward)
    return np.round(np.concatenate([x, y]), 4) + 0.0


def camera(name: str, pos, target, fovy: float, indent: str) -> str:
    return (
        f'{indent}<camera name="{name}" pos="{fmt(*pos)}" xyaxes="{fmt(*look_at(pos, target))}" '
        f'fovy="{fmt(fovy)}"/>'
    )


def xml(kin: DeltaKinematics | None = None) -> str:
    """The text of delta.xml for a delta (default: DeltaKinematics(), the scenario defaults)."""
    kin = kin or DeltaKinematics()
    g, lim, m = kin.geometry, kin.limits, kin.masses
    drive = kin.drives[0]
    gear = drive.ratio
    home_point = np.array(HOME_POINT_M)
    q_home = kin.joints(home_point)
    assert np.isfinite(q_home).all() and kin.check(home_point).ok.all()
    assert np.ptp(q_home) < 1e-12  # the symmetric point: equal angles
    torque = kin.joint_torque_limit_nm
    kp = SERVO_STIFFNESS_NM_PER_DEG / math.radians(1.0) / gear**2  # joint stiffness / gear^2
    armature = m.rotor_inertia_kgm2 * gear**2
    rod_mass = m.forearm_kg / 2.0
    arms, sites, equalities, servos = [], [], [], []
    half = ROD_SPACING_M / 2.0
    for i, (phi, q) in enumerate(zip(ARM_ANGLES_RAD, q_home, strict=True), start=1):
        frame = rot_z(phi) @ rot_y(q)  # arm frame: x along the arm, y its hinge axis
        e = np.array([math.cos(phi), math.sin(phi), 0.0])
        t = np.array([-math.sin(phi), math.cos(phi), 0.0])
        joint_pos = g.base_radius_m * e
        ends = np.concatenate(
            [joint_pos - SERVO_HALF_LENGTH_M * t, joint_pos + SERVO_HALF_LENGTH_M * t]
        )
        servos.append(f"""
      <geom name="servo{i}" class="visual" type="cylinder" size="{fmt(SERVO_RADIUS_M)}"
            fromto="{fmt(*ends)}" material="servo"/>""")
        elbow = joint_pos + frame @ np.array([g.upper_arm_m, 0.0, 0.0])
        follower = home_point + g.platform_radius_m * e - elbow  # C_i - B_i, world
        rod = frame.T @ follower  # in the arm frame
        assert abs(np.linalg.norm(rod) - g.forearm_m) < 1e-12
        second = np.cross(rod, [0.0, 1.0, 0.0])
        second /= np.linalg.norm(second)
        rods = []
        elbow_ends = f"{fmt(g.upper_arm_m, -half, 0)} {fmt(g.upper_arm_m, half, 0)}"
        for side, sign in (("a", 1.0), ("b", -1.0)):
            name = f"rod{i}{side}"
            rods.append(f"""
          <body name="{name}" pos="{fmt(g.upper_arm_m, sign * half, 0)}">
            <joint name="{name}_1" axis="0 1 0" class="rod_joint"/>
            <joint name="{name}_2" axis="{fmt(*second)}" class="rod_joint"/>
            <geom name="{name}" class="rod" fromto="0 0 0 {fmt(*rod)}" mass="{fmt(rod_mass)}"/>
            <site name="{name}_end" pos="{fmt(*rod)}"/>
          </body>""")
            platform_site = g.platform_radius_m * e + sign * half * t
            sites.append(f'      <site name="c{i}{side}" pos="{fmt(*platform_site)}"/>')
            equalities.append(
                f'    <connect name="close{i}{side}" class="delta" site1="{name}_end" '
                f'site2="c{i}{side}"/>'
            )
        arms.append(f"""
      <body name="upper_arm{i}" pos="{fmt(*joint_pos)}" quat="{fmt(*quat(frame))}">
        <joint name="q{i}" class="arm_joint" ref="{fmt(q)}"/>
        <geom name="upper_arm{i}" class="upper_arm" fromto="0 0 0 {fmt(g.upper_arm_m)} 0 0"
              mass="{fmt(m.upper_arm_kg)}"/>
        <geom name="elbow{i}" class="elbow" fromto="{elbow_ends}"
              mass="{fmt(m.elbow_kg)}"/>{"".join(rods)}
      </body>""")
    actuators = "\n".join(
        f'    <position name="q{i}" joint="q{i}" gear="{fmt(gear)}" kp="{fmt(kp)}" '
        f'dampratio="1"\n              forcerange="{fmt(-torque / gear, torque / gear)}" '
        f'ctrlrange="{fmt(gear * lim.q_min_rad, gear * lim.q_max_rad)}"/>'
        for i in (1, 2, 3)
    )
    qpos = []
    for q in q_home:
        qpos += [q, 0.0, 0.0, 0.0, 0.0]  # the arm's hinge, then its two rods' universal joints
    qpos += [*home_point, 1.0, 0.0, 0.0, 0.0]
    ctrl = gear * q_home
    deg = math.degrees
    mm = [fmt(v * 1e3) for v in (g.base_radius_m, g.platform_radius_m, g.upper_arm_m, g.forearm_m)]
    dims = (
        f"R {mm[0]} mm, r {mm[1]} mm, l1 {mm[2]} mm, l2 {mm[3]} mm,\n  q in "
        f"[{fmt(deg(lim.q_min_rad))}, {fmt(deg(lim.q_max_rad))}] deg"
    )
    home = (
        f"the platform centre at ({fmt(*(home_point * 1e3))}) mm,\n  all three arms at "
        f"q = {deg(q_home[0]):.4f} deg"
    )
    stiffness = fmt(SERVO_STIFFNESS_NM_PER_DEG)
    return f"""<!--
  Rotary delta robot for removing and replenishing plug seedlings (Zhao, Cheng, Dong, Ma,
  Xiong, Tong, "Research on the End Effector and Optimal Motion Control Strategy for a Plug
  Seedling Transplanting Parallel Robot", Agriculture 2022): the robot only. Frames, joints,
  actuators, the closed chains and where the numbers come from: README.md beside this file;
  scene.xml adds a floor and a light to view it alone.

  Written by scripts/make_delta_model.py from DeltaKinematics() (the [delta] scenario
  defaults, estimates: {dims}) and drawn at the home pose: {home}.
  Do not edit by hand: change the script and run it.
-->
<mujoco model="delta">
  <compiler angle="radian" meshdir="assets" autolimits="true"/>

  <option timestep="0.001" integrator="implicitfast" cone="elliptic" iterations="50"
          tolerance="1e-10"/>

  <asset>
    <mesh name="delta_base" file="delta_base.stl"/>
    <mesh name="delta_platform" file="delta_platform.stl"/>
    <material name="frame" rgba="0.35 0.37 0.4 1"/>
    <material name="carbon" rgba="0.12 0.12 0.13 1"/>
    <material name="aluminium" rgba="0.75 0.77 0.8 1"/>
    <material name="servo" rgba="0.1 0.1 0.1 1"/>
  </asset>

  <default>
    <default class="delta">
      <default class="visual">
        <geom contype="0" conaffinity="0" group="2" density="0"/>
        <default class="upper_arm">
          <geom type="capsule" size="{fmt(UPPER_ARM_RADIUS_M)}" material="carbon"/>
        </default>
        <default class="elbow">
          <geom type="capsule" size="0.008" material="aluminium"/>
        </default>
        <default class="rod">
          <geom type="capsule" size="{fmt(ROD_RADIUS_M)}" material="carbon"/>
        </default>
      </default>
      <!-- collides with the world (bit 1) only, never with the robot's own geoms -->
      <default class="collision">
        <geom contype="2" conaffinity="1" group="3" condim="3" rgba="0.9 0.45 0.1 0.4"/>
      </default>
      <default class="arm_joint">
        <joint type="hinge" axis="0 1 0" range="{fmt(lim.q_min_rad, lim.q_max_rad)}" damping="0.05"
               armature="{fmt(armature)}"/>
      </default>
      <default class="rod_joint">
        <joint type="hinge" damping="0.001"/>
      </default>
      <site size="0.004" group="4"/>
      <equality solref="0.002 1" solimp="0.99 0.999 0.0001"/>
    </default>
  </default>

  <worldbody>
    <!-- the static platform: the paper's base frame (origin O, Z up); arm i's hinge at radius
         R on the direction phi_i = 0, 120, 240 deg, its axis tangential -->
    <body name="base" childclass="delta">
      <geom name="base" class="visual" type="mesh" mesh="delta_base" material="frame"/>
      <geom name="base_collision" class="collision" type="cylinder" size="0.26 0.01" pos="0 0 0.02"
            mass="20"/>
{"".join(servos)}{"".join(arms)}
    </body>

    <!-- the moving platform, held only by the six rods' connect equalities -->
    <body name="platform" pos="{fmt(*home_point)}" childclass="delta">
      <freejoint name="platform"/>
      <geom name="platform" class="collision" type="cylinder"
            size="{fmt(PLATFORM_RADIUS_M, PLATFORM_HALF_HEIGHT_M)}" mass="{fmt(m.platform_kg)}"/>
      <geom name="platform_visual" class="visual" type="mesh" mesh="delta_platform"
            material="aluminium"/>
      <site name="tool_centre" pos="0 0 0"/>
{chr(10).join(sites)}
{camera("claws_closeup", *CLOSEUP_M, "      ")}
    </body>
  </worldbody>

  <equality>
{chr(10).join(equalities)}
  </equality>

  <!-- The three servo motors (MINAS A6 class, 750 W) through {fmt(gear)}:1 reducers: position
       loops on the motor shaft, ctrl in motor radians (gear * q), torque-limited so that the
       joint never exceeds {fmt(torque)} N m (the paper's tau_max); stiffness {stiffness} N m/deg
       at the joint. -->
  <actuator>
{actuators}
  </actuator>

  <!-- home: the platform centre at ({fmt(*(home_point * 1e3))}) mm. qpos per arm: q_i, then the
       universal joints of rods a and b (0: drawn in this pose); then the platform's free
       joint. ctrl: the motor angles gear * q_i. -->
  <keyframe>
    <key name="home" qpos="{fmt(*qpos)}"
         ctrl="{fmt(*ctrl)}"/>
  </keyframe>
</mujoco>
"""


NUMBER = re.compile(r"-?\d+(?:\.\d+)?(?:e-?\d+)?")


def same_model(committed: str, written: str) -> bool:
    """The same text and the same numbers but in their last bits: the rotations go through
    numpy's matrix products, whose last bit depends on the CPU's BLAS kernel."""
    if NUMBER.split(committed) != NUMBER.split(written):
        return False
    a, b = ([float(x) for x in NUMBER.findall(s)] for s in (committed, written))
    return len(a) == len(b) and all(math.isclose(x, y, rel_tol=1e-14, abs_tol=1e-15)
                                    for x, y in zip(a, b, strict=True))  # fmt: skip


def main(argv: list[str]) -> int:
    text = xml()
    if "--check" in argv:
        if not MODEL.exists() or not same_model(MODEL.read_text(), text):
            print(f"{MODEL} is stale: run scripts/make_delta_model.py")
            return 1
        return 0
    MODEL.parent.mkdir(parents=True, exist_ok=True)
    MODEL.write_text(text)
    print(f"wrote {MODEL}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
