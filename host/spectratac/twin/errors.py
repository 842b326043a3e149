"""Typed errors raised by the digital twin."""

from __future__ import annotations

from spectratac.errors import SpectraTacError


class TwinError(SpectraTacError):
    """Bad input to the twin (scene, settings, unit); the message names the field and the fix."""


class I2CNack(SpectraTacError):
    """The simulated I2C device did not acknowledge: absent device, bad register or bad length."""
