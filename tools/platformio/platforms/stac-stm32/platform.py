"""Project-local PlatformIO platform: everything comes from PATH, nothing from the registry."""

from platformio.public import PlatformBase


class Stacstm32Platform(PlatformBase):
    """Cortex-M builds with the system arm-none-eabi toolchain."""
