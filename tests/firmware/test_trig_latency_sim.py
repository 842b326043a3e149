"""STATUS's per-sensor TRIG latency comes from the firmware core, through the simulated device.

The simulated device runs the real core (stac_acquisition.c) over its twin's VEML3328s, so the
latency it reports is the core's own measurement: from each sensor's TRIG write to the poll
that found TRIG clear, at least the integration time and at most one poll interval and a few
transfers more. Read on the sensor's clock, never the host's.
"""

from __future__ import annotations

import pytest
from spectratac.device.sensor import Sensor

POLL_INTERVAL_US = 250  # STAC_POLL_INTERVAL_US (firmware/core/stac_acquisition.h)
SLACK_US = 2000  # the transfers of the pass that polls


@pytest.mark.parametrize("integration_ms", [50, 100])
def test_status_reports_trig_latency_from_the_core(integration_ms: int) -> None:
    with Sensor.open("sim://?speed=max") as s:
        assert s.status().trig_latency_us_max == (0, 0, 0), "not measured before streaming"
        s.configure(integration_ms=integration_ms)
        s.start()
        s.read(5)
        status = s.status()
        s.stop()
    it_us = integration_ms * 1000
    for last, top in zip(status.trig_latency_us_last, status.trig_latency_us_max, strict=True):
        assert it_us <= last <= top <= it_us + POLL_INTERVAL_US + SLACK_US, status
