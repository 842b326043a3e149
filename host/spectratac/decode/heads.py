"""The fused output head: which outputs a decoder has and how raw head values become them.

Raw head columns: [scaled targets (R), log std (R, if uncertainty), class logits (K),
contact logit (1, if contact)]. Outputs keep that order, in physical units: targets times
their scale, std = exp(log std) x scale x calibration, class probabilities (softmax) and
contact probability (sigmoid, as 0.5 (1 + tanh(x / 2)): never overflows).

>>> h = Heads(("Fz",), uncertainty=True, n_classes=3, contact=True)
>>> h.n_out, h.output_names()
(6, ['Fz', 'std:Fz', 'p:class1', 'p:class2', 'p:class3', 'p:contact'])
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

F64 = NDArray[np.float64]


@dataclass(frozen=True)
class Heads:
    regression: tuple[str, ...]  # regression target names (R)
    uncertainty: bool = False
    n_classes: int = 0  # K (0: no class head)
    contact: bool = False

    @property
    def n_reg(self) -> int:
        return len(self.regression)

    @property
    def n_out(self) -> int:
        r = self.n_reg
        return r + (r if self.uncertainty else 0) + self.n_classes + int(self.contact)

    def slices(self) -> dict[str, slice]:
        """Column ranges of each output group (absent groups are empty slices)."""
        r = self.n_reg
        a = r + (r if self.uncertainty else 0)
        b = a + self.n_classes
        return {
            "targets": slice(0, r),
            "std": slice(r, a),
            "classes": slice(a, b),
            "contact": slice(b, b + int(self.contact)),
        }

    def output_names(self) -> list[str]:
        names = list(self.regression)
        if self.uncertainty:
            names += [f"std:{t}" for t in self.regression]
        names += [f"p:class{k + 1}" for k in range(self.n_classes)]
        return names + (["p:contact"] if self.contact else [])

    def to_dict(self) -> dict[str, Any]:
        return {
            "regression": list(self.regression),
            "uncertainty": self.uncertainty,
            "n_classes": self.n_classes,
            "contact": self.contact,
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Heads:
        return cls(
            tuple(d["regression"]), bool(d["uncertainty"]), int(d["n_classes"]), bool(d["contact"])
        )


def postprocess(heads: Heads, raw: F64, y_scale: F64, std_scale: F64) -> F64:
    """Physical outputs (N, O) from raw head values (N, O), in raw's dtype."""
    s = heads.slices()
    out = np.empty_like(raw)
    dt = raw.dtype
    out[:, s["targets"]] = raw[:, s["targets"]] * y_scale.astype(dt)
    if heads.uncertainty:
        out[:, s["std"]] = np.exp(raw[:, s["std"]]) * (y_scale * std_scale).astype(dt)
    if heads.n_classes:
        lg = raw[:, s["classes"]]
        e = np.exp(lg - lg.max(axis=1, keepdims=True))
        out[:, s["classes"]] = e / e.sum(axis=1, keepdims=True)
    if heads.contact:
        out[:, s["contact"]] = 0.5 * (1.0 + np.tanh(0.5 * raw[:, s["contact"]]))  # no overflow
    return out
