"""`spectratac export rosbag`, as a ROS user meets it: the bag read back with rosbags' own
Reader holds every sample of the recording, stamped by the dataset builder's clock fits."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from spectratac.cli import main
from spectratac.cli.outputs import MARKER
from spectratac.dataset.build import session_datasets
from spectratac.decode import Decoder
from spectratac.hardware.generated import vocabulary as vocab
from spectratac.record import RecordOptions, record_url
from spectratac.record.reader import read_recording
from spectratac.record.timeline import Timeline
from spectratac.ros2 import BagExportError, export_rosbag

STORE = get_typestore(Stores.ROS2_JAZZY)  # a reader that is not the exporter's typestore


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("rec") / "s.mcap"
    options = RecordOptions(samples=60, leds=[[[500] * 3] * 3, [[300, 600, 900]] * 3])
    record_url("sim://?scene=tour&speed=10&ft=bota", path, options)
    return path


@pytest.fixture(scope="module")
def model(recording: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    [ds] = session_datasets(read_recording(recording))
    path = tmp_path_factory.mktemp("model") / "fz.stac"
    Decoder.untrained(ds, targets=("Fz",)).save(path)
    return path


def read_bag(path: Path) -> dict[str, list[tuple[int, object]]]:
    """topic -> [(bag timestamp, message)], in the bag's order."""
    out: dict[str, list[tuple[int, object]]] = {}
    with Reader(path) as reader:
        for conn in reader.connections:  # a type ROS lacks: its definition is in the bag
            if conn.msgtype not in STORE.types:
                assert conn.msgdef.data, f"{conn.topic}: {conn.msgtype} without a definition"
                STORE.register(get_types_from_msg(conn.msgdef.data, conn.msgtype))
        for conn, t, raw in reader.messages():
            out.setdefault(conn.topic, []).append((t, STORE.deserialize_cdr(raw, conn.msgtype)))
    return out


def stamp_ns(msg: object) -> int:
    s = msg.header.stamp  # type: ignore[attr-defined]
    return int(s.sec) * 10**9 + int(s.nanosec)


