"""Typed errors of the F/T drivers; each message says what was wrong and what to do."""

from __future__ import annotations

from spectratac.errors import SpectraTacError


class FTError(SpectraTacError):
    """Base of errors about a reference F/T sensor or the link to it."""


class FTURLError(FTError, ValueError):
    """The F/T URL is malformed, names an unknown scheme, or has a bad option."""


class FTNotFoundError(FTError):
    """The serial port, host name or CSV file named by the URL does not exist."""


class FTTimeoutError(FTError, TimeoutError):
    """The F/T sensor did not answer within the timeout (unreachable, wrong port, powered off)."""


class FTConfigError(FTError):
    """The sensor's configuration (e.g. counts per force/torque) is unavailable or invalid."""


class FTProtocolError(FTError):
    """The sensor answered, but not as the protocol says (wrong device on that port?)."""


class FTDisconnectedError(FTError):
    """The link was lost; records received before the loss remain readable."""


class FTStalledError(FTDisconnectedError, FTTimeoutError):
    """A streaming F/T sensor sent nothing for longer than the stall timeout; the records
    received before remain readable. The message names the sensor and the setting."""


class FTBagError(FTConfigError):
    """A ROS 2 bag cannot serve as the reference: unreadable, damaged, empty, or without a
    usable wrench topic (the message lists the topics it has and their types)."""
