"""Generate the C and Python protocol code from protocol/messages.toml.

python tools/codegen/generate.py            # rewrite the committed files
python tools/codegen/generate.py --root DIR # write the same tree under DIR (drift check)
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import c_backend
import markdown_backend
import python_backend
import sim_abi_backend
from definition import load

REPO = Path(__file__).resolve().parents[2]
DEFINITION = REPO / "protocol" / "messages.toml"
OUTPUTS = {
    "firmware/core/generated/stac_messages.h": c_backend.render_header,
    "firmware/core/generated/stac_messages.c": c_backend.render_source,
    "host/spectratac/protocol/messages.py": python_backend.render,
    "protocol/MESSAGES.md": markdown_backend.render,
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
    definition = load(DEFINITION)
    for rel, render in OUTPUTS.items():
        path = args.root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        text = render(definition)
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
    print(f"definition hash 0x{definition.hash:08X}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
