"""The one place where a scenario becomes the configs the twin's parts take.

`assemble(scenario)` maps the typed scenario sections onto the firmware side (`Machine`:
kinematics, drives, motion, SGF, PGF, EEPROM image), the scene (`SceneConfig`), the hobby
servos (`ServoConfig`) and the trial's judge (`JudgeConfig`), builds the Machine once and
(by default) runs the preflight checks. No other module reads scenario sections: a new
scenario key is a field in `transplanter.scenario.schema` plus one line here.
"""

from __future__ import annotations

import dataclasses
import math
import zlib
from dataclasses import dataclass
from typing import Any

from transplanter.kinds import kinematics_class
from transplanter.machine.config import GRIPPER_SERVO, WRIST_SERVO, Machine
from transplanter.machine.eeprom import (
    ANGLE_COUNTS_PER_DEG,
    DATA_SIZE,
    POSITION_COUNTS_PER_M,
    SPEED_COUNTS_PER_M_S,
    EepromImage,
    Pickup,
)
from transplanter.machine.faults import FaultConfig
from transplanter.machine.kinematics import Kinematics, UnknownKind
from transplanter.machine.motion import MotionConfig
from transplanter.machine.pgf import PGFConfig, build_program
from transplanter.machine.sgf import SGFConfig
from transplanter.scenario.schema import Scenario, ScenarioError, TaughtPickup, TaughtSection
from transplanter.scene import SceneConfig
from transplanter.scene import kinds as scene_kinds
from transplanter.units import M_PER_MM

__all__ = [
    "JudgeConfig",
    "ServoConfig",
    "TwinConfig",
    "VisionConfig",
    "assemble",
    "claws_config",
    "fault_config",
    "judge_config",
    "machine_config",
    "plugs_config",
    "scene_config",
    "vision_config",
    "with_eeprom",
]


@dataclass(frozen=True)
class ServoConfig:
    """A hobby servo: rated speed (deg/s); for the gripper, the jaw opening at 180 deg (m)."""

    speed_deg_s: float
    max_opening_m: float | None = None


@dataclass(frozen=True)
class JudgeConfig:
    """How a trial judges each seedling (scenario [metrics]) and the sizes it needs."""

    knocked_offset_m: float
    knocked_tilt_rad: float
    lifted_fraction: float
    between_jaws_m: float
    settle_s: float
    damage_bend_rad: float  # a shoot bent further than this from its pot's axis is damaged
    pot_height_m: float
    cell_pitch_m: float
    row_pitch_m: float


@dataclass(frozen=True)
class TwinConfig:
    """Everything a Twin and a trial need, built once from a scenario."""

    name: str
    seed: int
    seedlings: int
    overrides: tuple[tuple[str, Any], ...]  # the scenario keys set on top of the file
    machine: Machine
    scene: SceneConfig
    gripper_servo: ServoConfig
    wrist_servo: ServoConfig
    judge: JudgeConfig
    faults: FaultConfig = FaultConfig()  # scenario [faults]: none by default


def judge_config(s: Scenario) -> JudgeConfig:
    """The pot line's judge for a scenario ([metrics], the pots' height, the cells' pitches),
    whatever robot works the line."""
    return JudgeConfig(
        knocked_offset_m=s.metrics.knocked_offset_m,
        knocked_tilt_rad=s.metrics.knocked_tilt_rad,
        lifted_fraction=s.metrics.lifted_fraction,
        between_jaws_m=s.metrics.between_jaws_m,
        settle_s=s.metrics.settle_s,
        damage_bend_rad=s.metrics.damage_bend_rad,
        pot_height_m=s.pots.height_m,
        cell_pitch_m=s.conveyor.cell_pitch_m,
        row_pitch_m=s.conveyor.row_pitch_m,
    )


