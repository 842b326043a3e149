"""Map a device's clock (optical sensor or F/T) onto the host's monotonic clock.

Model: host = offset + (1 + drift) * sensor. Arrival times are the true host time of a
sample plus a transport latency that is never negative and heavy-tailed (USB polling, OS
scheduling, occasional stalls of tens of ms), so the true line runs along the *lower
envelope* of the (sensor time, arrival time) cloud. fit_clock takes the line that lies
below every point and is closest to them on average (a linear programme whose answer is the
lower convex hull's edge above the mean sensor time), after reducing the cloud to per-bin
minima and rejecting impossibly early points (timestamp glitches). A window= refits on
overlapping windows and joins them piecewise linearly, to follow a drift that changes.

With time-sync exchanges (host_sent, device_rx_us, device_tx_us, host_received), the offset
comes from them NTP-style (device midpoint ~ host midpoint, error <= asymmetry of the round
trip; the shortest round trips are used) and the drift from the arrival envelope, which
removes the envelope's one bias: the minimum transport latency.

>>> rng = np.random.default_rng(0)
>>> s = np.arange(0, 60, 0.001)
>>> h = 100.05 + (1 + 1e-4) * s + rng.lognormal(np.log(2e-3), 1.0, s.size)
>>> model = fit_clock(s, h)
>>> round(model.offset, 4), round(model.drift * 1e6)
(100.05, 100)
>>> round(float(model.to_sensor(model.to_host(12.5))), 9)
12.5
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from spectratac.errors import SpectraTacError

F64 = NDArray[np.float64]

_BINS = 4096  # per-bin minima kept for the envelope (bounds cost; error <= drift * bin width)
_MIN_POINTS = 2


class ClockFitError(SpectraTacError, ValueError):
    """Not enough (or inconsistent) timing data to fit a clock model."""


class Exchange(Protocol):
    """A time-sync round trip (spectratac.device.TimeSyncExchange has this shape)."""

    host_sent: float
    device_rx_us: int
    device_tx_us: int
    host_received: float


@dataclass(frozen=True)
class ClockModel:
    """host = offset + (1 + drift) * sensor, optionally piecewise (knots from windowed fits).

    Internally anchored at (sensor_ref, host_ref) so that large clock values keep precision."""

    sensor_ref: float
    host_ref: float
    drift: float
    method: str = "envelope"
    residuals: dict[str, float] = field(default_factory=dict)
    knots_sensor: F64 | None = field(default=None, repr=False)
    knots_host: F64 | None = field(default=None, repr=False)

    @property
    def offset(self) -> float:
        """Host time at sensor time 0 (s)."""
        return self.host_ref - (1.0 + self.drift) * self.sensor_ref

    def to_host(self, sensor_time: ArrayLike) -> F64:
        """Host monotonic time (s) of sensor clock time(s)."""
        s = np.asarray(sensor_time, dtype=np.float64)
        if self.knots_sensor is None or self.knots_host is None:
            return self.host_ref + (1.0 + self.drift) * (s - self.sensor_ref)
        return _interp_extrapolate(s, self.knots_sensor, self.knots_host)

    def to_sensor(self, host_time: ArrayLike) -> F64:
        """Sensor clock time (s) of host monotonic time(s)."""
        h = np.asarray(host_time, dtype=np.float64)
        if self.knots_sensor is None or self.knots_host is None:
            return self.sensor_ref + (h - self.host_ref) / (1.0 + self.drift)
        return _interp_extrapolate(h, self.knots_host, self.knots_sensor)

    def as_dict(self) -> dict[str, Any]:
        return {
            "offset": self.offset,
            "drift": self.drift,
            "sensor_ref": self.sensor_ref,
            "host_ref": self.host_ref,
            "method": self.method,
            "piecewise_knots": 0 if self.knots_sensor is None else len(self.knots_sensor),
            "residuals": dict(self.residuals),
        }


def fit_clock(
    sensor_times: ArrayLike,
    host_times: ArrayLike,
    *,
    exchanges: Sequence[Exchange] | None = None,
    window: float | None = None,
    drift: float | None = None,
) -> ClockModel:
    """Fit host = offset + (1 + drift) * sensor from arrival times and/or time-sync exchanges.

    `sensor_times` (s, device clock) and `host_times` (s, host arrival) pair up sample by
    sample; either may be empty when `exchanges` are given. `window` (sensor seconds) refits
    on overlapping windows for a piecewise model that follows a changing drift. `drift`:
    known from elsewhere (a declared clock), so only the offset is fitted, and no windows."""
    s = np.asarray(sensor_times, dtype=np.float64).ravel()
    h = np.asarray(host_times, dtype=np.float64).ravel()
    if s.shape != h.shape:
        raise ClockFitError(f"{s.size} sensor times but {h.size} host times: pair them up")
    ok = np.isfinite(s) & np.isfinite(h)
    s, h = s[ok], h[ok]
    have_arrivals = s.size >= _MIN_POINTS and np.ptp(s) > 0
    sync = _exchange_points(exchanges or ())
    if not have_arrivals and sync is None:
        raise ClockFitError(
            "need at least two samples with distinct sensor times, or time-sync exchanges"
        )
    if not have_arrivals:
        assert sync is not None
        return _fit_exchanges_only(*sync)
    s_ref, h_ref = float(s[0]), float(h[0])
    x, y = s - s_ref, (h - h_ref) - (s - s_ref)  # y: departure from slope 1, small numbers
    if drift is None:
        slope, intercept = _envelope_line(x, y)
    else:
        slope, intercept = drift, _envelope_offset(x, y - drift * x)
    method = "envelope"
    local = None
    if exchanges:
        sync = _exchange_points(exchanges, 1.0 + slope)
    if sync is not None:
        local = (sync[0] - s_ref, (sync[1] - h_ref) - (sync[0] - s_ref), sync[2])
        intercept = _weighted_median(local[1] - slope * local[0], local[2])
        method = "envelope+exchanges"
    resid = y - (intercept + slope * x)
    model = ClockModel(s_ref, h_ref + intercept, slope, method, _residual_stats(resid))
    if window is not None and drift is None and np.ptp(x) > 1.5 * window:
        model = _piecewise(model, x, y, window, h_ref, local)
    return model


# ---------------------------------------------------------------------------- envelope
def _envelope_line(x: F64, y: F64) -> tuple[float, float]:
    """(slope, intercept) of the LP lower-envelope line of points (x, y)."""
    bx, by, weight = _bin_minima(x, y)
    keep = _reject_early(bx, by)
    bx, by, weight = bx[keep], by[keep], weight[keep]
    hull = _lower_hull(bx, by)
    x_mean = float(np.average(bx, weights=weight))
    hx, hy = bx[hull], by[hull]
    if len(hx) == 1:
        return 0.0, float(hy[0])
    j = int(np.clip(np.searchsorted(hx, x_mean) - 1, 0, len(hx) - 2))
    slope = float((hy[j + 1] - hy[j]) / (hx[j + 1] - hx[j]))
    return slope, float(hy[j] - slope * hx[j])


def _envelope_offset(x: F64, y: F64) -> float:
    """The intercept of the highest horizontal line under points (x, y), glitches set aside."""
    bx, by, _ = _bin_minima(x, y)
    return float(np.min(by[_reject_early(bx, by)]))


def _bin_minima(x: F64, y: F64) -> tuple[F64, F64, F64]:
    """The lowest point of each of up to _BINS sensor-time bins, and each bin's count."""
    order = np.argsort(x, kind="stable")
    x, y = x[order], y[order]
    if len(x) <= _BINS:
        return x, y, np.ones(len(x))
    edges = np.linspace(x[0], x[-1], _BINS + 1)
    b = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, _BINS - 1)
    starts = np.flatnonzero(np.r_[True, b[1:] != b[:-1]])
    counts = np.diff(np.r_[starts, len(x)]).astype(np.float64)
    # lowest y per bin: sort each bin by y via lexsort on (y, bin)
    idx = np.lexsort((y, b))[starts]
    return x[idx], y[idx], counts


