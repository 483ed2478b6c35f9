"""Rerun every number README.md quotes from a command and diff it against the README's text.

Run: .venv/bin/python scripts/readme_numbers.py            (every block; minutes on 2 cores)
     .venv/bin/python scripts/readme_numbers.py --quick    (a subset for CI, well under a minute)
     .venv/bin/python scripts/readme_numbers.py --update   (rewrite the README's stale numbers)

The README marks the text this script owns, so that it never guesses:

    <!-- readme_numbers: NAME -->TEXT<!-- /readme_numbers -->

(inline, or with TEXT on lines of its own, a fenced block). NAME is one of BLOCKS below: each
says which command of the README gives the text and how the text is made from that command's
output. Nothing outside the markers is read or written. Every number in TEXT is compared, in
order, with the same number in the text the twin gives now; each is printed with what the
README says and what the twin gives, and the exit status is 1 when any differs (2 when the
README's markers and BLOCKS disagree). Numbers that measure the computer rather than the twin
(wall time, real-time factor) are printed but not compared, and --update leaves them as they
are (docs/performance.md and the benchmarks measure speed).

--quick runs the cheap part: the paper trial (40 seedlings, seed 1: a few seconds), the 22 mm
trial (20 seedlings), `ik`, `plan`, and one row (32 mm) of the z_low sweep table instead of
all seven. With --update it rewrites only what it ran. The commands run in this process through
`transplanter.cli.main`, with --json (and the sweep's --out) pointed into a scratch directory;
--sweep-out DIR keeps the sweep's files there instead (a rerun into the same DIR resumes).

tests/test_readme_numbers.py runs --quick and checks that every `transplanter ...` line the
README quotes parses.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import re
import sys
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

README = Path(__file__).resolve().parent.parent / "README.md"

BLOCK_RE = re.compile(
    r"<!-- readme_numbers: (?P<name>[a-z0-9_]+) -->(?P<body>.*?)<!-- /readme_numbers -->", re.S
)
# A number as the twin prints it: not part of a name (theta1, X140), and a minus sign only
# where it cannot be a range's dash (91.2-100.0)
NUMBER_RE = re.compile(r"(?:(?<![\w.)%])-)?(?<![\w.])\d+(?:\.\d+)?")


class Runs:
    """Runs the README's commands in this process, each once, in a scratch directory."""

    def __init__(self, scratch: Path, sweep_out: Path | None = None):
        self.scratch = scratch
        self.sweep_out = sweep_out
        self._cache: dict[tuple[str, ...], tuple[str, dict | None]] = {}

    def cli(self, argv: list[str], json_out: bool = False) -> tuple[str, dict | None]:
        """stdout of `transplanter ARGV` (and its --json, when asked), exit 0 or 1 required."""
        key = tuple(argv) + (("--json",) if json_out else ())
        if key in self._cache:
            return self._cache[key]
        from transplanter.cli import main

        extra: list[str] = []
        json_path = self.scratch / f"run{len(self._cache)}.json"
        if json_out:
            extra = ["--json", str(json_path), "--quiet"]
        print(f"  running: transplanter {' '.join(argv)}", file=sys.stderr, flush=True)
        out = io.StringIO()
        with contextlib.redirect_stdout(out):
            status = main(argv + extra)
        if status not in (0, 1):
            raise RuntimeError(f"transplanter {' '.join(argv)} exited {status}")
        data = json.loads(json_path.read_text()) if json_out else None
        self._cache[key] = (out.getvalue(), data)
        return self._cache[key]

    def sweep(self, vary: str) -> str:
        """The settings table `transplanter sweep` prints for the README's z_low sweep."""
        out_dir = self.sweep_out or self.scratch / ("sweep_" + re.sub(r"\W", "_", vary))
        argv = ["sweep", "paper", "--vary", vary, "--seeds", "1-3", "--seedlings", "40",
                "--workers", "2", "--out", str(out_dir), "--quiet"]  # fmt: skip
        text, _ = self.cli(argv)
        lines = text.splitlines()
        start = next(i for i, line in enumerate(lines) if line.startswith("taught.z_low_mm"))
        end = next(i for i in range(start, len(lines)) if lines[i].startswith("results in"))
        self.sweep_dir = out_dir
        return "\n".join(lines[start:end])

    def sweep_runs(self) -> list[dict]:
        """The rows of the full sweep's runs.jsonl (after `sweep`)."""
        path = self.sweep_dir / "runs.jsonl"
        return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def _fenced(text: str) -> str:
    return f"\n```\n{text}\n```\n"


