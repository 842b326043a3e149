"""JSON descriptions of device messages as a recording stores them, and the dataset-style
sensor configuration (the form `spectratac.dataset` and decoders compare).

>>> from spectratac.protocol.generated import messages as m
>>> cfg = m.Config(config_id=3, integration_ms=100, gain=1, digital_gain=0, sensitivity=1,
...                led_settle_us=1000, led_step_count=1,
...                led_duty=(((500,) * 3,) * 3,) + (((0,) * 3,) * 3,) * 7)
>>> summary = config_summary(cfg.to_dict())
>>> summary["integration_ms"], summary["gain"], summary["sensitivity"], summary["leds"]
(100, 2.0, 'low', [[[500, 500, 500], [500, 500, 500], [500, 500, 500]]])
"""

from __future__ import annotations

from typing import Any

from spectratac.protocol.generated import messages as m

_GAIN = {int(m.Gain.GAIN_X1): 1.0, int(m.Gain.GAIN_X2): 2.0, int(m.Gain.GAIN_X4): 4.0}
_GAIN[int(m.Gain.GAIN_X0_5)] = 0.5
_DG = {int(m.DigitalGain.DG_X1): 1, int(m.DigitalGain.DG_X2): 2, int(m.DigitalGain.DG_X4): 4}


def info_dict(info: m.Info) -> dict[str, Any]:
    """INFO as JSON plus the derived identity a dataset needs (unit id, version strings)."""
    return info.to_dict() | {
        "unit_id": info.device_uid.hex(),
        "firmware": ".".join(map(str, info.firmware_version)),
        "protocol": f"{info.protocol_major}.{info.protocol_minor}",
        "definition_hash_hex": f"0x{info.definition_hash:08X}",
    }


def config_summary(reply: dict[str, Any]) -> dict[str, Any]:
    """The dataset-style configuration from a CONFIG reply's to_dict() (see dataset.schema)."""
    steps = int(reply["led_step_count"])
    return {
        "integration_ms": int(reply["integration_ms"]),
        "gain": _GAIN.get(int(reply["gain"]), float("nan")),
        "digital_gain": _DG.get(int(reply["digital_gain"]), 0),
        "sensitivity": "low" if int(reply["sensitivity"]) else "high",
        "leds": [[list(map(int, led)) for led in step] for step in reply["led_duty"][:steps]],
        "settle_us": int(reply["led_settle_us"]),
    }
