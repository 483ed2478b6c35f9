"""The SGF at the other end of the COM bus, as the HMI drives it: one line at a time on a
simulated clock (``rig.DirectLink``), its position read with ``M114``."""

from __future__ import annotations

import re

import numpy as np

from transplanter.machine.config import power_on_joints
from transplanter.machine.rig import DirectLink, SimulatedEndstops
from transplanter.machine.sgf import SGF, SGFConfig
from transplanter.units import M_PER_MM

__all__ = ["SGFPort"]

_M114 = re.compile(
    r"X:(?P<x>\S+) Y:(?P<y>\S+) Z:(?P<z>\S+) A:(?P<a>-?\d+) B:(?P<b>-?\d+) C:(?P<c>-?\d+)"
)


class SGFPort(DirectLink):
    """A real SGF on a simulated clock, one line at a time (the PGF's side of the COM bus,
    without the bus's timing): ``send`` delivers a line and advances the clock until the
    SGF has answered it (``ok`` or ``error:N``), reading the limit switches of
    ``rig.SimulatedEndstops`` (the motors start at ``config.power_on_joints``); RuntimeError
    (``rig.NoAnswer``) if it would answer only after ``max_time_s``."""

    def __init__(self, config: SGFConfig, max_time_s: float = 1e4):
        super().__init__(SGF(config), SimulatedEndstops(config, power_on_joints(config)))
        self.max_time_s = max_time_s
        self.log: list[tuple[float, str, tuple[str, ...]]] = []
        """(t, line, replies) of every line sent."""

    def send(self, line: str, until_s: float | None = None) -> list[str]:
        """The SGF's replies to ``line``, the last one its ``ok`` or ``error:N``."""
        replies = super().send(line, self.max_time_s if until_s is None else until_s)
        self.log.append((self.t, line, tuple(replies)))
        return replies

    def where(self) -> tuple[np.ndarray, np.ndarray] | None:
        """M114: where the SGF says the arm is ((x, y, z) m) and its logical step counters;
        None while it does not know (not homed)."""
        for reply in self.send("M114"):
            m = _M114.match(reply)
            if m and m.group("x") != "nan":
                position = np.array([float(m.group(a)) * M_PER_MM for a in "xyz"])
                steps = np.array([int(m.group(a)) for a in "abc"], dtype=np.int64)
                return position, steps
        return None