def assemble(scenario: Scenario, preflight: bool = True) -> TwinConfig:
    """The twin's configs for a scenario; with preflight, every taught point and move is
    checked first (ScenarioError naming the key)."""
    require_kinds(
        scenario,
        "the five-bar's pot trial",
        None,
        "parallel_jaw",
        "its jaws are drawn in the five-bar's own model, models/fivebar; the fuzzy gripper "
        "runs on the serial arm (serial_arm, serial_arm_pots), the plug claws on the delta "
        "(delta_refill)",
    )
    machine = machine_config(scenario)
    if preflight:
        from transplanter.scenario.preflight import check_program

        check_program(machine)
    s = scenario
    faults = fault_config(s, machine)
    scene = scene_config(s, machine)
    if preflight:
        from transplanter.scenario.preflight import check_pickups_on_cells, check_timestep

        check_timestep(scene)
        check_pickups_on_cells(machine, scene)
    return TwinConfig(
        name=s.meta.name,
        seed=s.meta.seed,
        seedlings=s.meta.seedlings,
        overrides=s.overrides,
        machine=machine,
        scene=scene,
        gripper_servo=ServoConfig(
            speed_deg_s=60.0 / s.gripper.servo_s_per_60deg,
            max_opening_m=s.gripper.max_opening_m,
        ),
        wrist_servo=ServoConfig(speed_deg_s=60.0 / s.gripper.wrist_servo_s_per_60deg),
        judge=judge_config(s),
        faults=faults,
    )


def _file_unit_config(s: Scenario, section: str, cls: type):
    """A config dataclass whose fields are the file keys of `section` (file units), from the
    scenario's SI values: each key back in its file unit as the user wrote it (rounded to 15
    significant digits, so that 32 mm is 32, not 32.000000000000004); fields that are not
    keys keep their defaults."""
    from transplanter.scenario.schema import SCHEMA, si_key

    keys = SCHEMA[section]
    values = getattr(s, section)
    kwargs = {
        f.name: float(f"{getattr(values, si_key(f.name)) / keys[f.name].scale:.15g}")
        for f in dataclasses.fields(cls)
        if f.name in keys
    }
    return cls(**kwargs)


def plugs_config(s: Scenario):
    """[plugs] as the scene's `PlugsConfig` (the delta's jobs)."""
    from transplanter.scene.plug_substrate import PlugsConfig

    return _file_unit_config(s, "plugs", PlugsConfig)


def claws_config(s: Scenario):
    """[plug_claws] as the scene's `PlugClawsConfig` (the delta's jobs)."""
    from transplanter.scene.effectors.plug_claws import PlugClawsConfig

    return _file_unit_config(s, "plug_claws", PlugClawsConfig)


def delta_sgf_config(s: Scenario, job, kinematics, **extra) -> SGFConfig:
    """The delta's controller for a job's section (`[delta_refill]`, `[delta_pots]`): its
    lines' segmentation, path acceleration and point time, the pick path of `bspline5` and
    the travel speed, with `[motion]`'s planner and end-effector limit; `extra`: SGFConfig's
    other fields (the pot line's conveyor index)."""
    motion = MotionConfig(
        resolution_m=job.segment_m,
        accel_m_s2=job.path_accel_m_s2,
        profile="scurve",
        compute_time_per_point_s=job.point_time_s,
        planner=s.motion.planner,
        ee_accel_limit_m_s2=s.motion.ee_accel_limit_m_s2,
        pick_lift_m=job.lift_m,
        pick_arc_m=job.arc_radius_m,
        pick_exit_m=job.exit_m,
    )
    return SGFConfig(
        kinematics=kinematics,
        motion=motion,
        homing=type(kinematics).homing_from_scenario(s),
        default_speed_m_s=job.travel_speed_m_s,
        command_queue_lines=4,
        **extra,
    )


def fuzzy_gripper_config(s: Scenario):
    """[fuzzy_gripper] as the scene's `FuzzyGripperConfig` (the serial arm's scene), its
    servo class `[serial4] gripper_servo`."""
    from dataclasses import replace

    from transplanter.scene.effectors.fuzzy_gripper import FuzzyGripperConfig

    config = _file_unit_config(s, "fuzzy_gripper", FuzzyGripperConfig)
    return replace(config, servo=s.serial4.gripper_servo)