def _reject_early(x: F64, y: F64) -> NDArray[np.bool_]:
    """Drop points far below their neighbours: latencies are >= 0, so a point far under the
    envelope is a timestamp glitch, not information."""
    if len(x) < 8:
        return np.ones(len(x), dtype=bool)
    # robust local level: a least-squares line through the lower half of the points
    coef = np.polyfit(x, y, 1)
    r = y - np.polyval(coef, x)
    low = r <= np.median(r)
    coef = np.polyfit(x[low], y[low], 1)
    r = y - np.polyval(coef, x)
    lower = r[r <= np.median(r)]
    spread = float(np.median(np.abs(lower - np.median(lower)))) * 1.4826
    floor = float(np.median(lower)) - 12.0 * max(spread, 1e-6)
    return r >= floor


def _lower_hull(x: F64, y: F64) -> NDArray[np.int64]:
    """Indices (ascending x) of the lower convex hull (Andrew's monotone chain)."""
    hull: list[int] = []
    for i in range(len(x)):
        while len(hull) >= 2:
            a, b = hull[-2], hull[-1]
            cross = (x[b] - x[a]) * (y[i] - y[a]) - (y[b] - y[a]) * (x[i] - x[a])
            if cross > 0:
                break
            hull.pop()
        if hull and x[hull[-1]] == x[i]:
            continue  # same x: the earlier (lower, after sorting) point stays
        hull.append(i)
    return np.asarray(hull, dtype=np.int64)


