"""Seed 002's cull and refill: a 128-cell planting tray graded by vision, its inferior
seedlings pulled to a bin and every hole refilled from a supply tray."""

from __future__ import annotations

from transplanter.kinds.interfaces import ALL

NAME = "plug_trays"
SUMMARY = "cull inferior plug seedlings to a bin and refill from a supply tray (seed 002)"
WORKCELL = "transplanter.scene.workcells.plug_trays"
UNIT = "cells"
RUN = "transplanter.runs.plug_trays"
UNITS_KEY = "delta_refill.max_cells"


def uses_robot() -> bool:
    return True


_OUT_OF_REACH = ("fivebar", "serial4")
"""Robots whose workspace misses the trays (the five-bar's 200 x 120 mm, the serial arm's
reach of 160 mm against two 566 x 286 mm trays)."""


def refusal(robot: str, effector: str) -> str | None:
    if robot in _OUT_OF_REACH:
        return (
            "the trays (two 566 x 286 mm trays and a bin) lie outside the "
            f"{robot} robot's workspace; the delta's scene alone hangs over them"
        )
    if robot != "delta":
        return (
            f"no host program drives the {robot} robot on the trays: their host "
            "(twin.delta_refill) drives the delta's own controller"
        )
    if effector != "plug_claws":
        return "the trays' plugs are pulled by the plug_claws effector only"
    return None


def reads(robot: str, effector: str) -> dict:
    return {
        "delta_refill": ALL,
        "plugs": ALL,
        "vision": ALL,
        "bus": ("baud_bps",),
        "physics": ("timestep_ms",),
    }


def runner(robot: str) -> str:
    return "transplanter.twin.delta_refill:run_delta_refill"