def fault_config(s: Scenario, machine: Machine) -> FaultConfig:
    """The faults a scenario injects ([faults]); a lost reply beyond the PGF's program (it
    would never happen) is a ScenarioError."""
    f = s.faults
    lines = len(build_program(machine.eeprom, machine.pgf))
    if f.lost_reply_line > lines:
        raise ScenarioError(
            f"faults.lost_reply_line = {f.lost_reply_line}: the PGF sends {lines} lines for "
            f"{machine.pgf.seedlings} seedlings (more only after stall recoveries), so that "
            f"reply is never lost; choose 1-{lines}, or 0 for none."
        )
    try:
        return FaultConfig(
            switch_stuck_closed=f.switch_stuck_closed,
            switch_dead=f.switch_dead,
            jam_motor=f.jam_motor,
            jam_at_s=f.jam_at_s,
            jam_duration_s=f.jam_duration_s,
            jam_torque_nm=f.jam_torque_nm,
            lost_reply_line=f.lost_reply_line,
        )
    except ValueError as exc:
        raise ScenarioError(f"the scenario's [faults]: {exc}") from None


def machine_config(s: Scenario) -> Machine:
    """The firmware side of the machine; a value the firmware refuses is a ScenarioError
    naming the scenario's sections."""
    try:
        return _machine(s)
    except ValueError as exc:
        if isinstance(exc, ScenarioError):
            raise
        raise ScenarioError(
            f"the scenario's [arm], [limits], [drives], [motion], [gripper] or [taught] values "
            f"do not make a working machine: {exc}"
        ) from None


def robot_kinematics(s: Scenario) -> Kinematics:
    """The arm of the scenario's ``[robot] kind``, made by its kinematics class from the
    scenario (the registry in ``transplanter.machine.kinematics``); an unknown kind is a
    ScenarioError naming the known ones."""
    try:
        cls = kinematics_class(s.robot.kind)
    except UnknownKind as exc:
        raise ScenarioError(f"robot.kind: {exc}.") from None
    return cls.from_scenario(s)


def _via_transfers(kinematics: Kinematics) -> bool:
    # imported here: scipy's optimiser is only loaded by a machine that runs splines
    from transplanter.machine.spline_motion import via_transfers

    return via_transfers(kinematics)


def _machine(s: Scenario) -> Machine:
    kinematics = robot_kinematics(s)
    arm_masses = None  # a kinematics kind without a scene module (a test's) has no masses
    if scene_kinds.has_scene("robot", s.robot.kind):
        arm_masses = getattr(scene_kinds.robot(s.robot.kind), "arm_masses", None)
    if arm_masses is None:
        return _machine_of(s, kinematics)
    # The arm's lumped dynamics take the MuJoCo model's masses and inertias (the robot
    # alone, compiled from this scenario's scene config, whose power-on pose comes from a
    # machine without the torque limit) and, at C, the heaviest pot the scenario draws with
    # its shoot.
    from transplanter.scene.build import robot_model

    bare = _machine_of(s, dataclasses.replace(kinematics, arm_torque_limit_nm=None))
    carried = s.pots.mass_max_kg + s.pots.shoot_mass_kg
    masses = arm_masses(robot_model(scene_config(s, bare)), carried)
    return _machine_of(s, dataclasses.replace(kinematics, masses=masses))


