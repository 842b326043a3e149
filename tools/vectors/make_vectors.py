"""Write the golden vectors in protocol/vectors/ (run once per protocol version, then frozen).

The vectors are the contract's test data: the Python tests and the firmware's C tests both
decode every one and compare with the meaning written beside the bytes. Re-running this after a
codec change would hide the change, so the vector test also checks CRC and COBS against an
independent reference implementation, and review the diff of protocol/vectors/ like code.
"""

from __future__ import annotations

import dataclasses
import json
import math
import sys
from pathlib import Path
from typing import Any

from cobs import cobs
from spectratac.protocol.framing import HEADER, crc32c, encode_frame, encode_raw
from spectratac.protocol.generated import messages as m
from spectratac.protocol.schema import Message
from spectratac.protocol.versions import RELEASED_DEFINITION_HASHES

OUT = Path(__file__).resolve().parents[2] / "protocol" / "vectors"
WHITE = ((500, 500, 500),) * 3
OFF = ((0, 0, 0),) * 3


def steps(*lit: tuple[tuple[int, int, int], ...]) -> tuple:
    return tuple(lit) + (OFF,) * (m.MAX_LED_STEPS - len(lit))


def mono(colour: int, duty: int) -> tuple[tuple[int, int, int], ...]:
    return tuple(tuple(duty if c == colour else 0 for c in range(3)) for _ in range(3))


V1_0 = (1, 0)  # the vectors written for protocol 1.0 stay 1.0 frames: a 1.1 receiver reads them
V1_1 = (1, 1)
V1_2 = (1, 2)
V1_3 = (1, 3)
V1_4 = (1, 4)


def meaning(msg: Message, seq: int, version: tuple[int, int]) -> dict[str, Any]:
    # the decoded form: float32 fields hold what the wire holds, not the float64 written here;
    # only the fields of the vector's own minor version (vectors are frozen once written)
    width = {"u8": 1, "i8": 1, "char": 1, "bytes": 1, "u16": 2, "i16": 2, "u32": 4, "i32": 4,
             "f32": 4, "u64": 8}  # fmt: skip
    room, known = type(msg).required_size(version[1]), set()
    for f in type(msg).FIELDS:  # fields are appended in version order
        room -= width[f.type] * f.count
        if room >= 0:
            known.add(f.name)
    decoded = type(msg).unpack(msg.pack()).to_dict()
    fields = {k: v for k, v in decoded.items() if k == "type" or k in known}
    return fields | {"seq": seq, "version": list(version)}


def valid(
    name: str, msg: Message, seq: int, doc: str, version: tuple[int, int] = V1_0
) -> dict[str, Any]:
    wire = encode_frame(msg, seq, version)
    return {
        "name": name,
        "doc": doc,
        "hex": wire.hex(),
        "valid": True,
        "message": meaning(msg, seq, version),
    }


def invalid(name: str, wire: bytes, error: str, doc: str) -> dict[str, Any]:
    return {
        "name": name,
        "doc": doc,
        "hex": wire.hex(),
        "valid": False,
        "message": None,
        "error": error,
    }


