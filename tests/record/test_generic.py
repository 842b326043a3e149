"""A recording as a third party meets it: the plain `mcap` reader and each channel's schema,
nothing of spectratac's reader (format 5: FORMAT.md, "Decoded channels"). Old files
(format 3, written by an earlier release: data/tour-v3.mcap) still read."""

from __future__ import annotations

import json
import math
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from jsonschema import Draft202012Validator
from mcap.reader import make_reader
from spectratac.dataset.frames import recorded_samples
from spectratac.protocol.generated import messages as m
from spectratac.record import Recording, RecordingSummary, RecordingWriter, read_recording
from spectratac.record.format import VERSION
from spectratac.record.schemas import (
    RATE_CAP_HZ,
    RateCap,
    counts_messages,
    device_estimate_messages,
    estimate_message,
    split_frames,
)

V3 = Path(__file__).parent / "data" / "tour-v3.mcap"
COMPACT = {"/spectratac/frames", "/ft/samples", "/spectratac/ground_truth"}


def third_party_read(path: Path) -> dict[str, list[tuple[int, dict[str, Any]]]]:
    """Every JSON message by topic, as (log_time, object), each validated against the JSON
    schema its channel names. Compact channels (custom binary encodings) are skipped."""
    out: dict[str, list[tuple[int, dict[str, Any]]]] = {}
    validators: dict[int, Draft202012Validator] = {}
    with open(path, "rb") as f:
        for schema, channel, message in make_reader(f).iter_messages():
            if channel.topic in COMPACT:  # protobuf-wrapped (format 5) or raw (before)
                assert channel.message_encoding in ("protobuf", "spectratac.frame",
                                                    "spectratac.ft_record",
                                                    "spectratac.ground_truth")  # fmt: skip
                continue
            assert schema is not None and schema.encoding == "jsonschema", channel.topic
            assert channel.message_encoding == "json"
            if schema.id not in validators:
                doc = json.loads(schema.data)
                Draft202012Validator.check_schema(doc)
                validators[schema.id] = Draft202012Validator(doc)
            obj = json.loads(message.data)  # strict JSON: NaN would be refused below
            validators[schema.id].validate(obj)
            out.setdefault(channel.topic, []).append((message.log_time, obj))
    return out


def test_fz_and_counts_read_with_the_schema_alone(
    tour_session: tuple[RecordingSummary, Recording],
) -> None:
    summary, rec = tour_session
    assert rec.session["version"] == VERSION == 5
    found = third_party_read(rec.path)
    # the reference: /ft/wrench.force.z, exactly the compact rows; at speed=10 the simulated
    # Bota sends 10 kHz of host time: an even subset at RATE_CAP_HZ
    wrench = [obj for _, obj in found["/ft/wrench"]]
    assert len(rec.ft) == summary.ft_samples > 10_000
    span = rec.ft["host_time"][-1] - rec.ft["host_time"][0]
    assert 0.5 * RATE_CAP_HZ * span < len(wrench) <= RATE_CAP_HZ * (span + 1)
    by_seq = {int(r["sequence"]): r for r in rec.ft}
    for w in wrench:
        row = by_seq[w["sequence"]]
        assert [w["force"][a] for a in "xyz"] == row["wrench"][:3].tolist()
        assert w["sensor_time"] == row["sensor_time"]
    fz = np.array([w["force"]["z"] for w in wrench])
    assert fz.min() < -1.0, "the tour's presses load the reference"
    # raw counts of every sample, IR too, with the device's time
    samples = recorded_samples(rec.frames, rec.frame_host_times)
    counts = [obj for _, obj in found["/spectratac/counts"]]
    assert len(counts) == len(samples) == summary.samples
    # stamped on the sensor's clock (record.timeline): at speed=10 the 25 scene seconds span
    # 25 s of log_time, the window ends' own steps
    log_s = np.array([t for t, _ in found["/spectratac/counts"]]) / 1e9
    device_s = samples["t_end_us"] / 1e6
    # (the live fit is provisional: the first samples may sit a little late)
    assert abs((log_s[-1] - log_s[0]) - (device_s[-1] - device_s[0])) < 0.02 * device_s[-1]
    assert np.median(np.diff(log_s)) == pytest.approx(np.median(np.diff(device_s)), abs=1e-6)
    ir = np.array([[c[f"s{i}"]["IR"] for i in range(3)] for c in counts])
    np.testing.assert_array_equal(ir, samples["counts"][:, :, 4])
    assert [c["sequence"] for c in counts] == samples["sequence"].tolist()
    # the truth of a simulated link, per sample; labels with their schema
    truth = [obj for _, obj in found["/spectratac/truth"]]
    assert len(truth) == len(rec.ground_truth)
    assert [t["force_n"]["z"] for t in truth] == rec.ground_truth["force_n"][:, 2].tolist()
    assert [obj["region"] for _, obj in found["/labels"]] == [lb["region"] for lb in rec.labels]
    assert found["/spectratac/session"][0][1]["version"] == 5