def _machine_of(s: Scenario, kinematics: Kinematics) -> Machine:
    mot, grip = s.motion, s.gripper
    motion = MotionConfig(
        resolution_m=mot.resolution_m,
        accel_m_s2=mot.accel_m_s2,
        profile=mot.profile,
        compute_time_per_point_s=mot.compute_time_per_point_s,
        planner=mot.planner,
        ee_accel_limit_m_s2=mot.ee_accel_limit_m_s2,
        carry_accel_limit_m_s2=grip.carry_accel_limit_m_s2,
    )
    sgf = SGFConfig(
        kinematics=kinematics,
        motion=motion,
        homing=type(kinematics).homing_from_scenario(s),
        conveyor_index_s=s.conveyor.index_time_s,
        stall_detection=s.recovery.stall_detection,
    )
    pgf = PGFConfig(
        gripper_servo=GRIPPER_SERVO,
        wrist_servo=WRIST_SERVO,
        gripper_open_deg=math.degrees(grip.open_rad),
        gripper_close_deg=math.degrees(grip.close_rad),
        open_dwell_s=grip.open_dwell_s,
        close_dwell_s=grip.close_dwell_s,
        release_dwell_s=grip.release_dwell_s,
        seedlings=s.meta.seedlings,
        line_numbers=s.bus.line_numbers,
        rehome_every_cycles=s.recovery.rehome_every_cycles,
        stall_recovery=s.recovery.stall_detection,
        stall_retries=s.recovery.stall_retries,
        stall_settle_s=s.recovery.stall_settle_s,
        reply_timeout_s=s.bus.reply_timeout_s,
        spline_transfer=motion.planner == "bspline5" and _via_transfers(kinematics),
    )
    taught = s.taught
    taught_image = EepromImage(
        pickups=tuple(
            Pickup(
                approach_xy_m=p.approach_m,
                grip_xy_m=p.grip_m,
                wrist_deg=math.degrees(p.wrist_rad),
            )
            for p in taught.pickup
        ),
        drop_xy_m=taught.drop_m,
        drop_wrist_deg=math.degrees(taught.drop_wrist_rad),
        z_up_m=taught.z_up_m,
        z_low_m=taught.z_low_m,
        s_low_m_s=taught.s_low_m_s,
        s_high_m_s=taught.s_high_m_s,
    )
    # The PGF works from the EEPROM's bytes, as on the machine: quantised and CRC-checked.
    eeprom = EepromImage.from_bytes(taught_image.to_bytes())
    _check_quantised(taught_image, eeprom)
    return Machine(sgf, pgf, eeprom, s.bus.baud_bps)


TAUGHT_QUANTA = {
    "_mm": 1 / (POSITION_COUNTS_PER_M * M_PER_MM),  # 0.001 mm
    "_mm_s": 1 / (SPEED_COUNTS_PER_M_S * M_PER_MM),  # 0.1 mm/s
    "_deg": 1 / ANGLE_COUNTS_PER_DEG,  # 0.01 deg
}
"""What the EEPROM stores of a taught key, in the key's file unit, by its unit suffix."""


def key_quantum(key: str) -> float | None:
    """The step a scenario key's value must be a whole multiple of ('section.key' in file
    units): the taught keys' EEPROM resolution; None for any other key."""
    if not key.startswith("taught."):
        return None
    for suffix in ("_mm_s", "_mm", "_deg"):  # the longest suffix first
        if key.rsplit(".", 1)[-1].split("[")[0].endswith(suffix):
            return TAUGHT_QUANTA[suffix]
    return None


def _check_quantised(given: EepromImage, stored: EepromImage) -> None:
    """ScenarioError naming the first taught value the EEPROM cannot hold as given (it stores
    micrometres, centidegrees and 0.1 mm/s): the physics must run on the user's value."""
    pairs = [
        ("taught.z_up_mm", given.z_up_m, stored.z_up_m, 1e3, "1 um", 3),
        ("taught.z_low_mm", given.z_low_m, stored.z_low_m, 1e3, "1 um", 3),
        ("taught.s_low_mm_s", given.s_low_m_s, stored.s_low_m_s, 1e3, "0.1 mm/s", 1),
        ("taught.s_high_mm_s", given.s_high_m_s, stored.s_high_m_s, 1e3, "0.1 mm/s", 1),
        ("taught.drop_wrist_deg", given.drop_wrist_deg, stored.drop_wrist_deg, 1, "0.01 deg", 2),
    ]
    for axis, (a, b) in enumerate(zip(given.drop_xy_m, stored.drop_xy_m, strict=True)):
        pairs.append((f"taught.drop_mm[{axis}]", a, b, 1e3, "1 um", 3))
    for k, (p, q) in enumerate(zip(given.pickups, stored.pickups, strict=True)):
        for name, xy, xy_stored in (
            ("approach_mm", p.approach_xy_m, q.approach_xy_m),
            ("grip_mm", p.grip_xy_m, q.grip_xy_m),
        ):
            for axis in (0, 1):
                key = f"taught.pickup[{k}].{name}[{axis}]"
                pairs.append((key, xy[axis], xy_stored[axis], 1e3, "1 um", 3))
        pairs.append((f"taught.pickup[{k}].wrist_deg", p.wrist_deg, q.wrist_deg, 1, "0.01 deg", 2))
    for key, value, kept, scale, quantum, places in pairs:
        if not math.isclose(value, kept, rel_tol=1e-9, abs_tol=1e-12):
            raise ScenarioError(
                f"{key} = {value * scale:.10g} is finer than the EEPROM stores ({quantum}): it "
                f"would run as {kept * scale:.{places}f}; give it with at most {places} decimals"
            )


