"""The command detector on synthetic estimate streams (hypothesis): presses of any region and
force, rises and falls read as any region, holds misread now and then, rest below the
release level, and out-of-distribution or invalid estimates with any values inserted
anywhere. Every press gives exactly one command, of its own region, during that press; rest
and flag flicker give none."""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import SimpleNamespace

from hypothesis import given, settings
from hypothesis import strategies as st
from spectratac.apps.snake.control import CommandDetector
from spectratac.hardware.generated import vocabulary as vocab

REGIONS = st.sampled_from(vocab.REGIONS)
ANY_REGION = st.sampled_from((-1, *vocab.REGIONS))
DT = 0.05  # 20 Hz


@dataclass
class Read:
    normal: float
    region: int
    press: int  # index of the press it belongs to, -1 at rest, -2 flagged
    ood: bool = False
    invalid: bool = False


@st.composite
def rest(draw: st.DrawFn, n_min: int = 2) -> list[Read]:
    """At least `n_min` usable estimates below the release level (0.7 N), any region."""
    forces = draw(st.lists(st.floats(-0.5, 0.65), min_size=n_min, max_size=12))
    regions = draw(st.lists(ANY_REGION, min_size=len(forces), max_size=len(forces)))
    return [Read(f, r, -1) for f, r in zip(forces, regions, strict=True)]


@st.composite
def press(draw: st.DrawFn, index: int) -> tuple[list[Read], int]:
    """A rise and a fall steep enough never to look held (each step >= 25 %), read as any
    region; a hold of 4+ estimates within +-3 % of the peak, read as the pressed region
    except for isolated misreads (at most a third of them, never two in a row)."""
    region, peak = draw(REGIONS), draw(st.floats(1.5, 6.0))
    rise = [peak * 0.75**k for k in range(draw(st.integers(1, 6)), 0, -1)]
    hold = [peak * (1 + e) for e in draw(st.lists(st.floats(-0.03, 0.03), min_size=4,
                                                  max_size=20))]  # fmt: skip
    fall = [peak * 0.75**k for k in range(1, draw(st.integers(2, 7)))]
    wrong: set[int] = set()
    for k in draw(st.lists(st.integers(0, len(hold) - 1), max_size=len(hold) // 3)):
        if not {k - 1, k, k + 1} & wrong:
            wrong.add(k)
    misread = draw(ANY_REGION.filter(lambda r: r != region))
    edges = draw(st.lists(ANY_REGION, min_size=len(rise) + len(fall),
                          max_size=len(rise) + len(fall)))  # fmt: skip
    regions = edges[: len(rise)]
    regions += [misread if k in wrong else region for k in range(len(hold))]
    regions += edges[len(rise) :]
    forces = rise + hold + fall
    return [Read(f, r, index) for f, r in zip(forces, regions, strict=True)], region


@st.composite
def session(draw: st.DrawFn) -> tuple[list[Read], list[int]]:
    """Rest, then presses each followed by rest, with flagged estimates (any force, region,
    NaN included) inserted anywhere; the pressed regions in order."""
    n = draw(st.integers(0, 4))
    reads = draw(rest())
    regions = []
    for i in range(n):
        p, region = draw(press(i))
        reads += p + draw(rest())
        regions.append(region)
    return flickered(draw, reads, draw(st.integers(0, len(reads)))), regions


def flickered(draw: st.DrawFn, reads: list[Read], n: int) -> list[Read]:
    """`reads` with `n` out-of-distribution or invalid estimates of any force (NaN too) and
    region inserted anywhere (they never give a command: no press is attributed to them)."""
    where = draw(st.lists(st.integers(0, len(reads)), min_size=n, max_size=n))
    forces = draw(st.lists(st.floats(-10.0, 10.0) | st.just(math.nan), min_size=n, max_size=n))
    regions = draw(st.lists(ANY_REGION, min_size=n, max_size=n))
    ood = draw(st.lists(st.booleans(), min_size=n, max_size=n))
    for at, f, r, o in sorted(zip(where, forces, regions, ood, strict=True), reverse=True):
        reads.insert(at, Read(f, r, -2, ood=o, invalid=not o))
    return reads


def commands(reads: list[Read]) -> list[tuple[int, int]]:
    """(press index, region) of every command the detector gives on `reads`."""
    det, out = CommandDetector(), []
    for i, r in enumerate(reads):
        est = SimpleNamespace(force=[0.0, 0.0, -r.normal], region=r.region, ood=r.ood,
                              invalid=r.invalid)  # fmt: skip
        c = det.feed(est, i * DT)
        if c is not None:
            out.append((r.press, c.region))
    return out


@settings(max_examples=150, deadline=None)
@given(session())
def test_every_press_gives_exactly_one_command_of_its_region(drawn) -> None:
    reads, regions = drawn
    got = commands(reads)
    assert [p for p, _ in got] == list(range(len(regions))), got  # none at rest, none twice
    assert [r for _, r in got] == regions


@settings(max_examples=100, deadline=None)
@given(st.data())
def test_flag_flicker_and_rest_give_no_command(data: st.DataObject) -> None:
    """Rest and flagged estimates only, whatever force and region the flagged ones carry
    (a foreign unit's flag flickering while the skin is untouched, or held down)."""
    reads = data.draw(rest(n_min=0))
    assert commands(flickered(data.draw, reads, data.draw(st.integers(1, 40)))) == []
