"""`spectratac record` as users run it: summaries, Ctrl-C, SIGKILL, and no torch."""

from __future__ import annotations

import contextlib
import json
import signal
import socket
import subprocess
import sys
import time
import warnings
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from spectratac.dataset.frames import recorded_samples
from spectratac.record import Recording, RecordingError, TruncatedRecordingWarning, read_recording

pytestmark = pytest.mark.subprocess

TOUR_FT = "sim://?scene=tour&seed=1&speed=10&ft=bota"


def spectratac(*args: str) -> list[str]:
    return [sys.executable, "-m", "spectratac", *args]


@contextlib.contextmanager
def stopped_at_exit(proc: subprocess.Popen[str]) -> Iterator[None]:
    """A 20-minute recording must not outlive a test that fails before it stops it."""
    try:
        yield
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate(timeout=30)


def wait_for_frames(path: Path, proc: subprocess.Popen[str], n: int) -> Recording:
    """Read the growing file until it holds `n` frames (bounded: the process must live)."""
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        assert proc.poll() is None, proc.communicate()
        if path.exists():
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", TruncatedRecordingWarning)
                try:
                    rec = read_recording(path)
                except RecordingError:  # not even the first chunk yet
                    rec = None
            if rec is not None and len(rec.frames) >= n:
                return rec
        time.sleep(0.1)
    raise AssertionError(f"{path} never reached {n} frames")


