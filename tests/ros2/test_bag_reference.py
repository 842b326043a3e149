"""A bag exported from a recording is a correct reference F/T for that recording, at any
simulation speed, in either storage: `dataset build --ft rosbag://…` gives the targets the
recording itself gives. Before the timeline, a speed=15 recording's bag gave 6.5 % of the
rows a target, ~750 F/T samples per window, with exit code 0. A reference that covers part
of a session or none of it is never silent."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml
from rosbags.rosbag2 import Reader
from spectratac.cli import main
from spectratac.dataset import Dataset
from spectratac.record import RecordOptions, record_url
from spectratac.record.reader import read_recording

REF = "/spectratac/reference/wrench"


def build(args: list[str], out: Path) -> int:
    return main(["dataset", "build", *args, "-o", str(out), "--json", "--no-progress"])


@pytest.mark.parametrize(
    ("speed", "storage"), [("1", "sqlite3"), ("15", "sqlite3"), ("15", "mcap"), ("max", "mcap")]
)
def test_an_exported_bag_gives_the_recordings_own_targets(
    tmp_path: Path, speed: str, storage: str, capsys: pytest.CaptureFixture[str]
) -> None:
    rec = tmp_path / "s.mcap"
    seconds = 3.0 if speed == "1" else 12.0
    record_url(f"sim://?scene=press&seed=1&speed={speed}&ft=bota", rec,
               RecordOptions(duration_s=seconds))  # fmt: skip
    bag = tmp_path / "bag"
    assert main(["export", "rosbag", str(rec), "-o", str(bag), "--storage", storage]) == 0
    with Reader(bag) as reader:  # rosbags reads it back, the reference span on sensor time
        ref = [c for c in reader.connections if c.topic == REF]
        times = [t for _, t, _ in reader.messages(connections=ref)]
    assert build([str(rec)], tmp_path / "own.npz") == 0
    own = Dataset.load(tmp_path / "own.npz")
    ft = read_recording(rec).ft
    assert ft is not None  # the bag spans the F/T's own seconds, not the host's
    assert (times[-1] - times[0]) / 1e9 == pytest.approx(np.ptp(ft["sensor_time"]), rel=0.02)
    url = f"rosbag://{bag}?topic={REF}"
    assert build([str(rec), "--ft", url], tmp_path / "bag.npz") == 0
    capsys.readouterr()
    via = Dataset.load(tmp_path / "bag.npz")
    assert own.target_valid.mean() >= 0.95
    assert via.target_valid.mean() >= 0.95 * own.target_valid.mean()
    both = own.target_valid & via.target_valid
    assert np.abs(own.targets[both] - via.targets[both]).max() <= 0.05
    assert np.median(via.arrays["ft_count"][both]) == np.median(own.arrays["ft_count"][both])


@pytest.fixture(scope="module")
def session(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """A speed=15 recording and its exported bag."""
    folder = tmp_path_factory.mktemp("s")
    rec = folder / "s.mcap"
    record_url("sim://?scene=press&seed=1&speed=15&ft=bota", rec, RecordOptions(duration_s=10))
    assert main(["export", "rosbag", str(rec), "-o", str(folder / "bag")]) == 0
    return rec, folder / "bag"


def test_a_reference_of_another_session_is_an_error(
    session: tuple[Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    _, bag = session
    other = tmp_path / "other.mcap"
    record_url("sim://?scene=idle&speed=15", other, RecordOptions(duration_s=3))
    capsys.readouterr()
    assert build([str(other), "--ft", f"rosbag://{bag}?topic={REF}"], tmp_path / "d.npz") == 3
    err = capsys.readouterr().err
    assert "covers none of the" in err and "Traceback" not in err


def test_a_reference_covering_part_of_the_session_exits_1(
    session: tuple[Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from rosbags.rosbag2 import Writer

    rec, bag = session
    half = tmp_path / "half"  # the reference up to the optical session's middle only
    info = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    with Reader(bag) as reader, Writer(half, version=8) as writer:
        for key, value in info["custom_data"].items():  # the timeline travels with the bag
            writer.set_custom_data(key, value)
        [conn] = [c for c in reader.connections if c.topic == REF]
        out = writer.add_connection(REF, conn.msgtype, msgdef=conn.msgdef.data,
                                    rihs01=conn.digest)  # fmt: skip
        counts = [c for c in reader.connections if c.topic.endswith("/counts")]
        optical = [t for _, t, _ in reader.messages(connections=counts)]
        middle = (optical[0] + optical[-1]) // 2
        for _, t, raw in reader.messages(connections=[conn]):
            if t <= middle:
                writer.write(out, t, raw)
    capsys.readouterr()
    assert main(["dataset", "build", str(rec), "--ft", f"rosbag://{half}?topic={REF}",
                 "-o", str(tmp_path / "d.npz"), "--no-progress"]) == 1  # fmt: skip
    err = capsys.readouterr().err
    assert "optical windows have a reference F/T target" in err
    assert (tmp_path / "d.npz").exists()  # the dataset is written; the shortfall is said