EEPROM_OVERRIDE = "eeprom"
"""The overrides entry (and so the results' "overrides") of a run from an EEPROM image."""


def with_eeprom(scenario: Scenario, image: EepromImage, source: str) -> Scenario:
    """The scenario with its [taught] section replaced by an EEPROM image's taught data (as
    `transplanter hmi` writes it; `trial --eeprom`), the rest unchanged. The image is recorded
    in the overrides as ``eeprom = "<source> (M_pp N, CRC-32 0x...)"``. ScenarioError if
    --set also sets a taught key, or the image's Z levels break the scenario's rules (inside
    limits.z_min_mm..z_max_mm, Z_up above Z_low); reach is the preflight's to check."""
    clash = sorted(k for k, _ in scenario.overrides if k.startswith("taught."))
    if clash:
        raise ScenarioError(
            f"{', '.join(clash)} and the EEPROM image {source} both set the taught data; "
            "drop the --set or re-teach the image"
        )
    lim = scenario.limits
    for name, value in (("Z_up", image.z_up_m), ("Z_low", image.z_low_m)):
        if not lim.z_min_m <= value <= lim.z_max_m:
            raise ScenarioError(
                f"EEPROM image {source}: {name} = {value * 1e3:g} mm is outside "
                f"[limits.z_min_mm, limits.z_max_mm] = [{lim.z_min_m * 1e3:g}, "
                f"{lim.z_max_m * 1e3:g}] mm"
            )
    if image.z_up_m <= image.z_low_m:
        raise ScenarioError(
            f"EEPROM image {source}: Z_up = {image.z_up_m * 1e3:g} mm must be above Z_low = "
            f"{image.z_low_m * 1e3:g} mm"
        )
    taught = TaughtSection(
        z_up_m=image.z_up_m,
        z_low_m=image.z_low_m,
        s_low_m_s=image.s_low_m_s,
        s_high_m_s=image.s_high_m_s,
        drop_m=image.drop_xy_m,
        drop_wrist_rad=math.radians(image.drop_wrist_deg),
        pickup=tuple(
            TaughtPickup(
                approach_m=p.approach_xy_m, grip_m=p.grip_xy_m, wrist_rad=math.radians(p.wrist_deg)
            )
            for p in image.pickups
        ),
    )
    crc = zlib.crc32(image.to_bytes()[:DATA_SIZE])
    record = f"{source} (M_pp {image.m_pp}, CRC-32 0x{crc:08x})"
    return dataclasses.replace(
        scenario, taught=taught, overrides=(*scenario.overrides, (EEPROM_OVERRIDE, record))
    )