def build() -> list[dict[str, Any]]:
    sample = m.Sample(
        sample_seq=1234,
        t_start_us=5_000_000,
        t_end_us=5_050_000,
        led_step=0,
        config_id=2,
        sensor_status=(0, m.SensorStatus.SENSOR_SATURATED, 0),
        counts=(
            (812, 1430, 977, 3321, 140),
            (65535, 65535, 40000, 65535, 2000),
            (0x0100, 0x0001, 0x00FF, 0xFF00, 0),
        ),
    )
    info = m.Info(
        protocol_major=1,
        protocol_minor=0,
        definition_hash=RELEASED_DEFINITION_HASHES[0],
        firmware_version=(0, 1, 0),
        build_id="v0.1.0-3-gabc123",
        device_uid=bytes(range(1, 13)),
        board="blackpill-f411",
        sensor_count=3,
        sensor_present=0b111,
        channels_per_sensor=5,
        capabilities=m.Capabilities.CAP_LED_SEQUENCE
        | m.Capabilities.CAP_TIME_SYNC
        | m.Capabilities.CAP_STATUS
        | m.Capabilities.CAP_LOG
        | m.Capabilities.CAP_IR_CHANNEL,
        max_led_steps=8,
        duty_full_scale=1000,
        integration_times_mask=0x0F,
        max_frame=256,
        baud=921600,
    )
    configure = m.Configure(
        integration_ms=50,
        gain=0,
        digital_gain=0,
        sensitivity=0,
        flags=m.ConfigureFlags.CONFIG_STREAM,
        led_settle_us=1000,
        led_step_count=1,
        led_duty=steps(WHITE),
    )
    rgb = m.Configure(
        integration_ms=100,
        gain=m.Gain.GAIN_X2,
        digital_gain=m.DigitalGain.DG_X1,
        sensitivity=m.Sensitivity.SENS_LOW,
        flags=0,
        led_settle_us=500,
        led_step_count=3,
        led_duty=steps(mono(0, 1000), mono(1, 1000), mono(2, 1000)),
    )
    status = m.Status(
        uptime_ms=3_600_000,
        device_time_us=0xFFFF_FFF0,
        streaming=1,
        config_id=2,
        sensor_present=0b101,
        samples_taken=72000,
        frames_sent=72010,
        frames_dropped=3,
        bus_errors=(0, 17, 0),
        saturations=(5, 0, 0),
        rx_frames=40,
        rx_errors=2,
        command_errors=1,
    )
    vectors = [
        valid("get_info", m.GetInfo(), 0, "Empty payload: the host's first message."),
        valid("configure_default", configure, 1, "One white step at 50 ms, stream at once."),
        valid(
            "configure_rgb_steps",
            rgb,
            2,
            "Three single-colour steps, 100 ms, gain x2, low sensitivity.",
        ),
        valid("start", m.Start(), 3, "Start streaming."),
        valid("stop", m.Stop(), 4, "Stop streaming."),
        valid(
            "time_sync_request",
            m.TimeSyncRequest(exchange_id=7, host_time_ns=1_732_000_000_123_456_789),
            5,
            "Clock probe carrying a 64-bit host time.",
        ),
        valid("get_status", m.GetStatus(), 6, "Ask for statistics."),
        valid("get_config", m.GetConfig(), 7, "Ask for the configuration in force."),
        valid(
            "reset_stats", m.ResetStats(), 0xFFFF, "Sequence number at its maximum before wrapping."
        ),
        valid("info", info, 0, "Device identity with all capabilities but simulation."),
        valid(
            "ack",
            m.Ack(acked_type=m.Configure.TYPE_ID, acked_seq=1, config_id=1),
            1,
            "CONFIGURE accepted.",
        ),
        valid(
            "nack_bad_integration",
            m.Nack(
                rejected_type=m.Configure.TYPE_ID,
                rejected_seq=9,
                error=m.Error.BAD_INTEGRATION_TIME,
                field_index=0,
            ),
            2,
            "CONFIGURE refused: 75 ms.",
        ),
        valid(
            "sample_typical", sample, 3, "A sample with one saturated sensor and byte-order probes."
        ),
        valid(
            "sample_all_zero", m.Sample(), 0, "All-zero payload: COBS must encode long zero runs."
        ),
        valid(
            "sample_saturated",
            m.Sample(
                sample_seq=0xFFFF_FFFF,
                t_start_us=0xFFFF_FF00,
                t_end_us=0x0000_C250,
                led_step=7,
                config_id=0xFFFF,
                sensor_status=(1, 1, 1),
                counts=((65535,) * 5,) * 3,
            ),
            4,
            "Counts of 65535 everywhere; t_end_us wrapped past 2^32.",
        ),
        valid("status", status, 5, "Statistics with a missing sensor 1."),
        valid(
            "time_sync_reply",
            m.TimeSyncReply(
                exchange_id=7,
                host_time_ns=1_732_000_000_123_456_789,
                device_rx_us=123_456,
                device_tx_us=123_470,
            ),
            6,
            "Answer to time_sync_request.",
        ),
        valid(
            "log",
            m.Log(level=m.LogLevel.LOG_WARN, device_time_us=42, text="sensor 1 lost: I2C timeout"),
            7,
            "Text padded with NUL bytes.",
        ),
        valid("log_empty", m.Log(), 8, "A payload that is nothing but 0x00 bytes."),
        valid(
            "config",
            m.Config(
                config_id=3,
                integration_ms=400,
                gain=3,
                digital_gain=2,
                sensitivity=1,
                flags=0,
                led_settle_us=10000,
                led_step_count=8,
                led_duty=tuple(((1000, 1000, 1000),) * 3 for _ in range(8)),
            ),
            9,
            "The longest message of 1.0 with every duty at full scale.",
        ),
    ]
    # A frame from a future minor version: known fields then bytes this version does not know.
    future = sample.pack() + bytes(range(1, 9))
    wire = encode_raw(m.Sample.TYPE_ID, future, seq=10, version=(1, 3))
    vectors.append(
        {
            "name": "sample_future_minor",
            "hex": wire.hex(),
            "valid": True,
            "future_minor": True,
            "doc": "v1.3 sample with 8 unknown trailing bytes: ignored.",
            "message": meaning(sample, 10, (1, 3)),
        }
    )
    # The longest legal frame: max_payload bytes, no zeros (so COBS adds one byte).
    longest = sample.pack() + bytes([0x5A]) * (m.MAX_PAYLOAD - m.Sample.PAYLOAD_SIZE)
    wire = encode_raw(m.Sample.TYPE_ID, longest, seq=11, version=(1, 9))
    vectors.append(
        {
            "name": "max_length_frame",
            "hex": wire.hex(),
            "valid": True,
            "future_minor": True,
            "doc": f"A {m.MAX_PAYLOAD}-byte payload from a later minor ({len(wire)} B on wire).",
            "message": meaning(sample, 11, (1, 9)),
        }
    )
    # Shorter than the 1.0 layout: every field of a 1.0 STATUS is 1.0, so none may be missing
    # (only fields newer than the sender's minor version are zero-filled).
    short = m.Status(uptime_ms=1000, device_time_us=2000, streaming=1, config_id=4)
    vectors.append(
        invalid(
            "status_short",
            encode_raw(m.Status.TYPE_ID, short.pack()[:11], seq=12),
            "short_payload",
            "A 1.0 STATUS with only its first 11 payload bytes: malformed, not zero-filled.",
        )
    )
    good = bytes.fromhex(vectors[12]["hex"])
    flipped = bytearray(good)
    flipped[10] ^= 0x04
    vectors += [
        invalid(
            "bad_crc_bit_flip", bytes(flipped), "bad_crc", "sample_typical with one bit flipped."
        ),
        invalid(
            "truncated",
            good[: len(good) // 2] + b"\x00",
            _kind(good[: len(good) // 2]),
            "sample_typical cut in half.",
        ),
        invalid(
            "bad_cobs",
            bytes([0x20, 0x01, 0x02, 0x00]),
            "bad_cobs",
            "A COBS code byte pointing past the end.",
        ),
        invalid(
            "too_short",
            cobs.encode(b"\x01\x00\x84") + b"\x00",
            "too_short",
            "Three bytes: no room for a CRC.",
        ),
        invalid(
            "oversize", bytes([0x41]) * 300 + b"\x00", "oversize", "300 bytes without a delimiter."
        ),
        invalid(
            "unknown_type",
            encode_raw(0x7E, b"\x01\x02", seq=13),
            "unknown_type",
            "Good CRC, type 0x7E not defined in 1.x.",
        ),
        invalid(
            "version_mismatch",
            encode_raw(m.Sample.TYPE_ID, sample.pack(), seq=14, version=(2, 0)),
            "version_mismatch",
            "A protocol 2.0 frame.",
        ),
        invalid(
            "oversize_payload",
            encode_raw(m.Sample.TYPE_ID, bytes([0x33]) * (m.MAX_PAYLOAD + 1), seq=15),
            "oversize",
            "One byte more than max_payload, good CRC.",
        ),
        invalid(
            "sample_empty",
            encode_raw(m.Sample.TYPE_ID, b"", seq=16),
            "short_payload",
            "A 1.0 SAMPLE with an empty payload and a good CRC: malformed, not a zero sample.",
        ),
    ]
    return vectors + build_1_1(info, sample) + build_1_2(status) + build_1_3() + build_1_4(status)


def nack(rejected: type[Message], seq: int, error: m.Error, field_index: int = 255) -> m.Nack:
    return m.Nack(
        rejected_type=rejected.TYPE_ID, rejected_seq=seq, error=error, field_index=field_index
    )


def build_1_1(info: m.Info, sample: m.Sample) -> list[dict[str, Any]]:
    """Protocol 1.1 (on-device decoding): model upload, model info, estimates, their NACKs."""
    image_crc = 0x1C29_1CA3  # any value: a device checks it against the image at MODEL_COMMIT
    full = bytes((i * 37 + 11) % 255 + 1 for i in range(224))  # no zero byte: longest COBS run
    last = bytes(range(1, 97)) + bytes(224 - 96)
    estimate = m.Estimate(
        sample_seq=sample.sample_seq,
        t_end_us=sample.t_end_us,
        config_id=sample.config_id,
        model_id=0x5EC7_A7AC,
        flags=m.EstimateFlags.EST_CONTACT,
        force=(0.375, -1.25, 4.5),
        torque=(0.001953125, -0.0078125, 0.0),
        region=5,
        region_prob=0.875,
        decode_us=812,
    )
    nan = math.nan
    info_1_1 = m.Info(
        **{f.name: getattr(info, f.name) for f in m.Info.FIELDS}
        | {
            "protocol_minor": 1,
            "definition_hash": RELEASED_DEFINITION_HASHES[1],
            "capabilities": info.capabilities
            | m.Capabilities.CAP_ESTIMATE
            | m.Capabilities.CAP_MODEL_UPLOAD,
        }
    )
    return [
        valid(
            "info_1_1",
            info_1_1,
            20,
            "A 1.1 device that decodes on board and accepts uploaded models.",
            V1_1,
        ),
        valid(
            "model_begin",
            m.ModelBegin(model_id=0x5EC7_A7AC, size=4096, crc=image_crc),
            21,
            "Announce a 4 KiB model image.",
            V1_1,
        ),
        valid(
            "model_chunk_max",
            m.ModelChunk(offset=224 * 18, length=224, data=full),
            22,
            "A full chunk (224 bytes, none zero): the longest host-to-device frame.",
            V1_1,
        ),
        valid(
            "model_chunk_last",
            m.ModelChunk(offset=4000, length=96, data=last),
            23,
            "The image's last 96 bytes; the unused rest of data is zero.",
            V1_1,
        ),
        valid("model_commit", m.ModelCommit(model_id=0x5EC7_A7AC), 24, "Finish the upload.", V1_1),
        valid("model_clear", m.ModelClear(), 25, "Erase the stored model.", V1_1),
        valid("get_model", m.GetModel(), 26, "Ask which model the device runs.", V1_1),
        valid(
            "model_info",
            m.ModelInfo(
                present=1,
                model_id=0x5EC7_A7AC,
                size=4096,
                crc=image_crc,
                weight_format=1,
                led_steps=3,
                n_inputs=135,
                capacity=128 * 1024,
                max_inputs=256,
                max_hidden=128,
            ),
            27,
            "An uploaded float16 model for three LED steps.",
            V1_1,
        ),
        valid(
            "model_info_none",
            m.ModelInfo(capacity=128 * 1024, max_inputs=256, max_hidden=128),
            28,
            "No model stored: only the limits are given.",
            V1_1,
        ),
        valid(
            "estimate_typical",
            estimate,
            29,
            "A contact estimate with dyadic values (exact in float32).",
            V1_1,
        ),
        valid(
            "estimate_invalid_nan",
            m.Estimate(
                sample_seq=1235,
                t_end_us=5_100_000,
                config_id=2,
                model_id=0x5EC7_A7AC,
                flags=m.EstimateFlags.EST_INVALID | m.EstimateFlags.EST_WARMUP,
                force=(nan, nan, nan),
                torque=(nan, nan, nan),
                region=0,
                region_prob=nan,
                decode_us=0xFFFF,
            ),
            30,
            "No usable estimate: every float is the quiet NaN 0x7FC00000; decode_us saturated.",
            V1_1,
        ),
        valid(
            "estimate_force_only",
            m.Estimate(
                sample_seq=0xFFFF_FFFF,
                t_end_us=0x0000_C250,
                config_id=0xFFFF,
                model_id=1,
                flags=m.EstimateFlags.EST_CONTACT | m.EstimateFlags.EST_OOD,
                force=(-0.5, 0.25, 12.0),
                torque=(nan, nan, nan),
                region=0,
                region_prob=nan,
                decode_us=95,
            ),
            31,
            "A force-only model without region head: torque and region_prob NaN.",
            V1_1,
        ),
        valid(
            "nack_model_too_large",
            nack(m.ModelBegin, 21, m.Error.MODEL_TOO_LARGE),
            32,
            "MODEL_BEGIN refused: larger than the model store.",
            V1_1,
        ),
        valid(
            "nack_model_bad_chunk",
            nack(m.ModelChunk, 22, m.Error.MODEL_BAD_CHUNK, field_index=0),
            33,
            "MODEL_CHUNK refused: offset out of order.",
            V1_1,
        ),
        valid(
            "nack_model_bad_crc",
            nack(m.ModelCommit, 24, m.Error.MODEL_BAD_CRC),
            34,
            "MODEL_COMMIT refused: the bytes do not match MODEL_BEGIN's CRC.",
            V1_1,
        ),
        valid(
            "nack_model_invalid",
            nack(m.ModelCommit, 24, m.Error.MODEL_INVALID),
            35,
            "MODEL_COMMIT refused: the image fails validation.",
            V1_1,
        ),
        valid(
            "nack_no_model",
            nack(m.Configure, 1, m.Error.NO_MODEL, field_index=4),
            36,
            "CONFIGURE with CONFIG_ESTIMATE refused: no model stored.",
            V1_1,
        ),
        valid(
            "nack_model_mismatch",
            nack(m.Configure, 2, m.Error.MODEL_MISMATCH, field_index=6),
            37,
            "CONFIGURE refused: the model was trained for another LED step count.",
            V1_1,
        ),
        valid(
            "nack_flash_error",
            nack(m.ModelChunk, 22, m.Error.FLASH_ERROR),
            38,
            "MODEL_CHUNK refused: programming the model store failed.",
            V1_1,
        ),
        valid(
            "configure_estimate_only",
            m.Configure(
                integration_ms=50,
                flags=m.ConfigureFlags.CONFIG_STREAM
                | m.ConfigureFlags.CONFIG_ESTIMATE
                | m.ConfigureFlags.CONFIG_ESTIMATE_ONLY,
                led_settle_us=1000,
                led_step_count=1,
                led_duty=steps(WHITE),
            ),
            39,
            "Stream estimates instead of samples.",
            V1_1,
        ),
    ]


def build_1_2(status: m.Status) -> list[dict[str, Any]]:
    """1.2 appended fields: STATUS's cycle counts, MODEL_INFO's image_crc."""
    return [
        valid(
            "status_1_2",
            dataclasses.replace(
                status,
                cycle_hz=96_000_000,
                acq_cycles_last=231_000,
                acq_cycles_max=245_500,
                decode_cycles_last=937_000,
                decode_cycles_max=951_000,
            ),
            40,
            "STATUS of a 1.2 device that measures itself (DWT cycle counter at 96 MHz).",
            V1_2,
        ),
        valid(
            "model_info_1_2",
            m.ModelInfo(
                present=1,
                model_id=0x5EC7_A7AC,
                size=426_740,
                crc=0x4867_4BC7,
                weight_format=0,
                led_steps=1,
                n_inputs=12,
                capacity=458_688,
                max_inputs=256,
                max_hidden=128,
                image_crc=0x1B2C_3D4E,
            ),
            41,
            "An uploaded float32 model: crc is the transfer's residue, image_crc the image's own.",
            V1_2,
        ),
    ]


def build_1_3() -> list[dict[str, Any]]:
    """1.3: TARE, and the EST_NO_REST flag of an estimate made before the baseline saw rest."""
    return [
        valid("tare", m.Tare(), 42, "Zero the model's drift baseline on the next sample.", V1_3),
        valid(
            "estimate_no_rest",
            m.Estimate(
                sample_seq=7,
                t_end_us=350_000,
                config_id=1,
                model_id=0x5EC7_A7AC,
                flags=m.EstimateFlags.EST_CONTACT | m.EstimateFlags.EST_NO_REST,
                force=(0.25, -0.5, -3.75),
                torque=(0.0, 0.0, 0.0),
                region=5,
                region_prob=0.875,
                decode_us=1200,
            ),
            43,
            "Joined under load: a contact estimate before the drift baseline has seen rest.",
            V1_3,
        ),
    ]


def build_1_4(status: m.Status) -> list[dict[str, Any]]:
    """1.4 (post-mortem, erase timing, brown-out, DFU by command): STATUS's appended fields,
    ENTER_BOOTLOADER, DEBUG_FAULT and their NACKs."""
    after_fault = dataclasses.replace(
        status,
        cycle_hz=96_000_000,
        reset_cause=m.ResetCause.RESET_PIN | m.ResetCause.RESET_SOFTWARE | m.ResetCause.RESET_FAULT,
        fault_pc=0x0800_1A2C,
        fault_lr=0x0800_0F13,
        fault_xpsr=0x0100_0003,
        fault_cfsr=0x0001_0000,  # UNDEFINSTR
        fault_hfsr=0x4000_0000,  # FORCED
        fault_mmfar=0xE000_EDF4,
        fault_bfar=0xE000_EDF8,
        abnormal_resets=1,
        safe_mode=0,
        bor_level=3,
        erase_us_last=1_840_000,
        erase_us_max=7_012_500,
        trig_latency_us_last=(50_120, 50_180, 0),
        trig_latency_us_max=(51_003, 50_990, 0),
    )
    safe = dataclasses.replace(
        status,
        reset_cause=m.ResetCause.RESET_PIN | m.ResetCause.RESET_IWDG,
        abnormal_resets=3,
        safe_mode=1,
        bor_level=0,
    )
    return [
        valid(
            "status_1_4_fault",
            after_fault,
            44,
            "STATUS after an injected HardFault (undefined instruction): the record survived the"
            " reset; brown-out level 3; a four-sector erase measured.",
            V1_4,
        ),
        valid(
            "status_1_4_safe_mode",
            safe,
            45,
            "The third watchdog reset in a row: booted without the model store; BOR off.",
            V1_4,
        ),
        valid(
            "enter_bootloader", m.EnterBootloader(), 46, "Restart in the ROM DFU bootloader.", V1_4
        ),
        valid(
            "debug_fault_hang",
            m.DebugFault(kind=m.FaultKind.FAULT_HANG),
            47,
            "Hang until the watchdog resets the device (test images).",
            V1_4,
        ),
        valid(
            "nack_bor_too_low",
            nack(m.ModelBegin, 48, m.Error.BOR_TOO_LOW),
            48,
            "MODEL_BEGIN refused: brown-out level below 3.",
            V1_4,
        ),
        valid(
            "nack_not_a_test_image",
            nack(m.DebugFault, 47, m.Error.NOT_A_TEST_IMAGE),
            49,
            "DEBUG_FAULT refused by a release image.",
            V1_4,
        ),
        valid(
            "nack_bad_fault_kind",
            nack(m.DebugFault, 50, m.Error.BAD_FAULT_KIND, field_index=0),
            50,
            "DEBUG_FAULT refused: kind 7 is not a fault_kind.",
            V1_4,
        ),
    ]


def _kind(encoded: bytes) -> str:
    try:
        raw = cobs.decode(encoded)
    except cobs.DecodeError:
        return "bad_cobs"
    if len(raw) < HEADER.size + 4:
        return "too_short"
    return "bad_crc" if crc32c(raw[:-4]) != int.from_bytes(raw[-4:], "little") else "ok"


def main() -> int:
    OUT.mkdir(parents=True, exist_ok=True)
    for old in OUT.glob("*.json"):
        old.unlink()
    for i, vector in enumerate(build()):
        path = OUT / f"{i:02d}_{vector['name']}.json"
        path.write_text(json.dumps(vector, indent=2) + "\n", encoding="utf-8")
    print(f"wrote {i + 1} vectors to {OUT}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
