"""The claws' bench run (`[workcell] kind = "plug_bench"`, seed 002's claw tests): one run of
`scenario.seedlings` picks per seed, each plug drawn in its moisture band, moved by the
bench itself (`transplanter.twin.plug_bench_trial`); its scene is the bench's own, so it is
neither filmed, viewed, recorded nor exported (its picks are the numbers: `--json`)."""

from __future__ import annotations

import math
from typing import Any

from transplanter.twin.plug_bench_trial import DEFINITIONS

__all__ = [
    "DEFINITIONS", "FILMED", "REFUSED_OPTIONS", "UNIT",
    "check", "export", "filmer", "line", "pool", "recorder", "row", "run", "study", "summary",
    "total", "viewer",
]  # fmt: skip

FILMED = ""
UNIT = "seedling"
_NONE = "the claws' bench builds a scene of its own for each pick (docs/plug_claws.md)"
REFUSED_OPTIONS = {
    "--clips-of-failures": f"--clips-of-failures: not available for the claws' bench: {_NONE}",
    "--eeprom": "--eeprom: not available for the claws' bench: it has no taught cycle",
    "--no-preflight": "--no-preflight: the claws' bench has no taught points to check",
    "--seedlings-of": f"render refused: {_NONE}",
    "--cells-of": f"render refused: {_NONE}",
}


def _refuse(what: str):
    from transplanter.scenario.schema import ScenarioError

    raise ScenarioError(f"{what}: not available for the claws' bench: {_NONE}")


def check(scenario) -> None:
    from transplanter.scenario.assemble import require_awake, require_kinds

    require_awake(scenario, "the claws' bench")
    require_kinds(
        scenario, "the claws' bench", None, "plug_claws",
        "the bench pulls plugs with the plug claws and moves them itself, no robot",
    )  # fmt: skip


def total(scenario) -> int:
    return scenario.meta.seedlings


def run(scenario, seed, *, progress=None, observers=()):
    from transplanter.twin.plug_bench_trial import run_bench_trial

    if observers:
        _refuse("observing a run")
    return run_bench_trial(scenario, seed, progress=progress)


def line(r) -> str:
    ret = "-" if r.substrate_retention is None else f"{100 * r.substrate_retention:.1f} %"
    return (
        f"seed {r.seed}: {r.successes}/{r.seedlings} seedlings arrived "
        f"({100 * r.success_rate:.1f} %), dropped {r.dropped}, substrate retention {ret}, "
        f"leaf damage {100 * r.leaf_damage_rate:.1f} %, {r.cycle_time_s:.3f} s per pick, "
        f"moisture drawn {r.moisture_pct:.1f} % on average; wall {r.wall_time_s:.1f} s"
    )


summary = line


def pool(results, pooled) -> tuple[dict[str, Any], list[str]]:
    payload: dict[str, Any] = {}
    for name in ("cycle_time_s", "leaf_damage_rate"):
        values = [getattr(r, name) for r in results if math.isfinite(getattr(r, name))]
        payload[f"mean_{name}"] = sum(values) / len(values) if values else None
    from transplanter.runs import pooled_line

    return payload, [pooled_line(pooled, "seedlings arrived")]


def study(scenario) -> dict[str, Any]:
    return {
        "kind": "plug_bench",
        "fields": ("substrate_retention", "leaf_damage_rate", "dropped", "moisture_pct_drawn"),
        "means": ("substrate_retention", "leaf_damage_rate", "moisture_pct_drawn"),
        "sections": ("plugs", "plug_claws", "plug_bench"),
    }


def row(scenario, seed: int, out: dict[str, Any]) -> None:
    r = run(scenario, seed)
    out.update(
        successes=r.successes,
        seedlings=r.seedlings,
        success_rate=r.success_rate,
        cycle_time_s=r.cycle_time_s,
        cycle_time_sd_s=r.cycle_time_sd_s,
        cycles=r.seedlings,
        valid=True,
        wall_time_s=r.wall_time_s,
        warnings="",
        substrate_retention=r.substrate_retention,
        leaf_damage_rate=r.leaf_damage_rate,
        dropped=r.dropped,
        moisture_pct_drawn=r.moisture_pct,
    )


def recorder(scenario, path, rate_hz: float):
    _refuse("--record")


def filmer(scenario, target, size, fps, camera, shadows, subset):
    _refuse("render")


def viewer(scenario, speed: float):
    _refuse("view")


def export(scenario, target):
    _refuse("export")
