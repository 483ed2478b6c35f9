"""The claws' test bench as a job (`[workcell] kind = "plug_bench"`): a run is
`scenario.seedlings` picks, one seedling each, on the bench of `transplanter.scene.plug_bench`,
as the end-effector tests of Zhao, Cheng, Dong, Ma, Xiong and Tong (*Research on the End
Effector and Optimal Motion Control Strategy for a Plug Seedling Transplanting Parallel Robot*,
Agriculture 2022, Sec. 2.2: 64 seedlings a run).

The run's seedlings are drawn from its seed, so that a run has a success rate, not a 0/1:

- each seedling is a healthy seedling of `plug_tray.draw_tray(seed)` (more trays, seed +
  k x 1000003, when one has too few), its leaves moved to the bench's cell;
- its plug's moisture is drawn uniformly in `plugs.moisture_pct` +- `plug_bench.
  moisture_band_pct` / 2 (the paper's factor levels are 10 % bands: 60-70, 70-80, 80-90 %);
- its vigour v, drawn normal with mean 1 and `plug_bench.vigour_cv_pct` (at least 0.2), scales
  its root growth: the roots bind as those of a seedling of age onset + v (age - onset)
  (`plugs.root_onset_d`), a seedling bigger or smaller than its sowing's mean;
- the rotary setting is the one the delta's job takes (`delta_refill.rotary_for`: across the
  narrower side with pose judgement, `fixed_rotary_deg` without).

Each pick: rotate, come down, extend, lift at `extraction_accel_m_s2` (the paper's factor C),
move to the target cell, lower, strip (`plug_bench.run_pick`). A seedling is a success
when its plug arrives seated in the target cell (the paper's healthy-seedling success: not
dropped); its retention is the mass delivered over the mass before (the paper's substrate
retention). Deterministic: the same scenario and seed give the same result.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from transplanter.scenario.assemble import require_awake
from transplanter.scene.plug_tray import draw_tray

__all__ = ["BenchRunResult", "run_bench_trial"]

TRAY_SEED_STEP = 1000003
"""The k-th extra tray of a run with more seedlings than one tray's healthy ones: seed + k x
this."""

DEFINITIONS = {
    "success_rate": "seedlings whose plug arrived seated in the target cell / seedlings "
    "(the paper's healthy-seedling transplanting success: not dropped / transplanted)",
    "substrate_retention": "mean over the arrived plugs of mass after / mass before (the "
    "paper's substrate retention)",
    "cycle_time_s": "mean time of one pick, from the first motion to the claws' release",
    "leaf_damage_rate": "seedlings with a leaf torn by a claw or the stripper / seedlings",
}


@dataclass
class BenchRunResult:
    seed: int
    seedlings: int
    successes: int
    dropped: int
    substrate_retention: float | None
    leaf_damage_rate: float
    cycle_time_s: float
    cycle_time_sd_s: float
    moisture_pct: float
    """Mean of the drawn moistures."""
    wall_time_s: float
    picks: list[dict[str, Any]] = field(default_factory=list)
    valid: bool = True  # what `transplanter trial` asks of every result
    fault: str | None = None
    recording_error: str | None = None

    @property
    def success_rate(self) -> float:
        return self.successes / self.seedlings

    def to_dict(self) -> dict[str, Any]:
        return {
            "trial": "plug_bench",
            "seed": self.seed,
            "seedlings": self.seedlings,
            "successes": self.successes,
            "success_rate": self.success_rate,
            "dropped": self.dropped,
            "substrate_retention": self.substrate_retention,
            "leaf_damage_rate": self.leaf_damage_rate,
            "cycle_time_s": self.cycle_time_s,
            "cycle_time_sd_s": self.cycle_time_sd_s,
            "moisture_pct": self.moisture_pct,
            "picks": self.picks,
            "wall_time_s": self.wall_time_s,
            "definitions": DEFINITIONS,
        }


def _seedlings(seed: int, n: int):
    """n healthy seedlings (cell, geometry) of the trays drawn from `seed`."""
    from transplanter.twin.delta_refill import HEALTHY_CLASSES

    out = []
    k = 0
    while len(out) < n:
        tray = draw_tray(seed + k * TRAY_SEED_STEP)
        out += [(c, tray.geometry) for c in tray.cells if c.truth in HEALTHY_CLASSES]
        k += 1
    return out[:n]


def run_bench_trial(sc, seed: int | None = None, progress=None) -> BenchRunResult:
    """One run of the scenario `sc` ([plugs], [plug_claws], [plug_bench], its seedlings) with
    seed `seed` (default the scenario's); `progress(done, sim_t)` after each pick (the
    simulated time of the picks so far)."""
    require_awake(sc, "the claws' bench")
    from transplanter.scenario.assemble import claws_config, plugs_config, require_kinds

    require_kinds(
        sc, "the claws' bench", None, "plug_claws",
        "the bench pulls plugs with the plug claws and moves them itself, no robot",
    )  # fmt: skip
    from transplanter.scene.plug_bench import BenchConfig, centred_seedling, run_pick
    from transplanter.twin.delta_grading import truth_cell
    from transplanter.twin.delta_refill import rotary_for

    wall0 = time.perf_counter()
    seed = sc.seed if seed is None else seed
    job = sc.plug_bench
    plugs, claws = plugs_config(sc), claws_config(sc)
    n = sc.meta.seedlings
    half = job.moisture_band_pct / 2
    moisture, vigour = np.zeros(n), np.zeros(n)
    for i in range(n):  # seedling i's own stream: the first seedlings of a longer run are these
        rng = np.random.default_rng([seed, 2, i])  # (the trays are drawn from `seed` itself)
        moisture[i] = rng.uniform(plugs.moisture_pct - half, plugs.moisture_pct + half)
        vigour[i] = max(rng.normal(1.0, job.vigour_cv_pct / 100), 0.2)
    fixed = math.degrees(job.fixed_rotary_rad)
    bench = BenchConfig(
        extraction_accel_m_s2=job.extraction_accel_m_s2,
        move_accel_m_s2=job.move_accel_m_s2,
        timestep_ms=job.timestep_s * 1e3,
    )
    picks: list[dict[str, Any]] = []
    for i, (cell, geometry) in enumerate(_seedlings(seed, n)):
        grown = max(plugs.age_d - plugs.root_onset_d, 0.0) * float(vigour[i])
        plug = replace(plugs, moisture_pct=float(moisture[i]), age_d=plugs.root_onset_d + grown)
        rotary = rotary_for(truth_cell(cell, geometry), job.pose_judgement, fixed)
        r = run_pick(
            plug, claws, replace(bench, rotary_deg=rotary), centred_seedling(cell, geometry)
        )
        picks.append(
            {
                "cell": cell.index,
                "truth": cell.truth,
                "moisture_pct": round(float(moisture[i]), 6),
                "vigour": round(float(vigour[i]), 6),
                "rotary_deg": rotary,
                "arrived": bool(r.held and r.in_target),
                "held": r.held,
                "retention": round(r.retention, 6),
                "peak_load_n": round(r.peak_load_n, 5),
                "pin_capacity_n": round(r.pin_capacity_n, 5),
                "leaf_damage": len(r.leaf_damage),
                "time_s": round(r.times_s["released"], 6),
            }
        )
        if progress is not None:
            progress(i + 1, sum(p["time_s"] for p in picks))
    arrived = [p for p in picks if p["arrived"]]
    times = np.array([p["time_s"] for p in picks])
    return BenchRunResult(
        seed=seed,
        seedlings=n,
        successes=len(arrived),
        dropped=sum(1 for p in picks if not p["held"]),
        substrate_retention=float(np.mean([p["retention"] for p in arrived])) if arrived else None,
        leaf_damage_rate=sum(1 for p in picks if p["leaf_damage"]) / n,
        cycle_time_s=float(times.mean()),
        cycle_time_sd_s=float(times.std(ddof=1)) if n > 1 else 0.0,
        moisture_pct=float(moisture.mean()),
        wall_time_s=time.perf_counter() - wall0,
        picks=picks,
    )
