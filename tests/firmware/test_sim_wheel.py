"""An installed wheel opens sim:// on its own: `pip wheel .` compiles the simulator library into
the package (setup.py, tools/firmware/build.toml), and a fresh virtual environment outside the
checkout streams samples from the library in its site-packages, not from the checkout.

Offline: the wheel is built without build isolation or dependencies, installed without an
index, and the environment borrows this one's installed dependencies (numpy, pyserial, ...)
through a .pth path entry; spectratac itself comes only from the wheel."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import pytest

pytestmark = pytest.mark.subprocess  # builds a wheel and installs it in a fresh venv

REPO = Path(__file__).resolve().parents[2]
TIMEOUT_S = 600

STREAM = """
import json, spectratac
from spectratac.device import Sensor
from spectratac.sim import native

with Sensor.open("sim://?scene=press&speed=max") as sensor:
    sensor.start()
    batch = sensor.read(200, timeout=60.0)
    sensor.stop()
print(json.dumps({
    "package": spectratac.__file__,
    "library": str(native.library_path()),
    "loaded": native.load()._name,
    "samples": len(batch),
    "sequence": batch["sequence"].tolist(),
    "counts_max": int(batch["counts"].max()),
}))
"""


def run(cmd: list[str], cwd: Path) -> subprocess.CompletedProcess[str]:
    env = {k: v for k, v in os.environ.items() if k != "SPECTRATAC_SIM_LIB"}  # no prebuilt library
    done = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=TIMEOUT_S)
    assert done.returncode == 0, f"{' '.join(cmd)}\n{done.stdout[-3000:]}{done.stderr[-3000:]}"
    return done


@pytest.mark.slow
def test_installed_wheel_streams_from_its_own_library(tmp_path: Path, native_build: object) -> None:
    dist, venv, elsewhere = tmp_path / "dist", tmp_path / "venv", tmp_path / "cwd"
    elsewhere.mkdir()
    pip = [sys.executable, "-m", "pip"]
    run(
        [*pip, "wheel", ".", "--no-deps", "--no-build-isolation", "--no-index", "-w", str(dist)],
        REPO,
    )
    (wheel,) = dist.glob("spectratac-*.whl")
    assert not wheel.name.endswith("-none-any.whl"), (
        "a wheel with a compiled library is platform-tagged"
    )
    assert "spectratac/sim/libstac_sim.so" in zipfile.ZipFile(wheel).namelist()

    run([sys.executable, "-m", "venv", "--without-pip", str(venv)], tmp_path)
    python = venv / "bin" / "python"
    site = Path(
        run(
            [str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
            elsewhere,
        ).stdout.strip()
    )
    (site / "borrowed-dependencies.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    run(
        [*pip, "--python", str(python), "install", "--no-deps", "--no-index", str(wheel)], elsewhere
    )

    env_free = [str(python), "-I", "-c", STREAM]  # -I: no PYTHONPATH, no cwd on sys.path
    out = json.loads(run(env_free, elsewhere).stdout.splitlines()[-1])
    assert Path(out["package"]).is_relative_to(site)
    assert Path(out["library"]) == Path(out["loaded"]) == site / "spectratac/sim/libstac_sim.so"
    assert not Path(out["loaded"]).is_relative_to(REPO)
    assert out["samples"] == 200 and out["sequence"] == list(range(200))
    assert out["counts_max"] > 0
