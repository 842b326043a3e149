"""`record_url`: open a device (and its reference F/T sensor) by URL and record a session.

A link with ground truth (a simulated device: its transport answers
spectratac.device.GroundTruth) gives the session message its "sim" description, every
sample its truth and the file its scene's label events, and ends the session with its scene
at the latest; a sim:// URL that says ``ft=bota`` or ``ft=netft`` opens the simulated
reference sensor of the same world when no F/T URL is given.

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
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any
from urllib.parse import parse_qs, urlsplit

from spectratac.device import Sensor, ground_truth_of, open_transport
from spectratac.device.transport import DEFAULT_BAUD
from spectratac.record.guided import GuidedProtocol
from spectratac.record.recorder import Recorder, RecordingStatus, RecordingSummary, RecordOptions

__all__ = ["RecordOptions", "ft_url_for", "record_url"]


def ft_url_for(url: str, ft_url: str | None) -> str | None:
    """The F/T URL to use: the one given, else the sim URL itself if it asks for F/T.

    >>> ft_url_for("sim://?scene=tour&ft=bota", None), ft_url_for("/dev/ttyACM0", None)
    ('sim://?scene=tour&ft=bota', None)
    """
    if ft_url:
        return ft_url
    parts = urlsplit(url)
    if parts.scheme == "sim" and parse_qs(parts.query).get("ft"):
        return url
    return None


def record_url(
    url: str,
    path: str | Path,
    options: RecordOptions | None = None,
    *,
    ft_url: str | None = None,
    guided: GuidedProtocol | None = None,
    stop: threading.Event | None = None,
    progress: Callable[[RecordingStatus], None] | None = None,
    sensor_options: dict[str, Any] | None = None,
) -> RecordingSummary:
    """Record `url` into `path`; returns the summary (see Recorder.run)."""
    ft_url = ft_url_for(url, ft_url)
    session: dict[str, Any] = {
        "host": {"hostname": socket.gethostname(), "python": sys.version.split()[0]},
        "sim": None,
    }
    sensor_options = dict(sensor_options or {})
    baudrate = sensor_options.pop("baudrate", DEFAULT_BAUD)
    with contextlib.ExitStack() as stack:
        transport = open_transport(url, baudrate)  # opened here to ask it for ground truth
        sensor = stack.enter_context(Sensor.attach(transport, **sensor_options))
        ft = None
        if ft_url is not None:
            from spectratac.ft import FTSensor

            ft = stack.enter_context(FTSensor.open(ft_url))
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
