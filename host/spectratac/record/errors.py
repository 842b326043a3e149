"""Typed errors and warnings of recording and reading MCAP sessions."""

from __future__ import annotations

from spectratac.errors import SpectraTacError


class RecordingError(SpectraTacError):
    """A recording could not be made or read; the message says what to do."""


class TruncatedRecordingWarning(UserWarning):
    """A recording ends early (killed, disk full, copied while written): only its readable
    prefix is used. Everything up to the last complete chunk is intact."""


class CorruptedRecordingWarning(UserWarning):
    """Chunks inside a recording are damaged (their CRC does not match): they are skipped and
    everything else is used. `chunks` and `lost` (messages by topic) say how much was lost."""

    def __init__(self, message: str, path: str, chunks: int, lost: dict[str, int]) -> None:
        super().__init__(message)
        self.path = path
        self.chunks = chunks
        self.lost = lost
