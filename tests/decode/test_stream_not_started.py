"""`Decoder.stream` on a sensor that is open but not streaming raises a typed error at once
(it waited forever, silently: the README's snippet without `sensor.start()` hung)."""

from __future__ import annotations

import itertools
import threading
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import pytest
from spectratac.dataset import SPECTRATAC_INPUTS, Dataset
from spectratac.decode import Decoder, Estimate, SensorNotStreamingError
from spectratac.device import Sensor

URL = "sim://?scene=tour&seed=8&speed=max"
WHITE = [[[500, 500, 500]] * 3]
HANG_GUARD_S = 60.0


def tiny_decoder() -> Decoder:
    ds = Dataset.generic(
        np.arange(1.0, 37.0).reshape(3, 12) * 100.0, np.zeros((3, 1)), list(SPECTRATAC_INPUTS),
        ["Fz"],
    )  # fmt: skip
    return Decoder.untrained(ds, features="paper33", seed=0)


def bounded(call: Callable[[], Any]) -> Any:
    """`call()` on a thread: its result or exception, or a failure if it hangs."""
    out: dict[str, Any] = {}

    def run() -> None:
        try:
            out["value"] = call()
        except BaseException as exc:
            out["error"] = exc

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    thread.join(HANG_GUARD_S)
    assert not thread.is_alive(), f"still waiting after {HANG_GUARD_S:g} s"
    if "error" in out:
        raise out["error"]
    return out["value"]


@pytest.fixture
def sensor() -> Iterator[Sensor]:
    with Sensor.open(URL) as s:
        s.configure(integration_ms=50, leds=WHITE)
        yield s


def first(dec: Decoder, sensor: Any) -> Estimate:
    return next(iter(dec.stream(sensor, check_config=False)))


def test_a_sensor_never_started_is_refused_at_once(sensor: Sensor) -> None:
    assert not sensor.streaming
    with pytest.raises(SensorNotStreamingError, match=r"call sensor\.start\(\)"):
        bounded(lambda: first(tiny_decoder(), sensor))


def test_a_stopped_sensor_is_refused(sensor: Sensor) -> None:
    sensor.start()
    sensor.stop()
    with pytest.raises(SensorNotStreamingError, match="is open but not streaming"):
        bounded(lambda: first(tiny_decoder(), sensor))


def test_a_started_sensor_streams_and_is_left_streaming(sensor: Sensor) -> None:
    sensor.start()
    dec = tiny_decoder()
    got = bounded(lambda: list(itertools.islice(dec.stream(sensor, check_config=False), 5)))
    assert len(got) == 5 and all(isinstance(e, Estimate) for e in got)
    assert sensor.streaming and sensor.status().streaming  # start and stop stay the caller's
    sensor.stop()


class LeftStreaming:
    """A sensor this host never started, on a device an earlier session left streaming."""

    def __init__(self, sensor: Sensor) -> None:
        self.sensor, self.streaming, self.url = sensor, False, sensor.url

    def __iter__(self) -> Iterator[Any]:
        return iter(self.sensor)

    def status(self) -> Any:
        return self.sensor.status()

    def get_config(self) -> Any:
        return self.sensor.get_config()


def test_a_device_that_streams_although_this_host_never_started_it_is_decoded(
    sensor: Sensor,
) -> None:
    sensor.start()
    assert isinstance(bounded(lambda: first(tiny_decoder(), LeftStreaming(sensor))), Estimate)
    sensor.stop()
