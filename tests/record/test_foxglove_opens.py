"""Every channel of every file we write opens in Foxglove/Lichtblick: its parse rules
(tests/lichtblick_rules.py) applied to a recording, a live-page clip and a ROS 2 bag written
with `--storage mcap`, and their messages decoded as the player decodes them. The bridge's
advertisement is checked in tests/apps/test_foxglove_bridge.py."""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from spectratac.apps.live.history import History
from spectratac.device import Sensor
from spectratac.ft import FT_RECORD
from spectratac.record import Recording, RecordingSummary, read_recording
from spectratac.record.format import FRAMES, FT_SAMPLES, GROUND_TRUTH, JSON_TOPICS
from spectratac.record.schemas import DECODED_TOPICS, SCHEMAS, metadata_schema

from tests.lichtblick_rules import check_mcap, parse_json_schema, rejected_channels


@pytest.mark.parametrize("topic", [*DECODED_TOPICS, *JSON_TOPICS])
def test_every_json_schema_we_write_is_inside_the_players_rules(topic: str) -> None:
    schema = SCHEMAS[topic] if topic in SCHEMAS else metadata_schema(topic)
    parse_json_schema(schema, schema["title"])


def test_every_channel_of_a_recording_opens_and_its_messages_decode(
    tour_session: tuple[RecordingSummary, Recording],
) -> None:
    _, rec = tour_session
    decoded = check_mcap(rec.path, messages=10_000)
    assert {FRAMES, FT_SAMPLES, GROUND_TRUTH, "/ft/wrench", "/spectratac/counts"} <= set(decoded)
    assert all(decoded[t] > 0 for t in (FRAMES, FT_SAMPLES, GROUND_TRUTH))
    # what a player shows of a compact channel is its exact bytes: the reader's frames
    from tests.lichtblick_rules import parse_channel

    with open(rec.path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None
        [frames] = [c for c in summary.channels.values() if c.topic == FRAMES]
        schema = summary.schemas[frames.schema_id]
        parsed = parse_channel(frames.message_encoding, schema.name, schema.encoding, schema.data)
        # in file order: log_time is the sensor's timeline, on which replies and samples
        # interleave otherwise than they arrived (the reader keeps arrival order)
        messages = reader.iter_messages([FRAMES], log_time_order=False)
        shown = [parsed.deserialize(m.data).data for _, _, m in messages]
    assert shown == rec.frames


def test_the_previous_layout_is_what_the_player_refused(tmp_path: Path) -> None:
    """The rules port is not vacuous: format 3's file (the previous release) fails it."""
    refused = rejected_channels(Path(__file__).parent / "data" / "tour-v3.mcap")
    assert refused[FRAMES] == "Unsupported encoding spectratac.frame"
    assert "Cannot convert undefined" in refused["/spectratac/session"]
    assert {FT_SAMPLES, GROUND_TRUTH, "/labels", "/spectratac/end"} <= set(refused)


def test_a_clip_opens_and_keeps_a_1_khz_reference_whole(tmp_path: Path) -> None:
    """A live-page clip of 10 s (History.save_mcap): 1 kHz of F/T, the page's estimates
    with and without a model; every F/T row is on /ft/wrench (it was thinned to 100 Hz)."""
    history = History()
    now = time.monotonic()
    t = now - 9.95 + np.arange(9_941) * 1e-3  # 9,941 rows, as the issue measured
    for start in range(0, len(t), 20):  # batches as a Bota driver hands them over
        rows = np.zeros(len(t[start : start + 20]), FT_RECORD)
        rows["host_time"] = t[start : start + 20]
        rows["sensor_time"] = rows["host_time"] - now
        rows["sequence"] = np.arange(start, start + len(rows))
        rows["wrench"][:, 2] = -1.5
        history.add_ft(rows)
    nan = math.nan
    for key in range(200):
        decoded = key % 2 == 0  # odd keys: rows of a session without a model
        history.add_row(key, {
            "t_s": key * 0.05, "host_time": now - 9.9 + key * 0.05, "device_time_s": key * 0.05,
            "step": 0, "Fx": 0.1 if decoded else None, "Fy": 0.0 if decoded else None,
            "Fz": -1.0 if decoded else None, "Tx": nan, "Ty": nan, "Tz": nan,
            "region": 5 if decoded else None, "region_prob": 0.9 if decoded else None,
            "contact": 1 if decoded else None, "ood": 0 if decoded else None,
            "invalid": 0 if decoded else None,
        })  # fmt: skip
    path = tmp_path / "clip.mcap"
    with Sensor.open("sim://?scene=tour&seed=1&speed=max") as sensor:
        history.save_mcap(path, 20.0, sensor, {"url": "sim://"})  # every row: 10 s
    decoded_by_topic = check_mcap(path, messages=20_000)
    assert decoded_by_topic["/ft/wrench"] == 9_941
    rec = read_recording(path)
    assert len(rec.ft) == 9_941
    assert len(rec.estimates) == 100  # the rows no model decoded are not estimates
    assert rec.estimates[0]["force"] == {"x": 0.1, "y": 0.0, "z": -1.0}
    assert rec.estimates[0]["torque"] == {} and rec.estimates[0]["decoded"] is True


@pytest.mark.slow
def test_a_ros2_bag_written_as_mcap_opens(
    tour_session: tuple[RecordingSummary, Recording], tmp_path: Path
) -> None:
    from spectratac.cli import main

    bag = tmp_path / "bag"
    assert main(["export", "rosbag", str(tour_session[1].path), "-o", str(bag),
                 "--storage", "mcap", "--no-progress"]) == 0  # fmt: skip
    [file] = bag.glob("*.mcap")
    decoded = check_mcap(file, messages=200)
    with open(file, "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    encodings = {(c.message_encoding, summary.schemas[c.schema_id].encoding)
                 for c in summary.channels.values()}  # fmt: skip
    assert encodings == {("cdr", "ros2msg")}
    assert all(n > 0 for n in decoded.values()), decoded


def test_json_messages_carry_no_null_for_a_missing_value(tmp_path: Path) -> None:
    """A label whose times are not known (speed=max) leaves them out instead of null."""
    from spectratac.record import RecordingWriter
    from spectratac.record.format import LABELS

    path = tmp_path / "l.mcap"
    with RecordingWriter(path, {}, unix_minus_monotonic_ns=0) as w:
        w.json(LABELS, {"source": "scene", "index": 0, "region": 3, "t_start": None,
                        "t_end": None}, 1.0)  # fmt: skip
    with open(path, "rb") as f:
        [(_, _, m)] = list(make_reader(f).iter_messages([LABELS]))
    assert json.loads(m.data) == {"source": "scene", "index": 0, "region": 3}
    check_mcap(path)