def scene_config(s: Scenario, machine: Machine) -> SceneConfig:
    """The physical parameters of a scenario as the scene builder's config.

    The power-on pose (the `home` keyframe) is machine.power_on_joints: a little short of
    limit switches 1-3, so that G28 has a little way to travel.
    """
    drv, grip, conv, pots, tube, phys = (
        s.drives, s.gripper, s.conveyor, s.pots, s.drop_tube, s.physics,
    )  # fmt: skip
    for group, kind in (
        ("robot", s.robot.kind),
        ("effector", s.effector.kind),
        ("workcell", s.workcell.kind),
    ):
        try:
            getattr(scene_kinds, group)(kind)
        except UnknownKind as exc:
            raise ScenarioError(f"{group}.kind: {exc}.") from None
    try:
        # the robot's own fields (its section, its power-on pose), from its scene module
        robot_fields = scene_kinds.robot(s.robot.kind).scene_fields(s, machine)
        return SceneConfig(
            robot_kind=s.robot.kind,
            effector_kind=s.effector.kind,
            workcell_kind=s.workcell.kind,
            **robot_fields,
            steps_per_rev=drv.steps_per_rev,
            holding_torque_nm=drv.holding_torque_nm,
            rotor_inertia_kgm2=drv.rotor_inertia_kgm2,
            detent_torque_nm=drv.detent_torque_nm,
            pullout_corner_rev_s=drv.pullout_corner_rev_s,
            rotor_damping_ratio=drv.rotor_damping_ratio,
            screw_efficiency=drv.screw_efficiency,
            z_lead_m=drv.z_lead_m,
            gripper_max_opening_m=grip.max_opening_m,
            grip_force_n=grip.grip_force_n,
            bridge_clearance_m=grip.bridge_clearance_m,
            rows=conv.rows,
            cols=conv.cols,
            live_rows=conv.live_rows,
            cell_pitch_m=conv.cell_pitch_m,
            row_pitch_m=conv.row_pitch_m,
            pickup_row_y_m=conv.pickup_row_y_m,
            pot_diameter_m=pots.diameter_m,
            pot_diameter_sd_m=pots.diameter_sd_m,
            pot_height_m=pots.height_m,
            pot_height_sd_m=pots.height_sd_m,
            pot_mass_kg=pots.mass_kg,
            pot_mass_sd_kg=pots.mass_sd_kg,
            pot_friction=pots.friction,
            pot_friction_sd=pots.friction_sd,
            pot_offset_sd_m=pots.placement_sd_m,
            pot_offset_max_m=pots.placement_max_m,
            pot_mass_range_kg=(pots.mass_min_kg, pots.mass_max_kg),
            pot_bond_share=pots.bond_share,
            pot_bond_force_n=pots.bond_force_n,
            pot_bond_sd_log=pots.bond_force_sd_log,
            pot_soft_share=pots.soft_share,
            pot_soft_wall_m=pots.soft_wall_m,
            pot_crooked_share=pots.crooked_share,
            pot_crooked_max_rad=pots.crooked_max_rad,
            pot_fill_gap_m=pots.fill_gap_m,
            pot_fill_gap_sd_m=pots.fill_gap_sd_m,
            canopy_contact=pots.canopy_contact,
            canopy_timeconst_s=pots.canopy_timeconst_s,
            canopy_friction=pots.canopy_friction,
            shoot_mass_kg=pots.shoot_mass_kg,
            stem_sway_hz=pots.stem_sway_hz,
            stem_sway_sd_hz=pots.stem_sway_sd_hz,
            stem_damping_ratio=pots.stem_damping_ratio,
            conveyor_index_error_sd_m=conv.index_error_sd_m,
            conveyor_index_drive=conv.index_drive,
            pot_feet=pots.feet,
            drop_tube_xy_m=(tube.x_m, tube.y_m),
            funnel_top_diameter_m=tube.funnel_top_diameter_m,
            funnel_top_z_m=tube.funnel_top_z_m,
            funnel_throat_diameter_m=tube.funnel_throat_diameter_m,
            funnel_height_m=tube.funnel_height_m,
            timestep_s=phys.timestep_s,
            sleep=phys.sleep,
        )
    except ValueError as exc:
        raise ScenarioError(f"the scenario does not make a buildable scene: {exc}") from None


@dataclass(frozen=True)
class VisionConfig:
    """Seed 002's vision from a scenario's [vision]: the trays' seedling draw
    (scene.plug_tray.SeedlingDraw), the imaging station's draw (scene.tray_camera.ImagingDraw),
    the picture's size, the camera's mounting and the pipeline's thresholds as the pipeline
    takes them (vision.pipeline.CameraMount, VisionThresholds)."""

    seedlings: Any
    imaging: Any
    width_px: int
    height_px: int
    mount: Any
    thresholds: Any


