"""The CPU time a device measured itself spending (STATUS, protocol 1.2): cycles of one
sample's acquisition and of one decode, from its cycle counter (DWT CYCCNT on the STM32F411).

A device without a counter (the simulator, QEMU) reports a rate of 0 Hz: its figures are then
"not measured", never a number; a 1.1 device does not report them at all.

>>> from spectratac.protocol.generated import messages as m
>>> c = CycleFigures.from_status(m.Status(cycle_hz=96_000_000, acq_cycles_last=96_000,
...     acq_cycles_max=120_000, decode_cycles_last=940_800, decode_cycles_max=960_000), 2)
>>> c.describe()
['acquisition      96,000 cycles a sample (1.000 ms at 96 MHz), max 120,000 (1.250 ms)', \
'decoding         940,800 cycles a decode (9.800 ms), max 960,000 (10.000 ms)']
>>> CycleFigures.from_status(m.Status(), 2).describe()
['cycle counts     not measured (the device has no cycle counter)']
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from spectratac.protocol.generated import messages as m

#: the protocol minor version that added the cycle fields to STATUS
SINCE_MINOR = 2


@dataclass(frozen=True)
class CycleFigures:
    """What STATUS says about the device's own CPU time; `measured` False: no figures."""

    reported: bool  # the device's protocol has the fields
    cycle_hz: int  # 0: no counter, not measured
    acq_last: int
    acq_max: int
    decode_last: int
    decode_max: int

    @classmethod
    def from_status(cls, status: m.Status, protocol_minor: int) -> CycleFigures:
        return cls(
            protocol_minor >= SINCE_MINOR,
            status.cycle_hz,
            status.acq_cycles_last,
            status.acq_cycles_max,
            status.decode_cycles_last,
            status.decode_cycles_max,
        )

    @property
    def measured(self) -> bool:
        return self.reported and self.cycle_hz > 0

    def _ms(self, cycles: int) -> float:
        return cycles / self.cycle_hz * 1e3

    def as_dict(self) -> dict[str, Any]:
        """For --json: the figures in cycles and ms, or measured False and why not."""
        if not self.measured:
            why = "no cycle counter" if self.reported else "firmware older than protocol 1.2"
            return {"measured": False, "why": why}
        return {
            "measured": True,
            "cycle_hz": self.cycle_hz,
            "acquisition": {"last_cycles": self.acq_last, "max_cycles": self.acq_max,
                            "last_ms": self._ms(self.acq_last),
                            "max_ms": self._ms(self.acq_max)},
            "decode": None if self.decode_max == 0 else {
                "last_cycles": self.decode_last, "max_cycles": self.decode_max,
                "last_ms": self._ms(self.decode_last), "max_ms": self._ms(self.decode_max)},
        }  # fmt: skip

    def describe(self) -> list[str]:
        """Lines for `spectratac info`."""
        if not self.reported:
            return ["cycle counts     not reported (firmware older than protocol 1.2)"]
        if not self.measured:
            return ["cycle counts     not measured (the device has no cycle counter)"]
        mhz = self.cycle_hz / 1e6
        lines = [
            f"acquisition      {self.acq_last:,} cycles a sample ({self._ms(self.acq_last):.3f} "
            f"ms at {mhz:g} MHz), max {self.acq_max:,} ({self._ms(self.acq_max):.3f} ms)"
        ]
        if self.decode_max == 0:
            lines.append("decoding         no decode since boot or RESET_STATS")
        else:
            lines.append(
                f"decoding         {self.decode_last:,} cycles a decode "
                f"({self._ms(self.decode_last):.3f} ms), max {self.decode_max:,} "
                f"({self._ms(self.decode_max):.3f} ms)"
            )
        return lines
