"""Bad input gets typed errors that name what was wrong; decoders never raise on garbage."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st
from spectratac.protocol import (
    FieldValueError,
    StreamDecoder,
    VersionMismatchError,
    accel,
    decode_frame,
    decode_samples,
    encode_frame,
    encode_raw,
)
from spectratac.protocol.generated import messages

WHITE = (((500, 500, 500),) * 3,) + (((0, 0, 0),) * 3,) * 7


def configure(**overrides: object) -> messages.Configure:
    fields = dict(integration_ms=50, led_step_count=1, led_duty=WHITE) | overrides
    return messages.Configure(**fields)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("overrides", "field", "hint"),
    [
        ({"integration_ms": 75}, "integration_ms", "50, 100, 200, 400"),
        ({"gain": 4}, "gain", "0, 1, 2, 3"),
        ({"digital_gain": 3}, "digital_gain", "0, 1, 2"),
        ({"sensitivity": 2}, "sensitivity", "0, 1"),
        ({"led_step_count": 9}, "led_step_count", "1..8"),
        ({"led_step_count": 0}, "led_step_count", "1..8"),
        ({"flags": 0x80}, "flags", "mask: 0x7"),
        ({"led_settle_us": 20000}, "led_settle_us", "0..10000"),
        ({"led_duty": ((((1001, 0, 0),) * 3),) * 8}, "led_duty", "0..1000"),
        ({"led_duty": ((0, 0),)}, "led_duty", "shape (8, 3, 3)"),
        ({"integration_ms": -1}, "integration_ms", "u16"),
    ],
)
def test_configure_out_of_range_names_field(overrides: dict, field: str, hint: str) -> None:
    with pytest.raises(ValueError, match=f"CONFIGURE.{field}") as info:
        encode_frame(configure(**overrides), seq=1)
    assert isinstance(info.value, FieldValueError)
    assert hint in str(info.value)


def test_text_fields_checked() -> None:
    with pytest.raises(FieldValueError, match=r"LOG\.text holds at most 64"):
        encode_frame(messages.Log(text="x" * 65), seq=0)
    with pytest.raises(FieldValueError, match=r"INFO\.device_uid must be exactly 12"):
        encode_frame(messages.Info(device_uid=b"\x01"), seq=0)


def test_major_mismatch_names_both_versions() -> None:
    wire = encode_raw(messages.Info.TYPE_ID, messages.Info().pack(), seq=0, version=(2, 7))
    with pytest.raises(
        VersionMismatchError,
        match=rf"peer speaks 2\.7.*this host speaks 1\.{messages.PROTOCOL_MINOR}",
    ):
        decode_frame(wire[:-1])
    decoder = StreamDecoder()
    assert decoder.feed(wire) == []
    assert decoder.stats.version_mismatch == 1 and decoder.stats.remote_version == (2, 7)


def test_unknown_type_counted_and_skipped() -> None:
    good = encode_frame(messages.Start(), seq=2)
    decoder = StreamDecoder()
    frames = decoder.feed(encode_raw(0x42, b"", seq=1) + good)
    assert [f.message for f in frames] == [messages.Start()]
    assert decoder.stats.unknown_type == 1


def test_sequence_gaps_and_restart_counted() -> None:
    decoder = StreamDecoder()
    for seq in (10, 11, 14, 15, 0xFFFF, 0, 1):
        decoder.feed(encode_frame(messages.Stop(), seq=seq))
    assert decoder.stats.seq_gaps == 2  # 12 and 13
    assert decoder.stats.seq_restarts == 1  # 15 -> 0xFFFF is a jump back, not 65519 losses
    decoder.reset()
    decoder.feed(encode_frame(messages.Stop(), seq=100))
    assert decoder.stats.seq_gaps == 2


def test_oversize_run_without_delimiter_resyncs() -> None:
    good = encode_frame(messages.Start(), seq=1)
    decoder = StreamDecoder()
    for _ in range(10):
        assert decoder.feed(b"\x55" * 100) == []
    assert [f.message for f in decoder.feed(b"\x00" + good)] == [messages.Start()]
    assert decoder.stats.oversize == 1


@given(st.binary(max_size=2000))
def test_garbage_never_raises(data: bytes) -> None:
    decoder = StreamDecoder()
    decoder.feed(data)
    decode_samples(data)


def test_pure_python_fallback_refused(monkeypatch: pytest.MonkeyPatch) -> None:
    import cobs.cobs

    monkeypatch.setattr(cobs.cobs, "_using_extension", False)
    monkeypatch.delenv(accel.ALLOW_SLOW_ENV, raising=False)
    with pytest.raises(accel.AccelerationError, match="cobs is running without its C extension"):
        accel.require_extensions()
    monkeypatch.setenv(accel.ALLOW_SLOW_ENV, "1")
    accel.require_extensions()


def test_installed_codec_is_accelerated() -> None:
    assert accel.missing_extensions() == []


@pytest.mark.subprocess
def test_the_set_up_check_runs_without_warnings() -> None:
    """The Makefile's set-up step checks the C extensions and prints nothing else on stderr
    (issue 24: runpy warned that the module was already in sys.modules)."""
    import re
    import subprocess
    import sys
    from pathlib import Path

    makefile = (Path(__file__).resolve().parents[2] / "Makefile").read_text(encoding="utf-8")
    (module,) = re.findall(r"\$\(BIN\)/python -W error -m (spectratac\.protocol\.\w+)", makefile)
    run = subprocess.run(
        [sys.executable, "-W", "error", "-m", module], capture_output=True, text=True, timeout=120
    )
    assert run.returncode == 0 and run.stderr == "", run.stderr
    assert "C extensions in use" in run.stdout
