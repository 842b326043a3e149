"""`search`: honest model selection within a budget of work (`spectratac train --recipe auto`).

    from spectratac.train.auto_recipe import search
    result = search(dataset, budget_s=300)          # grouped K-fold CV, local processes
    result.decoder.save("model.stac")               # the chosen model, refitted on all rows
    print(result.text()); result.report             # every candidate: CV error, cost

Each candidate (auto_recipe/space.py) is cross-validated by groups: whole sessions, else
presses, else guarded time blocks (train/groups.py), or the `groups` given. Every trial, ridge
and network alike, fits each fold on a subsample of at most `max_fit_rows` rows (every k-th
row: at 100 Hz neighbours are near-duplicates), and on fold 0 also on half of it: the
learning curve in the report says whether more rows would still help. Trials run in parallel
(local processes, or Ray with `ray_address`) in order of predicted cost, cheapest first,
while the budget allows. The budget is in units of work (auto_recipe/budget.py), not wall
seconds, so the same data and seed give the same trials and the same choice on a quiet or a
busy machine; the wall time is reported beside it. The linear baselines always run; ridge
with more than MAX_RIDGE_FEATURES monomials is left out.

The winner is the model with the fewest inference FLOPs whose CV error is within one
standard error of the best candidate's, the error of the paired per-fold difference (the
folds are the same for every candidate, so fold-to-fold spread common to all of them is not
noise between them; with the unpaired error over 4 folds the rule discarded the context
models that were best). It is refitted on all rows (network epochs scaled so that it sees as
many samples as a fold did) and its report is stored in the decoder's metadata under
"auto_recipe".
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from spectratac import threads
from spectratac.dataset.schema import Dataset
from spectratac.decode.decoder import Decoder
from spectratac.decode.errors import DecoderConfigError
from spectratac.decode.networks import flops
from spectratac.train.auto_recipe.budget import Stopwatch, WorkBudget, nominal_s, work
from spectratac.train.auto_recipe.report import render
from spectratac.train.auto_recipe.space import Candidate, candidates
from spectratac.train.auto_recipe.trial import TIMING_ROWS, Fold, TrialJob, thin
from spectratac.train.check import forward_plan, time_order
from spectratac.train.fitting import train
from spectratac.train.groups import Groups, group_folds, purge, row_groups
from spectratac.train.metrics import decoder_mae
from spectratac.train.plan import default_features, default_targets, plan, select_rows
from spectratac.train.remounts import remounted_sessions
from spectratac.train.spec import TrainSpec

DEFAULT_FOLDS = 5
MAX_FIT_ROWS = 20_000  # rows per fold fit, every trial (every k-th row)
# ridge candidates with more features are left out: the design matrix grows with the
# feature count and the normal equations with its square. 2000 admits the quadratic over the
# paper's features with the drift baseline's (1710 monomials: one fit on 36 000 twin rows
# took 29 s on one core, 0.5 GB of float64), not the cubic (7139)
MAX_RIDGE_FEATURES = 2000
# With this many sessions or more (weeks of a drifting sensor), candidates are ranked on
# forward-in-time folds; round-robin folds interpolate across the drift and chose models
# that did well between sessions they had seen and badly on the next ones.
FORWARD_MIN_SESSIONS = 8


@dataclass
class SearchResult:
    """The chosen decoder (refitted on all rows) and the search report (a JSON-able dict)."""

    decoder: Decoder
    report: dict[str, Any]

    def text(self) -> str:
        return render(self.report)


def _folds(ds: Dataset, rows: NDArray[np.intp], g: Groups, k: int) -> list[Fold]:
    out = []
    for held in group_folds(g.ids, rows, k):
        fit = np.setdiff1d(rows, held)
        fit = purge(fit, held, g, np.asarray(ds.session), np.asarray(ds.t_end))
        out.append((fit, held))
    return out


def _forward_folds(ds: Dataset, rows: NDArray[np.intp]) -> tuple[list[Fold], dict[str, Any]] | None:
    """Forward-in-time folds over the sessions of `rows` (train/check.py `forward_plan`:
    fold k trains on the first k sessions in time order, is scored on the horizon after
    them), or None with fewer than FORWARD_MIN_SESSIONS sessions."""
    ses = np.asarray(ds.session, np.int64)[rows]
    ids, ordered_by = time_order(ds, np.unique(ses))
    if len(ids) < FORWARD_MIN_SESSIONS:
        return None
    ks, horizon = forward_plan(len(ids))
    place = np.argsort(ids)
    when = place[np.searchsorted(np.sort(ids), ses)]
    folds = [(rows[when < k], rows[(when >= k) & (when < k + horizon)]) for k in ks]
    return folds, {"trained_on": ks, "horizon": horizon, "sessions": len(ids),
                   "ordered_by": ordered_by, "order": [int(i) for i in ids],
                   "remounted": remounted_sessions(ds, ids)}  # fmt: skip


def _n_features(ds: Dataset, c: Candidate) -> int:
    return plan(ds, c.spec).features.n_features


def _units(ds: Dataset, c: Candidate, rows: int) -> float:
    """Work of one fit of `c` on `rows` rows."""
    p = plan(ds, c.spec)
    f = p.features.n_features
    if c.classical:
        return work("classical", rows, f, 1, 0)
    train_flops = 3 * flops(c.spec.arch, f, p.heads.n_out)
    return work("network", rows, f, c.spec.epochs, train_flops)


def trial_units(ds: Dataset, c: Candidate, fit_rows: int, k: int) -> float:
    """Work of a trial: k fold fits on `fit_rows` rows, plus the learning curve's half fit."""
    return _units(ds, c, fit_rows) * k + _units(ds, c, fit_rows // 2)


def refit_units(ds: Dataset, c: Candidate, fit_rows: int, all_rows: int) -> float:
    """Work of the final refit: ridge on every row; a network for as many samples as a
    fold's fit saw (its epochs are scaled, `_refit_spec`)."""
    return _units(ds, c, all_rows if c.classical else fit_rows)


def _refit_spec(c: Candidate, fold_rows: int, all_rows: int, threads: int) -> TrainSpec:
    if c.classical:
        return c.spec
    epochs = max(1, round(c.spec.epochs * fold_rows / max(all_rows, 1)))
    return replace(c.spec, epochs=epochs, threads=threads)


def _se(v: NDArray[np.float64]) -> float:
    return float(v.std(ddof=1) / np.sqrt(v.size)) if v.size > 1 else float("nan")


def _summarise(c: Candidate, res: dict[str, Any], k: int) -> dict[str, Any]:
    s = np.asarray(res["fold_score"], np.float64)
    mae = {}
    for t in res["fold_mae"][0]:
        v = np.asarray([f[t] for f in res["fold_mae"]])
        mae[t] = {"mean": float(v.mean()), "se": _se(v)}
    tr = float(np.mean(res["train_score"]))
    train_mae = {t: float(np.mean([f[t] for f in res["train_mae"]])) for t in mae}
    return {
        "status": "done",
        "cv_score": float(s.mean()),
        "cv_se": _se(s),
        "fold_score": [float(x) for x in s],
        "cv_mae": mae,
        "cv_fold_mae": [dict(f) for f in res["fold_mae"]],
        "fold_train_mae": [dict(f) for f in res["train_mae"]],
        "train_score": tr,
        "train_mae": train_mae,
        "gap": float(s.mean() / tr) if tr > 0 else float("inf"),
        "learning_curve": res["learning_curve"],
        "fold_session_mae": res.get("fold_session_mae"),
        "seconds": float(res["seconds"]),
        **res["cost"],
    }


def paired_se(r: dict[str, Any], best: dict[str, Any]) -> float:
    """Standard error of r's CV score minus the best's: over the per-fold differences when
    both have per-fold scores on the same folds, else the best's own standard error.

    >>> best = {"cv_se": 0.05, "fold_score": [0.10, 0.30, 0.20]}
    >>> round(paired_se({"fold_score": [0.12, 0.32, 0.22]}, best), 6), paired_se({}, best)
    (0.0, 0.05)
    """
    a, b = r.get("fold_score"), best.get("fold_score")
    if a is not None and b is not None and len(a) == len(b) > 1:
        return _se(np.asarray(a, np.float64) - np.asarray(b, np.float64))
    se = best.get("cv_se", float("nan"))
    return float(se) if np.isfinite(se) else 0.0


def one_se_choice(rows: list[dict[str, Any]]) -> tuple[str, str]:
    """(chosen, best) names: the fewest FLOPs within one standard error of the best mean
    (the paired error over folds, `paired_se`), where a network must also earn its cost: it
    is chosen only if its mean is no worse than every classical baseline's (rows with
    "family": "classical"), so that a cheap network never wins by noise over a better ridge.

    >>> ok = {"status": "done", "eligible": True, "cv_se": 0.02}
    >>> r = [{"name": "big", "cv_score": 0.10, "flops": 1e5, **ok},
    ...      {"name": "small", "cv_score": 0.11, "flops": 50, **ok}]
    >>> one_se_choice(r)
    ('small', 'big')
    >>> r += [{"name": "poly2", "family": "classical", "cv_score": 0.105, "flops": 900, **ok}]
    >>> one_se_choice(r)
    ('poly2', 'big')
    """
    ok = [r for r in rows if r.get("eligible") and r.get("status") == "done"]
    if not ok:
        raise DecoderConfigError("no candidate finished within the budget: give more time")
    best = min(ok, key=lambda r: r["cv_score"])
    classical = min((r["cv_score"] for r in ok if r.get("family") == "classical"), default=np.inf)

    def earns(r: dict[str, Any]) -> bool:
        return r.get("family") == "classical" or r["cv_score"] <= classical

    near = [r for r in ok if r["cv_score"] <= best["cv_score"] + paired_se(r, best) and earns(r)]
    chosen = min(near, key=lambda r: (r["flops"], r["cv_score"]))
    return chosen["name"], best["name"]


def search(
    dataset: Dataset,
    budget_s: float = 300.0,
    *,
    groups: ArrayLike | None = None,
    rows: ArrayLike | None = None,
    targets: tuple[str, ...] | None = None,
    features: str | None = None,
    folds: int = DEFAULT_FOLDS,
    workers: int | None = None,
    ray_address: str | None = None,
    space: list[Candidate] | None = None,
    max_fit_rows: int = MAX_FIT_ROWS,
    clock: Callable[[], float] = time.monotonic,
    progress: Callable[[str], None] | None = None,
) -> SearchResult:
    """Search the recipe space on `rows` (default all) of `dataset` within `budget_s`
    nominal seconds per worker (units of work, the final refit included: budget.py) and
    return the chosen decoder and the report.

    groups: a group id per dataset row (>= 0; rows of a group are held out together), e.g.
    units for a held-out-unit study; default sessions, else presses, else time blocks.
    targets / features: as TrainSpec's (default: every target and class of the dataset;
    paper33 for SpectraTac data, else generic). workers: parallel trials (default: cores);
    1 runs them in this process. ray_address: run trials on that Ray cluster instead.
    space: the candidates (default `space.candidates`). clock: wall seconds, reported only.
    """
    watch = Stopwatch(clock)
    sel = select_rows(dataset.n, rows)
    tg = tuple(targets) if targets else default_targets(dataset)
    feats = features or default_features(dataset)
    if groups is not None:
        ids = np.asarray(groups, np.int64)
        if ids.shape != (dataset.n,):
            raise DecoderConfigError(f"groups has shape {ids.shape}; give one id per row")
        g = Groups(ids, "given")
    else:
        g = row_groups(dataset.session, dataset.press, dataset.t_end, sel)
    sel = sel[g.ids[sel] >= 0]
    forward = _forward_folds(dataset, sel) if groups is None and g.kind == "session" else None
    if forward is not None:
        fold_rows, fwd_plan = forward
        k = len(fold_rows)
    else:
        k = max(2, min(folds, np.unique(g.ids[sel]).size))  # the groups of these rows
        fold_rows, fwd_plan = _folds(dataset, sel, g, k), None
    names = set(dataset.target_names)
    reg = tuple(t for t in tg if t in names)
    space = candidates(feats, tg, reg) if space is None else space
    y = np.asarray(dataset.targets, np.float64)[sel]
    tv = np.asarray(dataset.target_valid, bool)[sel]
    std = {t: float(np.nanstd(y[tv, dataset.target_names.index(t)])) or 1.0 for t in reg}
    n_fold = int(np.mean([f.size for f, _ in fold_rows]))
    fit_n = min(n_fold, max_fit_rows) if max_fit_rows > 0 else n_fold
    ncores = threads.usable_cpus()
    runner = _runner(dataset, ray_address, workers or ncores)
    budget = WorkBudget(budget_s, runner.workers)
    table: dict[str, dict[str, Any]] = {}
    trial_s = {c.name: nominal_s(c.family, trial_units(dataset, c, fit_n, k)) for c in space}
    refit_s = {c.name: nominal_s(c.family, refit_units(dataset, c, fit_n, sel.size)) for c in space}
    by_name = {c.name: c for c in space}
    # cheapest first (stable: ties keep the space's order), so that a costly early candidate
    # never spends the budget the cheaper ones would have used
    order = sorted(space, key=lambda c: trial_s[c.name])
    needs_all = len(reg) < len(tg)  # classes asked for: only networks decode them

    launched: set[str] = set()

    def is_always(c: Candidate) -> bool:
        return c.classical and c.spec.degree == 1  # the linear baselines: seconds

    def best_refit() -> float:
        done = [n for n, r in table.items() if r.get("status") == "done"]
        if not done:
            return 0.0
        return refit_s[min(done, key=lambda n: table[n]["cv_score"])]

    def collect(timeout: float | None) -> None:
        for job, res in runner.done(timeout):
            c = by_name[job.name]
            if isinstance(res, BaseException):
                table[c.name] = {"status": f"failed: {res}"}
                continue
            table[c.name] = _summarise(c, res, k)
            if progress:
                progress(f"{c.name}: CV {table[c.name]['cv_score']:.4f} "
                         f"({res['seconds']:.1f} s)")  # fmt: skip

    try:
        for c in order:
            if c.classical and _n_features(dataset, c) > MAX_RIDGE_FEATURES:
                table[c.name] = {"status": f"skipped: {_n_features(dataset, c)} features, "
                                 f"over {MAX_RIDGE_FEATURES} for ridge"}  # fmt: skip
                continue
            while runner.busy >= runner.workers:
                collect(None)
            collect(0)
            # the refit of the best so far or of this one, on every core
            refit = max(refit_s[c.name], best_refit()) * runner.workers
            always = is_always(c)
            # the linear baselines always run: their cost is set aside before any other trial
            reserve = sum(trial_s[o.name] for o in order if is_always(o) and o.name not in launched
                          and o is not c)  # fmt: skip
            if not always and not budget.fits(trial_s[c.name] + reserve, refit):
                table[c.name] = {"status": "skipped: would not fit the budget",
                                 "predicted_s": trial_s[c.name]}  # fmt: skip
                continue
            budget.spend(trial_s[c.name])
            job = TrialJob(c.name, c.spec.to_dict(), fold_rows, fit_n, std,
                           by_session=fwd_plan is not None)  # fmt: skip
            runner.submit(job)
            launched.add(c.name)
        while runner.busy:
            collect(None)
        collect(0)
    finally:
        runner.close()
    rows_out = []
    for c in order:
        r = {"name": c.name, "family": c.family, "spec": c.spec.to_dict(), **table[c.name]}
        r["eligible"] = not (needs_all and c.classical)
        r["work_s"] = trial_s[c.name]
        rows_out.append(r)
    chosen_name, best_name = one_se_choice(rows_out)
    chosen = by_name[chosen_name]
    search_s = watch.elapsed()
    t_refit = clock()
    spec = _refit_spec(chosen, fit_n, sel.size, 0)
    dec = train(dataset, spec, rows=sel, progress=False)
    refit_seconds = clock() - t_refit
    # the refit's error on rows it trained on, as each fold's was measured: the forward
    # figure sets it beside the folds' (train/check.py `trend_figure`)
    refit_train_mae = decoder_mae(dec, dataset, thin(sel, TIMING_ROWS)) if fwd_plan else None
    budget.spend(refit_s[chosen_name] * runner.workers)
    report = {
        "budget_s": float(budget_s),
        "budget": "nominal seconds per worker: units of work at the reference machine's rate",
        "work_s": budget.spent / runner.workers,
        "search_s": search_s,
        "refit_s": refit_seconds,
        "elapsed_s": watch.elapsed(),
        "within_budget": budget.spent <= budget.total,
        "runner": runner.name,
        "workers": runner.workers,
        "folds": k,
        "fold_kind": "forward" if fwd_plan is not None else "round-robin",
        "forward": fwd_plan,
        "fit_rows": fit_n,
        "groups": {"kind": g.kind, "n": g.n_groups},
        "rows": int(sel.size),
        "targets": list(tg),
        "score": "mean over regression targets of CV MAE / target std (lower is better)",
        "target_std": std,
        "rule": "fewest inference FLOPs within one standard error (paired over folds) of the "
        "best; a network only if no classical baseline scores better",
        "chosen": chosen_name,
        "refit_train_mae": refit_train_mae,
        "best": best_name,
        "candidates": rows_out,
    }
    dec.meta["auto_recipe"] = report
    return SearchResult(dec, report)


def planned_work(
    dataset: Dataset,
    budget_s: float,
    *,
    rows: ArrayLike | None = None,
    targets: tuple[str, ...] | None = None,
    features: str | None = None,
    workers: int = 1,
    folds: int = DEFAULT_FOLDS,
    max_fit_rows: int = MAX_FIT_ROWS,
) -> dict[str, Any]:
    """What `search` will launch within `budget_s` (the same folds, space, costs and order;
    each candidate's own refit reserved, as the search reserves the best's): its nominal
    seconds per worker, the refit included (`work_s`), and how many fits and prediction
    passes (each assembling the whole dataset) the trials and the refit make. A time
    estimate counts these: at a small size the fixed cost of each fit and pass is most of a
    trial, which the work alone leaves out."""
    sel = select_rows(dataset.n, rows)
    tg = tuple(targets) if targets else default_targets(dataset)
    feats = features or default_features(dataset)
    g = row_groups(dataset.session, dataset.press, dataset.t_end, sel)
    sel = sel[g.ids[sel] >= 0]
    forward = _forward_folds(dataset, sel) if g.kind == "session" else None
    if forward is not None:
        fold_rows, horizon = forward[0], int(forward[1]["horizon"])
    else:
        k = max(2, min(folds, np.unique(g.ids[sel]).size))
        fold_rows, horizon = _folds(dataset, sel, g, k), 0
    k = len(fold_rows)
    names = set(dataset.target_names)
    space = candidates(feats, tg, tuple(t for t in tg if t in names))
    n_fold = int(np.mean([f.size for f, _ in fold_rows]))
    fit_n = min(n_fold, max_fit_rows) if max_fit_rows > 0 else n_fold
    budget = WorkBudget(budget_s, workers)
    trial_s = {c.name: nominal_s(c.family, trial_units(dataset, c, fit_n, k)) for c in space}
    refit_s = {c.name: nominal_s(c.family, refit_units(dataset, c, fit_n, sel.size)) for c in space}
    order = sorted(space, key=lambda c: trial_s[c.name])
    by_name = {c.name: c for c in space}
    launched: list[str] = []
    for c in order:
        if c.classical and _n_features(dataset, c) > MAX_RIDGE_FEATURES:
            continue
        always = c.classical and c.spec.degree == 1
        if always or budget.fits(trial_s[c.name], refit_s[c.name] * max(1, workers)):
            budget.spend(trial_s[c.name])
            launched.append(c.name)
    refit = max((refit_s[n] for n in launched), default=0.0)
    # the same per family: a family's nominal seconds buy different wall seconds
    by_family = {"classical": 0.0, "network": 0.0}
    for n in launched:
        by_family[by_name[n].family] += trial_s[n]
    if launched:  # the refit reserved is the dearest candidate's
        dearest = by_name[max(launched, key=lambda n: refit_s[n])]
        by_family[dearest.family] += refit * max(1, workers)
    # with the drift baseline or temporal context, assembling the dataset is most of a
    # pass's and a fit's fixed cost: those are counted apart ("..._drift")
    drift = [n for n in launched if by_name[n].spec.drift != "none" or by_name[n].spec.context]
    out: dict[str, Any] = {
        "trials": launched,
        "work_s": (budget.spent + refit * max(1, workers)) / max(1, workers),
        "work_by_family": {f: w / max(1, workers) for f, w in by_family.items()},
    }
    for key, names in (("", [n for n in launched if n not in drift]), ("_drift", drift)):
        # per fold: a fit, its held-out pass, one per session ahead and the training rows'
        # pass; and the learning curve's half fit and its pass
        out["fits" + key] = len(names) * (k + 1)
        out["passes" + key] = len(names) * (k * (2 + horizon) + 1)
    out["fits"] += 1  # the refit
    if horizon:  # forward folds: the refit's training error, beside the folds'
        out["passes"] += 1
    return out


def _runner(ds: Dataset, ray_address: str | None, workers: int) -> Any:
    from spectratac.train.auto_recipe import runners

    if ray_address:
        return runners.RayRunner(ds, ray_address)
    if workers <= 1:
        return runners.InlineRunner(ds)
    return runners.LocalRunner(ds, workers)
