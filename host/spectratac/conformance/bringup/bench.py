"""What every bring-up check works with: the open device, a way to open it again after a reset,
the STATUS it gave first (before any check changed its counters), and streaming of a few
samples of one configuration."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from spectratac.device import SAMPLE_RECORD, DeviceError, Sensor
from spectratac.protocol.generated import messages as m

#: bound on a wait in which no sample arrives (s): generous, as a loaded host (or QEMU on one)
#: runs late; a read returns as soon as its samples have arrived, so the bound only ends a
#: dead device's wait, and a slow one that still sends is waited for
WAIT_S = 30.0
#: how long a device may take to come back after a reset it was asked for (USB re-enumerates)
REOPEN_S = 60.0


@dataclass
class Bench:
    url: str
    sensor: Sensor
    timeout: float
    #: STATUS as the device gave it before the first check (its boot's reset cause)
    first_status: m.Status | None = None
    #: LOG lines that came with the first replies: a boot LOG (reset cause, clock fallback)
    #: if this run is the first host the device answered since its reset
    boot_logs: list[str] = field(default_factory=list)
    notes: dict[str, Any] = field(default_factory=dict)

    @classmethod
    def open(cls, url: str, timeout: float) -> Bench:
        sensor = _open(url, timeout)
        bench = cls(url, sensor, timeout)
        if sensor.info.capabilities & m.Capabilities.CAP_STATUS:
            bench.first_status = sensor.status()
        # the boot LOG precedes the device's first reply, so it has arrived by now
        bench.boot_logs = [log.text for log in sensor.logs]
        return bench

    @property
    def minor(self) -> int:
        return int(self.sensor.info.protocol_minor)

    @property
    def version(self) -> str:
        i = self.sensor.info
        return f"{i.protocol_major}.{i.protocol_minor}"

    def speaks(self, minor: int) -> bool:
        return self.minor >= minor

    def reopen(self, within_s: float = REOPEN_S) -> None:
        """Close the link and open it again, retrying until the device answers (a board that
        reset re-enumerates on USB; a simulated device boots afresh)."""
        self.sensor.close()
        deadline = time.monotonic() + within_s
        while True:
            try:
                self.sensor = _open(self.url, self.timeout)
                return
            except DeviceError:
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.2)

    def stream(
        self,
        n: int,
        integration_ms: int = 50,
        leds: np.ndarray | list[Any] | None = None,
        skip: int = 0,
    ) -> np.ndarray:
        """`n` samples of one new configuration (after dropping its first `skip`), fewer if
        the device stops sending; only samples the new configuration produced are kept."""
        s = self.sensor
        config_id = s.configure(integration_ms=integration_ms, leds=leds)
        s.read(1_000_000, timeout=0)  # an earlier stream's leftovers
        s.start()
        try:
            kept = self.read_config(config_id, n + skip)
        finally:
            s.stop()
        return kept[skip : skip + n]

    def read_config(self, config_id: int, n: int) -> np.ndarray:
        """Up to `n` samples of the running configuration `config_id` (fewer if the device
        stops sending for WAIT_S); samples of an earlier configuration are dropped."""
        kept: list[np.ndarray] = []
        have = 0
        while have < n:
            batch = self.sensor.read(n - have, timeout=WAIT_S)
            if not len(batch):
                break  # nothing for WAIT_S: the device stopped sending
            batch = batch[batch["config_id"] == config_id]
            kept.append(batch)
            have += len(batch)
        return np.concatenate(kept) if kept else np.zeros(0, SAMPLE_RECORD)


def _open(url: str, timeout: float) -> Sensor:
    # a wrong definition hash is a failed identity check, reported, not a refusal to look; a
    # stream that goes quiet ends a check's read after WAIT_S, not the link's stall watch
    # (whose few seconds a loaded host, or QEMU on one, can exceed)
    return Sensor.open(url, timeout=timeout, strict_hash=False, stall_timeout=WAIT_S)
