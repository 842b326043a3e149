"""The budget of a search, in units of work: predict what a trial and the final refit cost,
and launch a trial only while it and the refit still fit.

A trial's cost is `work` (a count of the arithmetic it does), converted to nominal seconds at
a fixed rate per family (NOMINAL_S_PER_WORK, measured once on this project's 2-core machine,
quiet). The rate is never re-measured during a search: which trials run depends on the data,
the space and the seed only, so the same data gives the same choice on a quiet machine and on
a busy one (the wall time then stretches, and the report shows both). The budget is
`budget_s` nominal seconds on each of the search's workers; the refit of the winner counts
toward it: a trial is launched only if, after it, the refit of the best candidate so far or
of this one would still fit.

>>> b = WorkBudget(60.0, workers=1)
>>> b.fits(trial_s=30.0, refit_s=10.0), b.fits(30.0, 31.0)
(True, False)
>>> b.spend(30.0); b.fits(20.0, 10.0), b.fits(20.0, 11.0)
(True, False)
"""

from __future__ import annotations

from collections.abc import Callable

# nominal seconds per unit of work (ridge: row x (features^2 + RIDGE_ROW_WORK), the second
# term the assembly and scoring of a row; networks: row x epoch x training FLOPs, one torch
# thread), measured quiet on the 2-core machine. Ridge on the twin, 10k rows per fold: 33
# features 4.1 s, 627 features 73 s, both ~5e-9 s per unit.
NOMINAL_S_PER_WORK = {"classical": 5e-9, "network": 4e-11}
RIDGE_ROW_WORK = 20_000


def work(family: str, rows: int, n_features: int, epochs: int, train_flops: int) -> float:
    """Arithmetic of one fit on `rows` rows (see NOMINAL_S_PER_WORK for the units)."""
    if family == "classical":
        return float(rows) * (n_features**2 + RIDGE_ROW_WORK)
    return float(rows) * epochs * train_flops


def nominal_s(family: str, units: float) -> float:
    """Units of work as seconds on the reference machine (fixed: no clock involved)."""
    return NOMINAL_S_PER_WORK[family] * units


class WorkBudget:
    """`budget_s` nominal seconds per worker, spent by the trials launched so far."""

    def __init__(self, budget_s: float, workers: int = 1) -> None:
        self.budget_s = float(budget_s)
        self.total = self.budget_s * max(1, workers)
        self.spent = 0.0

    def spend(self, trial_s: float) -> None:
        self.spent += float(trial_s)

    def fits(self, trial_s: float, refit_s: float) -> bool:
        """Whether a trial of `trial_s` nominal seconds, and after the search a refit of
        `refit_s` (run on every worker's core), still fit in the budget."""
        return self.spent + trial_s + refit_s <= self.total


class Stopwatch:
    """Wall seconds since creation (injectable clock): reported, never used to decide."""

    def __init__(self, clock: Callable[[], float]) -> None:
        self.clock = clock
        self.t0 = clock()

    def elapsed(self) -> float:
        return self.clock() - self.t0