def _piecewise(
    model: ClockModel,
    x: F64,
    y: F64,
    window: float,
    h_ref: float,
    sync: tuple[F64, F64, F64] | None,
) -> ClockModel:
    """Refit on windows of `window` s stepping by half a window; knots at window centres.
    With exchanges, the knots shift together so that the exchanges keep setting the offset."""
    centres = np.arange(x.min() + window / 2, x.max() - window / 2 + 1e-12, window / 2)
    knots = []
    for c in centres:
        sel = (x >= c - window / 2) & (x <= c + window / 2)
        if np.count_nonzero(sel) >= _MIN_POINTS and np.ptp(x[sel]) > 0:
            slope, intercept = _envelope_line(x[sel], y[sel])
            knots.append((c, intercept + slope * c))
    if len(knots) < 2:
        return model
    kx, ky = np.asarray(knots).T
    if sync is not None:
        xs, ys, weight = sync
        ky = ky + _weighted_median(ys - _interp_extrapolate(xs, kx, ky), weight)
    s_ref = model.sensor_ref
    return ClockModel(
        model.sensor_ref,
        model.host_ref,
        model.drift,
        model.method + ",piecewise",
        model.residuals,
        kx + s_ref,
        ky + kx + h_ref,
    )


# ---------------------------------------------------------------------------- exchanges
#: Stretches of device time in which the shortest round trips are picked (see below), and
#: how much longer than the session's shortest a round trip may be and still be used.
_SYNC_BINS = 16
_SYNC_WORST = 20.0


def _exchange_points(
    exchanges: Sequence[Exchange], ratio: float = 1.0
) -> tuple[F64, F64, F64] | None:
    """(device mid s, host mid s, weight) of the usable round trips: those within 1.5x the
    shortest round trip (long ones carry more asymmetry). `ratio` converts the device's
    turnaround to host seconds (host s per device s, from the arrivals when known)."""
    if not exchanges:
        return None
    host_sent = np.array([e.host_sent for e in exchanges], dtype=np.float64)
    host_recv = np.array([e.host_received for e in exchanges], dtype=np.float64)
    rx = np.array([e.device_rx_us for e in exchanges], dtype=np.float64)
    tx = np.array([e.device_tx_us for e in exchanges], dtype=np.float64)
    rtt = (host_recv - host_sent) - (tx - rx) * 1e-6 * ratio  # minus the device's turnaround
    ok = np.isfinite(rtt) & (rtt >= 0)
    if not ok.any():
        raise ClockFitError("no time-sync exchange has a non-negative round trip")
    best = float(np.min(rtt[ok]))
    # "shortest" is judged per stretch of time: a globally best burst would otherwise be the
    # only one kept, and one burst (milliseconds of device time) cannot show the drift
    mid = (rx + tx) / 2e6
    span = float(np.ptp(mid[ok]))
    where = np.zeros(len(mid), dtype=np.int64)
    if span > 0:
        where = np.minimum(
            ((mid - mid[ok].min()) / span * _SYNC_BINS).astype(np.int64), _SYNC_BINS - 1
        )
        where = np.where(ok, where, 0)
    local = np.full(_SYNC_BINS, np.inf)
    np.minimum.at(local, where[ok], rtt[ok])
    use = ok & (rtt <= 1.5 * local[where] + 50e-6) & (rtt <= _SYNC_WORST * best + 1e-3)
    weight = 1.0 / (rtt[use] + 1e-5)
    return mid[use], (host_sent[use] + host_recv[use]) / 2, weight


def _fit_exchanges_only(s: F64, h: F64, w: F64) -> ClockModel:
    s_ref, h_ref = float(s[0]), float(h[0])
    x, y = s - s_ref, (h - h_ref) - (s - s_ref)
    if len(x) >= 2 and np.ptp(x) > 0:
        slope, intercept = np.polyfit(x, y, 1, w=np.sqrt(w))
    else:
        slope, intercept = 0.0, _weighted_median(y, w)
    resid = y - (intercept + slope * x)
    return ClockModel(
        s_ref, h_ref + float(intercept), float(slope), "exchanges", _residual_stats(resid)
    )


# ---------------------------------------------------------------------------- helpers
def _weighted_median(values: F64, weights: F64) -> float:
    order = np.argsort(values)
    cum = np.cumsum(weights[order])
    return float(values[order][np.searchsorted(cum, cum[-1] / 2)])


def _residual_stats(r: F64) -> dict[str, float]:
    if r.size == 0:
        return {"n": 0}
    q = np.percentile(r, [0, 50, 95, 100])
    return {
        "n": int(r.size),
        "min": float(q[0]),
        "median": float(q[1]),
        "p95": float(q[2]),
        "max": float(q[3]),
        "below_envelope": int(np.count_nonzero(r < -1e-6)),
    }


def _interp_extrapolate(v: F64, xp: F64, fp: F64) -> F64:
    """np.interp with linear extrapolation from the end segments."""
    out = np.interp(v, xp, fp)
    lo, hi = v < xp[0], v > xp[-1]
    if np.any(lo):
        out = np.where(lo, fp[0] + (v - xp[0]) * (fp[1] - fp[0]) / (xp[1] - xp[0]), out)
    if np.any(hi):
        out = np.where(hi, fp[-1] + (v - xp[-1]) * (fp[-1] - fp[-2]) / (xp[-1] - xp[-2]), out)
    return out
