"""The held-out check: a decoder's training error beside its error on whole held-out groups,
and when their ratio calls for a warning.

Held out are whole groups (train/groups.py), taken from the first of: the holdout split's
test rows, the held-out sessions, the model's own validation groups, or else about
HELDOUT_FRACTION of the groups of the training rows, on which a check model, trained like
the real one on the other groups, is scored (the real model keeps every row). The worst
held-out group is reported beside the mean.

Groups dealt round-robin interpolate across a drifting sensor: on real recordings the
figure was 3-5x lower than the error later measured on new sessions. With sessions in time
order (at least MIN_FORWARD_SESSIONS; ordered by their `started_unix` when every session
records it, else by session number), forward chaining trains on the earlier sessions and
scores each of the last FORWARD_SESSIONS; their mean, each session weighing half the one
after it (`recent_weighted`: drift grows with time), is the figure to expect on the next
session (`HeldOutCheck.expected`, printed by `expected_text`), the worst beside it.

With weeks of sessions (WEEKS_SESSIONS or more) each fold scores the horizon the figure
promises (a third of the sessions, at most MAX_HORIZON), and the figure is the real model's
training error plus the folds' mean excess over theirs, with a range (`trend_figure`).

How well the printed figure predicts the next sessions' error is measured by
`tools/bench/heldout_forward.py` (one session ahead) and `tools/bench/forward_figure.py`
(weeks); their figures are in tools/bench/MEASUREMENTS.md.

A decoder whose error on whole held-out groups (sessions, presses, time blocks) is many times
its error on its training rows has learnt what is particular to the training groups: session
offsets, drift, the exact presses. GAP_WARN = 2: on the synthetic skin
(`spectratac.sim.generic_skin`) sessions that are alike give a ratio near 1 and drifting
sessions several times that (tools/bench/MEASUREMENTS.md), so a ratio above 2 is no longer
noise.

>>> gap({"Fz": 0.25}, {"Fz": 4.8})
(19.2, 'held-out error is 19.2x the training error (Fz; warning above 2x)')
>>> gap({"Fz": 1.0}, {"Fz": 1.3})
(1.3, None)
"""

from __future__ import annotations

import math
import textwrap
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from spectratac.dataset.schema import Dataset
from spectratac.decode.assemble import session_order
from spectratac.decode.decoder import Decoder
from spectratac.hardware.generated.vocabulary import AXIS_UNITS
from spectratac.train.groups import Split, press_units, row_groups, val_split
from spectratac.train.holdout import parse_sessions, session_rows
from spectratac.train.metrics import decoder_mae
from spectratac.train.plan import rows_of
from spectratac.train.remounts import remounted_sessions
from spectratac.train.spec import TrainSpec

