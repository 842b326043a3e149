"""Decoding counts into F/T and contact region: the paper's recipe (features, scaling, model).

Importing this package never imports torch; `train_paper_recipe` imports it when called.

>>> from spectratac.decode import features33
>>> features33([[1.0] * 12]).shape
(1, 33)
"""

from __future__ import annotations

from spectratac.decode.features import (
    EPS,
    FEATURE_NAMES,
    FeatureError,
    features33,
    raw12_from_counts,
)
from spectratac.decode.metrics import region_accuracy, regression_metrics
from spectratac.decode.model import PaperDecoder, Prediction
from spectratac.decode.scaling import Standardizer, ZeroAnchoredScaler
from spectratac.decode.train import PAPER_LOSS_WEIGHTS, TrainConfig, train_paper_recipe

__all__ = [
    "EPS",
    "FEATURE_NAMES",
    "PAPER_LOSS_WEIGHTS",
    "FeatureError",
    "PaperDecoder",
    "Prediction",
    "Standardizer",
    "TrainConfig",
    "ZeroAnchoredScaler",
    "features33",
    "raw12_from_counts",
    "region_accuracy",
    "regression_metrics",
    "train_paper_recipe",
]
