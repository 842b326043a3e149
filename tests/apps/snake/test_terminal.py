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


#: curses' exit (xterm's rmcup): the game leaves its screen; what follows is the shell's.
LEAVE_GAME_SCREEN = b"\x1b[?1049l"


def last_game_screen(raw: bytes) -> list[str]:
    """The game's screen as a person last saw it: every byte the game wrote up to the moment
    it left the screen, played through the emulator. Taken from the whole byte stream, not
    from whichever read happened to come last: on a busy machine one read can hold the final
    redraws and the exit together, and the screen after the exit is blank."""
    end = raw.rfind(LEAVE_GAME_SCREEN)
    screen = pyte.Screen(COLS, ROWS)
    pyte.ByteStream(screen).feed(raw if end < 0 else raw[:end])
    return list(screen.display)


def run_in_terminal(args: list[str], timeout: float = 120.0) -> tuple[int, list[str]]:
    """Run `args` in a pseudo terminal until it exits; (exit code, its last game screen)."""
    main, child = pty.openpty()
    os.set_blocking(main, False)
    env = dict(os.environ, TERM="xterm", LINES=str(ROWS), COLUMNS=str(COLS))
    proc = subprocess.Popen(args, stdin=child, stdout=child, stderr=child, env=env)
    os.close(child)
    deadline = time.monotonic() + timeout
    raw = bytearray()
    try:
        while time.monotonic() < deadline:
            ready, _, _ = select.select([main], [], [], 0.2)
            if ready:
                try:
                    data = os.read(main, 65536)
                except OSError:  # the child closed the terminal
                    break
                raw += data
            elif proc.poll() is not None:
                break
        return proc.wait(timeout=10), last_game_screen(bytes(raw))
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
    assert commands[:5] == ["neutral", "left", "down", "right", "up"], text
    # and it is the screen of the game's end: drawn at 12 s or later on the sensor's clock
    shown = re.search(r"\bt +([\d.]+) s", text)
    assert shown and float(shown.group(1)) >= 12.0, text


def test_the_last_game_screen_survives_the_exit_arriving_in_the_same_read() -> None:
    # What a stalled reader gets: the final redraw, the exit and the shell's line in one read.
    final = b"\x1b[?1049h\x1b[H\x1b[2JSpectraTac Snake\x1b[5;1Hneutral  region 5"
    raw = final + LEAVE_GAME_SCREEN + b"\r\n" * ROWS + b"score 3, length 4, 7 moves\r\n"
    shown = last_game_screen(raw)
    assert shown[0].startswith("SpectraTac Snake") and shown[4].startswith("neutral")
    everything = pyte.Screen(COLS, ROWS)
    pyte.ByteStream(everything).feed(raw)
    assert "SpectraTac Snake" not in "\n".join(everything.display)  # why the cut matters
