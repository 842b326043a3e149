"""Every ```sh and ```python block of README.md and firmware/README.md runs as written, in
order, against the simulated device (issue 37): a snippet that errors or hangs fails here.

The blocks of one document run one after the other in one temporary folder (the first
session's steps build on each other: record, then dataset, then train...), shell blocks
through `bash -e -o pipefail` with this interpreter's bin folder first on PATH (so
`spectratac` is the venv's), Python blocks with this interpreter. Each block has a generous
timeout: a hang guard, not a performance assertion.

What a reader has and this machine has not is replaced, line by line, by the rules below, each
named with its reason; the rest of a block runs as printed:

- BOARD: the real board (`/dev/ttyACM0`) and the real F/T sensor (`netft://192.168.1.1`) become
  one simulated unit with its simulated Net F/T (the same sim URL, as `record` opens them) and a
  model store kept in a file, so a model uploaded by one command is there for the next.
- INTERACTIVE: `spectratac live` and `spectratac snake` run until a person presses Ctrl-C or q;
  without a `--duration` they get `--duration 5`, and a Snake for the terminal (curses needs
  one) plays `--json`.
- SKIPPED: commands that need a physical board or that are the suite or the demo themselves.

The firmware's build and test commands stand in firmware/README.md's tables, not in code
blocks: tests/firmware runs each of them (test_stm32.py builds both STM32 images,
test_native_lib.py the simulator library, the C tests run through their own tests), with the
markers `firmware` and `qemu` that need the ARM toolchain and QEMU.
"""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

from tests import processes

pytestmark = [pytest.mark.subprocess, pytest.mark.train]

REPO = Path(__file__).resolve().parents[2]
DOCUMENTS = ("README.md", "firmware/README.md")
VENV_BIN = Path(sys.executable).parent
BLOCK_TIMEOUT_S = 300.0  # a hang guard: the first session's training takes well under a minute
RUNNABLE = ("sh", "python")

BOARD = '"sim://?scene=calibration&seed=1&speed=max&ft=netft&model_store=board-flash.bin"'
#: What stands for real hardware: exact text -> its stand-in.
SUBSTITUTIONS = {
    "/dev/ttyACM0": BOARD,  # the board, as Linux names its USB CDC-ACM port
    "netft://192.168.1.1": BOARD,  # the F/T sensor: the simulated Net F/T of the same scene
}
#: Command lines that are not run (the command, without its comment) -> why.
SKIPPED = {
    "make firmware && make flash": "flashing needs a Black Pill in DFU mode on USB; "
    "tests/firmware/test_stm32.py builds the image",
    "make test": "the suite itself",
    "make demo": "the same job as `spectratac demo`, run on a short scene by "
    "tests/apps/test_calibration_demo.py",
}
INTERACTIVE = re.compile(r"^spectratac (live|snake) ")


@dataclass(frozen=True)
class Block:
    lang: str
    code: str
    line: int  # of the opening fence, 1-based


def blocks(markdown: str) -> list[Block]:
    """The fenced code blocks of a markdown text, in order."""
    found: list[Block] = []
    lang: str | None = None
    start, body = 0, []
    for number, line in enumerate(markdown.splitlines(), 1):
        fence = re.match(r"^```\s*([\w+-]*)\s*$", line)
        if fence and lang is None:
            lang, start, body = fence.group(1), number, []
        elif line.startswith("```") and lang is not None:
            found.append(Block(lang, "\n".join(body) + "\n", start))
            lang = None
        elif lang is not None:
            body.append(line)
    assert lang is None, f"a code block opened at line {start} is never closed"
    return found


def as_run(block: Block) -> str:
    """The block's code as it runs on this machine (the rules of the module docstring)."""
    if block.lang != "sh":
        return block.code
    lines = []
    for line in block.code.splitlines():
        command = line.split(" #")[0].strip()
        if command in SKIPPED:
            lines.append(": " + shlex.quote(f"skipped {command}: {SKIPPED[command]}"))
            continue
        for real, stand_in in SUBSTITUTIONS.items():
            line = line.replace(real, stand_in)
        if INTERACTIVE.match(command):
            extra = "" if "--duration" in command else " --duration 5"
            if command.startswith("spectratac snake") and not {"--json", "--web"} & set(
                command.split()
            ):
                extra += " --json"
            code, _, comment = line.partition(" #")
            line = code.rstrip() + extra + (f"  #{comment}" if comment else "")
        lines.append(line)
    return "\n".join(lines) + "\n"


class BlockFailed(AssertionError):
    pass