def test_every_channel_names_a_schema(
    tour_session: tuple[RecordingSummary, Recording],
) -> None:
    _, rec = tour_session
    with open(rec.path, "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    assert all(c.schema_id != 0 for c in summary.channels.values())
    compact = {c.topic for c in summary.channels.values() if c.message_encoding == "protobuf"}
    assert compact == COMPACT  # each with a decoded copy: frames, wrench, truth
    titles = {summary.schemas[c.schema_id].name for c in summary.channels.values() if c.schema_id}
    assert {"spectratac.RawCounts", "spectratac.Wrench", "spectratac.Label"} <= titles


def test_format_3_files_still_read(tmp_path: Path) -> None:
    from spectratac.dataset.build import build_datasets

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        old = read_recording(V3)
    assert old.session["version"] == 3 and not old.truncated
    assert len(old.frames) > 30 and len(old.ft) > 1000 and old.ground_truth is not None
    assert old.labels and old.estimates == []
    assert "/ft/wrench" not in third_party_read(V3)  # the old layout: no decoded channels
    (ds,) = build_datasets([V3])
    assert ds.n >= 30


def test_a_clip_writer_stores_host_estimates_and_the_reader_returns_them(
    tmp_path: Path,
) -> None:
    path = tmp_path / "clip.mcap"
    nan = math.nan
    rows = [
        {"key": 0, "host_time": 1.0, "device_time_s": 0.05, "Fx": 0.1, "Fy": 0.0, "Fz": -2.5,
         "Tx": None, "Ty": None, "Tz": None, "region": 5, "region_prob": 0.9, "contact": 1,
         "ood": 0, "invalid": 0},
        {"key": 1, "host_time": 1.05, "device_time_s": 0.1, "Fx": nan, "Fy": nan, "Fz": nan,
         "Tx": nan, "Ty": nan, "Tz": nan, "region": 0, "region_prob": nan, "contact": 0,
         "ood": 1, "invalid": 1},
    ]  # fmt: skip
    with RecordingWriter(path, {}, unix_minus_monotonic_ns=0) as w:
        w.estimates(rows)
    rec = read_recording(path)
    assert [e["force"].get("z") for e in rec.estimates] == [-2.5, None]  # not finite: absent
    assert rec.estimates[0]["torque"] == {} and rec.estimates[0]["decoded"]
    assert not rec.estimates[1]["decoded"] and rec.estimates[1]["force"] == {}
    assert rec.estimates[1]["invalid"] and rec.estimates[0]["t_end_us"] == 50_000
    assert [t for t, _ in third_party_read(path)["/spectratac/estimates"]] == [10**9, 1_050 * 10**6]


def test_compact_only_writes_no_decoded_channel(tmp_path: Path) -> None:
    path = tmp_path / "compact.mcap"
    sample = m.Sample(sample_seq=3).pack()
    with RecordingWriter(path, {}, unix_minus_monotonic_ns=0, decoded=False) as w:
        w.frames([(_frame(m.Sample.TYPE_ID, sample), 1.0)])
    assert set(third_party_read(path)) == {"/spectratac/session"}
    assert len(read_recording(path).frames) == 1


# ---------------------------------------------------------------------- the codec
def _frame(type_id: int, payload: bytes) -> bytes:
    from spectratac.protocol.framing import crc32c

    body = bytes([m.PROTOCOL_MAJOR, m.PROTOCOL_MINOR, type_id, 0, 0]) + payload
    return body + crc32c(body).to_bytes(4, "little")


u16 = st.integers(0, 0xFFFF)
f32 = st.floats(width=32, allow_nan=True, allow_infinity=True)


@settings(max_examples=60, deadline=None)
@given(
    seq=st.integers(0, 2**32 - 1),
    counts=st.lists(st.lists(u16, min_size=5, max_size=5), min_size=3, max_size=3),
    force=st.lists(f32, min_size=3, max_size=3),
    flags=st.integers(0, 15),
    region=st.integers(0, 9),
)
def test_frames_decode_to_schema_messages(
    seq: int, counts: list[list[int]], force: list[float], flags: int, region: int
) -> None:
    sample = m.Sample(sample_seq=seq, t_end_us=7, counts=tuple(map(tuple, counts))).pack()
    estimate = m.Estimate(sample_seq=seq, flags=flags, force=tuple(force), region=region,
                          region_prob=0.5).pack()  # fmt: skip
    frames = [(_frame(m.Sample.TYPE_ID, sample), 1.0), (_frame(0x81, b""), 1.5),
              (_frame(m.Estimate.TYPE_ID, estimate), 2.0)]  # fmt: skip
    samples, sample_t, estimates, estimate_t = split_frames(frames)
    assert sample_t == [1.0] and estimate_t == [2.0]
    [c] = [json.loads(b) for b in counts_messages(samples)]
    assert [[c[f"s{i}"][k] for k in ("R", "G", "B", "C", "IR")] for i in range(3)] == counts
    assert c["sequence"] == seq and c["t_end_us"] == 7
    [e] = [json.loads(b) for b in device_estimate_messages(estimates)]
    expect = [float(np.float32(v)) if math.isfinite(v) else None for v in force]
    assert [e["force"].get(a) for a in "xyz"] == expect
    assert e["decoded"] == bool(e["force"] or e["torque"])
    assert e["contact"] == bool(flags & 1) and e["invalid"] == bool(flags & 2)
    assert e["ood"] == bool(flags & 4) and e["region"] == region and e["source"] == "device"


def test_an_estimate_message_never_holds_nan() -> None:
    data = estimate_message("host", 1, 2, [math.nan, None, 1.0], [math.inf] * 3, 0, math.nan,
                            contact=False, ood=False, invalid=True)  # fmt: skip
    obj = json.loads(data)
    assert obj["force"] == {"z": 1.0} and "region_prob" not in obj and obj["decoded"] is True
    assert b"NaN" not in data and b"Infinity" not in data  # JSON has neither


@settings(max_examples=80, deadline=None)
@given(
    batches=st.lists(st.tuples(st.integers(0, 3000), st.floats(0.0, 0.5)), min_size=1,
                     max_size=40),
    rate=st.sampled_from([10.0, 100.0, 1000.0]),
)  # fmt: skip
def test_the_rate_cap_copies_slow_streams_whole_and_thins_fast_ones_evenly(
    batches: list[tuple[int, float]], rate: float
) -> None:
    cap = RateCap(rate)
    t, kept = 0.0, 0
    for n, dt in batches:
        t += dt
        rows = np.arange(n)
        part = rows[cap.take(n, t)]
        kept += len(part)
        if len(part) > 1:  # an even subset: one stride
            assert len(set(np.diff(part).tolist())) == 1
        assert n == 0 or part[0] == 0
    assert kept <= rate * (t + 1) + len(batches)  # one second's burst, at most


def test_the_rate_cap_leaves_a_real_sensors_rate_alone() -> None:
    cap = RateCap()
    taken = [len(range(10)[cap.take(10, i * 0.01)]) for i in range(1000)]  # 1 kHz, 10 s
    assert sum(taken) == 10_000


def test_the_rate_cap_copies_a_1_khz_batch_of_ten_seconds_whole() -> None:
    """A clip hands the writer its whole window at once: the span of the batch counts."""
    t = np.arange(9_941) * 1e-3
    assert len(range(9_941)[RateCap().take(9_941, float(t[-1]), float(t[0]))]) == 9_941
    fast = np.arange(99_410) * 1e-4  # 10 kHz (speed=10): an even subset at the cap
    kept = len(range(99_410)[RateCap().take(99_410, float(fast[-1]), float(fast[0]))])
    assert 9_000 < kept <= RATE_CAP_HZ * (fast[-1] + 1)
