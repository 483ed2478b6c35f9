"""The key reference (transplanter.scenario.keys, `transplanter keys`): a scenario's keys are
exactly those its kinds read, each with its value in file units; docs/keys.md is what
`keys --markdown` prints."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from transplanter import cli
from transplanter.scenario.keys import all_key_rows, markdown, scenario_key_rows
from transplanter.scenario.schema import SCHEMA, ScenarioError, load_scenario

DOCS = Path(__file__).resolve().parents[1] / "docs" / "keys.md"


def test_the_deltas_run_size_key_is_listed_with_its_value(capsys):
    """`keys delta_refill` names the key that sizes a run (issue: a user had to read
    docs/delta.md to find it), its range, default and the scenario's value, and --set moves
    the value."""
    assert cli.main(["keys", "delta_refill"]) == 0
    out = capsys.readouterr().out
    line = next(x for x in out.splitlines() if x.strip().startswith("max_cells"))
    assert "= 0" in line and "int 0 .. 128" in line and "default 0" in line
    assert "cells serviced per tray (0: all)" in out
    assert out.startswith("delta_refill: ") and "robot delta, effector plug_claws" in out
    assert cli.main(["keys", "delta_refill", "--set", "delta_refill.max_cells=3"]) == 0
    line = next(x for x in capsys.readouterr().out.splitlines() if "max_cells" in x)
    assert "= 3" in line


@pytest.mark.parametrize("name", ["paper", "delta_refill", "serial_arm_pots", "plug_bench"])
def test_a_scenarios_keys_are_exactly_those_it_can_be_given(name):
    """Every listed key takes its own listed value back through --set (values in file units,
    the loader's own reading); a key of the schema not listed is refused."""
    sc = load_scenario(name)
    rows = scenario_key_rows(sc)
    listed = {r.dotted for r in rows}
    for r in rows:
        if r.section == "scenario" and r.key in ("name", "description"):
            continue
        again = load_scenario(name, {r.dotted: r.value})
        assert scenario_key_rows(again) == rows, r.dotted
    unlisted = [f"{s}.{k}" for s, keys in SCHEMA.items() for k in keys
                if f"{s}.{k}" not in listed]  # fmt: skip
    assert unlisted
    for dotted in unlisted[:: max(1, len(unlisted) // 12)]:
        with pytest.raises(ScenarioError, match="no kind of this scenario reads"):
            load_scenario(name, {dotted: scenario_default(dotted)})


def scenario_default(dotted: str):
    """A value of the right kind for a key (its range's low end, a choice, false, '')."""
    section, _, key = dotted.partition(".")
    spec = SCHEMA[section][key]
    if spec.choices:
        return spec.choices[0]
    return {"bool": False, "str": "x", "int": int(spec.lo or 0), "xy": [0.0, 0.0],
            "list": []}.get(spec.kind, float(spec.lo or 0.0))  # fmt: skip


def test_the_json_lists_every_key_with_who_reads_it(capsys):
    assert cli.main(["keys", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert len(rows) == sum(len(k) for k in SCHEMA.values()) == len(all_key_rows())
    by = {r["key"]: r for r in rows}
    on_the_pgf = "the conveyor_tube job with the fivebar or gantry robot"
    assert by["taught.z_low_mm"]["read_by"] == on_the_pgf
    assert by["taught.z_low_mm"]["unit"] == "mm" and by["physics.sleep"]["kind"] == "bool"
    assert by["scenario.seed"]["allowed"] == "0 .. 9223372036854775807"  # whole, not 9.2e18


def test_docs_keys_is_current():
    """docs/keys.md is `transplanter keys --markdown` (regenerate it after a schema change)."""
    assert DOCS.read_text() == markdown(), "run: transplanter keys --markdown > docs/keys.md"


def test_bad_input_is_refused_in_one_line(capsys):
    assert cli.main(["keys", "no_such_scenario"]) == 2
    assert "scenario refused" in capsys.readouterr().err
    assert cli.main(["keys", "--markdown", "paper"]) == 2
    assert cli.main(["keys", "--set", "taught.z_low_mm=30"]) == 2
    assert "give the scenario" in capsys.readouterr().err
