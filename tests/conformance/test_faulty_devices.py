"""A conformance suite that can fail: each faulty simulated device breaks exactly one check.

The faults are real misbehaviour of the simulated device on its link (spectratac.sim.faults),
not mocks of the suite: the suite talks to them exactly as it talks to a board.
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np
import pytest
from spectratac.conformance import CHECKS, MODEL_CHECKS, run_check, run_suite
from spectratac.conformance import checks as c
from spectratac.conformance import model_checks as mc
from spectratac.conformance.checks import Check
from spectratac.device import Sensor
from spectratac.sim.faults import CONFORMANCE_FAULTS, LATE_STOP_US, SYNC_JITTER_US

pytestmark = pytest.mark.slow  # each suite run streams ~8 s of real time

BREAKS = {
    "wrong_hash": c.handshake,
    "bad_info": c.info_limits,
    "stale_config": c.configure_ack,
    "wrong_nack_field": c.configure_nack,
    "silent_unknown": c.bad_messages,
    "fast_clock": c.sample_rate,
    "short_window": c.continuity_and_time,
    "sync_jitter": c.time_sync,
    "no_rx_errors": c.garbage_recovery,
    "late_stop": c.stop_stops,
    "flag_fault": c.sensor_status,
    "bad_model_info": mc.model_info,
    "accept_large_model": mc.model_too_large,
    "accept_bad_chunk": mc.chunk_order,
    "accept_bad_crc": mc.bad_crc,
    "accept_bad_model": mc.damaged_model,
    "wrong_model_crc": mc.upload_round_trip,
    "estimate_skew": mc.estimates_beside,
    "ignore_estimate_only": mc.estimates_instead,
    "volatile_model": mc.survives_reset,
    "sticky_model": mc.clear,
    "begin_erases": mc.refused_begin_keeps_model,
}
NAME_OF = {check: name for name, check in CHECKS} | {check: name for name, check, _ in MODEL_CHECKS}
#: the simulated device decodes on board and takes uploads (protocol 1.1): every check runs
ROWS = len(CHECKS) + len(MODEL_CHECKS)


#: (failed checks, rows reported) of the whole suite against the device with a fault
Failed = tuple[list[str], int]


def _failed(url: str) -> Failed:
    result = run_suite(url)
    assert result.passed == all(outcome.passed for _, outcome in result.rows)
    return [name for name, outcome in result.rows if not outcome.passed], len(result.rows)


@pytest.fixture(scope="module")
def failed_with(tmp_path_factory: pytest.TempPathFactory) -> Callable[[str], Failed]:
    """The suite against the healthy device and every faulty one, all at once: a run is ~8 s
    of real-time streaming for <1 s of CPU, so 23 one after another kept a test worker
    waiting for over 3 minutes. Each device has its own model store: devices of one seed
    share their flash, as two opens of one board would."""
    store = tmp_path_factory.mktemp("faulty-flash")
    faults = ["none", *BREAKS]
    with ThreadPoolExecutor(len(faults)) as pool:
        futures = {
            f: pool.submit(_failed, f"sim://?scene=idle&fault={f}&model_store={store / f}.flash")
            for f in faults
        }
    return lambda fault: futures[fault].result()  # a run's error is raised in its own test


def test_every_check_has_a_fault_that_breaks_it() -> None:
    assert set(BREAKS) == set(CONFORMANCE_FAULTS)
    assert sorted(NAME_OF[check] for check in BREAKS.values()) == sorted(NAME_OF.values())


def test_the_healthy_device_passes_every_check(failed_with: Callable[[str], Failed]) -> None:
    assert failed_with("none") == ([], ROWS)


@pytest.mark.parametrize("fault", [f for f in BREAKS if f != "wrong_hash"])
def test_a_faulty_device_fails_exactly_its_check(
    fault: str, failed_with: Callable[[str], Failed]
) -> None:
    assert failed_with(fault) == ([NAME_OF[BREAKS[fault]]], ROWS)


def test_a_wrong_definition_hash_fails_the_handshake_and_stops_the_suite(
    failed_with: Callable[[str], Failed],
) -> None:
    """The host refuses to talk on (strict hash) to a device built from other definitions:
    the handshake row fails and no other check can run, so none is reported."""
    assert failed_with("wrong_hash") == ([NAME_OF[c.handshake]], 1)


@pytest.mark.parametrize(("fault", "passes"), [("none", True), ("late_stop", False)])
def test_stop_really_stops_judges_a_late_host_by_the_device(
    fault: str, passes: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A host that runs each read later than a late_stop device streams on (a loaded
    machine) still catches the late samples, and does not blame a healthy device."""
    with Sensor.open(f"sim://?scene=idle&fault={fault}") as s:
        read = s.read

        def late_read(n: int, timeout: float | None = None) -> np.ndarray:
            time.sleep(LATE_STOP_US / 1e6 * 1.5)  # descheduled: the device runs on meanwhile
            return read(n, timeout)

        monkeypatch.setattr(s, "read", late_read)
        outcome = run_check(s, c.stop_stops)
    assert outcome.passed is passes, outcome.detail


@pytest.mark.parametrize(
    "check", [c.sample_rate, c.continuity_and_time, c.garbage_recovery, c.stop_stops]
)
def test_a_streaming_check_ignores_samples_an_earlier_stream_left_unread(check: Check) -> None:
    """A loaded host reads less than the device sent before a check's STOP: the next check
    starts with those samples still buffered, and must judge only its own stream."""
    with Sensor.open("sim://?scene=idle&fault=none") as s:
        s.configure(integration_ms=50, leds=c.WHITE)
        s.start()
        for _ in range(3000):  # bound: 30 s for six samples
            if s.stats.samples_received >= 6:
                break
            time.sleep(0.01)
        s.stop()
        assert s.stats.samples_received >= 6, "the device sent no 6 samples within 30 s"
        outcome = run_check(s, check)
    assert outcome.passed, outcome.detail


@pytest.mark.parametrize(("fault", "passes"), [("none", True), ("sync_jitter", False)])
def test_time_sync_judges_only_the_exchanges_a_loaded_host_did_not_delay(
    fault: str, passes: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Every third TIME_SYNC request leaves 200 ms late (the host descheduled between taking
    its send time and writing): the wide error bars of those round trips would cover the
    sync_jitter device's 50 ms, so only the undelayed exchanges may be judged."""
    with Sensor.open(f"sim://?scene=idle&fault={fault}") as s:
        request_at = s.link.request_at
        calls = itertools.count()

        def late_request_at(*args: Any, **kwargs: Any) -> Any:
            if next(calls) % 3 == 0:
                time.sleep(SYNC_JITTER_US / 1e6 * 4)
            return request_at(*args, **kwargs)

        s.configure(integration_ms=50, leds=c.WHITE)
        s.start()  # the device clock runs from the first START
        s.stop()
        monkeypatch.setattr(s.link, "request_at", late_request_at)
        outcome = run_check(s, c.time_sync)
    assert outcome.passed is passes, outcome.detail
