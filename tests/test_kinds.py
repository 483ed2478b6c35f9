"""transplanter.kinds: the registry of robots, effectors and jobs behind their written
interfaces, what each reads of a scenario, and the loader's refusal of a key that no kind of
a scenario reads."""

from __future__ import annotations

import dataclasses
import types

import pytest

from transplanter import kinds
from transplanter.kinds import sections
from transplanter.kinds.interfaces import ALL, problems
from transplanter.scenario import schema
from transplanter.scenario.schema import ScenarioError, load_scenario, packaged_scenarios

ON_THE_PGF = "the conveyor_tube job with the fivebar or gantry robot"
"""Who reads the PGF's taught keys: the pot line with a robot on the SGF."""

PRESENTATION = {("costs", "drives_usd"), ("scenario", "description"), ("scenario", "name")}
"""Keys every scenario reads for its reports and `compare`, not its physics."""


@pytest.mark.parametrize("category", list(kinds.CATEGORIES))
def test_every_registered_kind_implements_its_interface(category):
    for name in kinds.names(category):
        kind = kinds.get(category, name)
        assert problems(category, kind) == [], (category, name)
        assert kind.NAME == name


@pytest.mark.parametrize("category", list(kinds.CATEGORIES))
def test_every_key_a_kind_reads_is_a_key_of_the_schema(category):
    for name in kinds.names(category):
        kind = kinds.get(category, name)
        tables = [kind.READS] if category != "job" else [
            kind.reads(r, e) for r in kinds.names("robot") for e in kinds.names("effector")
        ]  # fmt: skip
        for table in tables:
            for section, keys in table.items():
                assert section in schema.SCHEMA, (name, section)
                if keys != ALL:
                    assert set(keys) <= set(schema.SCHEMA[section]), (name, section, keys)


def test_the_checker_names_what_a_kind_lacks():
    half = types.SimpleNamespace(NAME="half", READS={"arm": "l0_mm"}, SCENE="", SUMMARY="x")
    found = problems("robot", half)
    assert "has no KINEMATICS" in found and "has no MODEL" in found
    assert "READS['arm'] is neither ALL nor a tuple of key names" in found
    assert "SCENE is empty" in found
    with pytest.raises(TypeError, match="the robot kind 'half' .*has no KINEMATICS"):
        kinds.register("robot", "half", half)


def test_a_kind_registered_at_run_time_is_one_of_the_known():
    robot = types.SimpleNamespace(
        NAME="test_arm", READS={"arm": ("l0_mm",)}, KINEMATICS="m:C", SCENE="m", MODEL="m",
        CONTROLLER="",
        SUMMARY="a test's arm",
    )  # fmt: skip
    kinds.register("robot", "test_arm", robot)
    try:
        assert kinds.robot("test_arm") is robot and "test_arm" in kinds.names("robot")
        assert "the test_arm robot" in kinds.readers("arm", "l0_mm")
    finally:
        kinds._REGISTERED["robot"].pop("test_arm")
    assert "test_arm" not in kinds.names("robot")


@dataclasses.dataclass(frozen=True)
class _SagSection:
    """A user's robot's own section: one key with no default, one with."""

    sag_m: float = sections.key("float", 0, 100, doc="the beam's sag under load")
    sag_per_kg_m: float = sections.key("float", 0, 100, doc="more sag per carried kg")


def _user_gantry(section_name: str = "sagging_gantry"):
    """The gantry's declaration with a section of its own, as a user's plug-in would give."""
    from transplanter.kinds.robots import gantry

    return types.SimpleNamespace(
        NAME="sagging_gantry", SUMMARY="a user's gantry", KINEMATICS=gantry.KINEMATICS,
        SCENE=gantry.SCENE, MODEL=gantry.MODEL, CONTROLLER="sgf",
        READS={**gantry.READS, section_name: ALL},
        SECTIONS={section_name: sections.Section(
            _SagSection, defaults={"sag_per_kg_mm": 0.5},
            check=lambda v: "sagging_gantry.sag_mm above 10 mm breaks the beam."
            if v["sag_m"] > 0.010 else None,
        )},
    )  # fmt: skip


