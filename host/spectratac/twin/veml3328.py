"""Register-level VEML3328 model: answers I2C transfers like the device on its bus.

Registers are 16-bit, little-endian; their addresses and the CONF bit fields come from the part
definition, hardware/definitions/veml3328.toml (generated `spectratac.hardware.generated.veml3328`):
CONF (the only writable register), data C, R, G, B, IR and ID (part ID in the low byte). CONF holds
SD1 and SD0 (shutdown when either is set), SD_ALS (only G, C, IR powered), the digital gain DG, the
analogue gain, SENS (low sensitivity, 1/3), the integration time IT, AF (active force) and TRIG.

Modes: in active-force mode (AF = 1) writing TRIG = 1 starts one integration at that instant;
the data registers update when the integration time has elapsed and TRIG then reads back 0;
reads before that return the previous data. With AF = 0 and the device powered, integrations
run back to back from the moment the device was configured; reads return the last completed
window. Shutdown stops integrating and keeps the last data. The model powers up shut down
(CONF = 0x8001), as drivers for this part write CONF to start it.

Transfers: write [reg, lsb, msb] sets CONF (the only writable register); write [reg] sets the
register pointer, and a following read returns that register (bytes past the second read as
0xFF: the device has released the bus). An absent device, an unknown register, a write to a
read-only register or a malformed write is not acknowledged (`I2CNack`).

This is the reference model. The simulated device normally runs its C mirror
(firmware/ports/native/veml_model.c), which asks the rig only for each window's counts;
tests/device/test_sim_models.py checks the two transfer by transfer. Change both together.

>>> from spectratac.twin import builtin_scenes as scenes
>>> from spectratac.twin.rig import TwinRig
>>> rig = TwinRig(scenes.idle(1.0), seed=0)
>>> rig.set_led_duties(0, np.full((3, 3), 0.25))
>>> dev = rig.sensors[0]
>>> dev.transfer(0, bytes([0x0C]), 2).hex()
'2800'
>>> dev.transfer(10, bytes([0x00, 0x0C, 0x00]), 0)  # AF=1, TRIG=1, IT=50 ms, powered
b''
>>> dev.transfer(49_000, bytes([0x04]), 2)  # not done yet: previous data
b'\\x00\\x00'
>>> c = int.from_bytes(dev.transfer(50_010, bytes([0x04]), 2), "little")
>>> 15_000 < c < 45_000, dev.transfer(50_020, bytes([0x00]), 2).hex()  # TRIG self-cleared
(True, '0800')
"""

from __future__ import annotations

from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from spectratac.hardware.generated import veml3328 as chip
from spectratac.twin.electronics import AF, SD0, SD1, SD_ALS, TRIG, SensorConfig
from spectratac.twin.errors import I2CNack

ADDRESS = chip.ADDRESS
REG_CONF = chip.REG_CONF
REG_C, REG_R, REG_G, REG_B, REG_IR = chip.REG_C, chip.REG_R, chip.REG_G, chip.REG_B, chip.REG_IR
REG_ID = chip.REG_ID
DEVICE_ID = chip.ID_LOW  # the ID register: part ID in the low byte, address option 0 above
POWER_ON_CONF = SD1 | SD0
DATA_REGS = (REG_R, REG_G, REG_B, REG_C, REG_IR)  # in the twin's channel order R G B C IR
READABLE = frozenset((REG_CONF, REG_ID, *DATA_REGS))
# Bits that exist in CONF (reserved bits read back as 0).
CONF_MASK = chip.CONF_DEFINED


class Windows(Protocol):
    """What a sensor asks of the rig (`TwinRig` has it): the counts of one integration
    window of sensor `k`, and whether they saturated."""

    def read_window(
        self, k: int, t0_us: int, t1_us: int, cfg: SensorConfig, *, sd_als: bool = False
    ) -> tuple[NDArray[np.uint16], bool]: ...


