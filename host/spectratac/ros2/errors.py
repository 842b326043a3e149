"""Typed errors of the bag exporter; each message says what was wrong and what to do."""

from __future__ import annotations

from spectratac.errors import SpectraTacError


class BagExportError(SpectraTacError):
    """A bag could not be written: nothing to export, a bad storage choice, or a write that
    failed (the partial bag is removed)."""
