"""The held-out check: a decoder's training error beside its error on whole held-out groups,
and when their ratio calls for a warning.

Held out are whole groups (train/groups.py), taken from the first of: the holdout split's
test rows, the held-out sessions, the model's own validation groups, or else about
HELDOUT_FRACTION of the groups of the training rows, on which a check model, trained like
the real one on the other groups, is scored (the real model keeps every row).

A decoder whose error on whole held-out groups (sessions, presses, time blocks) is many times
its error on its training rows has learnt what is particular to the training groups: session
offsets, drift, the exact presses. GAP_WARN = 2, from measurements on the synthetic skin
(`spectratac.sim.generic_skin`, 8 sessions of 8 s, the paper's recipe, 10 epochs): with
sessions that are alike (drift=False) the ratio is 1.2, the cost of a new session's noise
and unseen press positions; with session-level gains, offsets and ageing (drift=True) it is
5.8, and 19.5 training on 24 sessions of 20 s and testing on 12 later ones. The CV ratios of
the ridge baselines on the drifting skin stay at 1.0-1.2. A ratio above 2 is no longer noise.

>>> gap({"Fz": 0.25}, {"Fz": 4.8})
(19.2, 'held-out error is 19.2x the training error (Fz; warning above 2x)')
>>> gap({"Fz": 1.0}, {"Fz": 1.3})
(1.3, None)
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from spectratac.dataset.schema import Dataset
from spectratac.decode.assemble import session_order
from spectratac.decode.decoder import Decoder
from spectratac.train.groups import Split, row_groups, val_split
from spectratac.train.metrics import decoder_mae
from spectratac.train.plan import rows_of

GAP_WARN = 2.0
HELDOUT_FRACTION = 0.2  # groups held out by the check model
Rows = NDArray[np.intp]


@dataclass(frozen=True)
class HeldOutCheck:
    """MAE per regression target on the rows the decoder trained on and on held-out groups,
    their largest ratio (`gap`), the warning when it exceeds GAP_WARN, which groups were held
    out (`heldout_groups`: session, press, block, ...) and how (`heldout_source`)."""

    train_mae: dict[str, float]
    heldout_mae: dict[str, float]
    heldout_groups: str
    heldout_source: str
    n_heldout: int
    gap: float
    warning: str | None

    @staticmethod
    def of(
        train_mae: dict[str, float],
        heldout_mae: dict[str, float],
        groups: str,
        source: str,
        n_heldout: int,
    ) -> HeldOutCheck:
        ratio, warning = gap(train_mae, heldout_mae)
        return HeldOutCheck(train_mae, heldout_mae, groups, source, n_heldout, ratio, warning)

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


def held_out_check(
    dec: Decoder,
    dataset: Dataset,
    rows: Rows | None,
    *,
    split: Split | None = None,
    held_sessions: bool = False,
    trainer: Callable[[Rows], Decoder],
) -> HeldOutCheck:
    """The check of `dec`, trained on `rows` (None: all) of `dataset`: on `split`'s test rows,
    on the rows outside `rows` (`held_sessions`), on its own validation groups, or else on
    about HELDOUT_FRACTION of the groups of `rows` scoring a check model `trainer(fit rows)`."""
    model = dec
    if split is not None:
        fit, held, kind, source = split.train, split.test, split.spec.by, "holdout split"
    elif held_sessions:
        assert rows is not None, "held-out sessions leave their rows out of `rows`"
        fit, kind, source = rows, "session", "--holdout-sessions"
        held = np.setdiff1d(np.arange(dataset.n), rows)
    elif dec.meta.get("n_val", 0) > 0:
        source = "the model's validation groups"
        fit, held = rows_of(dec.meta["fit_rows"]), rows_of(dec.meta["val_rows"])
        kind = dec.meta["val_groups"]
    else:
        fit, held, kind = heldout_groups(dataset, rows)
        model, source = trainer(fit), "a check model trained on the other groups"
    return HeldOutCheck.of(
        decoder_mae(model, dataset, fit),
        decoder_mae(model, dataset, held),
        kind,
        source,
        int(np.asarray(held).size),
    )


def heldout_groups(dataset: Dataset, rows: Rows | None) -> tuple[Rows, Rows, str]:
    """(fit, held-out, group kind): about HELDOUT_FRACTION of the whole groups of `rows`."""
    sel = np.arange(dataset.n) if rows is None else np.asarray(rows)
    groups = row_groups(dataset.session, dataset.press, dataset.t_end, sel)
    order = np.concatenate(session_order(np.asarray(dataset.session), np.asarray(dataset.t_end)))
    fit, held = val_split(order[np.isin(order, sel)], HELDOUT_FRACTION, groups)
    return fit, held, groups.kind


def gap(train: dict[str, float], held: dict[str, float]) -> tuple[float, str | None]:
    """(largest held-out / training MAE ratio over targets, warning text or None)."""
    ratios = {
        t: held[t] / train[t]
        for t in held
        if t in train and math.isfinite(held[t]) and math.isfinite(train[t]) and train[t] > 0
    }
    if not ratios:
        return float("nan"), None
    worst = max(ratios, key=lambda t: ratios[t])
    r = round(ratios[worst], 2)
    if r <= GAP_WARN:
        return r, None
    return r, f"held-out error is {r}x the training error ({worst}; warning above {GAP_WARN:g}x)"


def cv_check(report: dict[str, Any]) -> HeldOutCheck:
    """The check of the auto recipe's choice: its training error against its grouped
    cross-validation error, from the search report (train/auto_recipe)."""
    chosen = next(c for c in report["candidates"] if c["name"] == report["chosen"])
    return HeldOutCheck.of(
        chosen["train_mae"],
        {t: v["mean"] for t, v in chosen["cv_mae"].items()},
        report["groups"]["kind"],
        f"{report['folds']}-fold cross-validation of the chosen candidate",
        report["rows"],
    )
