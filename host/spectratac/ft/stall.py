"""The stall timeout of a reference F/T sensor: how long a streaming sensor may send nothing
before it counts as stalled, and the one line that tells the user. A recorder keeps the
optical stream going when the F/T goes quiet; this says so, naming the sensor and the option.

>>> default_ft_stall_timeout(1000.0), default_ft_stall_timeout(0.5), default_ft_stall_timeout(0)
(5.0, 20.0, 5.0)
"""

from __future__ import annotations

#: The shortest default, s: a loaded host may hold a healthy link's reader for a second or two.
FT_STALL_FLOOR_S = 5.0
#: The default is this many periods of the sensor's nominal rate.
FT_STALL_PERIODS = 10
#: Where the user changes it (the CLI's option, and the attribute in Python).
STALL_OPTION = "--stall-timeout S (off: no watch; Python: ft.stall_timeout = S)"


def default_ft_stall_timeout(rate_hz: float) -> float:
    """FT_STALL_PERIODS periods of `rate_hz`, at least FT_STALL_FLOOR_S (an unknown rate, 0,
    gets the floor)."""
    if not rate_hz > 0:
        return FT_STALL_FLOOR_S
    return max(FT_STALL_FLOOR_S, round(FT_STALL_PERIODS / rate_hz, 6))


def stall_message(url: str, quiet_s: float, limit_s: float) -> str:
    """What a stalled F/T sensor means for the user, and what to do."""
    return (
        f"the reference F/T sensor {url} sent nothing for {quiet_s:.1f} s while streaming "
        f"(stall timeout {limit_s:g} s): the optical stream goes on, without F/T rows while "
        f"it is quiet. Check the sensor and its link, or allow a longer quiet with "
        f"{STALL_OPTION}"
    )
