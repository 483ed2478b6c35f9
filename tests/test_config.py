"""Assembly: each scenario key reaches the part of the twin that uses it, once."""

import math
import re

import pytest

from conftest import paper_scenario
from transplanter.scenario.assemble import assemble, machine_config, scene_config
from transplanter.scenario.schema import ScenarioError


def test_paper_assembly_maps_each_section(paper, paper_twin_config):
    cfg = paper_twin_config
    assert (cfg.name, cfg.seed, cfg.seedlings) == ("paper", 1, 40)
    m = cfg.machine
    assert m.kinematics.geometry.l1_m == pytest.approx(0.120) and m.kinematics.mode == "+-"
    assert m.sgf.home_joint_positions == pytest.approx((math.radians(200), math.radians(-20), 0.16))
    assert m.drives[2].lead_m == pytest.approx(0.008) and m.drives[0].ratio == 3.0
    assert m.pgf.gripper_open_deg == pytest.approx(155.0) and m.pgf.seedlings == 40
    assert m.eeprom.m_pp == 5 and m.eeprom.s_high_m_s == pytest.approx(0.150)
    assert cfg.scene.pot_mass_kg == pytest.approx(0.047) and cfg.scene.grip_force_n == 6.0
    # the scene's power-on pose is short of the switches, its hard stops beyond the windows
    assert cfg.scene.power_on_theta1_rad == pytest.approx(math.radians(195))
    assert cfg.scene.theta1_range_rad[1] == pytest.approx(math.radians(240))
    assert cfg.gripper_servo.speed_deg_s == pytest.approx(400.0)
    assert cfg.gripper_servo.max_opening_m == pytest.approx(0.050)
    assert cfg.judge.knocked_tilt_rad == pytest.approx(math.radians(25))
    assert cfg.judge.row_pitch_m == pytest.approx(0.045)


def test_an_override_reaches_the_physics_and_the_firmware():
    s = paper_scenario(**{"drives.holding_torque_nm": 0.3, "taught.z_low_mm": 30.0})
    cfg = assemble(s)
    assert cfg.scene.holding_torque_nm == 0.3
    assert cfg.machine.drives[0].holding_torque_nm == 0.3
    assert cfg.machine.eeprom.z_low_m == pytest.approx(0.030)


def test_a_scene_the_builder_refuses_is_a_scenario_error():
    s = paper_scenario(**{"pots.placement_max_mm": 4.5})  # 35 + 9 + 2 mm > 45 mm cells
    # the machine reads the arms' masses from the compiled robot model, whose scene config
    # the builder checks first: refused there already
    with pytest.raises(ScenarioError, match="pots do not fit their cells"):
        machine_config(s)
    with pytest.raises(ScenarioError, match="pots do not fit their cells"):
        scene_config(s, machine_config(paper_scenario()))


def test_a_taught_value_finer_than_the_eeprom_is_refused_not_rounded():
    from transplanter.scenario.assemble import key_quantum
    from transplanter.scenario.schema import ScenarioError, load_scenario

    for key, value, quantum in (
        ("taught.z_low_mm", 34.0004, "1 um"),
        ("taught.s_high_mm_s", 150.04, "0.1 mm/s"),
        ("taught.drop_wrist_deg", 135.005, "0.01 deg"),
    ):
        with pytest.raises(ScenarioError, match=rf"{re.escape(key)} = .* \({re.escape(quantum)}\)"):
            assemble(load_scenario("paper", {key: value}))
    assemble(load_scenario("paper", {"taught.z_low_mm": 34.001, "taught.s_high_mm_s": 150.1}))
    assert key_quantum("taught.z_low_mm") == 0.001
    assert key_quantum("taught.s_low_mm_s") == 0.1
    assert key_quantum("taught.pickup[2].wrist_deg") == 0.01
    assert key_quantum("pots.friction") is None


@pytest.mark.parametrize(
    ("scenario", "overrides", "needle"),
    [
        ("paper", {"effector.kind": "fuzzy_gripper"}, "the five-bar's pot trial runs"),
        ("paper", {"effector.kind": "plug_claws"}, "the five-bar's pot trial runs"),
        ("delta_refill", {"robot.kind": "fivebar"}, "the plug-tray job runs"),
        ("delta_refill", {"effector.kind": "parallel_jaw"}, "the plug-tray job runs"),
        ("serial_arm_pots", {"effector.kind": "parallel_jaw"}, 'runs robot.kind = "serial4"'),
        ("serial_arm", {"effector.kind": "plug_claws"}, 'runs robot.kind = "serial4"'),
        ("delta_pots", {"effector.kind": "plug_claws"}, "the delta's pot job runs"),
    ],
)
def test_a_job_refuses_a_robot_or_effector_it_is_not_built_for(scenario, overrides, needle, capsys):
    """Each job runs the robot and effector its scene and host are built around; a scenario
    naming another kind is refused (exit 2) naming the key, not run with the job's own kinds
    (a delta tray with `robot.kind = "fivebar"` used to run the delta)."""
    from transplanter import cli

    key, value = next(iter(overrides.items()))
    args = ["trial", scenario, "--set", f'{key}="{value}"', "--seed", "1"]
    if scenario == "delta_refill":
        args += ["--set", 'delta_refill.vision="truth"', "--set", "delta_refill.max_cells=1"]
    elif scenario in ("paper", "serial_arm_pots", "delta_pots"):
        args += ["--seedlings", "1"]
    assert cli.main(args) == 2
    err = capsys.readouterr().err
    assert f'{key} = "{value}"' in err and needle in err
