"""Feature sets as data: linear rows plus ratio rows over the assembled input vector.

Every feature set here has the form

    lin = (u - center) @ L.T                      (raw values, sensor differences, deltas)
    rat = (u @ P.T) / (|u| @ Q.T + EPS)           (clear-normalised chromaticity, fractions)
    f   = [lin, rat]
    mon = prod_k f[M[:, k]]                       (monomials; index -1 stands for 1)
    f   = [lin, rat, mon]

so that one small description runs identically in NumPy, torch, ONNX and C. The ratio
denominators are >= EPS, so dark (all-zero) inputs give finite features. Monomials (degree
2 or 3 over the linear and ratio features, `degree`) turn a linear head into a polynomial
ridge regression (train/ridge.py).

kinds (per LED step, on the current sample x_t):
- paper33: the paper's 33 (raw 12, pairwise sensor differences 12, R/C, G/C, B/C 9);
  needs the 12 SpectraTac inputs s0.R .. s2.C.
- raw: the C inputs as they are.
- generic: the C inputs and each as a fraction of their summed magnitude (any sensor).
Then, whatever the kind: x_t - x_{t-lag} per context lag, x_t - ema_tau per moving average,
and x_t - b_t and x_t / (|b_t| + |x_t| / RATIO_BOUND) with a baseline (|ratio| <= RATIO_BOUND
even where b_t ~ 0).

>>> from spectratac.decode.layout import Layout
>>> from spectratac.dataset import SPECTRATAC_INPUTS
>>> fs = build_features("paper33", Layout(SPECTRATAC_INPUTS))
>>> fs.n_features, fs.names[12], fs.names[24]
(33, 's0.R-s1.R', 's0.R/s0.C')
>>> fs = build_features("generic", Layout(("a", "b"), lags=(1,)))
>>> fs.names
['a', 'b', 'a-a[t-1]', 'b-b[t-1]', 'a/sum', 'b/sum']
>>> fs = build_features("raw", Layout(("a", "b")), degree=2)
>>> fs.names, fs.apply(np.array([[2.0, 3.0]])).tolist()
(['a', 'b', 'a*a', 'a*b', 'b*b'], [[2.0, 3.0, 4.0, 6.0, 9.0]])
"""

from __future__ import annotations

from dataclasses import dataclass, field
from itertools import combinations_with_replacement
from typing import Any

import numpy as np
from numpy.typing import NDArray

from spectratac.decode.errors import DecoderConfigError
from spectratac.decode.layout import Layout
from spectratac.decode.paper_features import EPS
from spectratac.hardware.generated import vocabulary as vocab

F64 = NDArray[np.float64]
MAX_DEGREE = 3
NO_FACTOR = -1  # a monomial's unused factor slot (the product skips it)
#: |x_t / b_t| never exceeds this: a baseline b near zero (a channel whose dark offset is ~0)
#: would otherwise give ratios of 1e4 and more that no network trained on x ~ b has seen.
RATIO_BOUND = 100.0


def _no_monomials() -> NDArray[np.int64]:
    return np.zeros((0, MAX_DEGREE), np.int64)


@dataclass(frozen=True)
class FeatureSet:
    kind: str
    L: F64  # (F_lin, D)
    P: F64  # (F_rat, D)
    Q: F64  # (F_rat, D)
    names: list[str]
    M: NDArray[np.int64] = field(default_factory=_no_monomials)  # (F_mon, 3) factor indices

    @property
    def n_base(self) -> int:
        """Linear plus ratio features: the ones monomials multiply."""
        return self.L.shape[0] + self.P.shape[0]

    @property
    def n_features(self) -> int:
        return self.n_base + self.M.shape[0]

    def apply(self, u: F64, center: F64 | None = None, dtype: Any = np.float64) -> F64:
        """Features (N, F) of assembled vectors (N, D), computed in `dtype`."""
        u = np.asarray(u, dtype=dtype)
        c = np.zeros(u.shape[-1], dtype) if center is None else center.astype(dtype)
        lin = (u - c) @ self.L.T.astype(dtype)
        if self.P.shape[0]:
            rat = (u @ self.P.T.astype(dtype)) / (np.abs(u) @ self.Q.T.astype(dtype) + dtype(EPS))
            lin = np.concatenate([lin, rat], axis=-1)
        if not self.M.shape[0]:
            return lin
        # a trailing column of ones: NO_FACTOR (-1) indexes it, so unused slots multiply by 1
        padded = np.concatenate([lin, np.ones((*lin.shape[:-1], 1), dtype)], axis=-1)
        return np.concatenate([lin, np.prod(padded[..., self.M], axis=-1)], axis=-1)

    def to_arrays(self) -> dict[str, NDArray[Any]]:
        a: dict[str, NDArray[Any]] = {"L": self.L, "P": self.P, "Q": self.Q}
        if self.M.shape[0]:
            a["M"] = self.M
        return a

    @classmethod
    def from_arrays(
        cls, kind: str, arrays: dict[str, NDArray[Any]], names: list[str]
    ) -> FeatureSet:
        m = arrays.get("M")
        mon = _no_monomials() if m is None else np.asarray(m, np.int64)
        return cls(kind, arrays["L"], arrays["P"], arrays["Q"], list(names), mon)


