"""FTSensor.open(url): pick the driver by URL scheme.

The drivers of this package open netft://, bota://, csv:// and rosbag:// (ROS 2 bag) URLs;
other schemes come from plug-ins: the ``spectratac.ft_sensors`` entry points of installed
packages (the simulator registers ``sim://``, which starts a simulated sensor and connects a
real driver to it), or `register_scheme` at run time.

>>> {"bota", "csv", "netft", "rosbag", "sim"} <= set(ft_schemes())
True
>>> open_url("nosuch://x", timeout=1.0, buffer_size=10)
Traceback (most recent call last):
...
spectratac.ft.errors.FTURLError: 'nosuch://x' is not an F/T URL: the schemes are ...
"""

from __future__ import annotations

from typing import Any, Protocol

from spectratac.ft.base import FTSensor
from spectratac.ft.errors import FTURLError
from spectratac.url_schemes import SchemeRegistry, check_url

#: Entry-point group of F/T sensor plug-ins: name = URL scheme, value = an FTOpener.
ENTRY_POINTS = "spectratac.ft_sensors"
EXAMPLES = (
    "netft://192.168.1.1?cpf=1000000&cpt=1000000, bota:///dev/ttyUSB0?baud=460800, "
    "csv://session_ft.csv, rosbag://my_bag?topic=/ft_sensor/wrench, sim://?scene=calibration&seed=3&speed=10&ft=netft"
)


class FTOpener(Protocol):
    """Connects to the F/T sensor of a URL of its scheme (see FTSensor.open)."""

    def __call__(
        self, url: str, *, timeout: float, buffer_size: int, **options: Any
    ) -> FTSensor: ...


_REGISTRY: SchemeRegistry[FTOpener] = SchemeRegistry(
    "F/T sensor",
    ENTRY_POINTS,
    {
        "netft": "spectratac.ft.netft:NetFTSensor.connect",
        "bota": "spectratac.ft.bota:BotaSensor.connect",
        "csv": "spectratac.ft.csvfile:CsvFTSensor.connect",
        "rosbag": "spectratac.ft.rosbag:RosbagFTSensor.connect",
    },
)


def register_scheme(scheme: str, opener: FTOpener, *, replace: bool = False) -> None:
    """Open `scheme`:// F/T URLs with `opener` from now on (in this process). Installed
    packages register theirs with a ``spectratac.ft_sensors`` entry point instead."""
    _REGISTRY.register(scheme, opener, replace=replace)


def ft_schemes() -> list[str]:
    """Every F/T URL scheme FTSensor.open accepts."""
    return _REGISTRY.schemes()


def open_url(url: str, *, timeout: float, buffer_size: int, **options: Any) -> FTSensor:
    check_url(url, FTURLError)  # a 100 KB path or host, or undecodable bytes: refused here
    scheme, sep, _ = url.partition("://")
    opener = _REGISTRY.lookup(scheme) if sep else None
    if opener is None:
        raise FTURLError(
            f"{url!r} is not an F/T URL: the schemes are "
            f"{', '.join(s + '://' for s in ft_schemes())}; examples: {EXAMPLES}"
        )
    return opener(url, timeout=timeout, buffer_size=buffer_size, **options)


FTSensor._dispatch = open_url  # FTSensor.open dispatches here: registered, not imported by it
