"""Reference six-axis F/T sensors behind one interface: ATI Net F/T (UDP RDT), Bota Systems
serial sensors, CSV replay, and simulated ones speaking those wire protocols (sim://).

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
    FTTimeoutError,
    FTURLError,
)
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
    "FTProtocolError",
    "FTSensor",
    "FTStats",
    "FTTimeoutError",
    "FTURLError",
    "open_ft",
]
