"""A scripted Bota-like device on a pty: the test decides every byte it sends."""

from __future__ import annotations

import os
import tty


class FakePort:
    """A pty whose far end the test writes to directly (no device logic at all)."""

    def __init__(self) -> None:
        self.master, slave = os.openpty()
        tty.setraw(slave)
        self.path = os.ttyname(slave)
        os.close(slave)

    def write(self, data: bytes) -> None:
        view = memoryview(data)
        while view:
            view = view[os.write(self.master, view) :]

    def read_available(self) -> bytes:
        os.set_blocking(self.master, False)
        try:
            return os.read(self.master, 65536)
        except (BlockingIOError, OSError):
            return b""

    def close(self) -> None:
        os.close(self.master)
