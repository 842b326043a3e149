"""Contact region -> Snake direction, following the paper's interaction demo.

The nine regions are numbered like a phone keypad (the sensor's vocabulary,
`spectratac.hardware.generated.vocabulary`)::

    1 2 3          up
    4 5 6    left  .  right        5, the centre, is neutral (no command)
    7 8 9         down

The paper maps the peripheral regions to up, down, left and right with the centre
neutral. Presets:

- ``cross`` (default): 2 up, 4 left, 6 right, 8 down; the corner regions 1, 3, 7, 9 lie
  between two directions and are neutral, so a press between directions never turns the
  snake the wrong way;
- ``keypad``: the whole top row is up and the whole bottom row down (1 2 3 up, 7 8 9
  down, 4 left, 6 right), for users who find the corners easier to hit.

Or give your own, region=direction pairs on top of ``cross``: ``"1=up,3=right"``.

>>> m = DirectionMap.parse("keypad")
>>> m.direction(1), m.direction(5), m.direction(-1)
('up', None, None)
>>> DirectionMap.parse("cross,1=left").direction(1)
'left'
>>> DirectionMap.parse("cross").describe()
'2=up 4=left 6=right 8=down'
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal, cast

from spectratac.errors import SpectraTacError
from spectratac.hardware.generated import vocabulary as vocab

Direction = Literal["up", "down", "left", "right"]
DIRECTIONS: tuple[Direction, ...] = ("up", "down", "left", "right")
NEUTRAL = "none"  # a region that gives no command

# The regions that lie in each direction from the centre (the vocabulary's keypad directions).
_CROSS = {r: cast(Direction, d) for d, r in vocab.DIRECTION_REGION.items() if d in DIRECTIONS}
PRESETS: dict[str, dict[int, Direction]] = {
    "cross": _CROSS,
    "keypad": {
        **_CROSS,
        **dict.fromkeys(vocab.KEYPAD[0], cast(Direction, "up")),
        **dict.fromkeys(vocab.KEYPAD[-1], cast(Direction, "down")),
    },
}


class MappingError(SpectraTacError, ValueError):
    """A region -> direction mapping that cannot be parsed."""


@dataclass(frozen=True)
class DirectionMap:
    """Which direction each region (1-9) commands; unmapped regions are neutral."""

    regions: dict[int, Direction] = field(default_factory=lambda: dict(PRESETS["cross"]))

    @classmethod
    def parse(cls, text: str) -> DirectionMap:
        """A preset name and/or region=direction pairs, comma-separated; pairs start from
        the preset given first, or from ``cross``; ``5=none`` makes a region neutral."""
        items = [t.strip().lower() for t in text.split(",") if t.strip()]
        regions: dict[int, Direction] = dict(PRESETS["cross"])
        if items and items[0] in PRESETS:
            regions = dict(PRESETS[items.pop(0)])
        for item in items:
            region, sep, direction = item.partition("=")
            if not sep or not region.strip().isdigit() or int(region) not in vocab.REGIONS:
                raise MappingError(
                    f"mapping item {item!r}: give a preset ({', '.join(PRESETS)}) or "
                    f"region=direction with a region 1-9, e.g. '1=up'"
                )
            d = direction.strip()
            if d == NEUTRAL:
                regions.pop(int(region), None)
            elif d in DIRECTIONS:
                regions[int(region)] = d  # type: ignore[assignment]
            else:
                raise MappingError(
                    f"mapping item {item!r}: direction must be one of "
                    f"{', '.join(DIRECTIONS)} or {NEUTRAL}"
                )
        return cls(regions)

    def direction(self, region: int) -> Direction | None:
        """The direction of `region`, None if it is neutral or no region (-1)."""
        return self.regions.get(int(region))

    def describe(self) -> str:
        return " ".join(f"{r}={d}" for r, d in sorted(self.regions.items()))

    def as_dict(self) -> dict[str, str]:
        return {str(r): self.regions.get(r, NEUTRAL) for r in vocab.REGIONS}
