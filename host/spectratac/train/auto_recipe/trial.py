"""One trial: a candidate's grouped K-fold cross-validation, run wherever a runner puts it.

A trial trains the candidate once per fold on the other folds' rows (at most `max_fit_rows`
of them, every k-th row: at 100 Hz neighbours are near-duplicates; ridge and networks alike)
and scores it on the fold's held-out groups. On fold 0 it also trains on half those rows:
the learning curve (rows, score) says whether the refit on all rows can still gain. The
error is the mean absolute error per regression target (train/metrics.py), and a
unit-free score: the mean over targets of MAE / the target's std.
The fold-0 decoder's inference cost is measured too: batch µs per sample and the latency of
one sample through the fused single-sample path.

Everything a trial needs is plain data (a spec dict, row arrays), so it pickles to a worker
process or a Ray task.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from spectratac.dataset.schema import Dataset
from spectratac.decode.decoder import Decoder
from spectratac.train.fitting import train
from spectratac.train.metrics import decoder_mae
from spectratac.train.spec import TrainSpec

Fold = tuple[NDArray[np.intp], NDArray[np.intp]]  # (fit rows, held-out rows)
TIMING_ROWS = 2000


@dataclass(frozen=True)
class TrialJob:
    name: str
    spec: dict[str, Any]
    folds: list[Fold]
    max_fit_rows: int
    target_std: dict[str, float]
    by_session: bool = False  # also each held-out session's MAE (forward folds)


def thin(rows: NDArray[np.intp], limit: int) -> NDArray[np.intp]:
    """Every k-th row so that at most `limit` remain (all when limit <= 0).

    >>> thin(np.arange(10), 4).tolist(), thin(np.arange(3), 0).tolist()
    ([0, 3, 6, 9], [0, 1, 2])
    """
    if limit <= 0 or rows.size <= limit:
        return rows
    return rows[:: -(-rows.size // limit)]


def inference_cost(dec: Decoder, ds: Dataset, rows: NDArray[np.intp]) -> dict[str, float]:
    """FLOPs per sample, batch µs per sample (best of 3) and single-sample µs (median)."""
    from spectratac.decode.assemble import assemble

    pick = rows[:TIMING_ROWS]
    u, valid = assemble(dec.layout, ds.inputs, ds.step, ds.session, ds.t_end)
    u = u[pick][valid[pick]]
    if not u.shape[0]:
        return {"flops": float(dec.flops_per_sample), "us_per_sample": float("nan"),
                "us_single": float("nan")}  # fmt: skip
    batch = []
    for _ in range(3):
        t0 = time.perf_counter()
        dec.runtime.run(u)
        batch.append((time.perf_counter() - t0) / u.shape[0])
    run1 = dec.runtime.run1
    single = []
    for row in u[:200]:
        t0 = time.perf_counter()
        run1(row)
        single.append(time.perf_counter() - t0)
    return {
        "flops": float(dec.flops_per_sample),
        "us_per_sample": 1e6 * min(batch),
        "us_single": 1e6 * float(np.median(single)),
    }


def run_trial(ds: Dataset, job: TrialJob) -> dict[str, Any]:
    """Cross-validate one candidate: per-fold MAE per target and score, seconds, cost."""
    t0 = time.perf_counter()
    spec = TrainSpec.from_dict(job.spec)
    per_fold: list[dict[str, float]] = []
    scores: list[float] = []
    train_scores: list[float] = []
    train_mae: list[dict[str, float]] = []
    cost: dict[str, float] = {}
    curve: list[list[float]] = []
    by_session: list[dict[str, dict[str, float]]] = []
    for i, (fit, held) in enumerate(job.folds):
        rows = thin(fit, job.max_fit_rows)
        dec = train(ds, spec, rows=rows, progress=False)
        err = decoder_mae(dec, ds, held)
        per_fold.append(err)
        if job.by_session:
            ses = np.asarray(ds.session, np.int64)[held]
            by_session.append(
                {str(s): decoder_mae(dec, ds, held[ses == s]) for s in np.unique(ses)}
            )
        scores.append(float(np.mean([err[t] / job.target_std[t] for t in err])))
        tr = decoder_mae(dec, ds, thin(rows, TIMING_ROWS))
        train_scores.append(float(np.mean([tr[t] / job.target_std[t] for t in tr])))
        train_mae.append(tr)
        if i == 0:
            cost = inference_cost(dec, ds, held)
            half = rows[::2]
            err_half = decoder_mae(train(ds, spec, rows=half, progress=False), ds, held)
            half_score = float(np.mean([err_half[t] / job.target_std[t] for t in err_half]))
            curve = [[int(half.size), half_score], [int(rows.size), scores[0]]]
    return {
        "name": job.name,
        "fold_mae": per_fold,
        "fold_score": scores,
        "train_score": train_scores,
        "train_mae": train_mae,
        "learning_curve": curve,
        "fold_session_mae": by_session or None,
        "seconds": time.perf_counter() - t0,
        "cost": cost,
        # What the thread policy gave this trial's process (torch's pool, if it trained one).
        "threads": _torch_threads(),
    }


def _torch_threads() -> int | None:
    torch = sys.modules.get("torch")
    return None if torch is None else int(torch.get_num_threads())
