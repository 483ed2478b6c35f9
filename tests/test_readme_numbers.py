"""README.md's numbers and commands: scripts/readme_numbers.py --quick finds no stale number,
every block it owns is marked in the README, and every `transplanter ...` line the README
quotes is a command the CLI's own parser takes."""

from __future__ import annotations

import importlib.util
import json
import re
import shlex
import subprocess
import sys

import pytest

from conftest import ROOT
from transplanter.cli import build_parser

README = ROOT / "README.md"
SCRIPT = ROOT / "scripts" / "readme_numbers.py"


def _script():
    spec = importlib.util.spec_from_file_location("readme_numbers", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up
    spec.loader.exec_module(module)
    return module


# --- the numbers -----------------------------------------------------------------------------


def test_every_block_of_the_script_is_marked_on_its_page_once():
    rn = _script()
    pages = {b.page for b in rn.BLOCKS.values()}
    assert {"README.md", "docs/drives.md", "docs/edge_trials.md"} <= pages
    for page in pages:
        text = (ROOT / page).read_text()
        names = [m["name"] for m in rn.BLOCK_RE.finditer(text)]
        assert sorted(names) == sorted(rn.page_blocks(page)), f"{page}: markers and BLOCKS differ"
        assert text.count("<!-- /readme_numbers -->") == len(names)  # none malformed


def test_a_sweep_becomes_a_table_with_its_seeds_failures_and_faults(tmp_path):
    rn = _script()
    out = tmp_path / "edge"
    out.mkdir()
    (out / "settings.csv").write_text(
        "taught.z_low_mm,physics.sleep,runs,errors,successes,seedlings,success_rate,ci95_low,"
        "ci95_high,ci_method,cycle_time_s\n"
        "22.0,True,2,0,0,80,0.0,0.0,0.045,Wilson,3.8948\n"
        "24.0,False,2,0,79,80,0.9875,0.93,1.0,bootstrap,3.81445\n"
    )
    base = {"lost_step_events": 0, "max_stem_bend_deg": 0.0, "error": None, "fault_kind": None}
    rows = [
        {**base, "taught.z_low_mm": 22.0, "physics.sleep": True, "seed": 2, "successes": 0,
         "fail_position_lost": 39, "fail_lost_steps": 1, "lost_step_events": 3,
         "fault_kind": "switch_stuck_closed"},
        {**base, "taught.z_low_mm": 22.0, "physics.sleep": True, "seed": 1, "successes": 0,
         "fail_position_lost": 40},
        {**base, "taught.z_low_mm": 24.0, "physics.sleep": False, "seed": 1, "successes": 40,
         "max_stem_bend_deg": 18.4},
        {**base, "taught.z_low_mm": 24.0, "physics.sleep": False, "seed": 2, "successes": 39,
         "fail_damaged": 1, "max_stem_bend_deg": 48.6},
    ]  # fmt: skip
    (out / "runs.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))

    class Runs:
        def sweep_dir(self, name, argv):
            assert (name, argv) == ("edge", ["paper"])
            return out

    table = rn.sweep_table(Runs(), "edge", ["paper"], ("per_seed", "success", "ci", "failures",
                                                       "events", "cycle", "bends"))  # fmt: skip
    assert table.strip().splitlines() == [
        "| taught.z_low_mm | physics.sleep | per seed | success | 95 % CI | failures | "
        "lost-step events | cycle s | largest shoot bend per seed, deg |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
        "| 22 | on | 0 0 | 0.0 % (0/80) | 0.0-4.5 % | 79 `position_lost`, 1 `lost_steps`, "
        "1 trial stopped by `switch_stuck_closed` | 3 | 3.895 | 0 0 |",
        "| 24 | off | 40 39 | 98.8 % (79/80) | 93.0-100.0 % | 1 `damaged` | 0 | 3.814 | 18 49 |",
    ]


def test_numbers_are_read_as_the_twin_prints_them():
    rn = _script()
    line = "success rate  100.0 % (40/40), 95 % CI 91.2-100.0 %, theta1 = -145.9911 deg, 24.3x"
    assert rn.NUMBER_RE.findall(line) == ["100.0", "40", "40", "95", "91.2", "100.0", "-145.9911",
                                          "24.3"]  # fmt: skip


def test_a_changed_number_is_a_difference_and_a_wall_time_is_not():
    rn = _script()
    block = rn.Block("b", lambda runs: "", "cmd", volatile=("wall time",))
    old = "success rate  70.0 % (84/120)\nwall time  6.1 s"
    new = "success rate  20.0 % (24/120)\nwall time  9.9 s"
    stale = [(f.readme, f.twin) for f in rn.compare(block, old, new) if f.differs]
    assert stale == [("70.0", "20.0"), ("84", "24")]
    assert rn.keep_volatile(block, old, new) == "success rate  20.0 % (24/120)\nwall time  6.1 s"


def test_update_rewrites_only_the_marked_text(tmp_path, monkeypatch):
    rn = _script()
    readme = tmp_path / "README.md"
    readme.write_text("24 mm: <!-- readme_numbers: x -->70 %<!-- /readme_numbers --> (70 %)\n")
    monkeypatch.setattr(rn, "BLOCKS", {"x": rn.Block("x", lambda runs: "20 %", "cmd", True)})
    assert rn.main(["--quick", "--readme", str(readme)]) == 1
    assert rn.main(["--quick", "--update", "--readme", str(readme)]) == 0
    assert readme.read_text() == (
        "24 mm: <!-- readme_numbers: x -->20 %<!-- /readme_numbers --> (70 %)\n"
    )
    assert rn.main(["--quick", "--readme", str(readme)]) == 0
    assert [p.name for p in tmp_path.iterdir()] == ["README.md"]  # no temporary file left


@pytest.mark.slow
def test_quick_subset_finds_no_stale_number():
    proc = subprocess.run(
        [sys.executable, str(SCRIPT), "--quick"],
        capture_output=True, text=True, timeout=300, cwd=ROOT,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert re.search(r"numbers in \d+ blocks \(quick\): 0 differ", proc.stdout), proc.stdout


# --- the commands ----------------------------------------------------------------------------


def readme_commands() -> list[str]:
    """Every `transplanter ...` the README and the command reference (docs/cli.md) quote:
    code spans, and the lines of their shell blocks (continuation lines joined, comments and
    a trailing & dropped)."""
    text = README.read_text() + "\n" + (ROOT / "docs" / "cli.md").read_text()
    found = [
        m[1].replace("\\|", "|")
        for m in re.finditer(r"`((?:\.venv/bin/)?transplanter[^`]*)`", text)
    ]
    for block in re.findall(r"```sh\n(.*?)```", text, re.S):
        for line in block.replace("\\\n", " ").splitlines():
            line = line.split(" #")[0].strip().rstrip("&").strip()
            if line.startswith((".venv/bin/transplanter", "transplanter")):
                found.append(line)
    return found


PLACEHOLDER = re.compile(r"\[|\]|\.\.\.|\||(?<![\w/.-])[A-Z][A-Z0-9_]*\b")


def _argv(command: str) -> list[str]:
    argv = shlex.split(command)
    assert argv[0].endswith("transplanter"), command
    return argv[1:]


def test_the_readme_quotes_commands():
    commands = readme_commands()
    assert len(commands) > 30
    assert any("sweep paper --vary taught.z_low_mm=20:44:4" in c for c in commands)


@pytest.mark.parametrize("command", readme_commands())
def test_every_quoted_command_parses(command, capsys):
    parser = build_parser()
    argv = _argv(command)
    if argv[0].startswith("-"):  # transplanter --version
        with pytest.raises(SystemExit) as exc:
            parser.parse_args(argv)
        assert exc.value.code == 0
        return
    with pytest.raises(SystemExit) as exc:  # the subcommand exists and has its --help
        parser.parse_args([argv[0], "--help"])
    assert exc.value.code == 0
    assert f"usage: transplanter {argv[0]}" in capsys.readouterr().out
    if len(argv) == 1 or PLACEHOLDER.search(command):
        return  # a mention of the subcommand, or a synopsis with placeholders
    args = parser.parse_args(argv)  # a complete command line: it parses as it stands
    assert args.command == argv[0]
