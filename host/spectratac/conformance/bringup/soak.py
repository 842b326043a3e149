"""A short soak: stream for a while (seconds of the device's clock) and count what the link
lost on the way: samples missing from the sequence, frames with a bad CRC or COBS, frames the
device could not send, and, on a link whose clock runs with the host's, how far the device's
clock drifts from the host's (the crystal's accuracy)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar

import numpy as np

from spectratac.conformance.bringup.bench import Bench
from spectratac.conformance.bringup.report import FAIL, PASS, SKIPPED, Row
from spectratac.device import SAMPLE_RECORD, ClockSync, DeviceError
from spectratac.protocol.generated import messages as m

INTEGRATION_MS = 50
WHITE = [[[500, 500, 500]] * 3]
#: the device clock may differ from the host's by at most this (USB full speed's tolerance,
#: ±0.25 %: a board off by more cannot keep its USB link)
DRIFT_MAX_PPM = 2500.0
HOST_COUNTERS = ("crc_errors", "cobs_errors", "other_frame_errors", "frame_gaps", "sample_gaps")
T = TypeVar("T")


def soak(bench: Bench, seconds: float) -> Row:
    if seconds <= 0:
        return Row("soak", SKIPPED, "--soak 0: no soak asked for")
    s = bench.sensor
    wanted = max(1, round(seconds * 1000 / INTEGRATION_MS))
    problems: list[str] = []

    def ask(what: str, command: Callable[[], T]) -> T | None:
        # On the lossy link a soak is meant to find, a command's reply can be lost too: that
        # is one more problem to report, and the counts are still what the user needs.
        try:
            return command()
        except DeviceError as exc:
            problems.append(f"{what} failed ({type(exc).__name__})")
            return None

    host_before = {k: getattr(s.stats, k) for k in HOST_COUNTERS}
    has_status = bool(s.info.capabilities & m.Capabilities.CAP_STATUS)
    dev_before = ask("STATUS before", s.status) if has_status else None
    scale = s.link_info.clock_scale
    sync_before = ask("TIME_SYNC before", s.sync_clock) if scale else None
    config_id = ask("CONFIGURE", lambda: s.configure(integration_ms=INTEGRATION_MS, leds=WHITE))
    samples = np.zeros(0, SAMPLE_RECORD)
    if config_id is not None:
        s.read(1_000_000, timeout=0)
        if ask("START", lambda: s.start() or True):
            try:
                samples = bench.read_config(config_id, wanted)
            finally:
                ask("STOP", s.stop)
    sync_after = ask("TIME_SYNC after", s.sync_clock) if scale else None
    dev_after = ask("STATUS after", s.status) if has_status else None
    host = {k: getattr(s.stats, k) - v for k, v in host_before.items()}
    values: dict[str, Any] = {"seconds": seconds, "samples": len(samples), "expected": wanted}
    values |= host
    if dev_before is not None and dev_after is not None:
        values["device_frames_dropped"] = dev_after.frames_dropped - dev_before.frames_dropped
        values["device_rx_errors"] = dev_after.rx_errors - dev_before.rx_errors
    seq = samples["sequence"].astype(np.int64) if len(samples) else np.zeros(0, np.int64)
    values["sequence_gaps"] = int(np.sum(np.diff(seq) - 1)) if len(seq) else 0
    problems[:0] = [f"{k.replace('_', ' ')} {v}" for k, v in values.items() if _bad(k, v)]
    if len(samples) < wanted:
        problems.append(f"only {len(samples)} of {wanted} samples arrived")
    if sync_before and sync_after and scale:
        host_s = _host_time(sync_after) - _host_time(sync_before)
        offset_change = sync_after.offset - sync_before.offset  # device − host, s
        ppm = offset_change / host_s / scale * 1e6 if host_s > 0 else 0.0
        bench.notes["clock_drift"] = {"ppm": round(ppm, 1), "over_host_s": round(host_s, 3)}
    said = f"{len(samples)} samples over {seconds:g} s: none lost, no CRC or COBS errors"
    return Row("soak", FAIL if problems else PASS, "; ".join(problems) or said, values)


def clock_drift(bench: Bench) -> Row:
    """How far the device's clock ran from the host's over the soak (TIME_SYNC before and
    after): a crystal is within tens of ppm, the internal RC oscillator within about 1 %."""
    drift = bench.notes.get("clock_drift")
    if drift is None:
        why = (
            "the device's clock is not tied to the host's (a simulation at full speed)"
            if bench.sensor.link_info.clock_scale is None
            else "no soak ran to measure it over"
        )
        return Row("clock drift", SKIPPED, why)
    ppm = drift["ppm"]
    if abs(ppm) > DRIFT_MAX_PPM:
        return Row(
            "clock drift",
            FAIL,
            f"the device clock runs {ppm:+.0f} ppm off the host's over {drift['over_host_s']:.1f} "
            f"s (more than {DRIFT_MAX_PPM:.0f}): the crystal is not in use or not 25 MHz",
            drift,
        )
    return Row(
        "clock drift",
        PASS,
        f"{ppm:+.0f} ppm off the host's over {drift['over_host_s']:.1f} s",
        drift,
    )


def _host_time(sync: ClockSync) -> float:
    """The host time (monotonic) of a sync's best exchange, whose offset it reports."""
    best = min(sync.exchanges, key=lambda e: e.round_trip)
    return (best.host_sent + best.host_received) / 2


def _bad(name: str, value: object) -> bool:
    counted = (*HOST_COUNTERS, "device_frames_dropped", "device_rx_errors", "sequence_gaps")
    return name in counted and bool(value)
