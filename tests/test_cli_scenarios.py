"""`transplanter --version` and `transplanter scenarios` (cli/scenarios.py)."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

import transplanter
from transplanter.cli import main
from transplanter.scenario.schema import packaged_scenarios

ROOT = Path(__file__).resolve().parents[1]


def test_version_is_the_packages(capsys):
    with pytest.raises(SystemExit) as info:
        main(["--version"])
    assert info.value.code == 0
    assert capsys.readouterr().out.strip() == f"transplanter {transplanter.__version__}"
    pyproject = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert pyproject["project"]["version"] == transplanter.__version__


def test_scenarios_lists_every_packaged_scenario_with_its_kinds(capsys):
    assert main(["scenarios"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].split() == ["scenario", "robot", "effector", "workcell", "description"]
    names = [line.split()[0] for line in lines[1:]]
    assert names == packaged_scenarios() and "paper" in names
    paper = next(line for line in lines[1:] if line.split()[0] == "paper")
    assert paper.split()[1:4] == ["fivebar", "parallel_jaw", "conveyor_tube"]
    assert "40 seedlings" in paper
    calibrated = next(line for line in lines[1:] if line.startswith("paper_calibrated "))
    assert "fitted" in calibrated
    # the columns line up: every description starts in the same column
    starts = {line.index(line.split()[4]) for line in lines}
    assert len(starts) == 1


def test_matrix_lists_every_robot_on_every_job(capsys):
    import json

    from transplanter import kinds
    from transplanter.cli import main
    from transplanter.scenario.schema import load_scenario

    assert main(["matrix", "--json"]) == 0
    cells = json.loads(capsys.readouterr().out)
    robots, jobs = kinds.names("robot"), kinds.names("job")
    moving = [j for j in jobs if kinds.job(j).uses_robot()]
    assert len(cells) == len(moving) * len(robots) + len(jobs) - len(moving)
    by = {(c["job"], c["robot"]): c for c in cells}
    assert by["conveyor_tube", "gantry"]["scenarios"] == ["gantry_pots", "gantry_pots_tuned"]
    assert by["conveyor_tube", "gantry"]["effectors"] == ["parallel_jaw"]
    assert by["plug_bench", None]["scenarios"] == ["plug_bench"]
    for (job, robot), cell in by.items():
        for name in cell["scenarios"]:  # each packaged scenario is of its cell's kinds
            s = load_scenario(name)
            assert (s.workcell.kind, s.effector.kind) == (job, *cell["effectors"][:1])
            assert robot is None or s.robot.kind == robot
        if not cell["effectors"]:  # refused: out of reach, or the job's own reason
            own = kinds.job(job).refusal(robot, kinds.names("effector")[0])
            assert cell["reason"] == (cell.get("reach") or own)
            assert cell["reason"]
    # out of reach, computed from each robot's kinematics (tests/test_reach.py)
    for robot, span in (("gantry", "310 x 260 x 160"), ("fivebar", "350 x 240 x 190")):
        assert by["plug_trays", robot]["reason"] == (
            f"no placement of the {robot} robot reaches the plug_trays job's key points: they "
            f"span 660 x 558 x 100 mm (x, y, z), its workspace {span} mm (its kinematics' "
            "check on a 10 mm grid, turned by 0, 90, 180 or 270 deg)"
        )
    # in reach, and no host program: the job's own reason
    assert by["pool_to_belt", "gantry"]["reach"] is None
    assert by["pool_to_belt", "gantry"]["reason"] == (
        "no host program drives the gantry robot on the pool and belt"
    )
    assert main(["matrix"]) == 0
    text = capsys.readouterr().out
    assert "gantry     gantry_pots, gantry_pots_tuned (effector parallel_jaw)" in text
    assert "pool_to_belt (tomatoes):" in text and "cannot run: no host program" in text


def _runnable_cells() -> list[tuple[str, str | None, str]]:
    """(job, robot, its first packaged scenario) of every runnable cell of the matrix."""
    from transplanter.cli.scenarios import matrix_cells

    return [(c["job"], c["robot"], c["scenarios"][0]) for c in matrix_cells() if c["scenarios"]]


def _units_done(job: str, out: dict) -> int:
    """How many of the job's units a trial's JSON says it did, in each job's own keys."""
    if job == "conveyor_tube":
        return len(out["per_seedling"])
    if job == "plug_trays":
        return len(out["cells"])
    if job == "pool_to_belt":
        return len(out["pick_place"]["tomatoes"])
    return out["seedlings"]  # the claws' bench


@pytest.mark.slow
@pytest.mark.parametrize(("job", "robot", "name"), _runnable_cells())
def test_every_runnable_cell_runs_for_two_units(job, robot, name, tmp_path):
    """Each runnable cell of `transplanter matrix` (four robots on the pot line, the delta on
    the trays, the serial arm on the tomatoes, the claws' bench) runs `trial --seedlings 2`
    through the one CLI path and does two of its job's units, judged with no error."""
    import json

    from transplanter.cli import main

    out = tmp_path / "r.json"
    argv = ["trial", name, "--seedlings", "2", "--quiet", "--json", str(out)]
    if job == "plug_trays":  # graded from the drawn truth: no OpenGL context needed
        argv += ["--set", 'delta_refill.vision="truth"']
    assert main(argv) == 0
    result = json.loads(out.read_text())
    assert _units_done(job, result) == 2, (name, result.keys())
    assert not result.get("errors"), result.get("errors")
