"""Errors and warnings of the decoder: what went wrong and what to do about it.

>>> issubclass(DecoderDataError, DecoderError) and issubclass(DecoderConfigError, DecoderError)
True
"""

from __future__ import annotations

from spectratac.errors import SpectraTacError


class DecoderError(SpectraTacError):
    """Any decoder problem: bad specification, bad data, bad model file."""


class DecoderDataError(DecoderError):
    """Training or prediction data cannot be used as given (NaN rows, bad labels, shapes)."""


class DecoderConfigError(DecoderError):
    """The data or sensor does not match the configuration the decoder was trained under."""


class DecoderFileError(DecoderError):
    """A model file is unreadable, damaged or of a newer format than this library reads."""


class DecoderUnitWarning(UserWarning):
    """The decoder runs on another unit than it was calibrated on: expect larger errors."""


class DecoderOodWarning(UserWarning):
    """Most estimates of a stream are out of distribution (decode.ood_watch): said once."""


class DecoderUnitError(DecoderError):
    """The sensor is another unit than the decoder was calibrated on, and the caller asked
    for the same unit (strict unit checking, `--strict-unit`)."""


class SensorNotStreamingError(DecoderError):
    """`Decoder.stream` was given a sensor that is open but not streaming: no sample would
    ever come. Call `sensor.start()` first."""