class Veml3328:
    """One VEML3328 on its own bus, driven by the rig's optics (see module docstring)."""

    def __init__(self, windows: Windows, index: int, *, present: bool = True) -> None:
        self.windows = windows
        self.index = index
        self.present = present
        self.conf = POWER_ON_CONF
        self.data = dict.fromkeys(DATA_REGS, 0)
        self.saturated = False  # the last completed window clipped at 65535
        self.completed = 0  # number of completed integrations
        self._pointer = REG_CONF
        self._pending: tuple[int, int, SensorConfig, bool] | None = None  # AF integration
        self._cont_start: int | None = None  # start of the back-to-back cycle (AF = 0)
        self._cont_done = -1  # index of the last stored continuous window
        self._now = 0

    @property
    def powered(self) -> bool:
        return not (self.conf & (SD0 | SD1))

    @property
    def config(self) -> SensorConfig:
        return SensorConfig.from_conf(self.conf)

    def transfer(self, now_us: int, write: bytes, read_len: int) -> bytes:
        """One I2C transaction at time `now_us`: write bytes, then read `read_len` bytes."""
        if not self.present:
            raise I2CNack(f"no device at 0x{ADDRESS:02x} on sensor bus {self.index}")
        if read_len < 0:
            raise I2CNack(f"read length must be >= 0, got {read_len}")
        now = int(now_us)
        self._advance(now)
        if write:
            reg = write[0]
            if reg not in READABLE:
                raise I2CNack(f"VEML3328 has no register 0x{reg:02x}")
            if len(write) == 3:
                if reg not in chip.WRITABLE_REGS:
                    raise I2CNack(f"register 0x{reg:02x} is read-only; only CONF 0x00 is writable")
                self._write_conf(now, write[1] | (write[2] << 8))
            elif len(write) != 1:
                raise I2CNack(f"write of {len(write)} bytes: send [reg] or [reg, lsb, msb]")
            self._pointer = reg
        if read_len == 0:
            return b""
        value = self._read(self._pointer)
        out = bytes((value & 0xFF, value >> 8))
        return out[:read_len] + b"\xff" * max(0, read_len - 2)

    # --- internals ----------------------------------------------------------------------------
    def _read(self, reg: int) -> int:
        if reg == REG_CONF:
            return self.conf
        if reg == REG_ID:
            return DEVICE_ID
        return self.data[reg]

    def _write_conf(self, now: int, value: int) -> None:
        old = self.conf
        self.conf = value & CONF_MASK
        if not self.powered:
            self._pending = None
            self._cont_start = None
            self.conf &= ~TRIG
            return
        if self.conf & AF:
            self._cont_start = None
            if self.conf & TRIG and self._pending is None:
                cfg = self.config
                end = now + cfg.integration_ms * 1000
                self._pending = (now, end, cfg, bool(self.conf & SD_ALS))
            elif not self.conf & TRIG:
                self._pending = None
            return
        self._pending = None
        self.conf &= ~TRIG
        # Continuous mode: a new cycle starts when the device powers up or its settings change.
        if self._cont_start is None or (old & ~TRIG) != (self.conf & ~TRIG):
            self._cont_start = now
            self._cont_done = -1

    def _advance(self, now: int) -> None:
        if now < self._now:
            now = self._now  # the bus clock never runs backwards; treat as simultaneous
        self._now = now
        if self._pending is not None and now >= self._pending[1]:
            t0, t1, cfg, sd_als = self._pending
            self._pending = None
            self.conf &= ~TRIG
            self._store(t0, t1, cfg, sd_als)
        if self._cont_start is not None and self.powered and not self.conf & AF:
            cfg = self.config
            it = cfg.integration_ms * 1000
            n = (now - self._cont_start) // it - 1  # last completed window index
            if n > self._cont_done:
                t0 = self._cont_start + n * it
                self._cont_done = n
                self._store(t0, t0 + it, cfg, bool(self.conf & SD_ALS))

    def _store(self, t0: int, t1: int, cfg: SensorConfig, sd_als: bool) -> None:
        counts, sat = self.windows.read_window(self.index, t0, t1, cfg, sd_als=sd_als)
        for reg, v in zip(DATA_REGS, counts.tolist(), strict=True):
            self.data[reg] = int(v)
        self.saturated = sat
        self.completed += 1

    def counts(self) -> np.ndarray:
        """Current data registers as (5,) uint16 in channel order R, G, B, C, IR."""
        return np.array([self.data[r] for r in DATA_REGS], dtype=np.uint16)
