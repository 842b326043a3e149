"""The decoder as a NumPy model: counts in, F/T, contact region and contact out; load, save,
predict, export and stream. Training lives in `spectratac.train`.

Importing this package never imports torch; the ONNX and TorchScript exporters import it
when called. Prediction, `Decoder.load` and `Decoder.stream` are NumPy.

    from spectratac.decode import Decoder
    dec = Decoder.load("model.stac", expect_config=cfg)
    est = dec.predict(dataset, rows=test_rows)       # Estimates
    for e in dec.stream(sensor): ...                 # Estimate per live sample

>>> from spectratac.decode import features33
>>> features33([[1.0] * 12]).shape
(1, 33)
"""

from __future__ import annotations

from spectratac.decode.decoder import Decoder
from spectratac.decode.errors import (
    DecoderConfigError,
    DecoderDataError,
    DecoderError,
    DecoderFileError,
    DecoderOodWarning,
    DecoderUnitWarning,
    SensorNotStreamingError,
)
from spectratac.decode.estimates import Estimate, Estimates
from spectratac.decode.paper_features import (
    EPS,
    FEATURE_NAMES,
    FeatureError,
    features33,
    raw12_from_counts,
)
from spectratac.decode.runtime import Runtime
from spectratac.decode.scaling import Standardizer, ZeroAnchoredScaler

__all__ = [
    "EPS",
    "FEATURE_NAMES",
    "Decoder",
    "DecoderConfigError",
    "DecoderDataError",
    "DecoderError",
    "DecoderFileError",
    "DecoderOodWarning",
    "DecoderUnitWarning",
    "Estimate",
    "Estimates",
    "FeatureError",
    "Runtime",
    "SensorNotStreamingError",
    "Standardizer",
    "ZeroAnchoredScaler",
    "features33",
    "raw12_from_counts",
]