GAP_WARN = 2.0
HELDOUT_FRACTION = 0.2  # groups held out by the check model
MIN_FORWARD_SESSIONS = 3  # forward chaining needs sessions before the ones it scores
FORWARD_SESSIONS = 4  # forward folds (one model each)
MAX_HORIZON = 8  # sessions ahead a forward fold scores, and the figure promises
WEEKS_SESSIONS = 8  # from this many sessions on, folds score a horizon, not one ahead
TRAIN_ERROR_ROWS = 2000  # rows a training error is measured on (as auto's trials do)
MIN_CHECK_BATCH = 64  # below this a step costs its fixed overhead more than its rows
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
    # The held-out group with the largest error beside the mean: {target: MAE} and its id.
    heldout_worst: dict[str, float] = field(default_factory=dict)
    heldout_worst_group: int | None = None
    # Forward chaining over sessions in time order (see `forward_check`): the mean and the
    # worst MAE on each later session of models trained on the sessions before it.
    forward: ForwardCheck | None = None

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
        d = asdict(self)
        d["expected_mae"], d["expected_source"] = self.expected()
        d["expected_range"] = self.expected_range()
        d["expected_text"] = self.expected_text()
        return d

    def expected(self) -> tuple[dict[str, float], str]:
        """The MAE to expect on the next session and where it comes from: with sessions in
        time order, forward chaining's mean over the later sessions (round-robin groups
        interpolate across drift and promise too little; the worst session is reported
        beside it), else the held-out groups' mean."""
        if self.forward is not None and self.forward.horizon > 1:
            fwd = self.forward
            ks = ", ".join(str(f["trained_on"]) for f in fwd.folds)
            mounts = ""
            if fwd.remounts_ahead:
                seen = ", ".join(str(s) for s in fwd.remounted)
                mounts = (
                    f"; the skin was re-mounted before session(s) {seen}: the range runs from "
                    f"no re-mounting ahead to {fwd.remounts_ahead} before your next session"
                )
            return dict(fwd.mean_mae), (
                f"forward check: models trained on the first {ks} sessions in "
                f"{fwd.ordered_by} order, each scored on the {fwd.horizon} after them; what "
                f"they erred beyond their training error, added to this model's{mounts}"
            )
        if self.forward is not None:
            fwd = self.forward
            return dict(fwd.mean_mae), (
                f"forward check over {len(fwd.sessions)} sessions in {fwd.ordered_by} order, "
                "each scored by a model trained on the sessions before it, recent ones "
                "weighted more"
            )
        return dict(self.heldout_mae), f"mean over held-out {plural(self.heldout_groups)}"

    def expected_range(self) -> dict[str, list[float]]:
        """{target: [low, high]} about the figure when the forward folds give one (weeks of
        sessions: `trend_figure`), else empty."""
        return dict(self.forward.range_mae) if self.forward is not None else {}

    def expected_text(self) -> str:
        """The sentence `spectratac train` prints: the error to expect on the next session,
        what the figure is, and the worst session beside it.

        >>> fwd = ForwardCheck([3, 4], {"3": {"Fz": 0.4}, "4": {"Fz": 0.6}}, {"Fz": 0.5},
        ...                    {"Fz": 0.6}, 4, "recording")
        >>> HeldOutCheck.of({"Fz": 0.3}, {"Fz": 0.35}, "session", "s", 9).expected_text()
        'expect on a new session: Fz ~0.35 N (mean over held-out sessions)'
        >>> c = replace(HeldOutCheck.of({"Fz": 0.3}, {"Fz": 0.35}, "session", "s", 9), forward=fwd)
        >>> print(c.expected_text())
        expect on your next session: Fz ~0.5 N (forward check over 2 sessions in recording
          order, each scored by a model trained on the sessions before it, recent ones
          weighted more; worst, session 4: Fz 0.6 N)
        """
        mae, source = self.expected()
        span = self.expected_range()
        cells = "  ".join(
            f"{t} ~{v:.3g}{_unit(t)}"
            + (f" (range {span[t][0]:.3g}-{span[t][1]:.3g}{_unit(t)})" if t in span else "")
            for t, v in mae.items()
        )
        if self.forward is None:
            return f"expect on a new session: {cells} ({source})"
        worst = "  ".join(f"{t} {v:.3g}{_unit(t)}" for t, v in self.forward.worst_mae.items())
        ahead = self.forward.horizon
        after = f" and the {ahead - 1} after it" if ahead > 1 else ""
        text = (
            f"expect on your next session{after}: {cells} ({source}; worst, session "
            f"{self.forward.worst_session}: {worst})"
        )
        return textwrap.fill(text, 86, subsequent_indent="  ")


def _unit(target: str) -> str:
    """' N' or ' N·m' after a force or torque target, nothing after other targets."""
    unit = AXIS_UNITS.get(target)
    return f" {unit}" if unit else ""


@dataclass(frozen=True)
class ForwardCheck:
    """Forward chaining: for each of the last sessions (`sessions`, in time order), a model
    trained on every session before it scored on it; `per_session` MAE, their mean
    (`recent_weighted`) and the worst session's; `ordered_by` says how the time order was
    known ("recording": the sessions' start times, "session number": their ids)."""

    sessions: list[int]
    per_session: dict[str, dict[str, float]]
    mean_mae: dict[str, float]
    worst_mae: dict[str, float]
    worst_session: int
    ordered_by: str = "session number"
    # sessions ahead each fold scores, and the folds: {"trained_on": k, "sessions", "mae"}
    horizon: int = 1
    folds: list[dict[str, Any]] = field(default_factory=list)
    # {target: [low, high]} about the figure (horizon > 1: `trend_figure`), and the real
    # model's error on rows it trained on, which the figure sets beside the folds'
    range_mae: dict[str, list[float]] = field(default_factory=dict)
    model_train_mae: dict[str, float] = field(default_factory=dict)
    # sessions that began on a re-mounted skin (train/remounts.py), and the re-mountings
    # the range's high end allows for ahead (`remount_figure`; 0: the range is the trend's)
    remounted: list[int] = field(default_factory=list)
    remounts_ahead: int = 0


