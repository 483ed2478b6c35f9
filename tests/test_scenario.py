"""Scenario loading: SI conversion, inheritance, overrides and refusals that name the key."""

import json
import math
from pathlib import Path

import pytest

from transplanter.scenario.assemble import assemble
from transplanter.scenario.schema import ScenarioError, load_scenario, parse_value, si_key

PAPER = Path(__file__).resolve().parents[1] / "scenarios" / "paper.toml"


def test_si_key_names():
    assert si_key("l1_mm") == "l1_m"
    assert si_key("s_high_mm_s") == "s_high_m_s"
    assert si_key("accel_mm_s2") == "accel_m_s2"
    assert si_key("open_deg") == "open_rad"
    assert si_key("mass_g") == "mass_kg"
    assert si_key("compute_time_per_point_us") == "compute_time_per_point_s"
    assert si_key("rows") == "rows"


def test_paper_scenario_converts_to_si():
    s = load_scenario(PAPER)
    assert s.name == "paper"
    assert s.arm.l1_m == pytest.approx(0.120)
    assert s.taught.s_high_m_s == pytest.approx(0.150)
    assert s.limits.motor1_max_rad == pytest.approx(math.radians(235))
    assert s.pots.mass_kg == pytest.approx(0.047)
    assert s.physics.timestep_s == pytest.approx(0.001)
    assert len(s.taught.pickup) == 5
    assert s.taught.pickup[4].grip_m == pytest.approx((0.090, 0.215))


def _variant(tmp_path, body: str) -> Path:
    path = tmp_path / "variant.toml"
    path.write_text(f'[scenario]\nbase = "paper.toml"\n{body}', encoding="utf-8")
    return path


def test_base_file_and_override(tmp_path):
    s = load_scenario(_variant(tmp_path, "[taught]\ns_high_mm_s = 200.0\n"))
    assert s.taught.s_high_m_s == pytest.approx(0.2)
    assert s.taught.s_low_m_s == pytest.approx(0.06)  # inherited
    s2 = load_scenario(PAPER, overrides={"scenario.seed": 7, "taught.z_low_mm": 30.0})
    assert s2.seed == 7 and s2.taught.z_low_m == pytest.approx(0.030)


@pytest.mark.parametrize(
    "body, needle",
    [
        ("[arm]\nl1_m = 0.12\n", "arm.l1_m: wrong unit; this value must be given as 'l1_mm'"),
        ("[arm]\nlink_mm = 3.0\n", "arm.link_mm: unknown key"),
        ("[wheels]\nn = 3\n", "unknown section [wheels]"),
        ('[arm]\nl1_mm = "long"\n', "arm.l1_mm: expected a number"),
        ("[arm]\nl1_mm = -3.0\n", "arm.l1_mm: -3.0 is outside the allowed range"),
        ("seedlings = 2.5\n", "scenario.seedlings: expected a whole number"),
        ('[motion]\nprofile = "cubic"\n', "motion.profile: 'cubic' is not one of"),
        ("[taught]\nz_low_mm = 200.0\n", "taught.z_low_mm = 200 mm is outside"),
        ("[taught]\ndrop_mm = [1.0]\n", "taught.drop_mm: expected a pair"),
        ("[gripper]\nclose_deg = 170.0\n", "gripper.close_deg must be below gripper.open_deg"),
        ("[physics]\nsleep = 1\n", "physics.sleep: expected true or false"),
        ('[arm]\nworking_mode = "-+"\n', "arm.working_mode = '-+': the MJCF model is assembled"),
        (
            "[drives]\nswitch1_theta1_deg = 250.0\n",
            "drives.switch1_theta1_deg (a limit switch) must",
        ),
        ("[drives]\nswitch3_z_mm = 200.0\n", "drives.switch3_z_mm (limit switch 3) must lie"),
        ("[pots]\nmass_min_g = 50.0\n", "pots.mass_g must lie within"),
        ("[motion]\ncompute_time_per_point_us = 0.0\n", "outside the allowed range"),
        ("[drives]\npullout_corner_rev_min = 900.0\n", "wrong unit; this value must be given"),
    ],
)
def test_bad_values_are_refused_naming_the_key(tmp_path, body, needle):
    with pytest.raises(ScenarioError) as err:
        load_scenario(_variant(tmp_path, body))
    assert needle in str(err.value)


