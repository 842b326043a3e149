"""The paper's 33 decoder features from the 12 raw counts (NumPy only).

Layout: raw R, G, B, C of sensors 1-3 (12); clear-normalised chromaticity R/(C+eps),
G/(C+eps), B/(C+eps) per sensor (9, eps = 1e-5); pairwise sensor differences s1-s2, s2-s3,
s3-s1 over R, G, B, C (12). Features are built from raw intensities before z-scoring, as the
paper does, so that the ratios keep their physical meaning.

>>> raw = np.arange(1, 13, dtype=float)[None, :]
>>> f = features33(raw)
>>> f.shape, float(f[0, 12]).__round__(4), float(f[0, 21])
((1, 33), 0.25, -4.0)
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from spectratac.decode.errors import DecoderDataError
from spectratac.hardware.generated import vocabulary as vocab

EPS = 1e-5
N_RAW = 12
_CH = vocab.DECODED_CHANNELS

FEATURE_NAMES: tuple[str, ...] = (
    tuple(f"{c}{i}" for i in (1, 2, 3) for c in _CH)
    + tuple(f"{c}{i}/C{i}" for i in (1, 2, 3) for c in _CH[:3])
    + tuple(f"{c}{i}-{c}{j}" for i, j in ((1, 2), (2, 3), (3, 1)) for c in _CH)
)


class FeatureError(DecoderDataError):
    """Input to the feature pipeline has the wrong shape or non-finite values."""


def raw12_from_counts(counts: ArrayLike) -> NDArray[np.float64]:
    """(N, 3 sensors, 5 channels R G B C IR) counts -> (N, 12) raw R, G, B, C per sensor."""
    c = np.asarray(counts)
    if c.ndim != 3 or c.shape[1] != 3 or c.shape[2] not in (4, 5):
        raise FeatureError(f"counts must have shape (N, 3, 5) or (N, 3, 4), got {c.shape}")
    return c[:, :, :4].reshape(c.shape[0], 12).astype(np.float64)


def features33(raw12: ArrayLike) -> NDArray[np.float64]:
    """Expand (N, 12) raw counts into the (N, 33) feature matrix."""
    x = np.asarray(raw12, dtype=np.float64)
    if x.ndim == 1:
        x = x[None, :]
    if x.ndim != 2 or x.shape[1] != N_RAW:
        raise FeatureError(f"raw counts must have shape (N, 12), got {x.shape}")
    if not np.all(np.isfinite(x)):
        raise FeatureError("raw counts contain NaN or inf; drop or repair those samples first")
    s = x.reshape(-1, 3, 4)
    chroma = s[:, :, :3] / (s[:, :, 3:4] + EPS)
    diffs = s - np.roll(s, -1, axis=1)  # s1-s2, s2-s3, s3-s1
    return np.concatenate([x, chroma.reshape(-1, 9), diffs.reshape(-1, 12)], axis=1)
