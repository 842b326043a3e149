"""Talking to a SpectraTac device: transports (by URL scheme, extensible with
`register_transport_scheme` or ``spectratac.transports`` entry points), the Sensor API, the
optional ground truth of simulated links, typed errors."""

from spectratac.device.errors import (
    BufferOverflowError,
    CommandRejectedError,
    DeviceError,
    DeviceNotFoundError,
    DeviceTimeoutError,
    DisconnectedError,
    PermissionDeniedError,
    ProtocolMismatchError,
)
from spectratac.device.ground_truth import CONTACT_TRUTH, GroundTruth, ground_truth_of
from spectratac.device.records import (
    SAMPLE_RECORD,
    SAMPLE_TIME_INVERTED,
    SAMPLE_WINDOW_CLIPPED,
    Sample,
)
from spectratac.device.sensor import ClockSync, Sensor, SensorStats, TimeSyncExchange
from spectratac.device.transport import (
    BadAddressError,
    TransportOpener,
    UnknownSchemeError,
    open_transport,
    transport_schemes,
)
from spectratac.device.transport import register_scheme as register_transport_scheme

__all__ = [
    "CONTACT_TRUTH",
    "SAMPLE_RECORD",
    "SAMPLE_TIME_INVERTED",
    "SAMPLE_WINDOW_CLIPPED",
    "BadAddressError",
    "BufferOverflowError",
    "ClockSync",
    "CommandRejectedError",
    "DeviceError",
    "DeviceNotFoundError",
    "DeviceTimeoutError",
    "DisconnectedError",
    "GroundTruth",
    "PermissionDeniedError",
    "ProtocolMismatchError",
    "Sample",
    "Sensor",
    "SensorStats",
    "TimeSyncExchange",
    "TransportOpener",
    "UnknownSchemeError",
    "ground_truth_of",
    "open_transport",
    "register_transport_scheme",
    "transport_schemes",
]
