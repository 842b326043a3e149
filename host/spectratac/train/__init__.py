"""Training decoders, honest about data they have not seen.

    from spectratac.train import TrainSpec, fit
    trained = fit(dataset, TrainSpec.paper())          # the decoder and its held-out check
    trained.decoder.save("model.stac")
    trained.check.heldout_mae, trained.check.warning   # error on whole held-out groups

`fit` is the entry point: it trains `spec` (or fine-tunes a decoder, `finetune_from=`, or
searches the recipe within `budget=` seconds) on the rows it may use (`holdout=` a split,
`holdout_sessions=` whole sessions left out), records them in the model, and checks the
decoder on whole held-out groups (train/check.py). `train(dataset, spec, rows)` fits one
decoder with no check: the building block `fit`, the auto recipe's folds and benchmarks use.
Groups and splits: train/groups.py. Torch is imported only when a network is fitted.

>>> from spectratac.train import TrainSpec
>>> TrainSpec.paper().model
'resmlp'
"""

from __future__ import annotations

from spectratac.train.check import HeldOutCheck
from spectratac.train.finetune import FinetuneMismatchError, FinetuneOptions, finetune
from spectratac.train.fitting import train
from spectratac.train.groups import KINDS, Split, SplitError, SplitSpec, make_split, split_dataset
from spectratac.train.spec import TrainSpec
from spectratac.train.torch_loop import PAPER_LOSS_WEIGHTS
from spectratac.train.trained import Trained, default_spec, fit

__all__ = [
    "KINDS",
    "PAPER_LOSS_WEIGHTS",
    "FinetuneMismatchError",
    "FinetuneOptions",
    "HeldOutCheck",
    "Split",
    "SplitError",
    "SplitSpec",
    "TrainSpec",
    "Trained",
    "default_spec",
    "finetune",
    "fit",
    "make_split",
    "split_dataset",
    "train",
]
