"""`record_url`: open a device (and its reference F/T sensor) by URL and record a session.

A link with ground truth (a simulated device: its transport answers
spectratac.device.GroundTruth) gives the session message its "truth" description, every
sample its truth and the file its scene's label events, and ends the session with its scene
at the latest. Without an F/T URL the link's paired one is used (`LinkInfo.paired_ft_url`:
a sim:// URL that says ``ft=bota`` opens the simulated reference sensor of the same world).

>>> import tempfile
>>> path = tempfile.mkdtemp() + "/press.mcap"
>>> summary = record_url("sim://?scene=press&speed=max", path, RecordOptions(samples=20))
>>> summary.samples >= 20, summary.labels >= 0
(True, True)
"""

from __future__ import annotations

import contextlib
import socket
import sys
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from spectratac.device import LinkInfo, Sensor, ground_truth_of, link_info_of, open_transport
from spectratac.device.transport import DEFAULT_BAUD
from spectratac.ft.errors import FTTimeoutError
from spectratac.record.guided import GuidedProtocol
from spectratac.record.recorder import Recorder, RecordingStatus, RecordingSummary, RecordOptions
from spectratac.record.stop import StopFlag

if TYPE_CHECKING:
    from spectratac.ft import FTSensor

__all__ = ["RecordOptions", "record_url"]

#: F/T open timeout when the caller gives none (FTSensor.open's own default).
DEFAULT_FT_TIMEOUT_S = 2.0


def record_url(
    url: str,
    path: str | Path,
    options: RecordOptions | None = None,
    *,
    ft_url: str | None = None,
    guided: GuidedProtocol | None = None,
    stop: StopFlag | None = None,
    progress: Callable[[RecordingStatus], None] | None = None,
    sensor_options: dict[str, Any] | None = None,
    on_open: Callable[[LinkInfo, str | None], None] | None = None,
) -> RecordingSummary:
    """Record `url` into `path`; returns the summary (see Recorder.run). `on_open` is told,
    once the device is open, what its link knows and which F/T URL the session uses. The
    ``timeout`` of `sensor_options` bounds the opening of the F/T sensor too (FTTimeoutError
    naming it when it does not answer in time); its ``stall_timeout`` is the F/T's too (a
    quiet F/T is said once on stderr and counted; the optical stream goes on)."""
    session: dict[str, Any] = {
        "host": {"hostname": socket.gethostname(), "python": sys.version.split()[0]},
    }
    sensor_options = dict(sensor_options or {})
    baudrate = sensor_options.pop("baudrate", DEFAULT_BAUD)
    with contextlib.ExitStack() as stack:
        transport = open_transport(url, baudrate)  # opened here to ask it for ground truth
        sensor = stack.enter_context(Sensor.attach(transport, **sensor_options))
        link = link_info_of(transport)
        ft_url = ft_url or link.paired_ft_url
        if on_open is not None:
            on_open(link, ft_url)
        ft = None
        if ft_url is not None:
            ft = stack.enter_context(_open_ft(ft_url, sensor_options.get("timeout")))
            ft.stall_timeout = sensor_options.get("stall_timeout")  # None: from its rate
            session |= {"ft_url": ft_url, "ft_link": ft.url}  # as given; as the driver opened it
        recorder = Recorder(
            sensor,
            path,
            options,
            ft=ft,
            session=session,
            ground_truth=ground_truth_of(transport),
            guided=guided,
        )
        return recorder.run(stop, progress)


def _open_ft(ft_url: str, timeout: float | None) -> FTSensor:
    """The session's reference F/T sensor, within the same timeout as the device."""
    from spectratac.ft import FTSensor

    timeout = DEFAULT_FT_TIMEOUT_S if timeout is None else timeout
    try:
        return FTSensor.open(ft_url, timeout=timeout)
    except FTTimeoutError as exc:
        raise FTTimeoutError(
            f"the reference F/T sensor did not answer within {timeout:g} s: {exc}; "
            f"or give it longer with --timeout S"
        ) from None
