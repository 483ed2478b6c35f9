"""transplanter.studies.grid: --vary and --param parsed and checked with the schema, the spec's
grid of (setting, seed) runs."""

import pytest

from conftest import ROOT
from transplanter.scenario.schema import ScenarioError, load_scenario
from transplanter.studies.grid import Axis, SweepRefused, SweepSpec, parse_param_range, parse_vary

REFUSED = Axis("taught.z_low_mm", (61.0, 70.0))


def _spec(axis=REFUSED, seeds=(1,), seedlings=2, **kw):
    return SweepSpec("paper", (axis,), tuple(seeds), seedlings, kw)


def test_float_range_is_exact_decimal_and_includes_hi():
    axis = parse_vary("taught.z_low_mm=26:46:2")
    assert axis == Axis("taught.z_low_mm", tuple(float(v) for v in range(26, 47, 2)))
    # 0.1 + 0.1 + ... accumulated in floats ends at 0.7999999999999999, not 0.8
    friction = parse_vary("pots.friction=0.1:0.8:0.1").values
    assert friction == (0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8)
    assert parse_vary("taught.z_low_mm=30:30:1").values == (30.0,)


def test_int_range_and_lists():
    assert parse_vary("recovery.rehome_every_cycles=0:6:3").values == (0, 3, 6)
    assert parse_vary("motion.profile=trapezoid,scurve").values == ("trapezoid", "scurve")
    assert parse_vary("taught.z_low_mm=30,34.5").values == (30.0, 34.5)  # floats, one type
    assert parse_vary("physics.sleep=true,false").values == (True, False)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("taught.z_low_mm=26:46:0", "the step must be above 0, got 0"),
        ("taught.z_low_mm=26:46:-2", "the step must be above 0, got -2"),
        ("taught.z_low_mm=26:46:3", "the step 3 does not divide the span 26..46 (20)"),
        ("taught.z_low_mm=46:26:2", "HI 26 is below LO 46"),
        ("taught.z_low_mm=26:46", "a range is LO:HI:STEP"),
        ("taught.z_low_mm=26:x:2", "'x' is not a number"),
        ("taught.z_low_mm=26:nan:2", "'nan' is not a number"),
        ("taught.zlow_mm=26:46:2", "taught.zlow_mm: unknown key"),
        ("taught.z_low_cm=2:4:1", "taught.z_low_cm: wrong unit"),
        ("tought.z_low_mm=26", "unknown section [tought]"),
        ("taught.z_low_mm=0:10000:1", "10001 values; at most 10000"),
        ("taught.z_low_mm=100:1200:100", "taught.z_low_mm: 1100.0 is outside the allowed range"),
        ("motion.profile=trapezoid,jerky", "'jerky' is not one of trapezoid, scurve"),
        ("recovery.rehome_every_cycles=0:5:2.5", "takes whole numbers"),
        ("recovery.rehome_every_cycles=1,2.5", "expected a whole number, got 2.5"),
        ("taught.z_low_mm=30,30.0", "the value 30.0 is given twice"),
        ("taught.z_low_mm=30,,34", "empty value"),
        ("taught.drop_mm=[0, 140]", "only single values can be varied"),
        ("scenario.seed=1,2", "use --seeds / --seedlings"),
        ("taught.z_low_mm", "write KEY=LO:HI:STEP or KEY=a,b,c"),
    ],
)
def test_bad_grids_are_refused_naming_the_problem(text, message):
    with pytest.raises(SweepRefused) as info:
        parse_vary(text)
    assert message in str(info.value)


def test_param_ranges():
    assert parse_param_range("taught.z_low_mm=28..40") == ("taught.z_low_mm", "float", 28.0, 40.0)
    assert parse_param_range("recovery.rehome_every_cycles=0..5") == (
        "recovery.rehome_every_cycles",
        "int",
        0,
        5,
    )
    for text, message in (
        ("taught.z_low_mm=40..28", "LO must be below HI"),
        ("taught.z_low_mm=28-40", "write KEY=LO..HI"),
        ("recovery.rehome_every_cycles=0..2.5", "takes whole numbers"),
        ("motion.profile=0..1", "only number keys can be tuned"),
        ("taught.z_low_mm=28..2000", "taught.z_low_mm: 2000.0 is outside the allowed range"),
    ):
        with pytest.raises(SweepRefused) as info:
            parse_param_range(text)
        assert message in str(info.value)


def test_spec_expands_the_grid_first_key_outermost():
    spec = SweepSpec(
        "paper",
        (Axis("taught.z_low_mm", (30.0, 34.0)), Axis("motion.profile", ("trapezoid", "scurve"))),
        (1, 2),
        2,
    )
    assert spec.runs_total == 8
    assert spec.settings() == [
        {"taught.z_low_mm": 30.0, "motion.profile": "trapezoid"},
        {"taught.z_low_mm": 30.0, "motion.profile": "scurve"},
        {"taught.z_low_mm": 34.0, "motion.profile": "trapezoid"},
        {"taught.z_low_mm": 34.0, "motion.profile": "scurve"},
    ]
    assert [(t["setting"]["taught.z_low_mm"], t["seed"]) for t in spec.tasks()][:3] == [
        (30.0, 1),
        (30.0, 2),
        (30.0, 1),
    ]
    with pytest.raises(SweepRefused, match="both set .--set. and varied"):
        _spec(**{"taught.z_low_mm": 30})
    with pytest.raises(SweepRefused, match="varied twice"):
        SweepSpec("paper", (REFUSED, REFUSED), (1,), 2)


