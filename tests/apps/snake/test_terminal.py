"""The terminal (curses) game, run as a user runs it: `spectratac snake` in a pseudo
terminal, its screen rebuilt by pyte (a VT100 emulator) and read back."""

from __future__ import annotations

import os
import pty
import re
import select
import subprocess
import sys
import time

import pyte
import pytest

from tests.apps.conftest import PRESSES_URL

pytestmark = pytest.mark.subprocess  # the game in a pty / Chromium

COLS, ROWS = 100, 30


def run_in_terminal(args: list[str], timeout: float = 120.0) -> tuple[int, pyte.Screen]:
    screen = pyte.Screen(COLS, ROWS)
    stream = pyte.ByteStream(screen)
    main, child = pty.openpty()
    os.set_blocking(main, False)
    env = dict(os.environ, TERM="xterm", LINES=str(ROWS), COLUMNS=str(COLS))
    proc = subprocess.Popen(args, stdin=child, stdout=child, stderr=child, env=env)
    os.close(child)
    deadline = time.monotonic() + timeout
    last = screen.display
    try:
        while time.monotonic() < deadline:
            ready, _, _ = select.select([main], [], [], 0.2)
            if ready:
                try:
                    data = os.read(main, 65536)
                except OSError:  # the child closed the terminal
                    break
                stream.feed(data)
                if "SpectraTac Snake" in screen.display[0]:  # a whole game screen
                    last = list(screen.display)
            elif proc.poll() is not None:
                break
        return proc.wait(timeout=10), last
    finally:
        if proc.poll() is None:
            proc.kill()
        os.close(main)


@pytest.mark.slow
def test_terminal_game_shows_board_keypad_and_the_scripted_commands(press_model) -> None:
    url = PRESSES_URL + "&speed=max"
    code, last = run_in_terminal(
        [sys.executable, "-m", "spectratac", "snake", str(press_model), url, "--duration", "12"]
    )
    text = "\n".join(last)
    assert code == 0, text
    assert "SpectraTac Snake" in text and "[2^]" in text and "[4<]" in text and "[5.]" in text
    assert "threshold 1.0 N" in text and "@@" in text and "()" in text
    # the commands panel lists the presses of the first 12 s, newest first
    commands = [
        m.group(1) for line in last if (m := re.search(r"(\w+) +region \d +[\d.]+ N", line))
    ]
    assert commands[:5] == ["neutral", "left", "down", "right", "up"]
