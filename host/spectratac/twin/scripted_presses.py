"""A scripted scene: presses on named regions, in a given order, at given forces.

It plays a demonstration (or a test) of the interaction apps: each press lands on the
centre of its region with no shear, rises, holds, falls, then the skin rests for a gap.
Regions are named by number (1-9, keypad layout, see `geometry`) or by their keypad
direction (the vocabulary's): ``up`` (2), ``down`` (8), ``left`` (4), ``right`` (6),
``centre`` (5, also spelt ``center``).

In sim:// URLs (scene name ``presses``)::

    sim://?scene=presses&order=up,left,centre,down&force=2.0,0.6,2.0,2.0&hold=0.9&gap=0.5

``force`` is one value for every press or one per press (N, normal); timing in seconds.

>>> s = scripted_presses(parse_order("up,5,right"), [2.0, 0.5, 3.0])
>>> [int(r) for r in press_regions(s)], s.presses.normal_peak.tolist()
([2, 5, 6], [2.0, 0.5, 3.0])
>>> round(s.duration_s, 1)
7.5
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from spectratac.hardware.generated import vocabulary as vocab
from spectratac.twin.errors import TwinError
from spectratac.twin.geometry import region_centre, region_of
from spectratac.twin.scene_model import Environment, Presses, Scene

REGION_NAMES = {**vocab.DIRECTION_REGION, "center": vocab.CENTRE_REGION}
DEFAULT_ORDER = "up,right,down,left,centre,up,left,down,right"
DEFAULT_FORCE_N = 2.5
LEAD_IN_S = 1.5  # rest before the first press: the decoder's no-contact baseline settles
RISE_S = 0.3
HOLD_S = 0.9
FALL_S = 0.3
GAP_S = 0.5  # one press every 2.0 s with the defaults


def parse_order(text: str) -> tuple[int, ...]:
    """Regions of a comma-separated script of region numbers or names.

    >>> parse_order("up, down,7,centre")
    (2, 8, 7, 5)
    """
    out = []
    for item in (t.strip().lower() for t in text.split(",")):
        if item in REGION_NAMES:
            out.append(REGION_NAMES[item])
        elif item.isdigit() and int(item) in vocab.REGIONS:
            out.append(int(item))
        else:
            raise TwinError(
                f"press script item {item!r}: give a region 1-{vocab.N_REGIONS} or one of "
                f"{', '.join(sorted(REGION_NAMES))} (e.g. order=up,left,5)"
            )
    if not out:
        raise TwinError("the press script is empty: give e.g. order=up,left,centre")
    return tuple(out)


def scripted_presses(
    regions: Sequence[int],
    forces: Sequence[float] | float = DEFAULT_FORCE_N,
    *,
    rise_s: float = RISE_S,
    hold_s: float = HOLD_S,
    fall_s: float = FALL_S,
    gap_s: float = GAP_S,
    lead_in_s: float = LEAD_IN_S,
) -> Scene:
    """One press per entry of `regions`, at the centre of that region, peaking at the
    matching entry of `forces` (N); the scene ends one gap after the last press."""
    n = len(regions)
    if np.size(forces) not in (1, n):
        raise TwinError(f"{np.size(forces)} forces for {n} presses: give one, or one per press")
    peak = np.broadcast_to(np.asarray(forces, dtype=np.float64), (n,)).copy()
    if min(rise_s, fall_s) <= 0 or min(hold_s, gap_s, lead_in_s) < 0:
        raise TwinError("rise and fall must be > 0 s; hold, gap and lead-in >= 0 s")
    period = rise_s + hold_s + fall_s + gap_s
    xy = np.array([region_centre(int(r)) for r in regions], dtype=np.float64)
    presses = Presses.steady(lead_in_s + period * np.arange(n), rise_s, hold_s, fall_s, xy, peak)
    return Scene("presses", float(lead_in_s + period * n), presses, Environment())


def from_url_params(
    order: str = DEFAULT_ORDER,
    force: str = str(DEFAULT_FORCE_N),
    hold: str = str(HOLD_S),
    gap: str = str(GAP_S),
    **_: str,
) -> Scene:
    """The scene of a sim:// URL's query values (strings), e.g. order=up,left&force=2."""
    try:
        forces = [float(f) for f in force.split(",")]
        hold_s, gap_s = float(hold), float(gap)
    except ValueError as exc:
        raise TwinError(f"presses scene: {exc}; example: force=2.0 or force=2.0,0.5,3") from None
    regions = parse_order(order)
    return scripted_presses(regions, forces[0] if len(forces) == 1 else forces,
                            hold_s=hold_s, gap_s=gap_s)  # fmt: skip


def press_regions(scene: Scene) -> NDArray[np.int8]:
    """The region each press of `scene` lands on (the script, read back from the scene)."""
    return region_of(scene.presses.x, scene.presses.y)
