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
# # The paper trial, step by step
#
# Runs the paper scenario through the whole twin (PGF -> bus -> SGF -> MuJoCo) and looks at
# the per-seedling results. This is a jupytext notebook: open it in Jupyter with jupytext, or
# run it as a script (`python notebooks/paper_trial.py`); the test suite executes it.

# %%
import os

from transplanter.config import assemble
from transplanter.report import format_summary
from transplanter.scenario import load_scenario
from transplanter.trial import run_trial

SEEDLINGS = int(os.environ.get("NOTEBOOK_SEEDLINGS", "10"))

config = assemble(load_scenario("paper", {"scenario.seedlings": SEEDLINGS}))
result = run_trial(config)
print(format_summary(result))

# %% [markdown]
# Cycle time per pickup position: the outer cells (x = +-90 mm) are farther from the drop
# point.

# %%
for rec in result.per_seedling:
    print(
        rec.index,
        rec.pickup,
        rec.outcome,
        f"{rec.cycle_time_s:.3f} s",
        f"{rec.peak_grip_force_n:.1f} N",
        "leaves hit" if rec.leaves_hit else "",
    )

# %% [markdown]
# Tune before touching hardware: a faster S_h, or a lower approach height (Z_low).

# %%
for over in ({"taught.s_high_mm_s": 250.0}, {"taught.z_low_mm": 22.0}):
    scenario = load_scenario("paper", {"scenario.seedlings": SEEDLINGS, **over})
    d = run_trial(assemble(scenario)).to_dict()
    print(over, f"cycle {d['cycle_time_s']:.3f} s, success {100 * d['success_rate']:.0f} %")
