"""The shared-backbone residual MLP, evaluated in NumPy (no torch needed at inference).

stem Linear(33, H) -> GELU, then `blocks` pre-norm residual blocks
h + W2 GELU(W1 LayerNorm(h)), a final LayerNorm, and two heads: 6-axis F/T (scaled targets)
and 9 region logits. GELU is the tanh approximation in training and inference alike.

>>> import numpy as np
>>> w = init_weights(hidden=8, blocks=1, rng=np.random.default_rng(0))
>>> ft, logits = forward(w, np.zeros((2, 33)))
>>> ft.shape, logits.shape
((2, 6), (2, 9))
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from spectratac.decode.features import N_FEATURES, features33
from spectratac.decode.scaling import Standardizer, ZeroAnchoredScaler
from spectratac.errors import SpectraTacError

F64 = NDArray[np.float64]
Weights = dict[str, NDArray[np.float32]]

N_OUT = 6
N_REGIONS = 9
LN_EPS = 1e-5


def gelu_tanh(x: F64) -> F64:
    return 0.5 * x * (1.0 + np.tanh(0.7978845608028654 * (x + 0.044715 * x * x * x)))


def layer_norm(x: F64, g: NDArray[np.float32], b: NDArray[np.float32]) -> F64:
    mu = x.mean(axis=-1, keepdims=True)
    var = x.var(axis=-1, keepdims=True)
    return (x - mu) / np.sqrt(var + LN_EPS) * g + b


def n_blocks(w: Weights) -> int:
    return sum(1 for k in w if k.startswith("blocks.") and k.endswith(".fc1.weight"))


def forward(w: Weights, z: F64) -> tuple[F64, F64]:
    """Scaled F/T (N, 6) and region logits (N, 9) for z-scored features (N, 33)."""
    h = gelu_tanh(z @ w["stem.weight"].T + w["stem.bias"])
    for i in range(n_blocks(w)):
        p = f"blocks.{i}."
        u = layer_norm(h, w[p + "norm.weight"], w[p + "norm.bias"])
        u = gelu_tanh(u @ w[p + "fc1.weight"].T + w[p + "fc1.bias"])
        h = h + u @ w[p + "fc2.weight"].T + w[p + "fc2.bias"]
    h = layer_norm(h, w["norm.weight"], w["norm.bias"])
    ft = h @ w["head_ft.weight"].T + w["head_ft.bias"]
    logits = h @ w["head_region.weight"].T + w["head_region.bias"]
    return ft, logits


def init_weights(hidden: int, blocks: int, rng: np.random.Generator) -> Weights:
    """Random weights with the same names and shapes as the torch module (for tests)."""

    def lin(name: str, n_out: int, n_in: int) -> dict[str, NDArray[np.float32]]:
        k = 1.0 / np.sqrt(n_in)
        return {
            f"{name}.weight": rng.uniform(-k, k, (n_out, n_in)).astype(np.float32),
            f"{name}.bias": rng.uniform(-k, k, n_out).astype(np.float32),
        }

    w: Weights = {}
    w.update(lin("stem", hidden, N_FEATURES))
    for i in range(blocks):
        w[f"blocks.{i}.norm.weight"] = np.ones(hidden, np.float32)
        w[f"blocks.{i}.norm.bias"] = np.zeros(hidden, np.float32)
        w.update(lin(f"blocks.{i}.fc1", hidden, hidden))
        w.update(lin(f"blocks.{i}.fc2", hidden, hidden))
    w["norm.weight"] = np.ones(hidden, np.float32)
    w["norm.bias"] = np.zeros(hidden, np.float32)
    w.update(lin("head_ft", N_OUT, hidden))
    w.update(lin("head_region", N_REGIONS, hidden))
    return w


@dataclass(frozen=True)
class Prediction:
    ft: F64  # (N, 6) in N and N·m
    region: NDArray[np.int8]  # (N,) 1-9
    region_prob: F64  # (N, 9)


@dataclass
class PaperDecoder:
    """A trained paper-recipe decoder: weights + input/target normalisation + metadata."""

    weights: Weights
    x_scaler: Standardizer
    y_scaler: ZeroAnchoredScaler
    meta: dict[str, Any] = field(default_factory=dict)
    history: list[float] = field(default_factory=list)

    def predict(self, raw12: F64) -> Prediction:
        """Decode (N, 12) raw counts (R, G, B, C per sensor)."""
        z = self.x_scaler.transform(features33(raw12))
        ft_s, logits = forward(self.weights, z)
        e = np.exp(logits - logits.max(axis=1, keepdims=True))
        prob = e / e.sum(axis=1, keepdims=True)
        return Prediction(
            ft=self.y_scaler.inverse(ft_s),
            region=(np.argmax(logits, axis=1) + 1).astype(np.int8),
            region_prob=prob,
        )

    def save(self, path: str | Path) -> None:
        arrays: dict[str, Any] = {f"w/{k}": v for k, v in self.weights.items()}
        arrays.update(
            x_mean=self.x_scaler.mean,
            x_std=self.x_scaler.std,
            y_std=self.y_scaler.std,
            history=np.asarray(self.history),
            meta=np.asarray(repr(self.meta)),
        )
        np.savez(path, **arrays)

    @staticmethod
    def load(path: str | Path) -> PaperDecoder:
        try:
            z = np.load(path, allow_pickle=False)
        except (OSError, ValueError) as exc:
            raise SpectraTacError(f"cannot read decoder file {path}: {exc}") from exc
        w = {k[2:]: z[k] for k in z.files if k.startswith("w/")}
        return PaperDecoder(
            weights=w,
            x_scaler=Standardizer(z["x_mean"], z["x_std"]),
            y_scaler=ZeroAnchoredScaler(z["y_std"]),
            meta={"repr": str(z["meta"])},
            history=z["history"].tolist(),
        )
