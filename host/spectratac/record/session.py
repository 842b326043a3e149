"""`record_url`: open a device (and its reference F/T sensor) by URL and record a session.

For a sim:// URL the session message names the scene, seed and speed, region labels come
from the scene (`SceneLabeler`), the session ends with the scene at the latest, and if the
URL says ``ft=bota`` or ``ft=netft`` the simulated reference sensor of the same world is
opened when no F/T URL is given.

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

from spectratac.device import Sensor
from spectratac.record.guided import GuidedProtocol
from spectratac.record.labels import SceneLabeler
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
    with contextlib.ExitStack() as stack:
        sensor = stack.enter_context(Sensor.open(url, **(sensor_options or {})))
        labeler = None
        scene_end = None
        if urlsplit(url).scheme == "sim":
            labeler, session["sim"] = _sim_world(url, stack)
            scene_end = session["sim"]["duration_s"]  # a scene that ends ends the session
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
            labeler=labeler,
            guided=guided,
            scene_end_s=scene_end,
        )
        return recorder.run(stop, progress)


def _sim_world(url: str, stack: contextlib.ExitStack) -> tuple[SceneLabeler, dict[str, Any]]:
    """Join the simulated world of `url` (the one the sensor just opened) for its scene."""
    from spectratac.sim.url import parse_sim_url
    from spectratac.sim.world import SimWorld

    opts = parse_sim_url(url)
    world = SimWorld.join(opts)
    stack.callback(world.release)
    paced = world.paced
    speed = float(world.speed) if paced else None
    meta = {
        "scene": opts.scene,
        "seed": opts.seed,
        "speed": world.speed,
        "params": dict(opts.scene_params),
        "absent": list(opts.absent),
        "epoch": world.epoch if paced else None,
        "duration_s": world.scene.duration_s,
        "presses": len(world.scene.presses),
    }
    return SceneLabeler(world.scene, world.epoch if paced else None, speed), meta
