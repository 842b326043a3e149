"""What a person sees of a verb's stderr: the bytes played through a terminal emulator
(pyte), so carriage returns redraw a progress bar in place as they do on screen; and the
checks that an estimate is said before any work shows progress (issue 26)."""

from __future__ import annotations

import fcntl
import os
import pty
import re
import struct
import subprocess
import sys
import termios
import threading
import tty

import pyte
import pytest

#: tqdm's time column while it runs: [elapsed<remaining], e.g. [00:03<00:12].
ETA = re.compile(r"\[\d\d:\d\d<\d\d:\d\d")


def screen(text: str, columns: int = 400, lines: int = 1000) -> list[str]:
    """The terminal's lines after `text` was written to it (trailing blanks stripped)."""
    scr = pyte.Screen(columns, lines)
    stream = pyte.Stream(scr)
    stream.feed(text.replace("\n", "\r\n"))
    return [line.rstrip() for line in scr.display if line.strip()]


def assert_estimate_first(stderr: str, what: str) -> str:
    """The line '<what>: estimated …' comes before any progress bar, and a bar later shows
    the time left; returns the estimate line."""
    found = re.search(rf"^{re.escape(what)}: estimated [^\n]+", stderr, re.M)
    assert found, f"no estimate line for {what!r} in:\n{stderr[:2000]}"
    first_bar = re.search(r"\d+%\|", stderr)
    assert first_bar is None or found.start() < first_bar.start(), "a bar came before the ETA"
    assert ETA.search(stderr[found.end() :]), f"no bar with the time left after:\n{stderr}"
    assert found.group(0) in screen(stderr), "the estimate line is not left on the screen"
    return found.group(0)


def run_in_terminal(argv: list[str], timeout: float) -> subprocess.CompletedProcess[str]:
    """Run a verb with its stderr on a terminal (a pty, as a person's shell gives it: progress
    bars show only there) and keep that output as the terminal receives it: bytes decoded
    without universal newlines, so a progress bar's carriage returns redraw in place in
    `screen` (text=True would turn each redraw into a line, and a bar that redraws for longer
    on a busy machine would scroll the estimate off the screen)."""
    master, slave = pty.openpty()
    tty.setraw(slave)  # the bytes as written: no newline translation
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 50, 200, 0, 0))
    chunks: list[bytes] = []

    def drain() -> None:
        while True:
            try:
                data = os.read(master, 65536)
            except OSError:  # EIO: every holder of the terminal's other end has closed it
                return
            if not data:
                return
            chunks.append(data)

    reader = threading.Thread(target=drain, daemon=True)
    reader.start()
    try:
        proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=slave)
        os.close(slave)
        slave = -1
        try:
            out, _ = proc.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.communicate()
            raise
        reader.join(timeout=30)
    finally:
        if slave >= 0:
            os.close(slave)
        os.close(master)
    return subprocess.CompletedProcess(
        proc.args, proc.returncode, out.decode(errors="replace"),
        b"".join(chunks).decode(errors="replace"),
    )  # fmt: skip


def pretend_terminal(monkeypatch: pytest.MonkeyPatch) -> None:
    """In-process runs (capsys): stderr says it is a terminal, so progress bars show."""
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
