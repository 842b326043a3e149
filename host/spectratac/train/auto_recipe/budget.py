"""The time budget of a search: predict what a trial and the final refit cost, and launch a
trial only while it and the refit still fit.

A trial's cost is `work` (a count of the arithmetic it does) times seconds per unit of work,
measured per family from the trials finished so far (the median; before the first one, a
prior measured on this project's 2-core machine). The refit of the winner counts toward the
budget: a trial is launched only if, when every running trial and it have finished, the
refit of the best candidate so far or of this one would still end within the budget.

>>> clock = iter([0.0, 10.0, 10.0]).__next__
>>> b = Budget(60.0, clock)
>>> b.fits(trial_s=30.0, refit_s=10.0, running_until=0.0), b.fits(30.0, 25.0, 0.0)
(True, False)
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

# seconds per unit of work, measured on the 2-core machine (ridge: row x (features^2 +
# RIDGE_ROW_WORK), the second term the assembly and scoring of a row; networks: row x epoch
# x training FLOPs, one torch thread). Ridge on the twin, 10k rows per fold: 33 features
# 4.1 s, 627 features 73 s, both ~5e-9 s per unit.
PRIOR_S_PER_WORK = {"classical": 5e-9, "network": 4e-11}
RIDGE_ROW_WORK = 20_000


def work(family: str, rows: int, n_features: int, epochs: int, train_flops: int) -> float:
    """Arithmetic of one fit on `rows` rows (see PRIOR_S_PER_WORK for the units)."""
    if family == "classical":
        return float(rows) * (n_features**2 + RIDGE_ROW_WORK)
    return float(rows) * epochs * train_flops


@dataclass
class CostModel:
    """Seconds per unit of work, per family, from finished trials."""

    observed: dict[str, list[float]] = field(default_factory=dict)

    def add(self, family: str, seconds: float, units: float) -> None:
        if units > 0 and seconds > 0:
            self.observed.setdefault(family, []).append(seconds / units)

    def rate(self, family: str) -> float:
        seen = self.observed.get(family)
        return float(np.median(seen)) if seen else PRIOR_S_PER_WORK[family]

    def seconds(self, family: str, units: float) -> float:
        return self.rate(family) * units


class Budget:
    """Wall-clock budget from the first call of `clock` (injectable for tests)."""

    def __init__(self, budget_s: float, clock: Callable[[], float]) -> None:
        self.budget_s = float(budget_s)
        self.clock = clock
        self.t0 = clock()

    def elapsed(self) -> float:
        return self.clock() - self.t0

    def fits(self, trial_s: float, refit_s: float, running_until: float) -> bool:
        """Whether a trial of `trial_s` launched now, after which a refit of `refit_s` runs
        once the trials running until `running_until` (elapsed seconds) are done, ends
        within the budget."""
        now = self.elapsed()
        return max(now + trial_s, running_until) + refit_s <= self.budget_s
