# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#     text_representation:
#       extension: .py
#       format_name: percent
#   kernelspec:
#     display_name: Python 3
#     language: python
#     name: python3
# ---

# %% [markdown]
# # Which arm for my line? The three machines side by side
#
# The five-bar of the paper trial, the serial servo arm on the same pot line and the rotary
# delta on its plug trays, each run over the same seeds and judged as `transplanter trial`
# judges it. `transplanter compare` pools each machine's trials into one row: success with
# its 95 % interval, cycle (or the delta's time per operation), plants per hour, damage, the
# drives' peak torque, their work per seedling and what they cost. `NOTEBOOK_SEEDLINGS` keeps
# it small here (and the delta services one cell a tray, graded from the truth); the command
# line equivalent of docs/compare.md's table is
#
# ```sh
# MUJOCO_GL=egl transplanter compare paper serial_arm_pots delta_refill --seeds 1-3 \
#     --seedlings 40 --out results/compare --workers 2
# ```

# %%
import json
import os
from pathlib import Path

from IPython.display import Image, display

from transplanter.studies.compare import CompareSpec, run_compare

SEEDLINGS = int(os.environ.get("NOTEBOOK_SEEDLINGS", "10"))
OUT = Path(os.environ.get("NOTEBOOK_OUT", "results")) / f"compare_arms_{SEEDLINGS}"

spec = CompareSpec(
    ("paper", "serial_arm_pots", "delta_refill"),
    seeds=(1,),
    seedlings=SEEDLINGS,
    overrides={"delta_refill.max_cells": 1, "delta_refill.vision": "truth"},  # the delta's only
    success_floor=0.9,
)
report = run_compare(spec, OUT, backend="inline")
print(report.table)

# %% [markdown]
# Each row, as `compare.json` holds it: the pooled success rate with its interval, and the
# drives' numbers from MuJoCo's actuator forces and velocities.

# %%
for row in report.rows:
    lo, hi = row["ci95"]
    print(
        f"{row['rank']}. {row['scenario']} ({row['robot']}, {row['effector']}): success rate "
        f"{100 * row['success_rate']:.0f} % ({row['successes']}/{row['seedlings']} "
        f"{row['unit']}, 95 % CI {100 * lo:.0f}-{100 * hi:.0f} %), {row['plants_per_hour']:.0f} "
        f"plants/h, drives {row['energy_per_seedling_j']:.2f} J a seedling, peak "
        f"{row['peak_motor_torque_nm']:.3f} N m"
    )
print(json.dumps(sorted(report.rows[0]), indent=None))

# %%
display(Image(filename=str(report.plot)))