def test_a_kind_brings_its_own_section_into_the_schema(tmp_path):
    """A robot kind registered at run time with a section of its own: the loader takes its
    keys (units, range, default, check), refuses them in a scenario of other kinds naming the
    kind, and a scenario of other kinds holds no such section; unregistered, it is gone."""
    kinds.register("robot", "sagging_gantry", _user_gantry())
    try:
        assert schema.KIND_SECTIONS["sagging_gantry"][0] == "the sagging_gantry robot"
        assert schema.SCHEMA["sagging_gantry"]["sag_mm"].scale == pytest.approx(1e-3)
        path = tmp_path / "mine.toml"
        path.write_text(
            '[scenario]\nbase = "gantry_pots"\nname = "mine"\n'
            '[robot]\nkind = "sagging_gantry"\n[sagging_gantry]\nsag_mm = 2.5\n'
        )
        sc = load_scenario(path)
        assert sc.sagging_gantry.sag_m == pytest.approx(0.0025)
        assert sc.sagging_gantry.sag_per_kg_m == pytest.approx(0.0005)  # the default
        assert sc.get("sagging_gantry.sag_mm") == pytest.approx(0.0025)
        assert ("sagging_gantry.sag_mm", pytest.approx(0.0025)) in schema.read_values(sc)
        with pytest.raises(ScenarioError, match="sag_mm above 10 mm breaks the beam"):
            load_scenario(path, {"sagging_gantry.sag_mm": 12.0})
        with pytest.raises(
            ScenarioError,
            match=r"sagging_gantry.sag_mm: 200.0 is outside the allowed range \[0, 100\]",
        ):
            load_scenario(path, {"sagging_gantry.sag_mm": 200.0})
        path.write_text(path.read_text().replace("sag_mm = 2.5\n", ""))
        with pytest.raises(ScenarioError, match=r"sagging_gantry.sag_mm is missing"):
            load_scenario(path)
        paper = load_scenario("paper")  # reads it not, and it has no default for sag_mm
        assert not paper.has_section("sagging_gantry") and paper.has_section("gantry")
        with pytest.raises(AttributeError, match="no kind of it reads it"):
            paper.sagging_gantry  # noqa: B018
        with pytest.raises(ScenarioError, match=r"\[sagging_gantry\] sag_mm \(read by the "
                           r"sagging_gantry robot\)"):  # fmt: skip
            load_scenario("paper", {"sagging_gantry.sag_mm": 1.0})
    finally:
        kinds._REGISTERED["robot"].pop("sagging_gantry")
        schema.add_kind_sections()
    assert "sagging_gantry" not in schema.SCHEMA
    with pytest.raises(ScenarioError, match="unknown section"):
        load_scenario("paper", {"sagging_gantry.sag_mm": 1.0})


def test_a_section_two_kinds_declare_is_refused_and_the_registry_undone():
    with pytest.raises(ValueError, match=r"\[gantry\] section is declared by the gantry robot "
                       "and by the sagging_gantry robot"):  # fmt: skip
        kinds.register("robot", "sagging_gantry", _user_gantry("gantry"))
    assert "sagging_gantry" not in kinds.names("robot")
    with pytest.raises(ValueError, match=r"declares the \[drives\] section, one of the "
                       "loader's shared sections"):  # fmt: skip
        kinds.register("robot", "sagging_gantry", _user_gantry("drives"))
    assert "sagging_gantry" not in kinds.names("robot") and "gantry" in schema.KIND_SECTIONS
    odd = types.SimpleNamespace(**{**vars(_user_gantry()), "SECTIONS": {"x": object()}})
    assert problems("robot", odd) == ["SECTIONS['x'] is not a kinds.sections.Section"]


def test_an_unknown_kind_names_the_known_ones_and_the_nearest():
    with pytest.raises(kinds.UnknownKind, match=r"'detla'; known kinds: delta, fivebar, gantry, "
                       r"serial4 \(robot.kind\); did you mean 'delta'\?"):  # fmt: skip
        kinds.robot("detla")
    with pytest.raises(ScenarioError, match=r"unknown job kind 'plug_tray'.*'plug_trays'"):
        load_scenario("delta_refill", {"workcell.kind": "plug_tray"})


