"""The search report as text: every candidate's CV error beside its inference cost, and the
budget's use in work (nominal seconds, what decides) beside the wall time (what it took).

>>> text = render({"budget_s": 60.0, "work_s": 40.0, "elapsed_s": 12.5, "search_s": 10.0,
...     "refit_s": 2.5, "within_budget": True, "runner": "inline", "workers": 1, "folds": 3,
...     "groups": {"kind": "session", "n": 6}, "rows": 600, "chosen": "linear",
...     "best": "linear", "rule": "fewest FLOPs within 1 se", "target_std": {"Fz": 2.0},
...     "candidates": [{"name": "linear", "family": "classical", "status": "done",
...     "cv_score": 0.5, "cv_se": 0.05, "cv_mae": {"Fz": {"mean": 1.0, "se": 0.1}},
...     "gap": 1.2, "flops": 64.0, "us_per_sample": 0.5, "us_single": 9.0, "seconds": 1.0}]})
>>> print(text.splitlines()[1])
  budget 60 s of work: used 40.0 s (within budget); wall: search 10.0 s + refit 2.5 s = 12.5 s
>>> text.splitlines()[3].split()[:6], text.splitlines()[3].endswith("<- chosen (best)")
(['linear', 'classical', '0.5000', '±', '0.0500', '1.000'], True)
"""

from __future__ import annotations

from typing import Any


def render(r: dict[str, Any]) -> str:
    g = r["groups"]
    within = "within budget" if r["within_budget"] else "OVER BUDGET"
    targets = list(r["target_std"])
    fwd = r.get("forward")
    how = (
        f"{r['folds']} forward-in-time folds (trained on the first "
        f"{', '.join(map(str, fwd['trained_on']))} of {fwd['sessions']} sessions, each scored "
        f"on the {fwd['horizon']} after them)"
        if fwd
        else f"{r['folds']}-fold CV by {g['kind']} ({g['n']} groups)"
    )
    lines = [
        f"auto recipe: {len(r['candidates'])} candidates, {how}, {r['rows']} rows, "
        f"{r['runner']} runner x{r['workers']}",
        f"  budget {r['budget_s']:.0f} s of work: used {r.get('work_s', float('nan')):.1f} s "
        f"({within}); wall: search {r['search_s']:.1f} s + refit {r['refit_s']:.1f} s = "
        f"{r['elapsed_s']:.1f} s",
        "  "
        + f"{'candidate':<24}{'family':<11}{'CV score ± se':<18}"
        + "".join(f"{t + ' MAE ± se':<16}" for t in targets)
        + f"{'gap':>5} {'FLOPs':>7} {'µs/sample':>10} {'µs/single':>10}",
    ]
    done = [c for c in r["candidates"] if c.get("status") == "done"]
    rest = [c for c in r["candidates"] if c.get("status") != "done"]
    for c in sorted(done, key=lambda c: c["cv_score"]):
        mark = ""
        if c["name"] == r["chosen"]:
            mark = "  <- chosen" + (" (best)" if c["name"] == r["best"] else "")
        elif c["name"] == r["best"]:
            mark = "  <- best"
        if not c.get("eligible", True):
            mark += "  (regression only: not eligible)"
        mae = "".join(
            f"{c['cv_mae'][t]['mean']:.3f} ± {c['cv_mae'][t]['se']:.3f}".ljust(16) for t in targets
        )
        lines.append(
            f"  {c['name']:<24}{c['family']:<11}{c['cv_score']:.4f} ± {c['cv_se']:.4f}".ljust(
                55 - 2 - 35 + 37
            )
            + mae
            + f"{c['gap']:>4.1f}x {c['flops']:>7.0f} {c['us_per_sample']:>10.2f} "
            f"{c['us_single']:>10.1f}{mark}"
        )
    for c in rest:
        lines.append(f"  {c['name']:<24}{c['family']:<11}{c['status']}")
    lines.append(f"  rule: {r['rule']}")
    return "\n".join(lines)
