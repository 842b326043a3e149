"""Durations as a person says them, for the time estimates the long verbs print (the demo's
stages here, every verb's through spectratac.cli.eta).

>>> [duration_text(s) for s in (0.2, 42.4, 200, 4000, 10780)]
['under 1 s', '42 s', '3 min 20 s', '1 h 7 min', '3 h']
"""

from __future__ import annotations


def duration_text(seconds: float) -> str:
    """Seconds as a person says them: 42 s, 3 min 20 s, 1 h 7 min."""
    if seconds < 0.5:
        return "under 1 s"
    s = round(seconds)
    if s < 60:
        return f"{s} s"
    if s < 3600:
        return f"{s // 60} min {s % 60} s" if s % 60 else f"{s // 60} min"
    hours, minutes = divmod(round(s / 60), 60)
    return f"{hours} h {minutes} min" if minutes else f"{hours} h"
