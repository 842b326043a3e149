"""Oracle predictions on a deterministic subsample of evaluation rows, session by session.

>>> import numpy as np
>>> from spectratac.dataset import Dataset
>>> ds = Dataset.generic(np.zeros((4, 1)), np.zeros(4), ["a"], ["Fz"])
>>> rows, pred, note = oracle_predictions(ds, np.arange(4))
>>> rows.size, pred, note[:22]
(0, None, 'no oracle: not a Spect')
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from spectratac.evaluate.oracle_floor import DEFAULT_SAMPLES, subsample, twin_oracle
from spectratac.evaluate.predictions import Predictions
from spectratac.twin.scene_model import Scene

FT = ["Fx", "Fy", "Fz", "Tx", "Ty", "Tz"]


def oracle_predictions(
    dataset: Any,
    rows: NDArray[np.int64],
    scene: Scene | None = None,
    samples: int = DEFAULT_SAMPLES,
    seed: int = 0,
) -> tuple[NDArray[np.int64], Predictions | None, str]:
    """(rows decoded, their oracle predictions, a note for the report)."""
    sub = subsample(np.asarray(rows, dtype=np.int64), samples, seed)
    sessions = dataset.arrays["session"][sub]
    kept: list[NDArray[np.int64]] = []
    targets: list[NDArray[np.float64]] = []
    regions: list[NDArray[np.int8]] = []
    reasons: list[str] = []
    for s in np.unique(sessions):
        o = twin_oracle(dataset, scene=scene, session=int(s))
        if o.oracle is None:
            reasons.append(o.reason)
            continue
        r = sub[sessions == s]
        est = o.decode(dataset, r)
        kept.append(r)
        targets.append(est.targets)
        regions.append(est.region)
    if not kept:
        why = "; ".join(sorted(set(reasons))) or "no rows to decode"
        return np.zeros(0, np.int64), None, f"no oracle: {why}"
    done = np.concatenate(kept)
    order = np.argsort(done)
    pred = Predictions(
        FT,
        np.concatenate(targets)[order],
        region=np.concatenate(regions)[order].astype(np.int64),
    )
    note = (
        f"oracle (true unit, model inversion per sample) on a deterministic subsample of "
        f"{done.size} of the {rows.size} evaluation rows (seed {seed}); it knows the unit, LEDs "
        "and environment but not the press history (creep), so a learned decoder can beat it"
    )
    if reasons:
        note += f"; rows of other sessions skipped: {'; '.join(sorted(set(reasons)))}"
    return done[order], pred, note