def monomials(n_base: int, degree: int) -> NDArray[np.int64]:
    """Factor indices (F_mon, 3) of every monomial of degree 2..`degree` over n_base features.

    >>> monomials(2, 2).tolist()
    [[0, 0, -1], [0, 1, -1], [1, 1, -1]]
    """
    if not 1 <= degree <= MAX_DEGREE:
        raise DecoderConfigError(f"polynomial degree {degree}: use 1 to {MAX_DEGREE}")
    rows = [
        list(c) + [NO_FACTOR] * (MAX_DEGREE - d)
        for d in range(2, degree + 1)
        for c in combinations_with_replacement(range(n_base), d)
    ]
    return np.array(rows, np.int64).reshape(-1, MAX_DEGREE)


def build_features(kind: str, layout: Layout, degree: int = 1) -> FeatureSet:
    """The feature set `kind` over `layout`'s assembled vector, with the monomials of degree
    2..`degree` of those features appended when degree > 1."""
    d, c, base = layout.size, len(layout.channels), layout.base
    names_in = layout.names()
    lin: list[F64] = []
    lin_names: list[str] = []
    num: list[F64] = []
    den: list[F64] = []
    rat_names: list[str] = []

    def unit(i: int) -> F64:
        v = np.zeros(d)
        v[i] = 1.0
        return v

    if kind == "paper33" and tuple(layout.channels) != vocab.DECODED_INPUTS:
        raise DecoderConfigError(
            f"features='paper33' needs the 12 SpectraTac inputs {', '.join(vocab.DECODED_INPUTS)}"
            f" in that order; this data has {', '.join(layout.channels)}: use features="
            f"'generic' or 'raw'"
        )
    if kind not in ("paper33", "raw", "generic"):
        raise DecoderConfigError(f"unknown feature set {kind!r}: use paper33, raw or generic")
    for s in range(layout.steps):
        o = s * c
        lin += [unit(o + i) for i in range(c)]
        lin_names += names_in[o : o + c]
        if kind == "paper33":
            for i, j in ((0, 1), (1, 2), (2, 0)):
                for ch in range(4):
                    lin.append(unit(o + 4 * i + ch) - unit(o + 4 * j + ch))
                    lin_names.append(f"{names_in[o + 4 * i + ch]}-{names_in[o + 4 * j + ch]}")
            for i in range(3):
                for ch in range(3):
                    num.append(unit(o + 4 * i + ch))
                    den.append(unit(o + 4 * i + 3))
                    rat_names.append(f"{names_in[o + 4 * i + ch]}/{names_in[o + 4 * i + 3]}")
        elif kind == "generic":
            total = sum(unit(o + i) for i in range(c))
            for i in range(c):
                num.append(unit(o + i))
                den.append(np.asarray(total, dtype=np.float64))
                rat_names.append(f"{names_in[o + i]}/sum")
    for k in range(len(layout.lags)):
        for i in range(base):
            lin.append(unit(i) - unit((k + 1) * base + i))
            lin_names.append(f"{names_in[i]}-{names_in[(k + 1) * base + i]}")
    k0 = 1 + len(layout.lags)
    for k in range(len(layout.emas)):
        for i in range(base):
            j = (k0 + k) * base + i
            lin.append(unit(i) - unit(j))
            lin_names.append(f"{names_in[i]}-{names_in[j]}")
    if layout.drift:
        for i in range(base):
            lin.append(unit(i) - unit(d - base + i))
            lin_names.append(f"{names_in[i]}-{names_in[d - base + i]}")
        for i in range(base):  # relative change: cancels per-channel gain and LED drift
            num.append(unit(i))
            # |b| + |x|/RATIO_BOUND: bounds |x/b| by RATIO_BOUND where the dark offset b is
            # near zero, and is x/b within 1 % elsewhere (x ~ b)
            den.append(unit(d - base + i) + unit(i) / RATIO_BOUND)
            rat_names.append(f"{names_in[i]}/{names_in[d - base + i]}")
    L = np.array(lin).reshape(-1, d)
    P = np.array(num).reshape(-1, d)
    Q = np.array(den).reshape(-1, d)
    names = lin_names + rat_names
    mon = monomials(len(names), degree)
    mon_names = ["*".join(names[i] for i in m if i != NO_FACTOR) for m in mon]
    return FeatureSet(kind, L, P, Q, names + mon_names, mon)
