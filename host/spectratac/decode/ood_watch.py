"""Say once, plainly, when most estimates of a stream are out of distribution.

An out-of-distribution estimate is flagged (`Estimate.ood`) and the apps ignore it: Snake and
the live page's commands never fire on one. A model that meets another unit flags nearly
every estimate, and a user who sees no command would not know why. `OodWatch` counts a
stream's estimates; once MIN_ESTIMATES have come and more than MOST of them were flagged, it
returns one message (how many, why, what to do: adapt the model to this sensor from a guided
session, no reference F/T needed), and never again for that stream.

>>> w = OodWatch("twin-0", ("twin-3",), url="sim://?seed=3", model="best.stac")
>>> said = [w.see(True) for _ in range(MIN_ESTIMATES)]
>>> said[:-1] == [None] * (MIN_ESTIMATES - 1), w.see(True)
(True, None)
>>> print(said[-1])  # doctest: +NORMALIZE_WHITESPACE
40 of the first 40 estimates are out of distribution (flagged ood; Snake and the live page
ignore them): the sensor is unit 'twin-3' but the model was calibrated on unit 'twin-0', and
another unit's light levels lie outside what the model was trained on. Adapt the model to
this sensor, no reference F/T needed: spectratac record "sim://?scene=guided&seed=3" --guided 9
-o g.mcap; spectratac dataset build g.mcap -o g.npz; spectratac train g.npz --finetune best.stac
-o unit.stac
"""

from __future__ import annotations

from collections.abc import Sequence
from urllib.parse import parse_qsl, urlencode, urlsplit

MIN_ESTIMATES = 40  # 2 s at 20 Hz: a press's flags alone do not make "most"
MOST = 0.5


def guided_url(url: str) -> str:
    """The URL a guided session of this sensor is recorded from: the sensor's own, except that
    a simulated unit is asked for its guided scene (a simulated person who follows the
    prompts), keeping its seed (the unit) and the rest.

    >>> guided_url("sim://?scene=presses&seed=2&speed=max"), guided_url("/dev/ttyACM0")
    ('sim://?scene=guided&seed=2&speed=max', '/dev/ttyACM0')
    """
    parts = urlsplit(url)
    if parts.scheme != "sim":
        return url
    query = dict(parse_qsl(parts.query))
    query.pop("scene", None)
    return f"sim://{parts.netloc}{parts.path}?{urlencode({'scene': 'guided', **query}, safe=',')}"


class OodWatch:
    """Counts one stream's estimates; `see` returns the message the first time most of them
    were out of distribution."""

    def __init__(
        self,
        model_unit: str | None,
        sensor_ids: Sequence[str],
        *,
        url: str | None = None,
        model: str | None = None,
    ) -> None:
        self.model_unit = model_unit
        self.sensor_ids = tuple(sensor_ids)
        self.url = guided_url(url) if url else "URL"
        self.model = model or "MODEL.stac"
        self.seen = 0
        self.flagged = 0
        self.said = False

    def see(self, ood: bool) -> str | None:
        self.seen += 1
        self.flagged += int(bool(ood))
        if self.said or self.seen < MIN_ESTIMATES or self.flagged <= MOST * self.seen:
            return None
        self.said = True
        return self.message()

    def message(self) -> str:
        ids = self.sensor_ids
        other = bool(self.model_unit and ids and self.model_unit not in ids)
        if other:
            also = f" ({', '.join(ids[1:])})" if len(ids) > 1 else ""
            why = (
                f"the sensor is unit {ids[0]!r}{also} but the model was calibrated on unit "
                f"{self.model_unit!r}, and another unit's light levels lie outside what the "
                "model was trained on"
            )
        else:
            why = (
                "the inputs lie outside what the model was trained on (another sensor or "
                "skin, a new mounting, saturated or dark sensors, or loads beyond the "
                "calibration's)"
            )
        return (
            f"{self.flagged} of the first {self.seen} estimates are out of distribution "
            f"(flagged ood; Snake and the live page ignore them): {why}. Adapt the model to "
            f'this sensor, no reference F/T needed: spectratac record "{self.url}" --guided 9 '
            f"-o g.mcap; spectratac dataset build g.mcap -o g.npz; spectratac train g.npz "
            f"--finetune {self.model} -o unit.stac"
        )
