"""How the device came up (STATUS, protocol 1.4): why it last reset, the fault record that
survived the reset, safe mode, the brown-out level, and the measured flash erase and TRIG
latencies. `spectratac info` prints it; a device older than 1.4 does not report it.

>>> from spectratac.protocol.generated import messages as m
>>> r = BootReport.from_status(m.Status(reset_cause=0x89, fault_pc=0x08001A2C,
...     fault_cfsr=0x10000, fault_hfsr=0x40000000, abnormal_resets=1, bor_level=3), 4)
>>> r.causes, r.fault_present, r.abnormal
(['pin', 'software', 'fault'], True, True)
>>> r.describe()[0]
'reset cause      pin, software, fault (1 abnormal reset in a row)'
>>> BootReport.from_status(m.Status(), 3).describe()
['reset cause      not reported (firmware older than protocol 1.4)']
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from spectratac.protocol.generated import messages as m

#: the protocol minor version that added these fields to STATUS
SINCE_MINOR = 4
#: brown-out level MODEL_BEGIN needs (flash writes need >= 2.7 V)
BOR_LEVEL_FOR_FLASH = 3
#: the reset thresholds of each brown-out level (RM0383, FLASH_OPTCR BOR_LEV)
BOR_VOLTS = {0: "off (~1.7 V POR/PDR only)", 1: "2.1 V", 2: "2.4 V", 3: "2.7 V"}
#: CFSR bits worth naming (ARMv7-M B3.2.15), (bit, name): what the core faulted on
CFSR_BITS: tuple[tuple[int, str], ...] = (
    (0, "IACCVIOL"), (1, "DACCVIOL"), (3, "MUNSTKERR"), (4, "MSTKERR"), (5, "MLSPERR"),
    (7, "MMARVALID"), (8, "IBUSERR"), (9, "PRECISERR"), (10, "IMPRECISERR"), (11, "UNSTKERR"),
    (12, "STKERR"), (13, "LSPERR"), (15, "BFARVALID"), (16, "UNDEFINSTR"), (17, "INVSTATE"),
    (18, "INVPC"), (19, "NOCP"), (24, "UNALIGNED"), (25, "DIVBYZERO"),
)  # fmt: skip
_ABNORMAL = (
    m.ResetCause.RESET_FAULT
    | m.ResetCause.RESET_IWDG
    | m.ResetCause.RESET_WWDG
    | m.ResetCause.RESET_BROWNOUT
)


@dataclass(frozen=True)
class BootReport:
    """STATUS's boot fields in host terms; `reported` False for a device older than 1.4."""

    reported: bool
    reset_cause: int
    fault: dict[str, int]  # pc, lr, xpsr, cfsr, hfsr, mmfar, bfar
    abnormal_resets: int
    safe_mode: bool
    bor_level: int
    erase_us_last: int
    erase_us_max: int
    trig_latency_us_last: tuple[int, ...]
    trig_latency_us_max: tuple[int, ...]

    @classmethod
    def from_status(cls, status: m.Status, protocol_minor: int) -> BootReport:
        fault = {
            k: int(getattr(status, f"fault_{k}"))
            for k in ("pc", "lr", "xpsr", "cfsr", "hfsr", "mmfar", "bfar")
        }
        return cls(
            protocol_minor >= SINCE_MINOR,
            status.reset_cause,
            fault,
            status.abnormal_resets,
            bool(status.safe_mode),
            status.bor_level,
            status.erase_us_last,
            status.erase_us_max,
            tuple(status.trig_latency_us_last),
            tuple(status.trig_latency_us_max),
        )

    @property
    def causes(self) -> list[str]:
        return [
            (f.name or "").removeprefix("RESET_").lower().replace("_", "-")
            for f in m.ResetCause
            if self.reset_cause & f
        ]

    @property
    def fault_present(self) -> bool:
        return bool(self.reset_cause & m.ResetCause.RESET_FAULT)

    @property
    def abnormal(self) -> bool:
        """The last reset was a fault, a watchdog or a brown-out."""
        return bool(self.reset_cause & _ABNORMAL)

    @property
    def uploads_allowed(self) -> bool:
        return self.bor_level >= BOR_LEVEL_FOR_FLASH

    def fault_flags(self) -> list[str]:
        cfsr = self.fault["cfsr"]
        names = [n for bit, n in CFSR_BITS if cfsr >> bit & 1]
        hfsr = self.fault["hfsr"]
        names += ["FORCED"] * bool(hfsr >> 30 & 1) + ["VECTTBL"] * bool(hfsr >> 1 & 1)
        return names

    def describe(self) -> list[str]:
        """Lines for `spectratac info`."""
        if not self.reported:
            return ["reset cause      not reported (firmware older than protocol 1.4)"]
        row = "s" if self.abnormal_resets != 1 else ""
        lines = [
            f"reset cause      {', '.join(self.causes) or 'none reported'} "
            f"({self.abnormal_resets} abnormal reset{row} in a row)"
        ]
        if self.fault_present:
            f = self.fault
            lines.append(
                f"fault record     pc 0x{f['pc']:08X}  lr 0x{f['lr']:08X}  xpsr 0x{f['xpsr']:08X}"
                f"  (exception {f['xpsr'] & 0x1FF})"
            )
            lines.append(
                f"                 cfsr 0x{f['cfsr']:08X}  hfsr 0x{f['hfsr']:08X}  mmfar "
                f"0x{f['mmfar']:08X}  bfar 0x{f['bfar']:08X}  [{' '.join(self.fault_flags())}]"
            )
        if self.safe_mode:
            lines.append(
                "safe mode        ON: booted without the model store after repeated abnormal "
                "resets (no on-device decoding until a normal reset; MODEL_CLEAR still works)"
            )
        bor = BOR_VOLTS.get(self.bor_level, f"?{self.bor_level}")
        advice = "" if self.uploads_allowed else " - uploads refused: spectratac flash --set-bor"
        lines.append(f"brown-out level  {self.bor_level} ({bor}){advice}")
        erase = (
            f"last {self.erase_us_last / 1e3:,.1f} ms, max {self.erase_us_max / 1e3:,.1f} ms"
            if self.erase_us_max
            else "none measured since boot"
        )
        lines.append(f"flash erase      {erase}")
        if any(self.trig_latency_us_max):
            last = ", ".join(f"{v / 1e3:.1f}" for v in self.trig_latency_us_last)
            top = ", ".join(f"{v / 1e3:.1f}" for v in self.trig_latency_us_max)
            lines.append(f"TRIG latency     last [{last}] ms, max [{top}] ms per sensor")
        return lines

    def as_dict(self) -> dict[str, Any]:
        """For --json."""
        if not self.reported:
            return {"reported": False, "why": "firmware older than protocol 1.4"}
        return {
            "reported": True,
            "reset_cause": self.reset_cause,
            "causes": self.causes,
            "abnormal_resets": self.abnormal_resets,
            "fault": (self.fault | {"flags": self.fault_flags()}) if self.fault_present else None,
            "safe_mode": self.safe_mode,
            "bor_level": self.bor_level,
            "uploads_allowed": self.uploads_allowed,
            "erase_us_last": self.erase_us_last,
            "erase_us_max": self.erase_us_max,
            "trig_latency_us_last": list(self.trig_latency_us_last),
            "trig_latency_us_max": list(self.trig_latency_us_max),
        }
