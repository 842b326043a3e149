"""`spectratac bringup` end to end on the simulated device: the real verb passes on a good
board, and a board built or behaving wrongly (a faulty simulated device, `sim://?fault=…`, or
a sensor that does not answer) fails exactly the check that should catch it, with a report
saying what was wrong; the report's files follow the outputs rule (`cli/outputs.py`)."""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from spectratac.cli import main
from spectratac.cli.exit_codes import ExitCode
from spectratac.conformance.bringup import FAIL, PASS, SKIPPED, plan, postmortem, runner, soak
from spectratac.conformance.bringup.bench import Bench
from spectratac.conformance.bringup.leds import CHANNELS, FULL_SCALE, LIT_MIN, colour_columns, judge
from spectratac.conformance.bringup.report import KIND, Report, Row, is_report
from spectratac.conformance.model_checks import TestModel
from spectratac.device import DeviceTimeoutError, Sensor
from spectratac.hardware.generated import vocabulary as vocab

pytestmark = pytest.mark.slow  # each run streams the whole plan (seconds at speed=max)

SIM = "sim://?scene=idle&speed=max"


@pytest.fixture
def sim(tmp_path: Path) -> str:
    """A simulated board with a flash of its own: a model another test left in the store of
    its seed (sticky_model keeps one) would make the model store check skip here."""
    return f"{SIM}&model_store={tmp_path / 'flash.bin'}"


#: a URL -> the checks it must fail, and a phrase of the report that says why
BREAKS = {
    "absent=1": ({"sensors"}, "sensor 1 did not answer the ID probe"),
    "fault=flag_fault": ({"sensors"}, "sensor 0 flagged SENSOR_BUS_FAULT"),
    "fault=fast_clock": ({"sample rate"}, "a sample every 55.00 ms (+10.0%"),
    "fault=short_window": ({"sample rate"}, "integration windows of 30.00 ms"),
    "fault=wrong_hash": ({"identity"}, "built from other message definitions"),
    "fault=swapped_led": ({"LED channels"}, "LED0.R lights B counts most"),
    "fault=sticky_model": ({"model store"}, "MODEL_CLEAR was acknowledged but the model"),
    "fault=wrong_model_crc": ({"model store"}, "the flash did not keep what was written"),
    "fault=hsi_clock": ({"clock"}, "16.0 MHz: the HSI fallback"),
    "fault=hsi_pll_clock": ({"clock"}, "96.0 MHz from the PLL, but on the internal RC (HSI)"),
    "fault=bor_off": ({"brown-out level"}, "level 0, not 3"),
    "fault=lost_fault_record": ({"fault record"}, "no fault record: the record in .noinit"),
}


def _run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, dict[str, Any]]:
    code = main(["bringup", *argv, "--json"])
    return code, json.loads(capsys.readouterr().out)


def _failed(report: dict[str, Any]) -> dict[str, str]:
    return {c["name"]: c["detail"] for c in report["checks"] if c["verdict"] == FAIL}