def test_a_taught_range_is_on_the_eeprom_grid():
    from transplanter.studies.grid import SweepRefused, parse_param_range

    assert parse_param_range("taught.z_low_mm=28..40.5")[2:] == (28.0, 40.5)
    with pytest.raises(SweepRefused, match="steps of 0.001"):
        parse_param_range("taught.z_low_mm=28.0005..40")
    from transplanter.studies.tune import Param

    dist = Param("taught.s_high_mm_s", "float", 120.0, 250.0).distribution()
    assert dist.step == 0.1


@pytest.mark.parametrize(
    "text, refusal",
    [
        ("taught.z_low_mm=30:40:1e-30", "makes more than 10000 values"),
        ("taught.z_low_mm=30:1e30:1", "makes more than 10000 values"),
        ("conveyor.rows=1:1e300:1", "makes more than 10000 values"),
    ],
)
def test_ranges_of_absurd_size_are_refused_in_one_line(text, refusal):
    """These ended in decimal.InvalidOperation tracebacks (a division of the span by a step
    too fine to count)."""
    with pytest.raises(SweepRefused, match=refusal):
        parse_vary(text)


def test_a_tuning_range_beyond_the_keys_range_is_refused_before_any_division():
    with pytest.raises(SweepRefused, match=r"1e\+30 is outside the allowed range"):
        parse_param_range("taught.z_low_mm=30..1e30")


def test_the_l9_design_runs_the_nine_rows_of_the_orthogonal_array():
    axes = (
        Axis("plugs.moisture_pct", (65.0, 75.0, 85.0)),
        Axis("plugs.age_d", (20.0, 25.0, 30.0)),
        Axis("plug_bench.extraction_accel_m_s2", (20.0, 30.0, 40.0)),
    )
    spec = SweepSpec("plug_bench", axes, (1, 2), 64, design="L9")
    assert spec.runs_total == 18 and len(spec.tasks()) == 18
    levels = [tuple(a.values.index(s[a.key]) + 1 for a in axes) for s in spec.settings()]
    assert levels == [(1, 1, 1), (1, 2, 2), (1, 3, 3), (2, 1, 2), (2, 2, 3), (2, 3, 1),
                      (3, 1, 3), (3, 2, 1), (3, 3, 2)]  # fmt: skip
    assert spec.manifest()["design"] == "L9"
    assert "design" not in SweepSpec("plug_bench", axes, (1,), 64).manifest()  # the full grid
    with pytest.raises(
        SweepRefused, match=r"got plugs.moisture_pct \(3 values\), plugs.age_d \(2 values\)"
    ):
        SweepSpec("plug_bench", (axes[0], Axis("plugs.age_d", (20.0, 25.0))), (1,), 1,
                  design="L9")  # fmt: skip
    with pytest.raises(SweepRefused, match="--design 'L27': choose one of full, L9"):
        SweepSpec("plug_bench", axes, (1,), 1, design="L27")


def test_a_five_bar_sweeps_identity_does_not_hold_the_plug_sections():
    axis = (Axis("taught.z_low_mm", (30.0,)),)

    def digest(name, **over):
        return SweepSpec(name, axis if name == "paper" else (Axis("plugs.age_d", (25.0,)),),
                         (1,), 2, over).manifest()["scenario_digest"]  # fmt: skip

    # [plugs] is not the five-bar's: its sweeps keep the digest they had before the plug
    # sections existed (checked against e03f64d: 533902d7...), so their results resume
    # (a [plugs] key given to the five-bar's scenario is refused now: no kind of it reads it)
    with pytest.raises(ScenarioError, match=r"\[plugs\] moisture_pct \(read by the plug"):
        digest("paper", **{"plugs.moisture_pct": 75})
    assert digest("plug_bench", **{"plugs.moisture_pct": 75}) != digest("plug_bench")


def test_a_studys_identity_is_the_keys_its_kinds_read(tmp_path):
    from transplanter.scenario.schema import read_values, scenario_digest

    def digest(name, **over):
        return scenario_digest(load_scenario(name, over))

    # every robot's own section counts: the gantry's guides, the five-bar's links
    assert digest("gantry_pots", **{"gantry.guide_friction_n": 5.0}) != digest("gantry_pots")
    assert digest("paper", **{"arm.l1_mm": 125.0}) != digest("paper")
    keys = {k for k, _ in read_values(load_scenario("gantry_pots"))}
    assert "gantry.belt_lead_mm" in keys and "taught.z_low_mm" in keys
    assert not any(k.startswith(("arm.", "delta.", "costs.")) for k in keys)
    assert "drives.arm_belt_ratio" not in keys and "drives.z_lead_mm" in keys
    # a copy under another name, description and price runs the same physics
    text = (ROOT / "scenarios" / "paper.toml").read_text()
    text = text.replace('name = "paper"', 'name = "mine"').replace(
        "drives_usd = 59.0", "drives_usd = 80.0"
    )
    parts = str(ROOT / "scenarios" / "parts")
    (tmp_path / "mine.toml").write_text(text.replace('base = "parts/', f'base = "{parts}/'))
    assert scenario_digest(load_scenario(tmp_path / "mine.toml")) == digest("paper")
