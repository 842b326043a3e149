"""Every wait ends: a streaming device that goes quiet (the simulated `stall` fault holds its
output for ten minutes) is dropped within the stall timeout with DeviceStalledError, after
every sample received before it has been read; with reconnect=True the stall reopens the link
instead. Host-time bounds here are hang guards (a stalled stream would wait 600 s), never
timing assertions."""

from __future__ import annotations

import concurrent.futures
import time
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

import pytest
from spectratac.device import DeviceStalledError, DisconnectedError, Sensor
from spectratac.device.sensor import STALL_FLOOR_S, default_stall_timeout
from spectratac.protocol.generated import messages as m

# The device streams for 1 s, then holds everything for 600 s.
STALLS = "sim://?scene=idle&speed=1&fault=stall&fault_stall=600&fault_every=1"
GUARD_S = 60.0  # a hang guard: the stall would last 600 s

T = TypeVar("T")


def bounded(fn: Callable[[], T], guard_s: float = GUARD_S) -> T:
    """fn() on a worker thread; fails the test instead of hanging the suite."""
    pool = concurrent.futures.ThreadPoolExecutor(1)
    try:
        return pool.submit(fn).result(timeout=guard_s)
    except concurrent.futures.TimeoutError:
        pytest.fail(f"still waiting after {guard_s} s: a wait that does not end")
    finally:
        pool.shutdown(wait=False)


def test_a_stalled_stream_raises_after_every_sample_received_before() -> None:
    with Sensor.open(STALLS, timeout=5.0, stall_timeout=0.5) as sensor:
        sensor.configure(integration_ms=50)
        sensor.start()

        def read_all() -> tuple[int, BaseException | None]:
            got = 0
            try:
                while True:
                    got += len(sensor.read(1000, timeout=30.0))
            except DisconnectedError as exc:
                return got, exc

        got, error = bounded(read_all)
        assert isinstance(error, DeviceStalledError)
        assert got >= 1 and got == sensor.stats.samples_received  # nothing lost
        assert sensor.stats.stalls == 1
        assert STALLS in str(error) and "--stall-timeout" in str(error)
        assert "stall_timeout=" in str(error)


def test_iteration_ends_with_the_stall_error() -> None:
    with Sensor.open(STALLS, timeout=5.0, stall_timeout=0.5) as sensor:
        sensor.configure(integration_ms=50)
        sensor.start()
        seen: list[int] = []

        def iterate() -> None:
            for sample in sensor:
                seen.append(sample.sequence)

        with pytest.raises(DeviceStalledError, match="stalled"):
            bounded(iterate)
        assert seen == list(range(len(seen))) and seen  # in order, none lost


def test_a_reconnecting_sensor_reopens_a_stalled_link() -> None:
    with Sensor.open(STALLS, timeout=5.0, stall_timeout=0.5, reconnect=True) as sensor:
        sensor.configure(integration_ms=50)
        sensor.start()

        def until_reconnected() -> int:
            while sensor.stats.reconnects == 0 or sensor.epoch == 0:
                sensor.read(100, timeout=0.2)
            return len(sensor.read(5, timeout=30.0))  # the new epoch streams again

        assert bounded(until_reconnected) == 5
        assert sensor.stats.stalls >= 1


def test_a_healthy_stream_never_counts_a_stall() -> None:
    with Sensor.open("sim://?scene=idle&speed=max", timeout=5.0, stall_timeout=2.0) as sensor:
        sensor.configure(integration_ms=50)
        sensor.start()
        assert len(sensor.read(400, timeout=60.0)) == 400
        sensor.stop()
        time.sleep(0.3)  # stopped: quiet is expected, the watch does not fire
        assert sensor.stats.stalls == 0


def test_the_default_is_ten_sequence_periods_in_host_time() -> None:
    one = m.Configure(integration_ms=200, led_settle_us=1000, led_step_count=4)
    assert default_stall_timeout(one, 1.0) == pytest.approx(10 * 4 * 0.201)
    assert default_stall_timeout(one, 0.1) == pytest.approx(10 * 4 * 0.201 / 0.1)
    assert default_stall_timeout(one, None) == pytest.approx(8.04)  # speed=max: as paced
    assert default_stall_timeout(None, 1.0) == STALL_FLOOR_S


