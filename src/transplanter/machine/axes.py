"""An arm's driven joints: each a stepper drive with its homing switch and its window."""

from __future__ import annotations

import math
from dataclasses import dataclass

from transplanter.machine.steppers import StepperDrive

__all__ = ["Axis"]


@dataclass(frozen=True)
class Axis:
    """One driven joint: its stepper drive, where its homing switch trips and its window."""

    name: str
    """Short name ("arm1", "z"); the drive's name by default."""
    drive: StepperDrive
    home_position: float
    """Joint position (rad or m) at which the axis's homing switch trips."""
    window: tuple[float, float]
    """(min, max) joint position the kinematics ever commands (rad or m)."""
    switch_name: str = ""
    """What its homing switch is called in messages ("arm 1 home"); default "<name> home"."""

    def __post_init__(self) -> None:
        lo, hi = self.window
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise ValueError(f"axis {self.name!r}: window must be finite with min < max")
        if not math.isfinite(self.home_position):
            raise ValueError(f"axis {self.name!r}: home_position must be finite")
        if not self.switch_name:
            object.__setattr__(self, "switch_name", f"{self.name} home")

    @property
    def linear(self) -> bool:
        """A slide (joint in m) rather than a rotary joint (rad)."""
        return self.drive.linear