# --- the blocks: each makes its text from the output of a command the README quotes ----------


def paper_trial(runs: Runs) -> str:
    """`transplanter trial paper` (the scenario's seed, 1): its summary from 'success rate' to
    the first failure kind, then '...', as the README shows it."""
    text, _ = runs.cli(["trial", "paper"], json_out=True)
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("success rate"))
    end = next(i for i, line in enumerate(lines) if line.startswith("failures: "))
    return _fenced("\n".join(lines[start : end + 1] + ["..."]))


def _paper_json(runs: Runs) -> dict:
    return runs.cli(["trial", "paper"], json_out=True)[1]


def paper_shoot_bend(runs: Runs) -> str:
    """The paper trial's shoot bend row, rounded: '6 deg mean, 13 at most'."""
    text, _ = runs.cli(["trial", "paper"], json_out=True)
    m = re.search(r"shoot bend\s+([\d.]+) deg at most, ([\d.]+) deg mean", text)
    damaged = _paper_json(runs)["failures"]["damaged"]
    at = "none" if damaged == 0 else f"{damaged} damaged"
    return f"{at} at the paper's setting: {float(m[2]):.0f} deg mean, {float(m[1]):.0f} at most"


def pgf_vs_trial(runs: Runs) -> str:
    """The paper trial's outcome and mean cycle (test_serve checks that pgf over serve gives
    the same)."""
    d = _paper_json(runs)
    return f"{d['successes']}/{d['seedlings']}, {d['cycle_time_s']:.3f} s both"


def _z22(runs: Runs) -> dict:
    argv = ["trial", "paper", "--set", "taught.z_low_mm=22", "--seedlings", "20"]
    return runs.cli(argv, json_out=True)[1]


def z_low_22(runs: Runs) -> str:
    """`transplanter trial paper --set taught.z_low_mm=22 --seedlings 20` (seed 1)."""
    d = _z22(runs)
    kinds = ", ".join(f"{n} {k}" for k, n in d["failures"].items() if n)
    return f"{d['successes']}/{d['seedlings']}, seed {d['seed']}: {kinds}"


def z_low_22_strike(runs: Runs) -> str:
    """The first lost-step event of the 22 mm trial, in full steps (16 microsteps each)."""
    events = _z22(runs)["lost_step_events"]
    return f"a motor loses {abs(events[0]['microsteps']) // 16} full steps"


def _calibrated(runs: Runs, seeds: str) -> str:
    d = runs.cli(["trial", "paper_calibrated", "--seeds", seeds, "--quiet"], json_out=True)[1]
    return f"{100 * d['pooled']['success_rate']:.1f} %"


def calibrated_seeds_1_3(runs: Runs) -> str:
    """`transplanter trial paper_calibrated --seeds 1-3`: the pooled rate."""
    return _calibrated(runs, "1-3")


def calibrated_seeds_4_6(runs: Runs) -> str:
    """`transplanter trial paper_calibrated --seeds 4-6`: the pooled rate (held out)."""
    return _calibrated(runs, "4-6")


def ik_example(runs: Runs) -> str:
    """`transplanter ik 0 200`."""
    return _fenced(runs.cli(["ik", "0", "200"])[0].rstrip("\n"))


def plan_example(runs: Runs) -> str:
    """`transplanter plan scenarios/example.gcode`."""
    gcode = README.parent / "scenarios" / "example.gcode"
    text = runs.cli(["plan", str(gcode)])[0].rstrip("\n")
    return _fenced(text)


def zlow_sweep(runs: Runs) -> str:
    """The settings table of the README's z_low sweep (20:44:4, seeds 1-3, 40 seedlings)."""
    return _fenced(runs.sweep("taught.z_low_mm=20:44:4"))


def zlow_sweep_quick(runs: Runs) -> str:
    """The 32 mm row of the same sweep alone (the same setting and seeds give the same row;
    `check` compares the columns it has: the table's failure columns depend on every row)."""
    return _fenced(runs.sweep("taught.z_low_mm=32"))