def test_who_reads_a_key():
    assert kinds.readers("delta", "base_radius_mm") == ["the delta robot"]
    assert kinds.readers("taught", "z_low_mm") == [ON_THE_PGF]
    assert kinds.readers("plugs", "moisture_pct") == ["the plug_bench job", "the plug_trays job"]
    assert kinds.readers("scenario", "seed") == ["every scenario"]
    # the bench moves the claws itself: no robot's keys are read there
    assert "delta" not in kinds.reads("delta", "plug_claws", "plug_bench")


def _unread_key(name: str) -> tuple[str, object]:
    """A key of the schema that the packaged scenario `name` does not read, with a value the
    schema takes (the reference scenario's, or the key's default)."""
    sc = load_scenario(name)
    table = kinds.reads(sc.robot.kind, sc.effector.kind, sc.workcell.kind)
    reference = schema._read_raw(schema.resolve_scenario_path(schema.REFERENCE_SCENARIO))
    for section, keys in schema.SCHEMA.items():
        for key, spec in keys.items():
            read = table.get(section, ())
            if read == ALL or key in read or spec.kind == "list":
                continue
            value = reference.get(section, {}).get(key)
            if value is None:
                value = schema.DEFAULT_SECTIONS.get(section, {}).get(key)
            if value is not None:
                return f"{section}.{key}", value
    raise AssertionError(f"{name} reads every key")


@pytest.mark.parametrize("name", packaged_scenarios())
def test_every_packaged_scenario_refuses_a_key_its_kinds_do_not_read(name):
    load_scenario(name)  # loads as packaged: it gives no key its kinds do not read
    key, value = _unread_key(name)
    with pytest.raises(ScenarioError) as info:
        load_scenario(name, {key: value})
    text = str(info.value)
    section, _, bare = key.partition(".")
    assert "1 key given by --set that no kind of this scenario reads" in text
    assert f"[{section}] {bare} (read by " in text


@pytest.mark.parametrize(
    ("name", "key", "value", "reader"),
    [
        ("paper", "delta.base_radius_mm", 250.0, "the delta robot"),
        ("plug_bench", "taught.z_low_mm", 30.0, ON_THE_PGF),
        ("delta_refill", "taught.z_low_mm", 22.0, ON_THE_PGF),
        ("delta_refill", "scenario.seedlings", 3, "the conveyor_tube job, the plug_bench job"),
        ("delta_refill", "motion.resolution_mm", 0.05, "the fivebar robot"),
        ("serial_arm_pots", "taught.z_low_mm", 30.0, "the conveyor_tube job with"),
        ("delta_pots", "recovery.stall_detection", True, "the fivebar robot"),
        ("plug_bench", "physics.timestep_ms", 0.5, "the conveyor_tube job, the plug_trays job"),
    ],
)
def test_a_key_of_another_kind_is_refused_by_name(name, key, value, reader):
    with pytest.raises(ScenarioError, match="no kind of this scenario reads") as info:
        load_scenario(name, {key: value})
    section, _, bare = key.partition(".")
    assert f"[{section}] {bare} (read by {reader}" in str(info.value)


def test_a_file_on_the_five_bars_file_with_another_robot_is_refused(tmp_path):
    """A user's delta scenario made from paper.toml inherits the five-bar's sections: refused
    section by section, not run with them ignored."""
    path = tmp_path / "mine.toml"
    path.write_text('[scenario]\nbase = "paper"\n[robot]\nkind = "delta"\n[effector]\n'
                    'kind = "fuzzy_gripper"\n')  # fmt: skip
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    text = str(info.value)
    assert "given in the scenario file or its base chain" in text
    assert "[arm] l0_mm, l1_mm, l2_mm, working_mode (read by the fivebar robot)" in text
    assert "[taught]" in text or "more sections" in text