def test_missing_value_is_refused(tmp_path):
    line = PAPER.parent / "parts" / "pot_line.toml"  # paper.toml's base: its pot line
    (tmp_path / "parts").mkdir()
    text = line.read_text(encoding="utf-8").replace("index_time_s = 0.6\n", "")
    (tmp_path / "parts" / "pot_line.toml").write_text(text, encoding="utf-8")
    path = tmp_path / "missing.toml"
    path.write_text(PAPER.read_text(encoding="utf-8"), encoding="utf-8")
    with pytest.raises(ScenarioError, match=r"conveyor.index_time_s is missing"):
        load_scenario(path)


def test_bad_pickup_table(tmp_path):
    text = PAPER.read_text(encoding="utf-8").replace("wrist_deg = 112.4\n", "wrist_rad = 1.5\n", 1)
    path = tmp_path / "pick.toml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ScenarioError, match=r"taught.pickup\[0\].wrist_rad: wrong unit"):
        load_scenario(path)


def test_not_toml_and_missing_file(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[arm\nl1_mm = 3", encoding="utf-8")
    with pytest.raises(ScenarioError, match="not valid TOML"):
        load_scenario(bad)
    with pytest.raises(ScenarioError, match="no such scenario file"):
        load_scenario(tmp_path / "nope.toml")


def test_section_that_is_not_a_table(tmp_path):
    path = tmp_path / "flat.toml"
    path.write_text('arm = 3\n[scenario]\nbase = "paper.toml"\n', encoding="utf-8")
    with pytest.raises(ScenarioError, match=r"\[arm\] must be a table of keys"):
        load_scenario(path)


def test_packaged_scenario_by_name_and_as_base(tmp_path):
    from transplanter.scenario.schema import packaged_scenarios

    assert "paper" in packaged_scenarios()
    by_name = load_scenario("paper")
    assert by_name.taught == load_scenario(PAPER).taught and by_name.arm == load_scenario(PAPER).arm
    # a variant elsewhere may start from the packaged scenario by its bare name
    path = tmp_path / "faster.toml"
    path.write_text(
        '[scenario]\nbase = "paper.toml"\nname = "faster"\n[taught]\ns_high_mm_s = 200\n'
    )
    s = load_scenario(path)
    assert s.name == "faster" and s.taught.s_high_m_s == pytest.approx(0.2)
    with pytest.raises(ScenarioError, match="no packaged scenario of that name"):
        load_scenario("no_such_scenario")


def test_sections_are_typed_and_frozen():
    import dataclasses

    s = load_scenario(PAPER, {"taught.z_low_mm": 30.0})
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.taught.z_low_m = 0.1
    assert isinstance(s.drives.steps_per_rev, int)
    assert isinstance(s.taught.pickup[0].grip_m, tuple)
    assert s.overrides == (("taught.z_low_mm", 30.0),)
    assert s.get("taught.z_low_mm") == pytest.approx(0.030)
    with pytest.raises(ScenarioError, match="not a scenario key"):
        s.get("taught.z_low_m")


def test_every_schema_key_is_a_section_field_with_its_unit_scale():
    from transplanter.scenario.schema import SCHEMA, SECTIONS

    for section, keys in SCHEMA.items():
        names = {f.name for f in dataclasses_fields(SECTIONS[section])}
        assert {si_key(k) for k in keys} == names
    assert SCHEMA["arm"]["l1_mm"].scale == 1e-3
    assert SCHEMA["limits"]["motor1_min_deg"].scale == pytest.approx(math.pi / 180)
    assert SCHEMA["pots"]["mass_g"].scale == 1e-3
    assert SCHEMA["motion"]["compute_time_per_point_us"].scale == 1e-6
    assert SCHEMA["conveyor"]["index_time_s"].scale == 1.0


def dataclasses_fields(cls):
    import dataclasses

    return dataclasses.fields(cls)


def test_base_may_be_an_absolute_path_but_not_a_relative_one_outside(tmp_path):
    """`transplanter tune` writes `base = "/abs/path.toml"` for a scenario kept elsewhere."""
    elsewhere = tmp_path / "lab"
    elsewhere.mkdir()
    (elsewhere / "mine.toml").write_text(
        PAPER.read_text().replace("z_low_mm = 34.0", "z_low_mm = 36.0")
    )
    tuned = tmp_path / "results" / "tuned.toml"
    tuned.parent.mkdir()
    tuned.write_text(
        f"[scenario]\nbase = {json.dumps(str(elsewhere / 'mine.toml'))}\n[taught]\n"
        "s_high_mm_s = 180.0\n"
    )
    s = load_scenario(tuned)
    assert s.taught.z_low_m == pytest.approx(0.036) and s.taught.s_high_m_s == pytest.approx(0.18)
    tuned.write_text('[scenario]\nbase = "../lab/mine.toml"\n')
    with pytest.raises(ScenarioError, match="points outside the scenario's directory"):
        load_scenario(tuned)


def test_check_value_and_key_spec_name_the_key():
    from transplanter.scenario.schema import check_value, key_spec, parse_value

    assert check_value("taught.z_low_mm", 30) == pytest.approx(0.030)
    assert key_spec("motion.profile").choices == ("trapezoid", "scurve")
    with pytest.raises(ScenarioError, match=r"taught.z_low_mm: 2000.0 is outside"):
        check_value("taught.z_low_mm", 2000.0)
    with pytest.raises(ScenarioError, match="taught.z_low_cm: wrong unit"):
        key_spec("taught.z_low_cm")
    assert parse_value("30") == 30 and parse_value("scurve") == "scurve"
    assert parse_value("[0, 140]") == [0, 140] and parse_value("true") is True


def test_friction_zero_means_no_friction_and_the_old_floor_key_is_refused_with_why():
    """pots.friction = 0 was once raised to 0.05 in silence, then refused below a floor key;
    now frictions are gamma-distributed (never below 0, no floor) and 0 means 0."""
    config = assemble(load_scenario("paper", {"pots.friction": 0.0, "pots.friction_sd": 0.0}))
    assert config.scene.pot_friction == 0.0
    with pytest.raises(ScenarioError, match="a mean of 0 has no spread"):
        load_scenario("paper", {"pots.friction": 0.0})  # the paper's sd 0.08 with mean 0
    with pytest.raises(ScenarioError, match="pots.friction_min was removed: frictions are drawn"):
        load_scenario("paper", {"pots.friction_min": 0.05})


def test_the_pots_feet_and_the_index_drive_are_scenario_keys_the_scene_uses():
    paper = assemble(load_scenario("paper")).scene
    assert (paper.pot_feet, paper.conveyor_index_drive, paper.live_rows) == (8, "stepper", 12)
    config = assemble(load_scenario("paper", {"pots.feet": 0, "conveyor.index_drive": "pd"}))
    assert (config.scene.pot_feet, config.scene.conveyor_index_drive) == (0, "pd")
    config = assemble(load_scenario("paper", {"pots.feet": 4}))
    assert config.scene.pot_feet == 4
    with pytest.raises(ScenarioError, match="pots.feet = 2: a pot does not stand on fewer than 3"):
        load_scenario("paper", {"pots.feet": 2})
    with pytest.raises(ScenarioError, match="pots.feet"):
        load_scenario("paper", {"pots.feet": 17})
    with pytest.raises(ScenarioError, match="conveyor.index_drive"):
        load_scenario("paper", {"conveyor.index_drive": "servo"})


def test_the_paper_scenario_injects_no_faults():
    from transplanter.machine.faults import FaultConfig

    s = load_scenario(PAPER)
    assert s.faults.switch_stuck_closed == s.faults.switch_dead == s.faults.jam_motor == 0
    assert s.faults.lost_reply_line == 0 and s.faults.jam_torque_nm == 0.0
    assert s.bus.reply_timeout_s == 30.0
    config = assemble(s)
    assert config.faults == FaultConfig() and config.machine.pgf.reply_timeout_s == 30.0


@pytest.mark.parametrize(
    ("overrides", "needle"),
    [
        ({"faults.switch_dead": 4}, "limit switch 4 (Z down) is not used in homing"),
        ({"faults.switch_dead": 5}, "faults.switch_dead: 5 is outside the allowed range [0, 4]"),
        ({"faults.switch_stuck_closed": 5}, "faults.switch_stuck_closed: 5 is outside"),
        (
            {"faults.switch_dead": 2, "faults.switch_stuck_closed": 2},
            "a switch cannot be dead and stuck closed",
        ),
        ({"faults.jam_motor": 1}, "needs faults.jam_torque_nm > 0 and faults.jam_duration_s"),
        ({"faults.jam_torque_nm": 1.0}, "faults.jam_motor = 0 (no jam): name the motor"),
        ({"faults.jam_motor": 4}, "faults.jam_motor: 4 is outside"),
        ({"faults.lost_reply_line": -1}, "faults.lost_reply_line: -1 is outside"),
    ],
)
def test_bad_fault_keys_are_refused_with_the_reason(overrides, needle):
    with pytest.raises(ScenarioError) as err:
        load_scenario(PAPER, overrides)
    assert needle in str(err.value)


def test_a_lost_reply_beyond_the_program_and_a_short_reply_timeout_are_refused():
    with pytest.raises(ScenarioError, match=r"the PGF sends 31 lines for 2 seedlings"):
        assemble(load_scenario(PAPER, {"scenario.seedlings": 2, "faults.lost_reply_line": 32}))
    with pytest.raises(ScenarioError) as err:
        assemble(load_scenario(PAPER, {"bus.reply_timeout_s": 5.0}))
    assert str(err.value) == (
        "bus.reply_timeout_s = 5 s is too short: G28 (homing, worst case) can take 9.36 s, and "
        "the PGF would stop a healthy run with a bus timeout; use at least 10.4 s."
    )
    # a conveyor index longer than the timeout is the longest line then
    with pytest.raises(ScenarioError, match=r"M710 \(conveyor.index_time_s\) can take 40.00 s"):
        assemble(load_scenario(PAPER, {"conveyor.index_time_s": 40.0}))


@pytest.mark.parametrize(
    "key", ["gripper.open_dwell_ms", "gripper.close_dwell_ms", "gripper.close_deg"]
)
def test_a_dwell_or_angle_finer_than_the_firmware_carries_out_is_refused_in_one_line(key):
    """1e-300 ms used to end in a 312-character G-code line and a traceback."""
    with pytest.raises(ScenarioError, match=r"1e-300 is finer than the firmware carries out"):
        load_scenario("paper", {key: 1e-300})
    load_scenario("paper", {key: 0.001})  # the finest step is taken as given


def test_a_scenario_nested_beyond_any_use_is_refused_in_one_line(tmp_path):
    """100,000 nested arrays used to end in a RecursionError traceback."""
    deep = tmp_path / "deep.toml"
    deep.write_text('[scenario]\nbase = "paper"\n[pots]\nmass_g = ' + "[" * 100_000 + "]" * 100_000)
    with pytest.raises(ScenarioError, match="nested too deeply for a scenario"):
        load_scenario(deep)
    with pytest.raises(ScenarioError, match="nested too deeply to be a scenario value"):
        parse_value("[" * 5000 + "]" * 5000)
    # a value nested a little is refused with a bounded picture of it
    with pytest.raises(ScenarioError, match=r"expected a number, got \[\[\[\[\.\.\.\]\]\]\]\."):
        load_scenario("paper", {"pots.mass_g": [[[[[[[[1]]]]]]]]})


def test_the_files_of_a_nested_or_nul_scenario_are_listed_quietly_and_it_is_refused(tmp_path):
    """scenario_files (the inputs no output may replace) read the TOML without the loader's
    guard: 5,000 nested '[' were a RecursionError; a NUL byte in `base` was a ValueError
    traceback from the loader and from scenario_files."""
    from transplanter.scenario.schema import resolve_scenario_path, scenario_files

    deep = tmp_path / "deep.toml"
    deep.write_text('[scenario]\nbase = "paper"\n[pots]\nmass_g = ' + "[" * 5000 + "]" * 5000)
    child = tmp_path / "child.toml"
    child.write_text('[scenario]\nbase = "deep.toml"\n')
    nul = tmp_path / "nul.toml"
    nul.write_text('[scenario]\nbase = "pa\\u0000per"\n')
    assert scenario_files(deep) == [deep.resolve()]  # load_scenario says why it stops
    assert scenario_files(child) == [child.resolve(), deep.resolve()]
    assert scenario_files(nul) == [nul.resolve()]
    for path in (deep, child):
        with pytest.raises(ScenarioError, match="nested too deeply for a scenario"):
            load_scenario(path)
    with pytest.raises(ScenarioError, match=r"scenario.base = 'pa\\x00per' holds a NUL byte"):
        load_scenario(nul)
    with pytest.raises(ScenarioError, match="holds a NUL byte"):
        resolve_scenario_path("pa\0per")


def test_a_range_prints_its_integer_bounds_whole():
    """--seed -1 was refused with the bound printed as 9.22337e+18."""
    from transplanter.scenario.schema import check_value

    for dotted, value, allowed in (
        ("scenario.seed", -1, "[0, 9223372036854775807]"),
        ("faults.lost_reply_line", 10**10, "[0, 1000000000]"),  # %g said 1e+09
        ("delta.max_condition", 1e7, "[1, 1e+06]"),  # a float bound: %g as before
    ):
        with pytest.raises(ScenarioError) as refused:
            check_value(dotted, value)
        assert str(refused.value) == f"{dotted}: {value!r} is outside the allowed range {allowed}."


def test_a_mistyped_name_is_refused_naming_the_nearest_known_one(tmp_path):
    """A scenario name, a key or a section one letter off named no near one."""
    from transplanter.scenario.schema import key_spec

    for name, overrides, hint in (
        ("papr", None, "no packaged scenario of that name; did you mean paper? (packaged: "),
        ("paper", {"taught.z_lwo_mm": 30}, "unknown key; did you mean taught.z_low_mm? Known"),
        ("paper", {"taugth.z_low_mm": 30}, "unknown section [taugth]; did you mean [taught]? K"),
    ):
        with pytest.raises(ScenarioError) as refused:
            load_scenario(name, overrides)
        assert hint in str(refused.value)
    with pytest.raises(ScenarioError, match=r"did you mean \[taught\]\?"):
        key_spec("taugth.z_low_mm")
    typo = tmp_path / "typo.toml"
    typo.write_text('[scenario]\nbase = "paper"\n[conveyer]\nrows = 8\n')
    with pytest.raises(ScenarioError, match=r"unknown section \[conveyer\]; did you mean \[conv"):
        load_scenario(typo)
    # nothing near: the list alone, as before
    with pytest.raises(ScenarioError, match=r"taught.qqqq: unknown key\. Known keys in \[taught\]"):
        load_scenario("paper", {"taught.qqqq": 30})
    with pytest.raises(ScenarioError, match=r"no packaged scenario of that name \(packaged: "):
        load_scenario("xqzv")


# --- [plugs], [plug_claws] and [plug_bench]: the delta's jobs ----------------------------


def test_the_plug_sections_default_to_the_scene_configs_and_give_back_what_is_set():
    from dataclasses import fields

    from transplanter.scenario.assemble import claws_config, plugs_config
    from transplanter.scenario.schema import CELL_DEPTH_M, SCHEMA
    from transplanter.scene.effectors.plug_claws import PlugClawsConfig
    from transplanter.scene.plug_substrate import PlugsConfig

    sc = load_scenario("delta_refill")
    assert plugs_config(sc) == PlugsConfig() and claws_config(sc) == PlugClawsConfig()
    # every field a key under its own name (file unit), but the tray's cell
    assert {f.name for f in fields(PlugsConfig)} - set(SCHEMA["plugs"]) == {
        "top_mm", "bottom_mm", "depth_mm"
    }  # fmt: skip
    assert {f.name for f in fields(PlugClawsConfig)} == set(SCHEMA["plug_claws"])
    assert PlugsConfig().depth_mm * 1e-3 == CELL_DEPTH_M
    sc = load_scenario("delta_refill", {"plugs.moisture_pct": 75, "plugs.clearance_mm": 0.3,
                                        "plug_claws.insertion_angle_deg": 12.3,
                                        "plug_claws.settle_ms": 31.7,
                                        "plugs.reference_mass_g": 10.1})  # fmt: skip
    assert sc.plugs.moisture_pct == 75.0 and sc.plug_claws.settle_s == pytest.approx(0.0317)
    plugs, claws = plugs_config(sc), claws_config(sc)
    assert (plugs.moisture_pct, plugs.clearance_mm, plugs.reference_mass_g) == (75, 0.3, 10.1)
    assert (claws.insertion_angle_deg, claws.settle_ms) == (12.3, 31.7)  # exactly as written
    # the metrics' settle_s keeps its own file key
    assert "settle_s" in SCHEMA["metrics"] and "settle_ms" in SCHEMA["plug_claws"]


@pytest.mark.parametrize(
    "overrides, needle",
    [
        ({"plugs.moisture_pct": 150}, "plugs.moisture_pct"),
        ({"plugs.moisture": 75}, "plugs.moisture: wrong unit; this value must be given as "
                                 "'moisture_pct'"),
        ({"plug_claws.rod_mm": 10}, "plug_claws.rod_mm must be below plug_claws.bore_mm"),
        ({"plug_claws.insertion_depth_mm": 38, "plug_claws.tray_substrate_below_top_mm": 5},
         "= 43 mm: the claws' tips would reach the floor of the 42 mm deep cell"),
        ({"plugs.core_top_depth_mm": 38, "plugs.surface_below_top_mm": 10},
         "the pin socket must lie inside the plug"),
        ({"plug_bench.extraction_accel_mm_s2": 20}, "wrong unit; this value must be given as "
                                                    "'extraction_accel_m_s2'"),
    ],
)  # fmt: skip
def test_plug_keys_the_physics_cannot_use_are_refused_with_the_reason(overrides, needle):
    with pytest.raises(ScenarioError) as info:
        load_scenario("delta_refill", overrides)
    assert needle in str(info.value)


def test_the_bench_scenario_takes_the_papers_64_seedlings_without_a_conveyor():
    sc = load_scenario("plug_bench")
    assert sc.workcell.kind == "plug_bench" and sc.meta.seedlings == 64
    assert sc.plug_bench.extraction_accel_m_s2 == 20.0  # m/s^2, as written
    with pytest.raises(ScenarioError, match="more than the conveyor holds"):
        load_scenario("paper", {"scenario.seedlings": 64})
