"""Put a recording's two clocks onto the host clock: the device's (from TIME_SYNC exchanges
and frame arrival times) and the reference F/T's (from its arrival times), with
`spectratac.fusion.fit_clock`, then average the F/T over each optical integration window.

`scale` is device seconds per host second, the recorded link's clock scale
(`spectratac.device.LinkInfo`): 1 for real hardware; a paced simulation's speed, whose device
and F/T clocks both run on scene time. Dividing by it first leaves fit_clock the small
offset and drift it is built for. What remains of the drift is a clock's error against its
declared rate, under 1 % for any oscillator; a fit far beyond that learnt the host's
scheduling, not the clock (a stalled host that reads a session's samples in one burst fits a
drift of -1 and puts every window on one instant), so the declared rate is used instead.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from spectratac.device.clock_sync import TimeSyncExchange
from spectratac.fusion import ClockFitError, ClockModel, fit_clock, window_average

_WRAP = 1 << 32
CAUSALITY_TOLERANCE_S = 0.5e-3  # how far before a window's end its frame may seem to arrive
#: The largest drift against the declared clock scale taken from the arrivals: quartz is off
#: by ~1e-4, an RC oscillator by ~1e-2, the simulated F/T's ft_drift by at most 1e-2.
MAX_DRIFT = 0.02


@dataclass
class Windows:
    """Integration windows on the host clock, and how they were obtained."""

    t_start: np.ndarray
    t_end: np.ndarray
    clock: dict[str, Any]


def sync_exchanges(
    records: list[dict[str, Any]], device_end_us: np.ndarray, arrival: np.ndarray, scale: float
) -> list[TimeSyncExchange]:
    """Recorded exchanges as TimeSyncExchange, their device times scaled by 1/`scale` and
    put on the same 2^32 µs lap as the samples' unwrapped clock (the two were unwrapped
    separately, by the sensor while recording and by us now)."""
    if not records:
        return []
    rx = np.array([r["device_rx_us"] for r in records], dtype=np.int64)
    tx = np.array([r["device_tx_us"] for r in records], dtype=np.int64)
    mid_host = np.array([(r["host_sent"] + r["host_received"]) / 2 for r in records])
    if len(device_end_us) >= 2:
        expect = np.interp(mid_host, arrival, device_end_us.astype(np.float64))
        lap = np.round(np.median(rx - expect) / _WRAP).astype(np.int64)
        rx, tx = rx - lap * _WRAP, tx - lap * _WRAP
    return [
        TimeSyncExchange(r["host_sent"], int(a / scale), int(b / scale), r["host_received"])
        for r, a, b in zip(records, rx, tx, strict=True)
    ]


def device_windows(samples: np.ndarray, exchanges: list[dict[str, Any]], scale: float) -> Windows:
    """Host-clock windows of RECORDED_SAMPLE rows.

    The exchanges set the offset (they remove the transport's minimum latency), unless they
    contradict causality: a window cannot end after its frame arrived. A device that stamps
    its TIME_SYNC replies late (the simulator answers with the time of its last step) would
    otherwise shift every window; then the arrival envelope alone is used, and the clock
    record says why."""
    end_s = samples["t_end_us"] / 1e6 / scale
    start_s = samples["t_start_us"] / 1e6 / scale
    arrival = samples["host_time"]
    sync = sync_exchanges(exchanges, samples["t_end_us"], arrival, scale)
    model, note = _declared_fit(end_s, arrival, sync)
    if sync:
        early = float(np.quantile(arrival - model.to_host(end_s), 0.01))
        if early < -CAUSALITY_TOLERANCE_S:
            model, note = _declared_fit(end_s, arrival, [])
            note["exchanges_rejected"] = (
                f"windows would end {-early * 1e3:.2f} ms after their frames arrived: the "
                "device's TIME_SYNC stamps are late"
            )
    return Windows(model.to_host(start_s), model.to_host(end_s), _describe(model, scale) | note)


def ft_host_times(ft: np.ndarray, scale: float) -> tuple[np.ndarray, dict[str, Any]]:
    """F/T sample times on the host clock (FT_RECORD rows; the F/T's own clock fitted to
    arrival times, held to the declared rate like the device's)."""
    sensor = ft["sensor_time"] / scale
    model, note = _declared_fit(sensor, ft["host_time"], [])
    return model.to_host(sensor), _describe(model, scale) | note


def _declared_fit(
    sensor: np.ndarray, arrival: np.ndarray, sync: list[TimeSyncExchange]
) -> tuple[ClockModel, dict[str, Any]]:
    """fit_clock, unless the drift it fits is beyond any clock's (MAX_DRIFT): then the
    arrivals came in bursts, not at the sensor's pace, and only the offset is fitted, the
    drift held at the declared scale's (0 once divided by it). The note says which."""
    model = fit_clock(sensor, arrival, exchanges=sync or None)
    if abs(model.drift) <= MAX_DRIFT:
        return model, {}
    note = (
        f"the arrivals fit a drift of {model.drift:+.1%}, beyond any clock's "
        f"±{MAX_DRIFT:.0%}: they came in bursts (a stalled host); the declared rate is used"
    )
    return fit_clock(sensor, arrival, exchanges=sync or None, drift=0.0), {"drift_rejected": note}


def ft_targets(
    ft: np.ndarray | None, windows: Windows, scale: float, max_gap_s: float | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, Any] | None]:
    """(targets (N, 6) NaN where invalid, valid, F/T count per window, F/T clock)."""
    n = len(windows.t_start)
    if ft is None or len(ft) < 2:
        return np.full((n, 6), np.nan), np.zeros(n, bool), np.zeros(n, np.int64), None
    try:
        t_host, clock = ft_host_times(ft, scale)
    except ClockFitError:
        return np.full((n, 6), np.nan), np.zeros(n, bool), np.zeros(n, np.int64), None
    # max_gap_s is on the host clock; the gap rule counts in F/T periods by default
    mean, valid, count = window_average(
        t_host, ft["wrench"], windows.t_start, windows.t_end, max_gap_s=max_gap_s
    )
    return mean, valid, count, clock


def _describe(model: ClockModel, scale: float) -> dict[str, Any]:
    return model.as_dict() | {"scale": scale}
