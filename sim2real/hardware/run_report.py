"""What a run reports: the loop's counts and timings, how it stopped, and the torque read back.

:func:`sim2real.hardware.deploy.drive` returns a :class:`RunReport`; the real-time loop
(:mod:`sim2real.hardware.loop`) counts into it and the safe stop (:mod:`sim2real.hardware.safe_stop`)
fills in the stop and :class:`TorqueOff`.  :meth:`RunReport.summary` is what ``biped run --json``
prints.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np


@dataclass
class TorqueOff:
    """Servos whose Torque Enable read back 0 after the stop, and those that did not answer
    (or still read 1): power to those must be cut by hand."""

    confirmed: list[int] = field(default_factory=list)
    unconfirmed: list[int] = field(default_factory=list)


@dataclass
class RunReport:
    ticks: int = 0
    overruns: int = 0
    bus_errors: int = 0
    retries: int = 0  # reads repeated within a tick
    missed_ticks: int = 0  # ticks without a good read: the last goals were held
    corrupt_replies: int = 0  # failed reads whose reply came but was corrupt
    stop_reason: str = ""
    stop_signal: str | None = None  # the signal that stopped the run (e.g. "SIGINT"), if one did
    stop_notes: list[str] = field(default_factory=list)
    torque_off: TorqueOff | None = None
    realtime: dict[str, Any] | None = None
    task: dict[str, Any] = field(default_factory=dict)  # the goal source's own report (GoalSource.task_report)
    compute_s: list[float] = field(default_factory=list)
    jitter_s: list[float] = field(default_factory=list)

    def summary(self) -> dict[str, Any]:
        def pct(values, q, scale):
            return float(np.percentile(values, q) * scale) if values else None

        torque = None if self.torque_off is None else {"confirmed": self.torque_off.confirmed,
                                                       "unconfirmed": self.torque_off.unconfirmed}
        return {"ticks": self.ticks, "overruns": self.overruns, "bus_errors": self.bus_errors,
                "retries": self.retries, "missed_ticks": self.missed_ticks, "corrupt_replies": self.corrupt_replies,
                "stop_reason": self.stop_reason, "stop_signal": self.stop_signal, "stop_notes": self.stop_notes,
                "torque_off": torque,
                "compute_us_p50": pct(self.compute_s, 50, 1e6), "compute_us_p99": pct(self.compute_s, 99, 1e6),
                "jitter_ms_p99": pct(self.jitter_s, 99, 1e3), "realtime": self.realtime, **self.task}
