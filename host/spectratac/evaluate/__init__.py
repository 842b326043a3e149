"""Evaluating decoders honestly: splits, metrics, Fig. 3 reports, a pluggable floor column
(`run.Floor`). What needs the twin (its oracle's floor, its fidelity report, the decoder
benchmarks) is in spectratac.studies; this part never imports the twin or the simulator.

Two splits are always reported: the paper's random split and a blocked split (whole presses
or time blocks held out, with a guard gap) that measures generalisation. A model records the
split it was trained under (`evaluate.holdout`), so evaluation scores only unseen rows.

>>> from spectratac.evaluate import SplitSpec
>>> SplitSpec().kind, SplitSpec("random").test_fraction
('blocked', 0.2)
"""

from __future__ import annotations

from spectratac.evaluate.holdout import fingerprint, mark, resolve
from spectratac.evaluate.metrics import (
    contact_scores,
    improvement,
    interval_coverage,
    region_accuracy,
    region_scores,
    regression_metrics,
    regression_scores,
)
from spectratac.evaluate.predictions import Predictions, predict
from spectratac.evaluate.report import write_report
from spectratac.evaluate.run import Evaluation, Section, evaluate_model
from spectratac.evaluate.scoring import Scored, score
from spectratac.evaluate.splits import (
    KINDS,
    Split,
    SplitError,
    SplitSpec,
    make_split,
    split_dataset,
)

__all__ = [
    "KINDS",
    "Evaluation",
    "Predictions",
    "Scored",
    "Section",
    "Split",
    "SplitError",
    "SplitSpec",
    "contact_scores",
    "evaluate_model",
    "fingerprint",
    "improvement",
    "interval_coverage",
    "make_split",
    "mark",
    "predict",
    "region_accuracy",
    "region_scores",
    "regression_metrics",
    "regression_scores",
    "resolve",
    "score",
    "split_dataset",
    "write_report",
]
