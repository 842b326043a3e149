"""Typed errors and warnings of recording and reading MCAP sessions."""

from __future__ import annotations

from spectratac.errors import SpectraTacError


class RecordingError(SpectraTacError):
    """A recording could not be made or read; the message says what to do."""


class TruncatedRecordingWarning(UserWarning):
    """A recording ends early (killed, disk full, copied while written): only its readable
    prefix is used. Everything up to the last complete chunk is intact."""
