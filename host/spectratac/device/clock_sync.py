"""TIME_SYNC round trips between the host clock and the device clock (NTP-style): what the
dataset builder and the live page fit the device clock to host time with."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

from spectratac.device.link import Link
from spectratac.protocol.generated import messages as m


@dataclass(frozen=True)
class TimeSyncExchange:
    """One TIME_SYNC round trip: host clock (s, monotonic) and device clock (µs, unwrapped).

    >>> ex = TimeSyncExchange(10.0, 5_000_100, 5_000_300, 10.0004)
    >>> round(ex.round_trip, 6), round(ex.offset, 6)
    (0.0004, -5.0)
    """

    host_sent: float
    device_rx_us: int
    device_tx_us: int
    host_received: float
    epoch: int = 0  # the sensor's connection epoch the device times belong to

    @property
    def round_trip(self) -> float:
        return self.host_received - self.host_sent

    @property
    def offset(self) -> float:
        """device time − host time in seconds, assuming a symmetric link (NTP)."""
        device_mid = (self.device_rx_us + self.device_tx_us) / 2e6
        return device_mid - (self.host_sent + self.host_received) / 2


@dataclass(frozen=True)
class ClockSync:
    offset: float  # device − host seconds, from the exchange with the shortest round trip
    round_trip: float
    exchanges: tuple[TimeSyncExchange, ...] = field(repr=False)


def sync_clock(link: Link, unwrap: Callable[[int], int], exchanges: int = 8) -> ClockSync:
    """Run `exchanges` TIME_SYNC round trips over `link`; `unwrap` extends the device's u32
    µs clock as the samples' times are (the same unwrapper). Keeps the exchange with the
    shortest round trip (least queuing) as the offset."""
    done: list[TimeSyncExchange] = []
    for i in range(exchanges):
        sent = time.monotonic()
        reply, received = link.request_at(  # not resent: a resend would void the timestamps
            m.TimeSyncRequest(exchange_id=i, host_time_ns=int(sent * 1e9)),
            m.TimeSyncReply,
            attempts=1,
        )
        rx = unwrap(reply.device_rx_us)
        done.append(
            TimeSyncExchange(
                sent,
                rx,
                rx + ((reply.device_tx_us - reply.device_rx_us) & 0xFFFF_FFFF),
                received,
                link.epoch,
            )
        )
    best = min(done, key=lambda e: e.round_trip)
    return ClockSync(best.offset, best.round_trip, tuple(done))
