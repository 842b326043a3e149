"""Decoding counts into F/T, contact region and contact: train, predict, save, export, stream.

Importing this package never imports torch; `train` imports it when called, and so do the
ONNX and TorchScript exporters. Prediction, `Decoder.load` and `Decoder.stream` are NumPy.

    from spectratac.decode import TrainSpec, train, Decoder
    dec = train(dataset, TrainSpec.paper(), rows=train_rows)
    est = dec.predict(dataset, rows=test_rows)       # Estimates
    dec.save("model.stac"); Decoder.load("model.stac", expect_config=cfg)

>>> from spectratac.decode import features33, TrainSpec
>>> features33([[1.0] * 12]).shape, TrainSpec.paper().model
((1, 33), 'resmlp')
"""

from __future__ import annotations

from spectratac.decode.decoder import Decoder
from spectratac.decode.errors import (
    DecoderConfigError,
    DecoderDataError,
    DecoderError,
    DecoderFileError,
    DecoderUnitWarning,
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
from spectratac.decode.spec import TrainSpec
from spectratac.decode.train import PAPER_LOSS_WEIGHTS, train

__all__ = [
    "EPS",
    "FEATURE_NAMES",
    "PAPER_LOSS_WEIGHTS",
    "Decoder",
    "DecoderConfigError",
    "DecoderDataError",
    "DecoderError",
    "DecoderFileError",
    "DecoderUnitWarning",
    "Estimate",
    "Estimates",
    "FeatureError",
    "Runtime",
    "Standardizer",
    "TrainSpec",
    "ZeroAnchoredScaler",
    "features33",
    "raw12_from_counts",
    "train",
]