def held_out_check(
    dec: Decoder,
    dataset: Dataset,
    rows: Rows | None,
    *,
    split: Split | None = None,
    held_sessions: bool = False,
    trainer: Callable[[Rows], Decoder],
    forward: bool = True,
) -> HeldOutCheck:
    """The check of `dec`, trained on `rows` (None: all) of `dataset`: on `split`'s test rows,
    on the rows outside `rows` (`held_sessions`), on its own validation groups, or else on
    about HELDOUT_FRACTION of the groups of `rows` scoring a check model `trainer(fit rows)`;
    beside it the worst held-out group, and (`forward`) forward chaining over sessions."""
    model = dec
    stride = check_stride(dataset, rows, check_model=needs_check_model(dec, split, held_sessions))
    trainer = thinned(trainer, stride)
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
    check = HeldOutCheck.of(
        decoder_mae(model, dataset, fit),
        decoder_mae(model, dataset, held),
        kind,
        source,
        int(np.asarray(held).size),
    )
    worst, worst_id = worst_group(model, dataset, np.asarray(held), kind)
    pool = np.arange(dataset.n) if rows is None else np.asarray(rows)
    fwd = forward_check(dataset, pool, trainer, final=dec) if forward else None
    return replace(check, heldout_worst=worst, heldout_worst_group=worst_id, forward=fwd)


def needs_check_model(dec: Decoder, split: Split | None, held_sessions: bool) -> bool:
    """Whether the held-out check trains a model of its own (no split, no held-out
    sessions, no validation groups in the model)."""
    return split is None and not held_sessions and not dec.meta.get("n_val", 0) > 0


def check_fit_rows(dataset: Dataset, rows: Rows | None, *, check_model: bool) -> list[int]:
    """Rows each model of the check trains on before thinning: the check model's (about
    1 - HELDOUT_FRACTION of the rows) when there is one, then each forward fold's."""
    sel = np.arange(dataset.n) if rows is None else np.asarray(rows)
    out = [round((1.0 - HELDOUT_FRACTION) * sel.size)] if check_model else []
    ses = np.asarray(dataset.session, np.int64)[sel]
    ids, _ = time_order(dataset, np.unique(ses))
    ks, _ = forward_plan(len(ids))
    sizes = np.array([np.count_nonzero(ses == i) for i in ids])
    return out + [int(sizes[:k].sum()) for k in ks]


