"""The decoder tests' small datasets (a short twin session, synthetic SpectraTac-shaped data)."""

from __future__ import annotations

from tests.decode.conftest import synth_ds, twin_ds

__all__ = ["synth_ds", "twin_ds"]