def wrench_of(msg: object) -> list[float]:
    w = msg.wrench  # type: ignore[attr-defined]
    return [w.force.x, w.force.y, w.force.z, w.torque.x, w.torque.y, w.torque.z]


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_every_sample_comes_back_from_the_bag(
    recording: Path, model: Path, tmp_path: Path, storage: str, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "bag"
    argv = ["export", "rosbag", str(recording), "-o", str(out), "--model", str(model)]
    assert main([*argv, "--storage", storage, "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["storage"] == storage
    rec = read_recording(recording)
    assert rec.ft is not None
    [ds] = session_datasets(rec)
    bag = read_bag(out)
    assert set(bag) == {
        "/spectratac/reference/wrench",
        "/spectratac/estimate/wrench",
        "/spectratac/raw/step_0/counts",
        "/spectratac/raw/step_1/counts",
    }
    for topic, messages in bag.items():
        assert summary["topics"][topic]["count"] == len(messages)
        times = [t for t, _ in messages]
        assert times == sorted(times), f"{topic}: stamps go back"

    # the reference: every F/T sample, its values, on the sensor's clock (a speed=10
    # simulation's F/T spans 10x the host's seconds), in the F/T sensor's own frame
    ref = bag["/spectratac/reference/wrench"]
    assert len(ref) == len(rec.ft)
    np.testing.assert_array_equal([wrench_of(m) for _, m in ref], rec.ft["wrench"])
    stamps = np.array([stamp_ns(m) for _, m in ref])
    assert stamps.tolist() == [t for t, _ in ref]
    span_ft = rec.ft["sensor_time"][-1] - rec.ft["sensor_time"][0]
    assert (stamps[-1] - stamps[0]) / 1e9 == pytest.approx(span_ft, rel=0.02)
    assert {m.header.frame_id for _, m in ref} == {"spectratac_ft_sensor"}  # type: ignore[attr-defined]
    timeline = Timeline.of_session(rec.session, rec.link.clock_scale)

    # raw counts: every sample on its LED step's topic, exact, at its window's end
    for step in (0, 1):
        rows = ds.step == step
        msgs = bag[f"/spectratac/raw/step_{step}/counts"]
        assert len(msgs) == rows.sum() > 0
        got = np.array([m.data for _, m in msgs]).reshape(-1, 3, 5)  # type: ignore[attr-defined]
        np.testing.assert_array_equal(got, ds.arrays["counts"][rows])
        assert [t for t, _ in msgs] == timeline.ns_array(ds.t_end[rows]).tolist()
        assert [stamp_ns(m) for _, m in msgs] == [t for t, _ in msgs]  # stamped counts
        assert {m.header.frame_id for _, m in msgs} == {"spectratac_board"}  # type: ignore[attr-defined]
        dims = msgs[0][1].layout.dim  # type: ignore[attr-defined]
        assert [(d.label, d.size, d.stride) for d in dims] == [("sensor", 3, 15), ("channel", 5, 5)]

    # estimates: the model's, within float32, NaN for what it does not estimate
    est = Decoder.load(model).predict(ds)
    keep = ~est.invalid
    msgs = bag["/spectratac/estimate/wrench"]
    assert len(msgs) == keep.sum() > 0
    got = np.array([wrench_of(m) for _, m in msgs])
    want_est = np.stack([est.column(a) for a in vocab.FT_AXES], axis=1)[keep]
    np.testing.assert_allclose(got[:, 2], want_est[:, 2], rtol=1e-6, atol=1e-6)
    assert np.isnan(got[:, [0, 1, 3, 4, 5]]).all()
    assert [stamp_ns(m) for _, m in msgs] == timeline.ns_array(ds.t_end[keep]).tolist()


def test_the_human_output_names_topics_and_how_to_play(
    recording: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "bag"
    assert main(["export", "rosbag", str(recording), "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert f"wrote {out} (sqlite3):" in text
    assert "/spectratac/reference/wrench       geometry_msgs/msg/WrenchStamped" in text
    assert f"play it: ros2 bag play {out}" in text
    # the bag and the marker that lets `--force` replace it (ROS ignores other files)
    assert sorted(p.name for p in out.iterdir()) == [MARKER, "bag.db3", "metadata.yaml"]
    assert [p.name for p in tmp_path.iterdir()] == ["bag"]  # no staging folder left


def test_a_long_export_shows_progress_unless_told_not_to(
    recording: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch
) -> None:
    from spectratac.cli import export_cmd

    from tests.terminal import pretend_terminal

    pretend_terminal(monkeypatch)  # bars show on a terminal only
    monkeypatch.setattr(export_cmd, "PROGRESS_FROM", 1)
    monkeypatch.setattr("spectratac.ros2.export._PROGRESS_EVERY", 500)
    assert main(["export", "rosbag", str(recording), "-o", str(tmp_path / "a")]) == 0
    err = capsys.readouterr().err
    assert "messages: 100%" in err and "msg/s]" in err
    argv = ["export", "rosbag", str(recording), "-o", str(tmp_path / "b"), "--no-progress"]
    assert main(argv) == 0
    assert "messages:" not in capsys.readouterr().err


def test_an_existing_bag_is_replaced_only_with_force(
    recording: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "bag"
    out.mkdir()
    (out / "keep.txt").write_text("the user's work")
    argv = ["export", "rosbag", str(recording), "-o", str(out)]
    assert main(argv) == 3
    assert "already exists; pass --force" in capsys.readouterr().err
    assert main([*argv, "--force"]) == 3  # --force replaces only a bag this verb wrote
    assert "keep.txt" in capsys.readouterr().err
    assert (out / "keep.txt").read_text() == "the user's work"
    (out / "keep.txt").unlink()
    assert main(argv) == 0  # an empty folder holds nothing to lose
    assert main([*argv, "--force"]) == 0
    assert sorted(p.name for p in out.iterdir()) == [MARKER, "bag.db3", "metadata.yaml"]


def test_a_failed_write_leaves_no_half_bag(
    recording: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from rosbags.rosbag2 import Writer

    real = Writer.write
    calls = 0

    def failing(self: Writer, *args: object) -> None:
        nonlocal calls
        calls += 1
        if calls == 100:
            raise OSError(28, "No space left on device")
        real(self, *args)  # type: ignore[arg-type]

    monkeypatch.setattr(Writer, "write", failing)
    with pytest.raises(BagExportError, match="No space left on device"):
        export_rosbag(recording, tmp_path / "bag")
    assert list(tmp_path.iterdir()) == []


def test_what_is_not_a_recording_is_a_typed_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"not a recording")
    assert main(["export", "rosbag", str(junk), "-o", str(tmp_path / "bag")]) == 3
    assert "spectratac export rosbag: error:" in capsys.readouterr().err
    assert not (tmp_path / "bag").exists()


def test_the_verb_is_listed_in_help(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["--help"])
    assert "export" in capsys.readouterr().out
    assert main(["export"]) == 2
    assert "rosbag" in capsys.readouterr().out


def test_help_says_where_estimates_come_from_without_a_model(
    capsys: pytest.CaptureFixture[str],
) -> None:
    # The exporter writes the recording's own estimates (an on-device model's, a live clip's)
    # when no --model is given: the help must not promise estimates only "with --model".
    with pytest.raises(SystemExit):
        main(["export", "rosbag", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "and, with --model, the decoded estimates" not in text
    assert "the estimates the recording holds" in text
    assert "--model STAC decode the samples with this model instead" in text