def test_a_good_board_passes_with_every_figure(
    sim: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "board.json"
    code, report = _run(capsys, sim, "-o", str(out))
    assert code == ExitCode.OK, _failed(report)
    assert json.loads(out.read_text()) == report  # the filed report is what was printed
    rows = {c["name"]: c for c in report["checks"]}
    assert list(rows) == [name for name, _ in plan()]
    assert report["kind"] == KIND and report["passed"] and not _failed(report)
    for row in rows.values():
        assert row["detail"], row  # a skipped check says why, a passed one what it measured
    assert report["device"]["board"] == "native-sim" and len(report["device"]["unit_id"]) == 24
    leds = rows["LED channels"]["values"]
    assert np.array(leds["matrix"]).shape == (9, 15) and len(leds["dark"]) == 15
    assert leds["columns"] == list(vocab.SENSOR_CHANNELS) and leds["channels"] == CHANNELS
    rates = rows["sample rate"]["values"]["rates"]
    assert [r["integration_ms"] for r in rates] == [50, 100, 200, 400]
    assert all(r["measured_hz"] == pytest.approx(r["expected_hz"], rel=0.05) for r in rates)
    soak = rows["soak"]["values"]
    assert soak["samples"] == soak["expected"] == 400 and soak["crc_errors"] == 0
    store = rows["model store"]["values"]
    assert store["image_bytes"] > 0 and store["commit_s"] >= 0
    assert rows["clock"]["verdict"] == SKIPPED  # the simulated core has no cycle counter
    # the simulated device is a test image: the commanded resets are reported after them
    assert "iwdg" in rows["watchdog"]["values"]["reset_cause"]
    fault = rows["fault record"]["values"]
    assert fault["fault"]["pc"] != "0x00000000" and "UNDEFINSTR" in fault["fault_flags"]


def test_the_text_report_has_a_line_per_check_and_the_matrix(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["bringup", SIM, "--soak", "1"]) == ExitCode.OK
    text = capsys.readouterr().out
    for name, _ in plan():
        assert name in text
    assert "LED response" in text and text.count("LED0.") >= 3
    assert text.rstrip().endswith("PASS")


@pytest.mark.parametrize("params", sorted(BREAKS))
def test_a_faulty_board_fails_the_check_that_catches_it(
    params: str, sim: str, capsys: pytest.CaptureFixture[str]
) -> None:
    code, report = _run(capsys, f"{sim}&{params}", "--soak", "2")
    names, phrase = BREAKS[params]
    failed = _failed(report)
    assert code == ExitCode.FAILURE and not report["passed"]
    assert set(failed) == names, failed
    assert phrase in " ".join(failed.values()), failed


def test_a_lossy_link_fails_the_soak_with_its_counts(
    sim: str, capsys: pytest.CaptureFixture[str]
) -> None:
    code, report = _run(capsys, f"{sim}&fault=corrupt&fault_rate=1e-3", "--soak", "20")
    soak = next(c for c in report["checks"] if c["name"] == "soak")
    assert code == ExitCode.FAILURE and soak["verdict"] == FAIL
    assert soak["values"]["crc_errors"] + soak["values"]["cobs_errors"] > 0
    assert "crc errors" in soak["detail"] or "cobs errors" in soak["detail"]


@pytest.mark.parametrize("lost", ["status", "configure", "stop"])
def test_a_lost_reply_in_the_soak_still_gives_its_counts(
    lost: str, sim: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """On the lossy link a soak is for, a command's reply can be lost as well (CI on ce4cb77:
    a corrupted GET_STATUS reply took the counts with it, and the row said only the timeout)."""
    bench = Bench.open(sim, timeout=2.0)
    try:

        def lose(*_: object, **__: object) -> None:
            raise DeviceTimeoutError(f"no reply to {lost.upper()} (injected)")

        monkeypatch.setattr(bench.sensor, lost, lose)
        row = soak.soak(bench, 1.0)
    finally:
        monkeypatch.undo()
        bench.sensor.close()
    assert (
        row.verdict == FAIL
        and f"{lost.upper()}" in row.detail
        and "DeviceTimeoutError" in row.detail
    )
    assert row.values is not None and row.values["crc_errors"] == row.values["cobs_errors"] == 0
    want = 0 if lost == "configure" else row.values["expected"]
    assert row.values["samples"] == want


def test_a_users_model_is_never_erased(sim: str, capsys: pytest.CaptureFixture[str]) -> None:
    model = TestModel.packaged()
    with Sensor.open(sim) as s:
        s.upload_model(model.image, 0x5EED)
    code, report = _run(capsys, sim, "--soak", "0")
    store = next(c for c in report["checks"] if c["name"] == "model store")
    assert code == ExitCode.OK and store["verdict"] == SKIPPED
    assert "spectratac model clear" in store["detail"]
    with Sensor.open(sim) as s:
        assert s.model_info().model_id == 0x5EED


def test_no_device_is_an_error_not_a_failed_check(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bringup", "/dev/ttyNOPE", "--no-progress"]) == ExitCode.ERROR
    assert "ttyNOPE" in capsys.readouterr().err


def test_force_replaces_a_report_and_nothing_else(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "report.json"
    out.write_text(json.dumps(Report("old", {}).as_dict(), indent=1))
    assert is_report(out)
    assert main(["bringup", SIM, "--soak", "0", "-o", str(out), "--force"]) == ExitCode.OK
    assert json.loads(out.read_text())["url"] == SIM
    notes = tmp_path / "notes.json"
    notes.write_text('{"mine": 1}')
    assert main(["bringup", SIM, "-o", str(notes), "--force"]) == ExitCode.ERROR
    assert notes.read_text() == '{"mine": 1}'
    assert "not" in capsys.readouterr().err


def test_ctrl_c_keeps_the_checks_done(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    def interrupt(_: object) -> Row:
        raise KeyboardInterrupt

    checks = plan()
    monkeypatch.setattr(runner, "plan", lambda _soak: [checks[0], ("sensors", interrupt)])
    out = tmp_path / "partial.json"
    assert main(["bringup", SIM, "-o", str(out)]) == ExitCode.INTERRUPTED
    kept = json.loads(out.read_text())
    assert kept["interrupted"] and not kept["passed"]
    assert [c["name"] for c in kept["checks"]] == ["identity"]


# The LED verdict on measured matrices: a channel that lights its own colour passes; a dead
# one, crossed colours, a saturated count or light leaking into the dark fail.

Level = st.integers(LIT_MIN + 200, 40_000)


def _board(levels: list[int], leak: float = 0.05) -> np.ndarray:
    """A matrix where channel ch lights its own colour at levels[ch] and others at `leak`."""
    lit = np.zeros((9, 15))
    for ch, level in enumerate(levels):
        for colour in range(3):
            lit[ch, colour_columns(colour)] = level * (1.0 if colour == ch % 3 else leak)
    return lit


@settings(max_examples=60, deadline=None)
@given(st.lists(Level, min_size=9, max_size=9), st.integers(0, 8))
def test_the_led_verdict(levels: list[int], ch: int) -> None:
    dark, none = np.zeros(15), np.zeros((9, 15), bool)
    lit = _board(levels)
    assert judge(lit, dark, none) == []
    dead = lit.copy()
    dead[ch] = 0
    assert judge(dead, dark, none) == [judge(dead, dark, none)[0]]
    assert f"{CHANNELS[ch]} does not light" in judge(dead, dark, none)[0]
    crossed = lit.copy()
    own, other = colour_columns(ch % 3), colour_columns((ch + 1) % 3)
    crossed[ch, own], crossed[ch, other] = lit[ch, other], lit[ch, own]
    assert "wired to the wrong PWM pins" in " ".join(judge(crossed, dark, none))
    saturated = none.copy()
    saturated[ch, own[0]] = True
    assert f"counts clip at full duty: {CHANNELS[ch]} on" in judge(lit, dark, saturated)[0]
    assert "dark" in judge(lit, np.full(15, FULL_SCALE * 0.1), none)[0]


@settings(max_examples=60, deadline=None)
@given(
    st.sampled_from([50, 100, 200, 400]),
    st.lists(st.floats(0.9, 1.4), min_size=3, max_size=3),
    st.integers(0, 2),
)
def test_the_trig_latency_verdict(it: int, ratios: list[float], slow: int) -> None:
    lat = np.array([[int(r * it * 1000) for r in ratios]] * 5, dtype=np.int64)
    worst = tuple(int(v) for v in lat.max(axis=0))
    row = postmortem.latency_row(lat, worst, [0, 1, 2], it)
    assert row.verdict == PASS and sum(row.values["histogram"]["0"]) == 5
    late = tuple(int(1.6 * it * 1000) if k == slow else w for k, w in enumerate(worst))
    row = postmortem.latency_row(lat, late, [0, 1, 2], it)
    assert row.verdict == FAIL and row.detail.startswith(f"sensor {slow}: TRIG took up to")
    unmeasured = lat.copy()
    unmeasured[2, slow] = 0
    row = postmortem.latency_row(unmeasured, worst, [0, 1, 2], it)
    assert row.verdict == FAIL and f"sensor {slow}: no TRIG latency measured" in row.detail
    assert postmortem.latency_row(lat * 0, worst, [0, 1, 2], it).verdict == SKIPPED


def test_an_older_firmware_is_told_to_update_not_failed() -> None:
    class Old:
        info = SimpleNamespace(protocol_major=1, protocol_minor=3)

    bench = Bench("old://", Old(), 2.0)  # type: ignore[arg-type]
    for check in (postmortem.reset_cause, postmortem.brownout, postmortem.trig_latency,
                  postmortem.watchdog, postmortem.fault_record):  # fmt: skip
        row = check(bench)
        assert row.verdict == SKIPPED and "protocol 1.3" in row.detail, row


def test_a_row_names_its_verdict() -> None:
    with pytest.raises(ValueError, match="verdict"):
        Row("x", "maybe", "")
    assert Row("x", PASS, "ok").verdict == PASS
