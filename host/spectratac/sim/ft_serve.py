"""Simulated reference F/T sensors selected by sim:// URLs, served to the real drivers.

    FTSensor.open("sim://?scene=calibration&seed=3&speed=10&ft=netft")   # or ft=bota

starts a simulated sensor of that scene's world in this process (a UDP RDT server on
127.0.0.1 for netft, a pty writing Bota frames for bota) and connects the real driver to it;
closing the FTSensor stops the server. Sensor.open() of the same URL gives the optical
sensor of the same world, so both ground truths agree. Parameters: ft_rate (Hz, 1000),
ft_loss (0.001), ft_offset (s, 0.05), ft_drift (1e-4), ft_port (netft UDP port, 0 = any).

>>> from spectratac.ft import FTSensor
>>> with FTSensor.open("sim://?scene=press&seed=1&speed=10&ft=bota&ft_loss=0") as ft:
...     rows = ft.read(50, timeout=5.0)
>>> len(rows), ft.info.kind, ft.stats.lost
(50, 'bota', 0)
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from spectratac.ft.base import FTSensor
from spectratac.ft.errors import FTURLError
from spectratac.sim.ft_bota import BotaServer
from spectratac.sim.ft_netft import NetFTServer
from spectratac.sim.ft_source import FTParams, FTSource
from spectratac.sim.url import SimOptions, parse_sim_url
from spectratac.sim.world import SimWorld

KINDS = ("netft", "bota")


def sim_options(url: str) -> tuple[SimOptions, str]:
    """The parsed URL and its F/T kind; FTURLError when either is missing or wrong."""
    try:
        opts = parse_sim_url(url)
    except ValueError as exc:
        raise FTURLError(str(exc)) from None
    kind = opts.scene_params.get("ft", "")
    if kind not in KINDS:
        raise FTURLError(
            f"{url}: say which simulated F/T sensor with ft=netft or ft=bota, e.g. "
            f"sim://?scene=calibration&seed=3&speed=10&ft=netft"
        )
    return opts, kind


def start_server(
    world: SimWorld,
    opts: SimOptions,
    kind: str,
    *,
    port: int | None = None,
    link: Path | None = None,
) -> NetFTServer | BotaServer:
    """Start the simulated sensor `kind` of `world` (FTURLError for speed=max without the
    world's optical sensor open: it sets the pace)."""
    source = FTSource(world, FTParams.from_sim(opts), stream=KINDS.index(kind))
    if kind == "netft":
        if port is None:
            try:
                port = int(opts.scene_params.get("ft_port", "0"))
            except ValueError:
                raise FTURLError(f"{opts.query()}: ft_port must be an integer") from None
        return NetFTServer(source, port=port)
    return BotaServer(source, link=link)


def simulated_ft_url(
    kind: str,
    *,
    scene: str,
    seed: int,
    speed: str,
    rate: float,
    loss: float,
    offset: float,
    drift: float,
) -> str:
    """The sim:// URL of a simulated `kind` F/T sensor (what `spectratac sim ft` serves).

    >>> simulated_ft_url("bota", scene="press", seed=1, speed="2", rate=500.0, loss=0.0,
    ...                  offset=0.0, drift=0.0)  # fmt: skip
    'sim://?scene=press&seed=1&speed=2&ft=bota&ft_rate=500.0&ft_loss=0.0&ft_offset=0.0&ft_drift=0.0'
    """
    return (
        f"sim://?scene={scene}&seed={seed}&speed={speed}&ft={kind}"
        f"&ft_rate={rate}&ft_loss={loss}&ft_offset={offset}&ft_drift={drift}"
    )


@contextlib.contextmanager
def serving(
    url: str, *, port: int | None = None, link: Path | None = None
) -> Iterator[NetFTServer | BotaServer]:
    """Serve the simulated F/T sensor of `url` (``ft=netft|bota``) to other programs until
    the block ends. FTURLError for a bad URL, OSError when the port or pty cannot be had."""
    opts, kind = sim_options(url)
    world = SimWorld.join(opts)
    try:
        server = start_server(world, opts, kind, port=port, link=link)
        try:
            yield server
        finally:
            server.stop()
    finally:
        world.release()


def open_sim_ft(url: str, *, timeout: float, buffer_size: int, **options: Any) -> FTSensor:
    opts, kind = sim_options(url)
    world = SimWorld.join(opts)
    try:
        server = start_server(world, opts, kind)
    except BaseException:
        world.release()
        raise
    try:
        sensor = FTSensor.open(server.url, timeout=timeout, buffer_size=buffer_size, **options)
    except BaseException:
        server.stop()
        world.release()
        raise
    sensor.info.extra["sim"] = url
    # losses it makes on purpose (ft_loss), so a report can tell them from a link's
    sensor.info.extra["simulated_loss"] = FTParams.from_sim(opts).loss
    sensor._on_close += [server.stop, world.release]
    return sensor
