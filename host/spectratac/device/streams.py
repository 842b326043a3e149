"""What code that consumes a live sensor needs from it, as typed protocols.

`Sensor` satisfies all three; so may a wrapper (the live page's SampleTap) or a test double.
The decoder takes a `SampleStream` and uses on-device estimates when it is an
`EstimateStream` that streams them; the live applications hold a `DeviceStream`.

>>> from spectratac.device import Sensor
>>> with Sensor.open("sim://?scene=idle&speed=max") as sensor:
...     kinds = [isinstance(sensor, p) for p in (SampleStream, EstimateStream, DeviceStream)]
>>> kinds
[True, True, True]
>>> isinstance(iter([]), SampleStream)  # samples without their configuration are not enough
False
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Protocol, runtime_checkable

import numpy as np

from spectratac.device.clock_sync import ClockSync, TimeSyncExchange
from spectratac.device.estimate_records import EstimateRow
from spectratac.device.link import FrameListener
from spectratac.device.link_info import LinkInfo
from spectratac.device.model_store import ModelInfo
from spectratac.device.records import Sample
from spectratac.device.sensor import EstimatesMode
from spectratac.device.stats import SensorStats
from spectratac.protocol.generated import messages as m


@runtime_checkable
class SampleStream(Protocol):
    """Samples one by one, and the configuration they are taken under."""

    def __iter__(self) -> Iterator[Sample]: ...

    def get_config(self) -> m.Config: ...


@runtime_checkable
class EstimateStream(SampleStream, Protocol):
    """A SampleStream that may carry the device's own estimates (protocol 1.1)."""

    @property
    def estimates(self) -> EstimatesMode:
        """ "off", or how the device sends estimates: "beside" or "instead" of samples."""
        ...

    def model_info(self) -> ModelInfo: ...

    def iter_estimates(self) -> Iterator[EstimateRow]: ...


@runtime_checkable
class DeviceStream(EstimateStream, Protocol):
    """A connected device as the live applications use it: samples in batches too, its
    identity, what its link knows about itself, link health, clock sync and raw frames (for
    clips), and closing."""

    @property
    def url(self) -> str: ...

    @property
    def info(self) -> m.Info: ...

    @property
    def link_info(self) -> LinkInfo: ...

    @property
    def stats(self) -> SensorStats: ...

    @property
    def time_sync(self) -> list[TimeSyncExchange]: ...

    def read(self, n: int, timeout: float | None = None) -> np.ndarray: ...

    def sync_clock(self, exchanges: int = 8) -> ClockSync: ...

    def add_listener(self, listener: FrameListener) -> None: ...

    def close(self) -> None: ...
