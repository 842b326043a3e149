"""Evaluating decoders honestly: metrics, Fig. 3 reports, a pluggable floor column
(`run.Floor`). What needs the twin (its oracle's floor, its fidelity report, the decoder
benchmarks) is in spectratac.studies; this part never imports the twin or the simulator.

Two splits (spectratac.train.groups) are always reported: the paper's random split and a
blocked split (whole presses or time blocks held out, with a guard gap) that measures
generalisation. A model records the split it was trained under (`train.holdout`), so
evaluation scores only unseen rows.

>>> from spectratac.evaluate import improvement
>>> improvement(0.4, 0.3) > 24.9
True
"""

from __future__ import annotations

from spectratac.evaluate.metrics import (
    contact_scores,
    improvement,
    interval_coverage,
    region_scores,
    regression_scores,
)
from spectratac.evaluate.predictions import Predictions, predict
from spectratac.evaluate.report import write_report
from spectratac.evaluate.run import Evaluation, Section, evaluate_model
from spectratac.evaluate.scoring import Scored, score

__all__ = [
    "Evaluation",
    "Predictions",
    "Scored",
    "Section",
    "contact_scores",
    "evaluate_model",
    "improvement",
    "interval_coverage",
    "predict",
    "region_scores",
    "regression_scores",
    "score",
    "write_report",
]