def zlow_24_per_seed(runs: Runs) -> str:
    """The 24 mm trials of the z_low sweep, seed by seed: '8, 7 and 9 of 40'."""
    runs.sweep("taught.z_low_mm=20:44:4")
    rows = sorted(
        (r for r in runs.sweep_runs() if r["taught.z_low_mm"] == 24.0), key=lambda r: r["seed"]
    )
    counts = [str(r["successes"]) for r in rows]
    return f"{', '.join(counts[:-1])} and {counts[-1]} of {rows[0]['seedlings']}"


@dataclass(frozen=True)
class Block:
    name: str
    make: Callable[[Runs], str]
    command: str  # the README's command the text comes from
    quick: bool = False  # run by --quick
    # lines whose numbers measure the computer, not the twin: shown, never compared
    volatile: tuple[str, ...] = ()
    # --quick: a function giving the block's text in part (the lines it gives replace the
    # README's lines that start with the same first field)
    partial: Callable[[Runs], str] | None = None


BLOCKS = {
    b.name: b
    for b in (
        Block("paper_trial", paper_trial, "transplanter trial paper", quick=True,
              volatile=("wall time", "real-time factor")),
        Block("paper_shoot_bend", paper_shoot_bend, "transplanter trial paper", quick=True),
        Block("calibrated_seeds_1_3", calibrated_seeds_1_3,
              "transplanter trial paper_calibrated --seeds 1-3"),
        Block("calibrated_seeds_4_6", calibrated_seeds_4_6,
              "transplanter trial paper_calibrated --seeds 4-6"),
        Block("z_low_22_strike", z_low_22_strike,
              "transplanter trial paper --set taught.z_low_mm=22 --seedlings 20", quick=True),
        Block("z_low_22", z_low_22,
              "transplanter trial paper --set taught.z_low_mm=22 --seedlings 20", quick=True),
        Block("ik_example", ik_example, "transplanter ik 0 200", quick=True),
        Block("plan_example", plan_example, "transplanter plan scenarios/example.gcode",
              quick=True),
        Block("pgf_vs_trial", pgf_vs_trial, "transplanter trial paper", quick=True),
        Block("zlow_sweep", zlow_sweep,
              "transplanter sweep paper --vary taught.z_low_mm=20:44:4 --seeds 1-3 "
              "--seedlings 40 --workers 2 --out results/zlow",
              partial=zlow_sweep_quick),
        Block("zlow_24_per_seed", zlow_24_per_seed, "the same sweep, runs.jsonl"),
    )
}  # fmt: skip


# --- comparing and rewriting -----------------------------------------------------------------


def _first_field(line: str) -> str:
    parts = line.split()
    return parts[0] if parts else ""


def _common(body: str, widths: dict[str, int]) -> str:
    """The lines of `body` whose first field is in `widths`, each cut to that many words."""
    return "\n".join(
        " ".join(line.split()[: widths[_first_field(line)]])
        for line in body.split("\n")
        if _first_field(line) in widths
    )


def keep_volatile(block: Block, old: str, new: str) -> str:
    """`new` with the README's own lines for the block's volatile lines (a wall time measured
    on a busy machine is no news)."""
    kept = {v: line for line in old.split("\n") for v in block.volatile if line.startswith(v)}
    return "\n".join(
        next((kept[v] for v in block.volatile if line.startswith(v) and v in kept), line)
        for line in new.split("\n")
    )


@dataclass
class Finding:
    block: str
    context: str
    readme: str
    twin: str
    compared: bool

    @property
    def differs(self) -> bool:
        return self.compared and self.readme != self.twin


def compare(block: Block, old: str, new: str) -> list[Finding]:
    """Every number of `old` (the README's text) against `new` (the twin's), line by line; a
    line of `new` missing from `old` or the other way round is a difference too."""
    findings: list[Finding] = []
    old_lines, new_lines = old.strip("\n").split("\n"), new.strip("\n").split("\n")
    for i in range(max(len(old_lines), len(new_lines))):
        o = old_lines[i] if i < len(old_lines) else ""
        n = new_lines[i] if i < len(new_lines) else ""
        volatile = any(o.startswith(v) or n.startswith(v) for v in block.volatile)
        o_nums, n_nums = NUMBER_RE.findall(o), NUMBER_RE.findall(n)
        line = (n or o).strip()
        label = NUMBER_RE.split(line)[0].strip()
        if not label and len(new_lines) > 1:
            label = f"row {_first_field(line)}"
        if o_nums == n_nums and not volatile and NUMBER_RE.sub("#", o) != NUMBER_RE.sub("#", n):
            findings.append(Finding(block.name, f"{label} (words)", o.strip(), n.strip(), True))
            continue
        for j in range(max(len(o_nums), len(n_nums))):
            findings.append(
                Finding(
                    block.name,
                    f"{label} #{j + 1}".strip() if len(n_nums) > 1 else label,
                    o_nums[j] if j < len(o_nums) else "(none)",
                    n_nums[j] if j < len(n_nums) else "(none)",
                    not volatile,
                )
            )
    return findings


