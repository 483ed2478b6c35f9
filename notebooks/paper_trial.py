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

from transplanter.scenario.assemble import assemble
from transplanter.scenario.schema import load_scenario
from transplanter.twin.report import format_summary
from transplanter.twin.trial import run_trial

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
# The same in a picture: each seedling's cycle time, coloured by its outcome.

# %%
import matplotlib.pyplot as plt  # noqa: E402
from IPython.display import display  # noqa: E402

fig, ax = plt.subplots(figsize=(7, 3))
ok = [r.outcome == "success" for r in result.per_seedling]
ax.bar(
    [r.index for r in result.per_seedling],
    [r.cycle_time_s or 0.0 for r in result.per_seedling],
    color=["tab:green" if good else "tab:red" for good in ok],
)
ax.axhline(3.5, color="k", lw=0.8, ls="--", label="paper: 3.5 s")
ax.set_xlabel("seedling")
ax.set_ylabel("cycle time (s)")
ax.legend(loc="lower right")
display(fig)
plt.close(fig)

# %% [markdown]
# Tune before touching hardware: a faster S_h, or a lower approach height (Z_low).

# %%
for over in ({"taught.s_high_mm_s": 250.0}, {"taught.z_low_mm": 22.0}):
    scenario = load_scenario("paper", {"scenario.seedlings": SEEDLINGS, **over})
    d = run_trial(assemble(scenario)).to_dict()
    print(over, f"cycle {d['cycle_time_s']:.3f} s, success {100 * d['success_rate']:.0f} %")