def vision_config(scenario: Scenario) -> VisionConfig:
    """[vision] as the draw, the camera and the pipeline take it (angles back in degrees,
    lengths in mm, the leaf hue band in OpenCV's 0-180)."""
    from transplanter.scene.plug_tray import SeedlingDraw
    from transplanter.scene.tray_camera import ImagingDraw
    from transplanter.vision.grading import GradingRule
    from transplanter.vision.pipeline import CameraMount, VisionThresholds

    v = scenario.vision
    mm, deg = 1.0 / M_PER_MM, math.degrees

    def span(pair, scale=1.0) -> tuple[float, float]:
        return (pair[0] * scale, pair[1] * scale)

    seedlings = SeedlingDraw.near_thresholds() if v.seedling_draw == "near_thresholds" else None
    imaging = ImagingDraw(
        light_scale=span(v.light_scale),
        leaf_hue_deg=tuple(deg(a) for a in v.leaf_hue_rad),
        leaf_saturation=span(v.leaf_saturation),
        leaf_value=span(v.leaf_value),
        leaf_jitter=v.leaf_jitter,
        substrate_hue_deg=tuple(deg(a) for a in v.substrate_hue_rad),
        substrate_saturation=span(v.substrate_saturation),
        substrate_value=span(v.substrate_value),
        yaw_deg=deg(v.tray_yaw_rad),
        tip_deg=deg(v.tray_tip_rad),
        shift_mm=v.tray_shift_m * mm,
    )
    thresholds = VisionThresholds(
        white_percentile=v.white_percentile,
        min_white_level=v.min_white_level,
        min_contrast=v.min_contrast,
        tray_band=span(v.tray_band),
        close_fraction=v.close_fraction,
        erode_mm=v.erode_m * mm,
        open_mm=v.open_m * mm,
        tray_aspect_tolerance=v.tray_aspect_tolerance,
        px_per_mm=1.0 / (v.rectified_resolution_m * mm),
        profile_level=v.profile_level,
        hue=tuple(round(deg(a) / 2) for a in v.leaf_hue_band_rad),
        min_saturation=v.leaf_min_saturation,
        min_value=v.leaf_min_value,
        min_component_mm2=v.min_component_mm2,
        core_radius_mm=v.core_radius_m * mm,
        rule=GradingRule(
            min_leaf_area_mm2=v.min_leaf_area_mm2,
            max_centroid_offset_mm=v.max_centroid_offset_m * mm,
            min_secant_mm=v.min_secant_m * mm,
            empty_area_mm2=v.empty_area_mm2,
        ),
    )
    mount = CameraMount(height_mm=v.camera_height_m * mm, leaf_height_mm=v.leaf_height_m * mm)
    return VisionConfig(
        seedlings=seedlings or SeedlingDraw(),
        imaging=imaging,
        width_px=v.image_width_px,
        height_px=v.image_height_px,
        mount=mount,
        thresholds=thresholds,
    )


def require_kinds(scenario, job: str, robot: str | None, effector: str, why: str) -> None:
    """A job built for one robot and one effector refuses a scenario whose `[robot] kind` or
    `[effector] kind` names another, rather than run its own and ignore the value (`why`:
    what the job's scene and host are built around, and where the other kinds run);
    ScenarioError naming the key. `robot` None: any robot (the job dispatches by it)."""
    wrong = []
    if robot is not None and scenario.robot.kind != robot:
        wrong.append(f'robot.kind = "{scenario.robot.kind}"')
    if scenario.effector.kind != effector:
        wrong.append(f'effector.kind = "{scenario.effector.kind}"')
    if wrong:
        wanted = ([f'robot.kind = "{robot}"'] if robot is not None else []) + [
            f'effector.kind = "{effector}"'
        ]
        raise ScenarioError(
            f"{' and '.join(wrong)}: {job} runs {' with '.join(wanted)} only ({why}); "
            f"set {' and '.join(wanted)}, or choose the scenario of the job that has yours"
        )


def require_awake(scenario, job: str) -> None:
    """A job whose scene keeps every body awake (the delta's tray and bench, the serial arm's
    jobs) refuses `physics.sleep = true` rather than ignore it: sleeping is the five-bar's
    pot-line setting (docs/edge_trials.md); ScenarioError naming the key."""
    if scenario.physics.sleep:
        raise ScenarioError(
            f"physics.sleep = true: {job} keeps every body of its scene awake (sleeping is the "
            "five-bar's pot-line setting); set physics.sleep = false"
        )
