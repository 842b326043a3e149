"""Project-local PlatformIO platform for host builds: the system gcc, nothing downloaded."""

from platformio.public import PlatformBase


class StacnativePlatform(PlatformBase):
    """Host builds (targets of tools/firmware/build.toml) with the system compiler."""
