"""What a transport knows about itself, as one typed value: `LinkInfo`.

A link to hardware knows nothing beyond its bytes, so the default says so. A transport that
knows more (a simulated device: its clock runs at the scene's speed, it can serve a
reference F/T sensor of the same scene, it carries ground truth) has a `link_info`
attribute; `link_info_of` reads it, and the data flow asks this value instead of parsing
URLs, so no part of it needs to know which kind of link it talks to.

>>> link_info_of(object())
LinkInfo(clock_scale=1.0, paired_ft_url=None, ground_truth=False, unit_name=None)
>>> info = LinkInfo(clock_scale=None, paired_ft_url="sim://?ft=bota", ground_truth=True)
>>> LinkInfo.from_dict(info.as_dict()) == info, info.as_dict()["clock_scale"]
(True, None)
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any


@dataclass(frozen=True)
class LinkInfo:
    """Facts about a link. clock_scale: device seconds per host second (1 for hardware, a
    paced simulation's speed; None when the device clock is not tied to the host's, as for a
    simulation at full speed); paired_ft_url: a reference F/T URL that serves the same
    contacts as this device (None: bring your own); ground_truth: the link carries
    `spectratac.device.GroundTruth` (`ground_truth_of` returns it); unit_name: the name
    datasets of this unit carry besides its unique id (a simulated unit: twin-<seed>)."""

    clock_scale: float | None = 1.0
    paired_ft_url: str | None = None
    ground_truth: bool = False
    unit_name: str | None = None

    def as_dict(self) -> dict[str, Any]:
        """JSON form, as a recording's session message stores it (record/FORMAT.md); the
        unit name stays out (a recording names its unit by the INFO's unique id)."""
        d = asdict(self)
        del d["unit_name"]
        return d

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> LinkInfo:
        """The inverse of as_dict; keys it does not know (from a newer writer) are ignored."""
        scale = data.get("clock_scale", 1.0)
        return cls(
            clock_scale=None if scale is None else float(scale),
            paired_ft_url=data.get("paired_ft_url"),
            ground_truth=bool(data.get("ground_truth", False)),
        )


#: What a link that says nothing about itself is: hardware.
HARDWARE = LinkInfo()


def link_info_of(transport: object) -> LinkInfo:
    """The transport's `link_info`, or the hardware default for one that has none."""
    info = getattr(transport, "link_info", None)
    return info if isinstance(info, LinkInfo) else HARDWARE
