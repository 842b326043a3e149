"""Talking to a SpectraTac device: transports (by URL scheme, extensible with
`register_transport_scheme` or ``spectratac.transports`` entry points), the Sensor API (a
façade over a Link and two RecordQueues), what a link knows about itself (`LinkInfo`), the
typed stream protocols that consumers of a sensor take (SampleStream, EstimateStream,
DeviceStream), the optional ground truth of simulated links, typed errors."""

from spectratac.device.clock_sync import ClockSync, TimeSyncExchange
from spectratac.device.errors import (
    BufferOverflowError,
    CommandRejectedError,
    DeviceError,
    DeviceNotFoundError,
    DeviceStalledError,
    DeviceTimeoutError,
    DisconnectedError,
    MissingCapabilityError,
    ModelUploadError,
    PermissionDeniedError,
    ProtocolMismatchError,
)
from spectratac.device.estimate_records import ESTIMATE_RECORD, EstimateRow
from spectratac.device.ground_truth import CONTACT_TRUTH, GroundTruth, ground_truth_of
from spectratac.device.link import Link
from spectratac.device.link_info import LinkInfo, link_info_of
from spectratac.device.model_store import ModelInfo
from spectratac.device.record_queue import RecordQueue
from spectratac.device.records import (
    SAMPLE_RECORD,
    SAMPLE_TIME_INVERTED,
    SAMPLE_WINDOW_CLIPPED,
    Sample,
)
from spectratac.device.sensor import EstimatesMode, Sensor
from spectratac.device.stats import SensorStats
from spectratac.device.streams import DeviceStream, EstimateStream, SampleStream
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
    "ESTIMATE_RECORD",
    "SAMPLE_RECORD",
    "SAMPLE_TIME_INVERTED",
    "SAMPLE_WINDOW_CLIPPED",
    "BadAddressError",
    "BufferOverflowError",
    "ClockSync",
    "CommandRejectedError",
    "DeviceError",
    "DeviceNotFoundError",
    "DeviceStalledError",
    "DeviceStream",
    "DeviceTimeoutError",
    "DisconnectedError",
    "EstimateRow",
    "EstimateStream",
    "EstimatesMode",
    "GroundTruth",
    "Link",
    "LinkInfo",
    "MissingCapabilityError",
    "ModelInfo",
    "ModelUploadError",
    "PermissionDeniedError",
    "ProtocolMismatchError",
    "RecordQueue",
    "Sample",
    "SampleStream",
    "Sensor",
    "SensorStats",
    "TimeSyncExchange",
    "TransportOpener",
    "UnknownSchemeError",
    "ground_truth_of",
    "link_info_of",
    "open_transport",
    "register_transport_scheme",
    "transport_schemes",
]
