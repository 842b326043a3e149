"""FTSensor.open(url): pick the driver by URL scheme; sim:// starts a simulated sensor too."""

from __future__ import annotations

from typing import Any

from spectratac.ft.base import FTSensor
from spectratac.ft.errors import FTURLError

SCHEMES = ("netft", "bota", "csv", "sim")
EXAMPLES = (
    "netft://192.168.1.1?cpf=1000000&cpt=1000000, bota:///dev/ttyUSB0?baud=460800, "
    "csv://session_ft.csv, sim://?scene=calibration&seed=3&speed=10&ft=netft"
)


def open_url(url: str, *, timeout: float, buffer_size: int, **options: Any) -> FTSensor:
    scheme, sep, _ = url.partition("://")
    if not sep or scheme not in SCHEMES:
        raise FTURLError(f"{url!r} is not an F/T URL; examples: {EXAMPLES}")
    if scheme == "csv":
        from spectratac.ft.csvfile import CsvFTSensor

        return CsvFTSensor.connect(url, timeout=timeout, buffer_size=buffer_size, **options)
    if scheme == "netft":
        from spectratac.ft.netft import NetFTSensor

        return NetFTSensor.connect(url, timeout=timeout, buffer_size=buffer_size, **options)
    if scheme == "bota":
        from spectratac.ft.bota import BotaSensor

        return BotaSensor.connect(url, timeout=timeout, buffer_size=buffer_size, **options)
    from spectratac.sim.ft_serve import open_sim_ft

    return open_sim_ft(url, timeout=timeout, buffer_size=buffer_size, **options)
