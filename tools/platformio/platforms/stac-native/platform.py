"""Project-local PlatformIO platform for host builds: the system gcc, nothing downloaded."""

from platformio.public import PlatformBase


class StacnativePlatform(PlatformBase):
    """Host builds (the firmware core's C unit tests) with the system compiler."""
