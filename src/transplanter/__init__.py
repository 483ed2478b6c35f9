"""MuJoCo digital twin of robotic seedling transplanters, driven by their own firmware.

The package follows the data: ``scenario`` (schema, assembly, preflight) -> ``machine`` (the
pure-numpy firmware side: kinematics, G-code, motion, drives, homing, SGF/PGF, bus) ->
``scene`` (the MuJoCo model of robot, workcell and effector) -> ``twin`` (firmware and physics
stepped together, the judge, a trial's results) -> ``viewing`` and ``studies``; ``cli`` is the
command line. The names below are the public API; each is imported when first used, so
``import transplanter`` loads neither MuJoCo nor the firmware.
"""

from __future__ import annotations

import importlib

__version__ = "0.1.0"

_API = {
    "load_scenario": "transplanter.scenario.schema",
    "Scenario": "transplanter.scenario.schema",
    "ScenarioError": "transplanter.scenario.schema",
    "assemble": "transplanter.scenario.assemble",
    "machine_config": "transplanter.scenario.assemble",
    "TwinConfig": "transplanter.scenario.assemble",
    "check_machine": "transplanter.scenario.preflight",
    "Kinematics": "transplanter.machine.kinematics",
    "kinematics_class": "transplanter.kinds",
    "register": "transplanter.machine.kinematics",
    "UnreachableError": "transplanter.machine.kinematics",
    "Machine": "transplanter.machine.config",
    "SGF": "transplanter.machine.sgf",
    "SGFConfig": "transplanter.machine.sgf",
    "plan_program": "transplanter.machine.planner",
    "Twin": "transplanter.twin.sim",
    "run_trial": "transplanter.twin.trial",
    "TrialResult": "transplanter.twin.results",
    "Outcome": "transplanter.twin.results",
    "pooled_rate": "transplanter.studies.stats",
    "run_sweep": "transplanter.studies.sweep",
    "run_scenario": "transplanter.studies.run",
    "run_job": "transplanter.studies.run",
    "TrialFailed": "transplanter.studies.run",
    "TransplanterError": "transplanter.errors",
    "Refusal": "transplanter.errors",
    "RefusalReason": "transplanter.errors",
    "ErrorCode": "transplanter.errors",
}

__all__ = ["__version__", *_API]


def __getattr__(name: str):
    if name in _API:
        value = getattr(importlib.import_module(_API[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'transplanter' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(__all__)
