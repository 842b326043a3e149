"""Reference six-axis F/T sensors behind one interface: ATI Net F/T (UDP RDT), Bota Systems
serial sensors, CSV and ROS 2 bag replay (csv://, rosbag://), and plug-ins registered by URL
scheme (`register_ft_scheme`, or the ``spectratac.ft_sensors`` entry points): the simulator's
sim:// sensors speak the real sensors' wire protocols.

    with open_ft("netft://192.168.1.1") as ft:      # or bota:///dev/ttyUSB0, csv://f.csv
        ft.start()
        rows = ft.read(1000)                           # FT_RECORD rows
        print(rows["wrench"].mean(axis=0), ft.stats.lost)
"""

from spectratac.ft.base import FTSensor
from spectratac.ft.errors import (
    FTConfigError,
    FTDisconnectedError,
    FTError,
    FTNotFoundError,
    FTProtocolError,
    FTStalledError,
    FTTimeoutError,
    FTURLError,
)
from spectratac.ft.open import FTOpener, ft_schemes
from spectratac.ft.open import register_scheme as register_ft_scheme
from spectratac.ft.records import AXES, FT_RECORD, FTInfo, FTStats

open_ft = FTSensor.open

__all__ = [
    "AXES",
    "FT_RECORD",
    "FTConfigError",
    "FTDisconnectedError",
    "FTError",
    "FTInfo",
    "FTNotFoundError",
    "FTOpener",
    "FTProtocolError",
    "FTSensor",
    "FTStalledError",
    "FTStats",
    "FTTimeoutError",
    "FTURLError",
    "ft_schemes",
    "open_ft",
    "register_ft_scheme",
]