def check_stride(dataset: Dataset, rows: Rows | None, *, check_model: bool) -> int:
    """Every how many rows the check's models train on, so that together they see no more
    rows than the model itself (at 100 Hz neighbouring rows are near-duplicates): the check
    costs at most one more fit, not five.

    >>> from spectratac.dataset import Dataset
    >>> ds = Dataset.generic(np.zeros((280, 1)), np.zeros((280, 1)), ["a"], ["Fz"])
    >>> ds.arrays["session"] = np.repeat(np.arange(28), 10)
    >>> check_fit_rows(ds, None, check_model=True), check_stride(ds, None, check_model=True)
    ([224, 90, 130, 160, 200], 3)
    """
    n = dataset.n if rows is None else np.asarray(rows).size
    total = sum(check_fit_rows(dataset, rows, check_model=check_model))
    return max(1, -(-total // max(n, 1)))


def check_plan(dataset: Dataset, rows: Rows | None, *, check_model: bool) -> list[int]:
    """Rows each model of the check trains on, thinned as `held_out_check` thins them:
    what a time estimate of the check counts."""
    stride = check_stride(dataset, rows, check_model=check_model)
    return [-(-r // stride) for r in check_fit_rows(dataset, rows, check_model=check_model)]


def _options_scope(
    ds: Dataset, spec: Any, holdout: str | None, holdout_sessions: str | None
) -> tuple[Rows | None, bool]:
    """(rows the real model trains on, None: all; whether the check trains a model of its
    own) for `spectratac train`'s options: a check model unless a split, held-out sessions
    or validation groups give the held-out rows."""
    rows = None
    if holdout_sessions:
        rows = np.setdiff1d(np.arange(ds.n), session_rows(ds, parse_sessions(holdout_sessions)))
    return rows, not holdout and not holdout_sessions and spec.val_fraction <= 0


def check_rows_for_options(
    ds: Dataset, spec: Any, holdout: str | None, holdout_sessions: str | None
) -> list[int]:
    """Rows of each model the held-out check will train (`check_plan`), for `spectratac
    train`'s options (`_options_scope`): the check model if any, and the forward folds."""
    rows, own = _options_scope(ds, spec, holdout, holdout_sessions)
    if holdout:  # a split's training rows: about the same sessions, fewer rows
        return [round(0.8 * r) for r in check_plan(ds, rows, check_model=False)]
    return check_plan(ds, rows, check_model=own)


def check_recipe_for_options(
    ds: Dataset, spec: TrainSpec, holdout: str | None, holdout_sessions: str | None
) -> TrainSpec:
    """The recipe the check's models will train with (`check_recipe`) for `spectratac
    train`'s options: a smaller batch than the real model's, so a different cost per row
    that a time estimate probes apart."""
    rows, own = _options_scope(ds, spec, holdout, holdout_sessions)
    return check_recipe(spec, check_stride(ds, rows, check_model=own))


def check_predictions(dataset: Dataset, rows: Rows | None) -> list[int]:
    """Rows of each prediction pass the check and the training summary make (every pass
    also assembles the whole dataset: with temporal context that is most of its cost): the
    training and held-out rows, each held-out group apart (`worst_group`), each session a
    forward fold scores, over weeks each fold's and the model's training error, and every
    row for the summary. What a time estimate counts beside the fits (`check_plan`)."""
    sel = np.arange(dataset.n) if rows is None else np.asarray(rows)
    fit, held, kind = heldout_groups(dataset, sel)
    groups = np.unique(group_ids(dataset, held, kind)).size if held.size else 0
    ses = np.asarray(dataset.session, np.int64)[sel]
    ids, _ = time_order(dataset, np.unique(ses))
    ks, horizon = forward_plan(len(ids))
    sizes = [int(np.count_nonzero(ses == i)) for i in ids]
    scored = [sizes[j] for k in ks for j in range(k, min(k + horizon, len(ids)))]
    per_group = [held.size // groups] * groups if groups else []
    # over weeks, each fold's and the model's training error (`spread` rows of theirs)
    trained = [sum(sizes[:k]) for k in ks] + [sel.size] if horizon > 1 else []
    spread_n = [-(-r // -(-r // TRAIN_ERROR_ROWS)) for r in trained if r > 0]
    return [int(fit.size), int(held.size), *per_group, *scored, *spread_n, int(dataset.n)]


def check_predictions_for_options(
    ds: Dataset, holdout: str | None, holdout_sessions: str | None
) -> list[int]:
    """`check_predictions` for `spectratac train`'s options, on the rows the real model
    trains on."""
    rows = None
    if holdout_sessions:
        rows = np.setdiff1d(np.arange(ds.n), session_rows(ds, parse_sessions(holdout_sessions)))
    out = check_predictions(ds, rows)
    return [round(0.8 * r) for r in out] if holdout else out


def check_recipe(spec: TrainSpec, stride: int) -> TrainSpec:
    """The recipe of the check's models, which train on every `stride`-th row: the real
    model's, with the batch divided by `stride` (at least MIN_CHECK_BATCH) so that each
    epoch takes as many optimiser steps as on every row. With the batch kept, a network
    on a third of the rows took a third of the steps, erred more than the model it checks
    and made the figure pessimistic; the rows it skips are near-duplicates at 100 Hz, the
    steps are what it learns by. Ridge has no batches.

    >>> check_recipe(TrainSpec.paper(), 3).batch_size, check_recipe(TrainSpec.best(), 8).batch_size
    (341, 64)
    """
    if spec.model == "ridge" or stride <= 1:
        return spec
    return replace(spec, batch_size=max(min(MIN_CHECK_BATCH, spec.batch_size),
                                        spec.batch_size // stride))  # fmt: skip


def thinned(trainer: Callable[[Rows], Decoder], stride: int) -> Callable[[Rows], Decoder]:
    """`trainer` on every `stride`-th of the rows it is given."""
    if stride <= 1:
        return trainer
    return lambda fit_rows: trainer(np.asarray(fit_rows)[::stride])


def worst_group(
    model: Decoder, dataset: Dataset, held: Rows, kind: str
) -> tuple[dict[str, float], int | None]:
    """MAE of the held-out group with the largest mean error, the groups being of the `kind`
    held out: sessions, presses (a press and the idle rows after it), else time blocks."""
    if held.size == 0:
        return {}, None
    ids = group_ids(dataset, held, kind)
    best: tuple[float, dict[str, float], int | None] = (-1.0, {}, None)
    for g in np.unique(ids):
        mae = decoder_mae(model, dataset, held[ids == g])
        vals = [v for v in mae.values() if math.isfinite(v)]
        score = float(np.mean(vals)) if vals else -1.0
        if score > best[0]:
            best = (score, mae, int(g))
    return best[1], best[2]


def group_ids(dataset: Dataset, held: Rows, kind: str) -> NDArray[np.int64]:
    """The group of each of the `held` rows, of the `kind` held out: sessions, presses (a
    press and the idle rows after it), else time blocks."""
    ses = np.asarray(dataset.session, np.int64)
    press = np.asarray(dataset.press, np.int64)
    if kind == "session":  # whole sessions, even when the rows hold only one (then: its MAE)
        return ses[held]
    if kind == "press" or (kind == "auto" and np.any(press[held] >= 0)):
        return np.asarray(press_units(np.asarray(dataset.t_end), ses, press)[held], np.int64)
    groups = row_groups(ses, press, dataset.t_end, held)
    return np.asarray(groups.ids)[held] if groups.ids.size == dataset.n else groups.ids


def forward_plan(n_sessions: int) -> tuple[list[int], int]:
    """(fold points, horizon): fold k trains on the first k sessions in time order and is
    scored on the `horizon` sessions after them. Up to 7 sessions: the last four sessions one
    at a time (horizon 1); with more, a horizon of a third of them (at most MAX_HORIZON,
    the sessions the printed figure is for), so that the folds see drift as far ahead as
    the next weeks will, at FORWARD_SESSIONS points spread over the later two thirds.

    >>> forward_plan(6), forward_plan(28), forward_plan(2)
    (([2, 3, 4, 5], 1), ([9, 13, 16, 20], 8), ([], 1))
    """
    if n_sessions < MIN_FORWARD_SESSIONS:
        return [], 1
    if n_sessions < WEEKS_SESSIONS:
        return list(range(n_sessions - min(FORWARD_SESSIONS, n_sessions - 1), n_sessions)), 1
    horizon = int(np.clip(n_sessions // 3, 2, MAX_HORIZON))
    last = n_sessions - horizon
    first = max(2, n_sessions // 3)
    ks = np.unique(np.rint(np.linspace(min(first, last), last, FORWARD_SESSIONS)).astype(int))
    return [int(k) for k in ks], horizon


def forward_check(
    dataset: Dataset,
    rows: Rows,
    trainer: Callable[[Rows], Decoder],
    *,
    final: Decoder | None = None,
) -> ForwardCheck | None:
    """Forward chaining over the sessions of `rows` in time order (`time_order`,
    `forward_plan`): for each fold point k, a model trained on the rows of the first k
    sessions, and on no other, is scored on each of the `horizon` sessions after them.
    None with fewer than MIN_FORWARD_SESSIONS sessions (no earlier data to train on)."""
    rows = np.asarray(rows)
    ses = np.asarray(dataset.session, np.int64)[rows]
    ids, ordered_by = time_order(dataset, np.unique(ses))
    ks, horizon = forward_plan(len(ids))
    if not ks:
        return None
    place = np.argsort(ids)  # the j-th smallest session id was recorded place[j]-th
    when = place[np.searchsorted(np.sort(ids), ses)]  # each row's session's place in time
    per: dict[str, dict[str, float]] = {}
    folds: list[dict[str, Any]] = []
    for k in ks:
        fit_rows = rows[when < k]
        model = trainer(fit_rows)
        scored = {
            str(ids[j]): decoder_mae(model, dataset, rows[when == j])
            for j in range(k, min(k + horizon, len(ids)))
        }
        per.update(scored)
        targets = list(next(iter(scored.values())))
        mean = {t: float(np.nanmean([m[t] for m in scored.values()])) for t in targets}
        folds.append({"trained_on": k, "sessions": [int(s) for s in scored], "mae": mean,
                      "session_mae": list(scored.values())})  # fmt: skip
        if horizon > 1:  # the figure sets each fold's training error beside the model's
            folds[-1]["train_mae"] = decoder_mae(model, dataset, spread(fit_rows))
    own = decoder_mae(final, dataset, spread(rows)) if horizon > 1 and final is not None else None
    remounted = remounted_sessions(dataset, ids) if horizon > 1 else []
    mean, span, ahead = forward_figure(folds, len(ids), horizon, own, ids, remounted)
    worst_s = max(per, key=lambda k: float(np.nanmean(list(per[k].values()))))
    return ForwardCheck(
        [int(k) for k in per], per, mean, dict(per[worst_s]), int(worst_s), ordered_by,
        horizon, folds, span, own or {}, remounted, ahead,
    )  # fmt: skip


def spread(rows: Rows) -> Rows:
    """At most TRAIN_ERROR_ROWS of `rows`, spread evenly over them: where a model's error on
    the rows it trained on is measured (the folds' and the real model's alike)."""
    rows = np.asarray(rows)
    return rows[:: -(-rows.size // TRAIN_ERROR_ROWS)] if rows.size else rows


def forward_figure(
    folds: list[dict[str, Any]],
    n: int,
    horizon: int,
    own: dict[str, float] | None = None,
    order: Sequence[int] = (),
    remounted: Sequence[int] = (),
) -> tuple[dict[str, float], dict[str, list[float]], int]:
    """({target: MAE to expect}, {target: [low, high]}, re-mountings the high end allows
    for) from forward folds over `n` sessions: one session ahead (horizon 1), the
    recent-weighted mean of the folds' errors and no range; further, `remount_figure` when
    the history (`order`: session ids in time order) holds re-mountings both inside and
    outside the folds' windows (its range widened to hold `trend_figure`'s), else
    `trend_figure`; `own` is the real model's training error."""
    targets = list(folds[0]["mae"])
    if horizon == 1:
        return {t: recent_weighted([f["mae"][t] for f in folds]) for t in targets}, {}, 0
    mean, span, ahead = {}, {}, 0
    for t in targets:
        mean[t], lo, hi = trend_figure(folds, t, n, horizon, (own or {}).get(t))
        by_mount = remount_figure(folds, t, order, remounted, horizon, (own or {}).get(t))
        if by_mount is not None:  # the range holds the trend's and the re-mountings' spans
            mean[t], low, high, ahead = by_mount
            lo = min(low, lo) if math.isfinite(lo) else low
            hi = max(high, hi) if math.isfinite(hi) else high
        if math.isfinite(lo) and math.isfinite(hi):
            span[t] = [lo, hi]
    return mean, span, ahead


def remount_figure(
    folds: list[dict[str, Any]],
    target: str,
    order: Sequence[int],
    remounted: Sequence[int],
    horizon: int,
    own: float | None,
) -> tuple[float, float, float, int] | None:
    """(figure, low, high, re-mountings at the high end) over the `horizon` sessions after
    the last of `order` (session ids in time order), when the skin was re-mounted now and
    then (`remounted`: train/remounts.py).

    A re-mounting moves the light a model learnt, so each fold's error on a session beyond
    its training error (its excess) is fitted as a + g i + b r: i sessions ahead, r
    re-mountings between the fold's last training session and that one (g, b >= 0). How
    often the history re-mounts (`rate` per session) gives r's expectation i rate: the
    figure is `own` (the real model's training error) + a + g i + b i rate, averaged over
    the horizon. The range runs from no re-mounting ahead to `q` re-mountings before the
    next session, q the 90th percentile of a Poisson count at the horizon's rate (at least
    one), each costing what the dearer re-mountings the folds met cost (the 90th percentile
    per re-mounting, at least b: one re-mounting's gain steps cost more than another's): a
    re-mounting cannot be foreseen, what it may cost can. None when every fold
    session, or none, follows a re-mounting its model did not see (nothing to part the two
    by), or without training errors.

    >>> folds = [{"trained_on": k, "train_mae": {"Fz": 0.1}, "sessions": list(range(k, k + 4)),
    ...           "session_mae": [{"Fz": 0.1 + 0.02 * i + 0.3 * (k + i - 1 >= 8)}
    ...                           for i in (1, 2, 3, 4)]} for k in (3, 5, 7)]
    >>> [round(v, 3) for v in remount_figure(folds, "Fz", list(range(11)), [8], 4, 0.05)]
    [0.175, 0.1, 0.4, 1]
    """
    if own is None or not math.isfinite(own) or not remounted:
        return None
    place = {int(s): i for i, s in enumerate(order)}
    marks = np.array(sorted(place[int(s)] for s in remounted if int(s) in place))
    ahead, unseen, excess = [], [], []
    for f in folds:
        k, trained = int(f["trained_on"]), (f.get("train_mae") or {}).get(target)
        if trained is None or not math.isfinite(trained):
            return None
        for s, m in zip(f["sessions"], f["session_mae"], strict=True):
            v, j = float(m[target]), place.get(int(s))
            if j is None or not math.isfinite(v):
                continue
            ahead.append(j - k + 1)
            unseen.append(int(np.count_nonzero((marks >= k) & (marks <= j))))
            excess.append(v - trained)
    r = np.asarray(unseen, np.float64)
    if not (r > 0).any() or not (r == 0).any():
        return None
    i, e = np.asarray(ahead, np.float64), np.asarray(excess, np.float64)
    g, b = np.linalg.lstsq(np.stack([np.ones_like(i), i, r], axis=1), e, rcond=None)[0][1:]
    g, b = max(float(g), 0.0), max(float(b), 0.0)
    a = float(np.mean(e - g * i - b * r))
    # what one re-mounting cost the sessions that met one: their excess beyond drift, per
    # re-mounting; the range prices re-mountings ahead at its 90th percentile
    met = r > 0
    dear = max(b, float(np.percentile((e - a - g * i)[met] / r[met], 90)))
    mid = (horizon + 1) / 2
    rate = marks.size / max(len(order) - 1, 1)
    q = max(1, poisson_quantile(0.9, rate * horizon))
    calm = own + a + g * mid
    point = calm + b * rate * mid
    return point, max(min(calm, point), own), calm + dear * q, q


def poisson_quantile(p: float, lam: float) -> int:
    """The smallest count whose Poisson(`lam`) cumulative probability reaches `p`.

    >>> poisson_quantile(0.9, 0.59), poisson_quantile(0.9, 0.0), poisson_quantile(0.5, 3.0)
    (2, 0, 3)
    """
    k, term = 0, math.exp(-lam)
    total = term
    while total < p and k < 1000:
        k += 1
        term *= lam / k
        total += term
    return k


def trend_figure(
    folds: list[dict[str, Any]], target: str, n: int, horizon: int, own: float | None = None
) -> tuple[float, float, float]:
    """(figure, low, high): the error to expect over the `horizon` sessions after all `n`.

    Each forward fold's error over its `horizon` sessions exceeds its error on the rows it
    trained on (its "train_mae") by what time does to a model: drift, re-mountings, the
    sessions it never saw. The figure is the real model's own training error (`own`) plus
    the folds' mean excess: a check model that fits worse or better than the real one
    (fewer rows, fewer steps) no longer moves the figure. Without training errors, the
    folds' mean error.

    The range says how far that mean can be from the next sessions: by the spread of the
    folds' excesses (a re-mounting strikes some windows and not others), and by the trend
    across folds (per-session errors fitted as a + b k + c ahead, read at k = n): the
    next sessions follow a model trained on more sessions than any fold, which drifts
    further from its older ones. The range is centred on the figure, the larger of the two
    either side, its low end never below `own`.

    >>> folds = [{"trained_on": k, "train_mae": {"Fz": 0.1},
    ...           "session_mae": [{"Fz": 0.01 * k + 0.1 * i} for i in (1, 2)]} for k in (4, 6, 8)]
    >>> [round(v, 3) for v in trend_figure(folds, "Fz", 10, 2, own=0.05)]
    [0.16, 0.07, 0.25]
    """
    ks, ahead, err, means, trained = [], [], [], [], []
    for f in folds:
        vals = [float(m[target]) for m in f["session_mae"]]
        if not np.isfinite(vals).any():
            continue
        means.append(float(np.nanmean(vals)))
        trained.append(float((f.get("train_mae") or {}).get(target, float("nan"))))
        for i, v in enumerate(vals, start=1):
            ks.append(f["trained_on"])
            ahead.append(i)
            err.append(v)
    if not means:
        return float("nan"), float("nan"), float("nan")
    ex = np.asarray(means) - np.asarray(trained)
    if own is None or not math.isfinite(own) or not np.isfinite(ex).all():
        own, ex = 0.0, np.asarray(means)  # no training errors to set beside each other
    point = own + float(np.mean(ex))
    e = np.asarray(err, np.float64)
    ok = np.isfinite(e)
    if np.unique(np.asarray(ks)[ok]).size < 2:
        return point, float("nan"), float("nan")
    x = np.stack([np.ones(ok.sum()), np.asarray(ks, np.float64)[ok],
                  np.asarray(ahead, np.float64)[ok]], axis=1)  # fmt: skip
    coef = np.linalg.lstsq(x, e[ok], rcond=None)[0]
    trend = float(coef[0] + coef[1] * n + coef[2] * (horizon + 1) / 2)
    width = max(float(np.std(ex, ddof=1)), abs(min(trend, 2.0 * e[ok].max()) - point))
    return point, max(point - width, own), point + width


def recent_weighted(errors: list[float]) -> float:
    """Mean of per-session errors in time order, each weighing half the one after it: the
    drift grows with time, so the latest folds are the nearest to the next session.

    >>> recent_weighted([1.0, 2.0, 4.0]), recent_weighted([3.0, float("nan")])
    (3.0, 3.0)
    """
    e = np.asarray(errors, np.float64)
    w = 0.5 ** np.arange(e.size - 1, -1, -1.0)
    ok = np.isfinite(e)
    return float(w[ok] @ e[ok] / w[ok].sum()) if ok.any() else float("nan")


def time_order(dataset: Dataset, ids: NDArray[np.int64]) -> tuple[list[int], str]:
    """Session ids in the order they were recorded, and how that is known: by the sessions'
    `started_unix` (dataset metadata, from the recordings) when every one of them has it, as
    `spectratac dataset build` may number recordings in the order its files were given;
    else by session number (datasets without start times number them in recording order).

    >>> from spectratac.dataset import Dataset
    >>> ds = Dataset.generic(np.zeros((3, 1)), np.zeros((3, 1)), ["a"], ["Fz"])
    >>> ds.meta["sessions"] = [{"started_unix": 30.0}, {"started_unix": 10.0},
    ...                        {"started_unix": 20.0}]
    >>> time_order(ds, np.array([0, 1, 2]))
    ([1, 2, 0], 'recording')
    >>> ds.meta["sessions"][2] = {}
    >>> time_order(ds, np.array([0, 1, 2]))
    ([0, 1, 2], 'session number')
    """
    numbers = sorted(int(i) for i in ids)
    meta = dataset.meta.get("sessions") or []
    raw = [
        meta[i].get("started_unix") if 0 <= i < len(meta) and isinstance(meta[i], dict) else None
        for i in numbers
    ]
    starts = [float(v) for v in raw if isinstance(v, (int, float)) and math.isfinite(v)]
    if numbers and len(starts) == len(numbers):
        order = sorted(range(len(numbers)), key=lambda j: (starts[j], numbers[j]))
        return [numbers[j] for j in order], "recording"
    return numbers, "session number"


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
    plan = report.get("forward")
    how = "forward-in-time folds" if plan else "cross-validation"
    check = HeldOutCheck.of(
        chosen["train_mae"],
        {t: v["mean"] for t, v in chosen["cv_mae"].items()},
        report["groups"]["kind"],
        f"{report['folds']}-fold {how} of the chosen candidate",
        report["rows"],
    )
    if not plan or not chosen.get("fold_session_mae"):
        return check
    return replace(check, forward=_forward_of_folds(plan, chosen, report.get("refit_train_mae")))


def _forward_of_folds(
    plan: dict[str, Any], chosen: dict[str, Any], own: dict[str, float] | None
) -> ForwardCheck:
    """The forward check of the auto recipe's choice, from its forward folds' scores."""
    ks = [int(k) for k in plan["trained_on"]]
    per: dict[str, dict[str, float]] = {}
    folds = []
    trained = chosen.get("fold_train_mae") or [{}] * len(ks)
    for k, mae, by_s, tr in zip(ks, chosen["cv_fold_mae"], chosen["fold_session_mae"], trained,
                                strict=True):  # fmt: skip
        per.update(by_s)
        folds.append({"trained_on": k, "sessions": [int(s) for s in by_s], "mae": mae,
                      "session_mae": list(by_s.values()), "train_mae": tr})  # fmt: skip
    order, remounted = plan.get("order") or [], plan.get("remounted") or []
    mean, span, ahead = forward_figure(
        folds, plan["sessions"], plan["horizon"], own, order, remounted
    )
    worst = max(per, key=lambda s: float(np.nanmean(list(per[s].values()))))
    return ForwardCheck(
        [int(s) for s in per], per, mean, dict(per[worst]), int(worst), plan["ordered_by"],
        plan["horizon"], folds, span, own or {}, list(remounted), ahead,
    )  # fmt: skip


def plural(kind: str) -> str:
    """A group kind in the plural: 'press' -> 'presses', 'session' -> 'sessions'.

    >>> plural("press"), plural("block")
    ('presses', 'blocks')
    """
    return kind + ("es" if kind.endswith("s") else "s")
