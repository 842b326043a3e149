"""Recording sessions to MCAP: raw device frames, reference F/T, clock sync, configuration
and region labels in one crash-safe file (layout: FORMAT.md; labels: LABELS.md).

    spectratac record sim://?scene=tour&speed=10&ft=bota -o session.mcap --duration 60

Nothing here imports torch: recording runs on NumPy and the mcap library alone.
"""

from spectratac.record.errors import RecordingError, TruncatedRecordingWarning
from spectratac.record.guided import DEFAULT_SEED, GuidedProtocol
from spectratac.record.labels import LabelQueue
from spectratac.record.reader import Recording, read_recording
from spectratac.record.recorder import (
    Recorder,
    RecordingStatus,
    RecordingSummary,
    RecordOptions,
)
from spectratac.record.session import record_url
from spectratac.record.stop import StopFlag, StopRequest, stopping_on
from spectratac.record.writer import RecordingWriter

__all__ = [
    "DEFAULT_SEED",
    "GuidedProtocol",
    "LabelQueue",
    "RecordOptions",
    "Recorder",
    "Recording",
    "RecordingError",
    "RecordingStatus",
    "RecordingSummary",
    "RecordingWriter",
    "StopFlag",
    "StopRequest",
    "TruncatedRecordingWarning",
    "read_recording",
    "record_url",
    "stopping_on",
]
