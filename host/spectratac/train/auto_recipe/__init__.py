"""Honest model selection within a time budget: `spectratac train --recipe auto`.

`search(dataset, budget_s=..., groups=..., rows=..., targets=..., features=..., folds=...,
workers=..., ray_address=...) -> SearchResult` with `.decoder` (the chosen model refitted on
all rows, a `Decoder`) and `.report` (a JSON-able dict: every candidate's grouped CV error
mean ± se, training error, inference FLOPs and µs per sample, the budget's use); `.text()`
renders it. See search.py for the method, space.py for the candidates.

>>> from spectratac.train.auto_recipe import search, candidates
>>> callable(search), len(candidates("generic", ("Fz",))) > 5
(True, True)
"""

from __future__ import annotations

from spectratac.train.auto_recipe.search import SearchResult, one_se_choice, search
from spectratac.train.auto_recipe.space import Candidate, candidates

__all__ = ["Candidate", "SearchResult", "candidates", "one_se_choice", "search"]
