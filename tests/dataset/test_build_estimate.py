"""`spectratac dataset build` says how long it will take before it starts, from a probe of
the recording it is given (its first chunks, built), never from a simulated session; then a
bar shows the time left. Run as a person runs it, on a real recording of the simulator."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from spectratac.cli import main

from tests.terminal import assert_estimate_first, pretend_terminal

pytestmark = pytest.mark.subprocess  # the recording comes from the simulated device


@pytest.fixture
def probe_everything(monkeypatch: pytest.MonkeyPatch) -> list[bytes]:
    """Every recording gets an estimate; a probe of 256 kB (a part of the tour's recording);
    the twin may not run; the bytes of every file the build read, in order."""
    import spectratac.dataset.build as build
    from spectratac.apps import estimates
    from spectratac.cli import dataset_cmd
    from spectratac.studies import cost_model

    def no_twin(*args: Any, **kwargs: Any) -> None:
        raise AssertionError("a twin session was simulated to estimate a user's build")

    read: list[bytes] = []
    real = build.read_recording

    def spy(path: Any) -> Any:
        read.append(Path(path).read_bytes())
        return real(path)

    monkeypatch.setattr(dataset_cmd, "LONG_BUILD_BYTES", 0)
    monkeypatch.setattr(estimates, "BUILD_PROBE_BYTES", 256 * 1024)
    monkeypatch.setattr(cost_model, "twin_probe", no_twin)
    monkeypatch.setattr(build, "read_recording", spy)
    return read


def test_dataset_build_probes_its_own_recording_then_counts_down(
    tour_mcap: Path, tmp_path: Path, probe_everything: list[bytes], capsys, monkeypatch
) -> None:
    pretend_terminal(monkeypatch)
    size = tour_mcap.stat().st_size
    assert size > 2 * 256 * 1024  # the probe is a part of the file, not all of it
    out = tmp_path / "d.npz"
    assert main(["dataset", "build", str(tour_mcap), "-o", str(out)]) == 0
    line = assert_estimate_first(capsys.readouterr().err, "dataset build of 1 recording(s)")
    assert "measured on this machine" in line
    # the recording's head, built in two sizes three times each, then the whole file
    data = tour_mcap.read_bytes()
    head = data[: 256 * 1024]
    assert probe_everything == [head[: len(head) // 2]] * 3 + [head] * 3 + [data]
    assert main(["dataset", "build", str(tour_mcap), "-o", str(out), "--force", "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["estimate"]["parts_s"]["build"] > 0 and summary["estimate"]["rates"]["s/MB"] > 0
