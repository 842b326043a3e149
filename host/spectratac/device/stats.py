"""`SensorStats`: the link-health counters of one Sensor (its Link counts frames, errors and
reconnects; the Sensor counts samples, estimates and what its queues dropped)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass
class SensorStats:
    """Link health as seen by the host."""

    frames_received: int = 0
    samples_received: int = 0
    crc_errors: int = 0
    cobs_errors: int = 0
    other_frame_errors: int = 0  # too short, oversize, unknown type, short payload
    frame_gaps: int = 0  # frames missing by the device's frame sequence numbers
    sample_gaps: int = 0  # samples missing by SAMPLE.sample_seq
    buffer_overflows: int = 0  # samples discarded by the overflow policy
    reconnects: int = 0
    stalls: int = 0  # streams dropped (or reopened) for sending nothing (Sensor.stall_timeout)
    logs: int = 0
    sample_time_errors: int = 0  # samples flagged SAMPLE_TIME_INVERTED or _WINDOW_CLIPPED
    version_mismatches: int = 0  # frames of another protocol major version, dropped
    command_retries: int = 0  # commands sent a second time after no reply
    estimates_received: int = 0  # ESTIMATE frames (protocol 1.1)
    estimate_gaps: int = 0  # estimates missing by ESTIMATE.sample_seq
    estimate_overflows: int = 0  # estimates discarded by the overflow policy
    model_upload_retries: int = 0  # model uploads restarted from MODEL_BEGIN

    def as_dict(self) -> dict[str, int]:
        return dict(self.__dict__)