def check(text: str, quick: bool, runs: Runs) -> tuple[list[Finding], str, list[str]]:
    """The findings, the README text with the twin's numbers, and the problems with the
    markers."""
    found = {m["name"]: m for m in BLOCK_RE.finditer(text)}
    problems = [f"README block {n!r} is not one of the script's" for n in found if n not in BLOCKS]
    problems += [f"no README block {n!r}" for n in BLOCKS if n not in found]
    if problems:
        return [], text, problems
    findings: list[Finding] = []
    replacements: dict[str, str] = {}
    for name, block in BLOCKS.items():
        old = found[name]["body"]
        if quick and not block.quick:
            if block.partial is None:
                continue
            part = block.partial(runs)
            # a partial run's line holds the columns common to every run (the table's failure
            # columns depend on the other rows): compare those words only, keep the README's
            widths = {_first_field(line): len(line.split()) for line in part.splitlines()}
            widths = {k: n for k, n in widths.items() if k not in ("", "```")}
            findings += compare(block, _common(old, widths), _common(part, widths))
            new = old
        else:
            new = block.make(runs)
            findings += compare(block, old, new)
            new = keep_volatile(block, old, new)
        replacements[name] = new

    def put(m: re.Match) -> str:
        body = replacements.get(m["name"], m["body"])
        return f"<!-- readme_numbers: {m['name']} -->{body}<!-- /readme_numbers -->"

    return findings, BLOCK_RE.sub(put, text), []


def write_atomically(path: Path, text: str) -> None:
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        os.chmod(tmp, path.stat().st_mode & 0o777)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="the cheap subset (CI)")
    parser.add_argument("--update", action="store_true", help="rewrite README.md's numbers")
    parser.add_argument("--readme", type=Path, default=README, help="default: the repo's")
    parser.add_argument(
        "--sweep-out", type=Path, default=None, help="keep the sweep's files here (a rerun resumes)"
    )
    parser.add_argument("--all", action="store_true", help="print equal numbers too")
    args = parser.parse_args(argv)

    text = args.readme.read_text(encoding="utf-8")
    with tempfile.TemporaryDirectory(prefix="readme_numbers_") as scratch:
        runs = Runs(Path(scratch), args.sweep_out)
        findings, new_text, problems = check(text, args.quick, runs)
    for p in problems:
        print(f"error: {p}", file=sys.stderr)
    if problems:
        return 2
    width = max((len(f.block) + len(f.context) for f in findings), default=20) + 3
    print(f"{'number':<{width}}  {'README':>10}  {'twin now':>10}")
    for f in findings:
        mark = "DIFF" if f.differs else ("" if f.compared else "(not compared: the computer)")
        if f.differs or args.all or not f.compared:
            where = f"{f.block}: {f.context}"
            print(f"{where:<{width}}  {f.readme:>10}  {f.twin:>10}  {mark}".rstrip())
    stale = [f for f in findings if f.differs]
    blocks = sorted({f.block for f in stale})
    print(
        f"{len(findings)} numbers in {len({f.block for f in findings})} blocks"
        f"{' (quick)' if args.quick else ''}: {len(stale)} differ"
        + (f" (in {', '.join(blocks)})" if blocks else "")
    )
    if args.update and new_text != text:
        if args.readme.read_text(encoding="utf-8") != text:
            print(
                f"error: {args.readme} changed while the commands ran; run again", file=sys.stderr
            )
            return 2
        write_atomically(args.readme, new_text)
        print(f"rewrote {args.readme}")
        return 0
    return 1 if stale else 0


if __name__ == "__main__":
    sys.exit(main())