def test_record_json_summary(tmp_path: Path) -> None:
    out = tmp_path / "s.mcap"
    run = subprocess.run(
        spectratac(
            "record",
            "sim://?scene=press&speed=max",
            "-o",
            str(out),
            "--count",
            "25",
            "--leds",
            "1000,0,0/0,0,1000",
            "--integration-ms",
            "100",
            "--json",
        ),
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert run.returncode == 0, run.stderr
    summary = json.loads(run.stdout)
    assert summary["samples"] >= 25 and summary["stopped_by"] == "samples"
    assert summary["path"] == str(out) and summary["file_bytes"] == out.stat().st_size
    rec = read_recording(out)
    cfg = rec.configs[summary["config_id"]]["config"]
    assert cfg["integration_ms"] == 100 and cfg["leds"] == [[[1000, 0, 0]] * 3, [[0, 0, 1000]] * 3]


def test_bad_arguments_are_usage_or_clear_errors(tmp_path: Path) -> None:
    run = subprocess.run(
        spectratac("record", "sim://?scene=idle", "-o", str(tmp_path / "x.mcap"), "--leds", "2000"),
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert run.returncode == 3 and "--leds" in run.stderr
    run = subprocess.run(
        spectratac(
            "record",
            "sim://?scene=idle",
            "--ft",
            "netft://",
            "-o",
            str(tmp_path / "y.mcap"),
            "--count",
            "3",
        ),
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert run.returncode == 3 and "error" in run.stderr


def test_timeout_reaches_the_ft_sensor(tmp_path: Path) -> None:
    """--timeout bounds the F/T open too: a Net F/T that never answers fails the verb with a
    typed error naming the F/T sensor, the given timeout (not the 2 s default) and what to do."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as silent:
        silent.bind(("127.0.0.1", 0))  # receives the RDT requests, answers none
        port = silent.getsockname()[1]
        run = subprocess.run(
            spectratac(
                "record",
                "sim://?scene=press&seed=1&speed=10",
                "--ft",
                f"netft://127.0.0.1:{port}?cpf=1000000&cpt=1000000&rate=1000",
                "-o",
                str(tmp_path / "silent.mcap"),
                "--count",
                "5",
                "--timeout",
                "0.7",
                "--no-progress",
            ),
            capture_output=True,
            text=True,
            timeout=120,
        )
    assert run.returncode == 3, run.stderr
    assert "reference F/T sensor did not answer within 0.7 s" in run.stderr
    assert "--timeout" in run.stderr and "Traceback" not in run.stderr


def test_sigint_stops_cleanly(tmp_path: Path) -> None:
    out = tmp_path / "int.mcap"
    proc = subprocess.Popen(
        spectratac("record", TOUR_FT, "-o", str(out), "--duration", "1200"),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    with stopped_at_exit(proc):
        wait_for_frames(out, proc, 50)
        proc.send_signal(signal.SIGINT)
        stdout, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 0, stderr
    assert "stopped by interrupt" in stdout and "F/T samples" in stdout
    assert "recording" in stderr  # the live progress display
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        rec = read_recording(out)  # a finished file: no warning
    assert rec.end is not None and rec.end["stopped_by"] == "interrupt"
    assert rec.ft is not None and len(rec.ft) > 0


def test_sigkill_keeps_the_flushed_prefix(tmp_path: Path) -> None:
    out = tmp_path / "killed.mcap"
    proc = subprocess.Popen(
        spectratac("record", TOUR_FT, "-o", str(out), "--duration", "1200", "--no-progress"),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    with stopped_at_exit(proc):
        seen = wait_for_frames(out, proc, 300)
        proc.send_signal(signal.SIGKILL)
        proc.communicate(timeout=30)
    assert proc.returncode == -signal.SIGKILL
    with pytest.warns(TruncatedRecordingWarning, match="readable prefix"):
        rec = read_recording(out)
    assert rec.truncated and rec.end is None
    assert rec.frames[: len(seen.frames)] == seen.frames  # nothing seen before the kill is lost
    samples = recorded_samples(rec.frames, rec.frame_host_times)
    assert len(samples) >= 250
    assert samples["sequence"][0] == 0 and np.all(np.diff(samples["sequence"].astype(int)) == 1)
    assert rec.ft is not None and len(rec.ft) > 1000 and rec.labels
    # the dataset builder takes the prefix too, and says so
    run = subprocess.run(
        spectratac("dataset", "build", str(out), "-o", str(tmp_path / "k.npz")),
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert run.returncode == 0, run.stderr
    assert "warning:" in run.stderr and "truncated" in run.stderr


def test_recording_and_building_never_import_torch(tmp_path: Path) -> None:
    t_mcap, t_npz = str(tmp_path / "t.mcap"), str(tmp_path / "t.npz")
    code = f"""
import sys
from spectratac.cli import main
assert main(["record", "sim://?scene=tour&speed=5&ft=bota", "-o", {t_mcap!r},
             "--count", "10", "--no-progress"]) == 0
assert main(["dataset", "build", {t_mcap!r}, "-o", {t_npz!r}]) == 0
assert main(["dataset", "info", {t_npz!r}]) == 0
print("torch" in sys.modules)
"""
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip().splitlines()[-1] == "False"


def test_duration_is_sensor_time_at_speed_10(tmp_path: Path) -> None:
    """--duration 3 at speed=10 records 3 s of data (60 samples at 50 ms), not 3 wall
    seconds (30 s of data); a simulated F/T's deliberate losses are named as such."""
    out = tmp_path / "s.mcap"
    args = ("record", TOUR_FT, "-o", str(out), "--duration", "3", "--no-progress")
    run = subprocess.run(spectratac(*args), capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    assert "lost on purpose: simulated ft_loss=0.001" in run.stdout
    assert "s of sensor time" in run.stdout
    # said before the work: 3 s of sensor time at the link's pace (speed=10)
    assert run.stderr.startswith("recording 3 s of sensor time: estimated under 1 s")
    rec = read_recording(out)
    samples = recorded_samples(rec.frames, rec.frame_host_times)
    span = (int(samples["t_end_us"].max()) - int(samples["t_start_us"].min())) / 1e6
    assert 3.0 <= span < 4.0, f"recorded {span:.2f} s of sensor time for --duration 3"
    json_run = subprocess.run(
        spectratac(*args, "--force", "--json"), capture_output=True, text=True, timeout=300
    )
    summary = json.loads(json_run.stdout)
    assert 3.0 <= summary["sensor_s"] < 4.0 and summary["ft_simulated_loss"] == 0.001
    assert summary["estimate"]["parts_s"]["record"] == 0.3
