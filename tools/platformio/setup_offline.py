"""Prepare a per-checkout PlatformIO core directory that never needs the registry.

PlatformIO Core wants its `tool-scons` package before it builds anything; offline it comes
from tools/platformio/tool-scons (a thin wrapper around the pip `scons` package) through a
`.pio-link` file. The project's own platforms are referenced from platformio.ini with
`symlink://`, so nothing else is installed. Prints the core directory to export as
PLATFORMIO_CORE_DIR.

    python -m tools.platformio.setup_offline [--core-dir build/pio-core]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
DEFAULT_CORE = REPO / "build" / "pio-core"

#: Environment for every pio invocation: the per-checkout core and no network side trips.
ENV = {
    "PLATFORMIO_SETTING_ENABLE_TELEMETRY": "No",
    "PLATFORMIO_SETTING_CHECK_PLATFORMIO_INTERVAL": "3650",
    "PLATFORMIO_SETTING_CHECK_PRUNE_SYSTEM_THRESHOLD": "0",
    "PLATFORMIO_NO_ANSI": "true",
}


def setup(core_dir: Path = DEFAULT_CORE) -> Path:
    packages = core_dir / "packages"
    packages.mkdir(parents=True, exist_ok=True)
    link = {
        "name": "tool-scons",
        "version": json.loads((HERE / "tool-scons" / "package.json").read_text())["version"],
        "spec": {
            "owner": "platformio",
            "id": None,
            "name": "tool-scons",
            "requirements": None,
            "uri": f"symlink://{HERE / 'tool-scons'}",
        },
    }
    target = packages / "tool-scons.pio-link"
    text = json.dumps(link, indent=2) + "\n"
    if not target.exists() or target.read_text() != text:
        target.write_text(text)
    return core_dir


def environment(core_dir: Path = DEFAULT_CORE) -> dict[str, str]:
    """Variables to add to os.environ for a pio run against this checkout."""
    return {**ENV, "PLATFORMIO_CORE_DIR": str(setup(core_dir))}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--core-dir", type=Path, default=DEFAULT_CORE)
    print(setup(ap.parse_args().core_dir.resolve()))


if __name__ == "__main__":
    main()
