"""FTSensor.open dispatches by URL scheme: the drivers' built-in schemes, plug-ins from entry
points (the simulator's sim://) or run-time registration; an unknown scheme is FTURLError."""

from __future__ import annotations

import subprocess
import sys
from importlib.metadata import entry_points
from typing import Any

import pytest
from spectratac.ft import FTSensor, FTURLError, ft_schemes, register_ft_scheme
from spectratac.ft.open import ENTRY_POINTS


def test_builtin_and_plugin_schemes() -> None:
    assert {"netft", "bota", "csv", "sim"} <= set(ft_schemes())
    [ep] = entry_points(group=ENTRY_POINTS, name="sim")
    assert ep.value == "spectratac.sim.ft_serve:open_sim_ft"


def test_an_unknown_scheme_names_the_known_ones() -> None:
    with pytest.raises(FTURLError, match=r"nosuch://x.*bota://.*csv://.*sim://"):
        FTSensor.open("nosuch://x")
    with pytest.raises(FTURLError, match="not an F/T URL"):
        FTSensor.open("no scheme at all")


@pytest.mark.subprocess
def test_the_base_class_dispatches_whatever_module_is_imported_first() -> None:
    """FTSensor.open dispatches through the registry that spectratac.ft.open registers (the
    base class never imports it): importing the base module alone, in a fresh process,
    already brings the registry, because a package's __init__ runs before its modules."""
    code = (
        "from spectratac.ft.base import FTSensor\n"
        "try:\n"
        "    FTSensor.open('nosuch://x')\n"
        "except Exception as exc:\n"
        "    print(type(exc).__name__)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "FTURLError", out.stderr


def test_a_scheme_registered_at_run_time_opens_its_urls(tmp_path: Any) -> None:
    csv = tmp_path / "ft.csv"
    csv.write_text("t,Fx,Fy,Fz,Tx,Ty,Tz\n0.0,0,0,-1,0,0,0\n")
    seen: list[str] = []

    def opener(url: str, *, timeout: float, buffer_size: int, **options: Any) -> FTSensor:
        seen.append(url)
        return FTSensor.open(f"csv://{csv}", timeout=timeout, buffer_size=buffer_size)

    register_ft_scheme("testreplay", opener)
    with FTSensor.open("testreplay://bench-1") as ft:
        rows = ft.read(1, timeout=1.0)
    assert seen == ["testreplay://bench-1"] and rows["wrench"][0, 2] == -1.0
