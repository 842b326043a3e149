"""One view of what a decoder predicted for some rows of a dataset (`Decoder.predict(dataset,
rows)` giving `Estimates`, or any object with the same fields), with its columns matched to
the dataset's target names.

>>> import numpy as np
>>> p = Predictions(["Fx", "Tz"], np.array([[1.0, 2.0]]))
>>> p.aligned(["Tz", "Fy"]).tolist()
[[2.0, nan]]
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from spectratac.dataset.schema import Dataset
from spectratac.errors import SpectraTacError

F64 = NDArray[np.float64]


class PredictionError(SpectraTacError):
    """A decoder's output cannot be matched to the dataset's targets."""


@dataclass
class Predictions:
    target_names: list[str]
    targets: F64  # (N, T)
    region: NDArray[np.int64] | None = None  # (N,) 1..9
    region_prob: F64 | None = None  # (N, 9) class probabilities
    contact: NDArray[np.bool_] | None = None  # (N,)
    contact_prob: F64 | None = None  # NaN when contact is derived from |F|, not a head
    std: F64 | None = None  # (N, T) predicted standard deviation, if the model has one

    def _columns(self, names: Sequence[str]) -> list[int | None]:
        mine = list(self.target_names)
        return [mine.index(n) if n in mine else None for n in names]

    def aligned(self, names: Sequence[str], std: bool = False) -> F64:
        """(N, len(names)) columns in the order of `names`; NaN where not predicted."""
        src = self.std if std else self.targets
        out = np.full((self.targets.shape[0], len(names)), np.nan)
        if src is None:
            return out
        for j, i in enumerate(self._columns(names)):
            if i is not None:
                out[:, j] = src[:, i]
        return out

    def predicts(self, names: Sequence[str]) -> list[str]:
        """Which of `names` this decoder predicts."""
        return [n for n, i in zip(names, self._columns(names), strict=True) if i is not None]


def predict(decoder: Any, dataset: Dataset, rows: NDArray[np.int64]) -> Predictions:
    """Run `decoder` on `rows` of `dataset` (the decoder sees the whole dataset, so models with
    temporal context can use the rows before each one)."""
    est = decoder.predict(dataset, rows=np.asarray(rows, dtype=np.int64))
    return _from_estimates(est)


def _opt(est: Any, name: str, dtype: Any) -> Any:
    v = getattr(est, name, None)
    return None if v is None else np.asarray(v, dtype=dtype)


def _from_estimates(est: Any) -> Predictions:
    names = list(getattr(est, "target_names", []))
    targets = np.asarray(est.targets, dtype=np.float64)
    if targets.ndim != 2 or targets.shape[1] != len(names):
        raise PredictionError(
            f"decoder returned targets {targets.shape} for names {names}: update the decoder"
        )
    region = _opt(est, "region", np.int64)
    if hasattr(est, "region_probs") and est.region_probs is None:
        region = None  # no class head: region is all -1 by convention, not a prediction
    contact = _opt(est, "contact", bool)
    return Predictions(
        target_names=names,
        targets=targets,
        region=region if region is not None and region.size else None,
        region_prob=_opt(est, "region_probs", np.float64),
        contact=contact if contact is not None and contact.size else None,
        contact_prob=_opt(est, "contact_prob", np.float64),
        std=_opt(est, "std", np.float64),
    )