def run_block(block: Block, folder: Path, name: str, timeout: float = BLOCK_TIMEOUT_S) -> str:
    """Run one block in `folder`; its output, or BlockFailed naming the block and why."""
    script = folder / f"block_{block.line}.{'py' if block.lang == 'python' else 'sh'}"
    script.write_text(as_run(block))
    cmd = (
        [sys.executable, script.name]
        if block.lang == "python"
        else ["bash", "-e", "-o", "pipefail", script.name]
    )
    env = dict(os.environ)
    env["PATH"] = f"{VENV_BIN}{os.pathsep}{env.get('PATH', '')}"
    env["BROWSER"] = "true"  # `live` opens the page in a browser: here, in none
    try:
        code, out, _ = processes.communicate_group(
            cmd, timeout, cwd=folder, env=env, stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
        )  # fmt: skip
    except subprocess.TimeoutExpired:
        raise BlockFailed(
            f"{name}:{block.line}: the ```{block.lang} block still ran after {timeout:.0f} s "
            f"(a hang?); stopped:\n{as_run(block)}"
        ) from None
    if code != 0:
        raise BlockFailed(
            f"{name}:{block.line}: the ```{block.lang} block exited {code}:\n"
            f"{as_run(block)}--- output (end) ---\n{out[-4000:]}"
        )
    return out


def run_document(markdown: str, folder: Path, name: str, timeout: float = BLOCK_TIMEOUT_S) -> int:
    """Run every runnable block in order; the number run."""
    runnable = [b for b in blocks(markdown) if b.lang in RUNNABLE]
    for block in runnable:
        run_block(block, folder, name, timeout)
    return len(runnable)


@pytest.mark.slow
@pytest.mark.parametrize("name", DOCUMENTS)
def test_every_block_runs_in_order(name: str, tmp_path: Path) -> None:
    ran = run_document((REPO / name).read_text(), tmp_path, name)
    assert ran > 0, f"{name} has no ```sh or ```python block left to run"


# The runner itself, on a synthetic document.

SYNTHETIC = """# A guide

```sh
echo first > made.txt
```

Text between.

```python
assert open("made.txt").read() == "first\\n"
```

```text
not run: exit 1
```
"""


def test_blocks_are_found_in_order_with_their_lines() -> None:
    found = blocks(SYNTHETIC)
    assert [(b.lang, b.line) for b in found] == [("sh", 3), ("python", 9), ("text", 13)]
    assert found[0].code == "echo first > made.txt\n"


def test_a_document_runs_in_one_folder_in_order(tmp_path: Path) -> None:
    assert run_document(SYNTHETIC, tmp_path, "synthetic.md") == 2


@pytest.mark.parametrize(
    ("code", "why"),
    [
        ("```sh\ntrue\nfalse\necho never\n```\n", "exited 1"),
        ("```sh\nfalse | cat\n```\n", "exited 1"),
        ("```python\nraise SystemExit('broken snippet')\n```\n", "broken snippet"),
        ("```sh\nspectratac no-such-verb\n```\n", "exited 2"),
    ],
)
def test_a_broken_block_fails(code: str, why: str, tmp_path: Path) -> None:
    with pytest.raises(BlockFailed, match=why):
        run_document(f"# Broken\n\n{code}", tmp_path, "broken.md")


def test_a_hanging_block_fails(tmp_path: Path) -> None:
    with pytest.raises(BlockFailed, match="still ran after"):
        run_document("```sh\nsleep 600\n```\n", tmp_path, "hang.md", timeout=1.0)


def test_a_skipped_line_runs_nothing_of_itself(tmp_path: Path) -> None:
    # The reason holds `;`: quoted, so none of it runs (a word of it run as a command fails).
    assert ";" in SKIPPED["make firmware && make flash"]
    document = "```sh\nmake firmware && make flash\ntouch ran\n```\n"
    assert run_document(document, tmp_path, "skip.md") == 1
    assert (tmp_path / "ran").exists()


def test_hardware_lines_run_against_the_simulated_device() -> None:
    block = Block(
        "sh",
        "make firmware && make flash\n"
        "spectratac record /dev/ttyACM0 --ft netft://192.168.1.1 -o s.mcap\n"
        "spectratac snake m.stac /dev/ttyACM0   # q quits\n"
        "spectratac live m.stac /dev/ttyACM0 --duration 3\n",
        1,
    )
    skipped, record, snake, live = as_run(block).splitlines()
    assert skipped.startswith(": 'skipped make firmware && make flash: flashing needs")
    assert record == f"spectratac record {BOARD} --ft {BOARD} -o s.mcap"
    assert snake == f"spectratac snake m.stac {BOARD} --duration 5 --json  # q quits"
    assert live == f"spectratac live m.stac {BOARD} --duration 3"
