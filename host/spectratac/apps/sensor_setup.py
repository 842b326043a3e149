"""Setting a sensor up for a trained decoder: configure it as the model was trained.

Shared by every verb that decodes live (`spectratac decode`, `live`, `snake`).

    with open_for_decoder(decoder, url) as sensor:
        for estimate in decoder.stream(sensor):
            ...
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Iterator
from typing import TYPE_CHECKING, Any

from spectratac.device.records import Sample
from spectratac.device.streams import SampleStream
from spectratac.errors import SpectraTacError
from spectratac.protocol.generated import messages as m

if TYPE_CHECKING:
    from spectratac.device import Sensor

SETTINGS = ("integration_ms", "gain", "digital_gain", "sensitivity", "leds", "settle_us")


def sensor_settings(config: dict[str, Any] | None) -> dict[str, Any]:
    """`Sensor.configure` keyword arguments for a model's training configuration.

    >>> sensor_settings({"integration_ms": 100, "leds": [[[9, 9, 9]] * 3], "note": "x"})
    {'integration_ms': 100, 'leds': [[[9, 9, 9], [9, 9, 9], [9, 9, 9]]]}
    """
    if not config:
        raise SpectraTacError(
            "the model records no sensor configuration (trained on data from another "
            "sensor?): pass --keep-config to decode with the device's own"
        )
    return {k: config[k] for k in SETTINGS if k in config}


@contextlib.contextmanager
def open_for_decoder(
    decoder: Any, url: str, *, keep_config: bool = False, **options: Any
) -> Iterator[Sensor]:
    """The sensor at `url`, configured as `decoder` was trained (unless `keep_config`:
    then `Decoder.stream` refuses a device configured otherwise) and streaming; stopped
    and closed on exit. `options` go to `Sensor.open` (timeout, buffer_size, ...)."""
    from spectratac.device import Sensor

    settings = None if keep_config else sensor_settings(decoder.config)
    with Sensor.open(url, **options) as sensor:
        if settings is not None:
            sensor.configure(**settings)
        sensor.start()
        try:
            yield sensor
        finally:
            if not sensor.stats.reconnects:
                with contextlib.suppress(SpectraTacError, OSError):
                    sensor.stop()


class SampleTap:
    """A sensor as `Decoder.stream` sees it, keeping the sample behind each estimate in
    `last` (the raw counts, the device clock) while the decoder consumes it, and when the
    consumer took it in `taken_at` (host monotonic s: the wait before decoding ends there)."""

    def __init__(self, sensor: SampleStream) -> None:
        self.sensor = sensor
        self.last: Sample | None = None
        self.taken_at = 0.0

    def __iter__(self) -> Iterator[Sample]:
        for sample in self.sensor:
            self.last = sample
            self.taken_at = time.monotonic()
            yield sample

    def get_config(self) -> m.Config:
        return self.sensor.get_config()

    @property
    def info(self) -> Any:
        """The sensor's INFO (its unique id: the decoder compares units on open), if any."""
        return getattr(self.sensor, "info", None)

    @property
    def url(self) -> str | None:
        """The sensor's URL, if it has one (advice names it)."""
        return getattr(self.sensor, "url", None)

    @property
    def link_info(self) -> Any:
        return getattr(self.sensor, "link_info", None)