def test_sections_a_scenario_does_not_read_are_the_references_never_its_own(tmp_path):
    """delta_refill gives no [arm]: its Scenario holds the reference's, which nothing reads."""
    sc = load_scenario("delta_refill")
    assert sc.arm == load_scenario(schema.REFERENCE_SCENARIO).arm
    assert sc.bus.baud_bps == 115200.0  # read: given in the file
    path = tmp_path / "no_bus.toml"
    text = (schema.resolve_scenario_path("delta_refill")).read_text()
    path.write_text(text.replace("baud_bps = 115200.0", ""))
    with pytest.raises(ScenarioError, match=r"bus.baud_bps is missing"):
        load_scenario(path)


def test_a_copy_of_paper_toml_elsewhere_finds_its_pot_line(tmp_path):
    path = tmp_path / "my_paper.toml"
    path.write_text(schema.resolve_scenario_path("paper").read_text())
    assert dataclasses.replace(load_scenario(path), path=None) == dataclasses.replace(
        load_scenario("paper"), path=None
    )


def test_units_are_the_jobs():
    assert schema.units_key("paper") == "scenario.seedlings"
    assert schema.units_key("delta_refill") == "delta_refill.max_cells"
    assert schema.units_key("serial_arm") == "pool_to_belt.count"
    assert schema.units_key("plug_bench") == "scenario.seedlings"
    assert schema.units_key("paper", {"workcell.kind": "plug_trays"}) == "delta_refill.max_cells"
    assert schema.with_units("delta_refill", {"a.b": 1}, 3) == {
        "a.b": 1,
        "delta_refill.max_cells": 3,
    }
    assert schema.with_units("delta_refill", {}, None) == {}
    assert schema.units_of(load_scenario("delta_refill")) == 0  # every cell
    assert schema.units_of(load_scenario("serial_arm")) == 6
    assert schema.units_of(load_scenario("paper")) == 40


@pytest.mark.parametrize(
    "argv",
    [
        ["trial", "paper", "--seedlings", "1"],
        ["trial", "plug_bench"],
        ["export", "paper", "OUT/scene.xml"],
        ["ik", "0", "215", "--scenario", "paper"],
        ["sweep", "paper", "--vary", "taught.z_low_mm=30,34", "--out", "OUT/s"],
        ["tune", "paper", "--param", "taught.z_low_mm=30..34", "--out", "OUT/t"],
        ["compare", "paper", "serial_arm_pots", "--out", "OUT/c"],
        ["serve", "paper", "--port", "OUT/pty"],
    ],
)
def test_every_command_refuses_a_key_no_kind_of_its_scenario_reads(argv, tmp_path, capsys):
    """`--set delta.base_radius_mm=250` on the five-bar's scenario used to run, record the
    key in the JSON's overrides and change nothing; now every command refuses it (exit 2)
    before any work, naming who reads it."""
    from transplanter import cli

    argv = [str(tmp_path / a[4:]) if a.startswith("OUT/") else a for a in argv]
    assert cli.main([*argv, "--set", "delta.base_radius_mm=250"]) == 2
    err = capsys.readouterr().err
    assert "[delta] base_radius_mm (read by the delta robot)" in err
    assert not any(tmp_path.iterdir())  # nothing written


def test_compare_applies_a_set_to_the_scenarios_that_read_it_only(tmp_path):
    from transplanter.studies.compare import CompareSpec

    spec = CompareSpec(("paper", "delta_refill"), (1,), 2, {"taught.z_low_mm": 30.0})
    paper, delta = spec.sweeps()
    assert paper.overrides == {"taught.z_low_mm": 30.0} and delta.overrides == {}
    assert (paper.seedlings, delta.seedlings) == (2, 2)  # 2 pots, 2 cells
    own = CompareSpec(("paper", "delta_refill"), (1,), 2, {"delta_refill.max_cells": 1})
    assert [s.seedlings for s in own.sweeps()] == [2, None]  # its own count wins
    with pytest.raises(ScenarioError, match=r"--set plugs.age_d: no scenario of the comp"):
        CompareSpec(("paper", "serial_arm_pots"), (1,), 2, {"plugs.age_d": 20.0}).sweeps()
