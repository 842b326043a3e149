"""Generate every constant shared between languages from its one definition.

protocol/messages.toml          -> the protocol's C header/source, Python module and MESSAGES.md
hardware/parts/veml3328.toml    -> the VEML3328 register map for the firmware and the host
firmware/ports/stm32f411/pinmap.toml -> the STM32 port's board.h
hardware/params.toml            -> the board geometry the digital twin uses
hardware/definitions/vocabulary.toml -> the sensor's regions, channels and axes (Python and C)

python tools/codegen/generate.py            # rewrite the committed files
python tools/codegen/generate.py --root DIR # write the same tree under DIR (drift check)
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import board_backend
import board_geometry_backend
import c_backend
import markdown_backend
import part
import part_c_backend
import part_python_backend
import python_backend
import sim_abi_backend
import vocabulary_backend
from definition import load

REPO = Path(__file__).resolve().parents[2]
DEFINITION = REPO / "protocol" / "messages.toml"
VEML3328 = REPO / "hardware" / "parts" / "veml3328.toml"
PINMAP = "firmware/ports/stm32f411/pinmap.toml"
PARAMS = "hardware/params.toml"
VOCABULARY = "hardware/definitions/vocabulary.toml"


def outputs() -> dict[str, Callable[[], str]]:
    """Generated file (relative to the repository) -> how to render it."""
    definition = load(DEFINITION)
    veml = part.load(VEML3328)
    vocabulary = vocabulary_backend.load(REPO / VOCABULARY, REPO / PARAMS, VOCABULARY)
    return {
        "firmware/core/generated/stac_messages.h": lambda: c_backend.render_header(definition),
        "firmware/core/generated/stac_messages.c": lambda: c_backend.render_source(definition),
        "host/spectratac/protocol/messages.py": lambda: python_backend.render(definition),
        "protocol/MESSAGES.md": lambda: markdown_backend.render(definition),
        "firmware/core/generated/veml3328_regs.h": lambda: part_c_backend.render_header(veml),
        "host/spectratac/hardware/veml3328.py": lambda: part_python_backend.render(veml),
        "firmware/ports/stm32f411/board.h": lambda: board_backend.render_header(
            board_backend.load(REPO / PINMAP, PINMAP)
        ),
        "host/spectratac/hardware/board.py": lambda: board_geometry_backend.render(
            REPO / PARAMS, PARAMS
        ),
        "host/spectratac/hardware/generated/vocabulary.py": (
            lambda: vocabulary_backend.render_python(vocabulary)
        ),
        "firmware/core/generated/stac_vocabulary.h": (
            lambda: vocabulary_backend.render_header(vocabulary)
        ),
    }


def ruff_format(source: str) -> str:
    """Generated Python is run through `ruff format` so that it is as clean as hand-written code."""
    ruff = shutil.which("ruff", path=str(Path(sys.executable).parent)) or shutil.which("ruff")
    if ruff is None:
        raise SystemExit("ruff is needed to format generated code: run `make venv` first")
    done = subprocess.run(
        [ruff, "format", "--stdin-filename", "messages.py", "-"],
        input=source,
        capture_output=True,
        text=True,
        check=True,
        cwd=REPO,
    )
    return done.stdout


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--root", type=Path, default=REPO, help="tree to write into")
    args = parser.parse_args(argv)
    for rel, render in outputs().items():
        path = args.root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        text = render()
        if rel.endswith(".py"):
            text = ruff_format(text)
        path.write_text(text, encoding="utf-8")
        print(f"wrote {path}")
    # The simulator library's C ABI, from its own definition (firmware/ports/native/stac_sim.toml).
    for rel, text in sim_abi_backend.render_all().items():
        path = args.root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(ruff_format(text) if rel.endswith(".py") else text, encoding="utf-8")
        print(f"wrote {path}")
    print(f"definition hash 0x{load(DEFINITION).hash:08X}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