@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan"), -float("inf"), 1e300])
def test_a_bad_stall_timeout_is_refused_before_anything_opens(bad: float) -> None:
    with pytest.raises(ValueError, match="stall_timeout"):
        Sensor.open("sim://?scene=idle&speed=max", stall_timeout=bad)


def test_an_infinite_stall_timeout_switches_the_watch_off() -> None:
    """stall_timeout=inf (--stall-timeout off): a device quiet past the default floor is
    waited for, not dropped (a device paused on a debugger)."""
    with Sensor.open(STALLS, timeout=5.0, stall_timeout=float("inf")) as sensor:
        sensor.configure(integration_ms=50)
        sensor.start()

        def read_past_the_floor() -> int:
            got = len(sensor.read(1000, timeout=5.0))
            quiet_reads = 0
            while quiet_reads * 0.5 < 2 * STALL_FLOOR_S:  # quiet well past the default
                batch = sensor.read(1000, timeout=0.5)
                got += len(batch)
                quiet_reads += len(batch) == 0
            return got

        got = bounded(read_past_the_floor)
        assert got >= 1 and sensor.stats.stalls == 0 and sensor.streaming


@pytest.mark.parametrize("verb", ["stream", "record", "decode", "live", "ft stream"])
def test_stall_timeout_off_is_accepted_and_bad_values_are_usage_errors(verb: str) -> None:
    from spectratac.cli import build_parser

    parser = build_parser()
    base = {"stream": [STALLS], "record": [STALLS, "-o", "r.mcap"], "decode": ["m.stac", STALLS],
            "live": ["m.stac", STALLS], "ft stream": ["bota:///dev/x"]}[verb]  # fmt: skip
    args = parser.parse_args([*verb.split(), *base, "--stall-timeout", "off"])
    assert args.stall_timeout == float("inf")
    for bad in ("inf", "nan", "-1", "0", "offf"):
        with pytest.raises(SystemExit) as exit_:
            parser.parse_args([*verb.split(), *base, "--stall-timeout", bad])
        assert exit_.value.code == 2


# ------------------------------------------------------------------ the streaming verbs
def test_stream_ends_with_exit_3_naming_the_device_and_the_option(
    capsys: pytest.CaptureFixture[str],
) -> None:
    from spectratac.cli import main

    argv = ["stream", STALLS, "--count", "100", "--timeout", "5", "--stall-timeout", "0.5"]
    assert bounded(lambda: main(argv)) == 3
    out, err = capsys.readouterr()
    assert len(out.splitlines()) >= 2  # the header and the rows before the stall
    assert f"spectratac stream: error: {STALLS} sent no data" in err
    assert "--stall-timeout S" in err and "Traceback" not in err


def test_record_keeps_what_came_before_the_stall(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from spectratac.cli import main
    from spectratac.record.reader import read_recording

    out = tmp_path / "r.mcap"
    argv = ["record", STALLS, "-o", str(out), "--duration", "60", "--timeout", "5",
            "--stall-timeout", "0.5", "--no-progress"]  # fmt: skip
    assert bounded(lambda: main(argv)) == 3
    assert "stalled" in capsys.readouterr().err
    recording = read_recording(out)
    assert recording.end is not None and recording.end["stopped_by"] == "error"
    assert recording.end["samples"] >= 1 and len(recording.frames) >= recording.end["samples"]
    assert not recording.truncated


@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan"), float("inf")])
def test_a_bad_reply_timeout_is_refused_before_anything_opens(bad: float) -> None:
    with pytest.raises(ValueError, match="timeout"):
        Sensor.open("sim://?scene=idle&speed=max", timeout=bad)


def test_a_read_with_an_endless_timeout_does_not_overflow() -> None:
    with Sensor.open("sim://?scene=idle&speed=max", timeout=5.0) as sensor:
        sensor.configure(integration_ms=50)
        sensor.start()
        batch = bounded(lambda: sensor.read(10, timeout=float("inf")))  # no OverflowError
        assert len(batch) == 10
