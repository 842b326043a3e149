"""Damaged inputs to the dataset layer: a recording with a corrupted chunk still builds (from
what survived) but says so and exits 1; a dataset file with a malformed `meta` or damaged bytes
is a DatasetError, never another exception; a dataset is written under its name only once
complete."""

from __future__ import annotations

import json
import re
import zipfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from spectratac.cli import main
from spectratac.cli.exit_codes import ExitCode
from spectratac.dataset import Dataset, DatasetError
from spectratac.dataset.build import UnlabelledSamplesWarning, session_datasets
from spectratac.record.format import FRAMES
from spectratac.record.reader import read_recording

from tests.dataset.mcap_chunks import middle_frame_chunk


def damage_a_middle_chunk(src: Path, dst: Path) -> None:
    """Flip a bit in the middle one of the chunks that hold frames. (The middle chunk of the
    file held F/T rows alone when a loaded host let the F/T run on after the optical stream.)"""
    data = bytearray(src.read_bytes())
    start, length = middle_frame_chunk(src, at_least=3)
    data[start + length // 2] ^= 0x40
    dst.write_bytes(bytes(data))


def test_a_damaged_recording_builds_what_survived_and_exits_1(
    tour_mcap: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    damaged = tmp_path / "damaged.mcap"
    damage_a_middle_chunk(tour_mcap, damaged)
    out = tmp_path / "d.npz"
    argv = ["dataset", "build", str(damaged), "-o", str(out), "--json", "--no-progress"]
    assert main(argv) == ExitCode.FAILURE
    report = json.loads(capsys.readouterr().out)
    [bad] = report["corrupted"]
    assert bad["path"] == str(damaged) and bad["chunks"] == 1 and bad["lost"][FRAMES] > 0
    assert main(["dataset", "build", str(tour_mcap), "-o", str(tmp_path / "full.npz")]) == 0
    part, full = Dataset.load(out), Dataset.load(tmp_path / "full.npz")
    # only the damaged chunk's samples go, and those whose scene labels were in it (said)
    unlabelled = [
        int(n)
        for w in report["warnings"]
        for n in re.findall(r"(\d+) of \d+ samples lost their scene labels", w)
    ]
    assert 0 < full.n - part.n <= bad["lost"][FRAMES] + sum(unlabelled)
    assert part.sequence[-1] == full.sequence[-1]  # the chunks after the damage are kept
    assert not part.meta["sessions"][0]["truncated"]
    assert main([*argv[:-2], "--force"]) == ExitCode.FAILURE
    assert "damaged: 1 chunk(s) skipped" in capsys.readouterr().err


@pytest.mark.parametrize("damaged", [True, False])
def test_samples_whose_labels_were_in_a_damaged_chunk_are_left_out(
    tour_mcap: Path, damaged: bool
) -> None:
    """A damaged chunk can hold the scene labels (ground-truth rows) of samples kept in
    another chunk: those samples are left out and counted; the build goes on (it raised
    "not written by spectratac record", exit 3, about one CI run in ten). In an intact
    recording a missing row still means a foreign file."""
    rec = read_recording(tour_mcap)
    assert rec.ground_truth is not None
    rec.ground_truth = rec.ground_truth[7:]  # the first seven samples' rows went with a chunk
    rec.corrupted_chunks = int(damaged)
    if not damaged:
        with pytest.raises(DatasetError, match="not written by `spectratac record`"):
            session_datasets(rec)
        return
    with pytest.warns(UnlabelledSamplesWarning) as caught:
        parts = session_datasets(rec)
    [warning] = [w.message for w in caught if isinstance(w.message, UnlabelledSamplesWarning)]
    assert warning.count == 7 and "7 of " in str(warning)
    full = session_datasets(read_recording(tour_mcap))
    assert sum(p.n for p in parts) == sum(p.n for p in full) - 7


def save_with_meta(path: Path, meta: object) -> Path:
    ds = Dataset.generic(np.ones((3, 2)), np.zeros((3, 1)), ["a", "b"], ["Fz"])
    np.savez(path, meta=np.array(json.dumps(meta)), **ds.arrays)
    return path


GOOD = {"format": "spectratac.dataset", "version": 1, "input_names": ["a", "b"],
        "target_names": ["Fz"]}  # fmt: skip


@pytest.mark.parametrize(
    "meta",
    [
        ["format", "spectratac.dataset"],
        "spectratac.dataset",
        {**GOOD, "version": "1"},
        {**GOOD, "input_names": 2},
        {**GOOD, "input_names": None},
        {**GOOD, "target_names": [1]},
        {k: v for k, v in GOOD.items() if k != "target_names"},
    ],
    ids=repr,
)
def test_a_malformed_meta_is_a_dataset_error(tmp_path: Path, meta: object) -> None:
    with pytest.raises(DatasetError):
        Dataset.load(save_with_meta(tmp_path / "m.npz", meta))


def test_text_where_numbers_belong_is_a_dataset_error(tmp_path: Path) -> None:
    path = save_with_meta(tmp_path / "m.npz", GOOD)
    arrays = dict(np.load(path))
    arrays["t_start"] = np.array(["x", "y", "z"])
    np.savez(path, **arrays)
    with pytest.raises(DatasetError, match=r"t_start|schema"):
        Dataset.load(path)


def test_a_crash_while_saving_leaves_no_half_written_dataset(tmp_path: Path, monkeypatch) -> None:
    ds = Dataset.generic(np.ones((3, 2)), np.zeros((3, 1)), ["a", "b"], ["Fz"])
    old = ds.save(tmp_path / "d.npz")

    def crash(file, *args, **kwargs) -> None:
        file.write(b"PK\x03\x04 half a zip")
        raise OSError("disk full")

    monkeypatch.setattr(np, "savez_compressed", crash)
    with pytest.raises(OSError, match="disk full"):
        ds.save(tmp_path / "new.npz")
    with pytest.raises(OSError, match="disk full"):
        ds.save(old)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d.npz"]
    assert Dataset.load(old).n == 3


@settings(
    max_examples=120, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(data=st.data())
def test_any_damaged_dataset_file_is_a_dataset_error_or_loads(tmp_path: Path, data) -> None:
    ds = Dataset.generic(np.arange(20.0).reshape(10, 2), np.zeros((10, 1)), ["a", "b"], ["Fz"])
    raw = bytearray(ds.save(tmp_path / "d.npz").read_bytes())
    for _ in range(data.draw(st.integers(1, 4))):
        raw[data.draw(st.integers(0, len(raw) - 1))] ^= data.draw(st.integers(1, 255))
    (tmp_path / "x.npz").write_bytes(bytes(raw))
    try:
        back = Dataset.load(tmp_path / "x.npz")
    except DatasetError:
        return
    assert back.n == 10 and back.input_names == ["a", "b"]


def test_a_zip_without_meta_is_not_a_dataset(tmp_path: Path) -> None:
    with zipfile.ZipFile(tmp_path / "z.npz", "w") as z:
        z.writestr("inputs.npy", b"junk")
    with pytest.raises(DatasetError):
        Dataset.load(tmp_path / "z.npz")


def test_a_generic_csv_that_is_not_utf8_is_a_dataset_error(tmp_path: Path) -> None:
    from spectratac.dataset.generic_io import load_any

    path = tmp_path / "latin1.csv"
    path.write_bytes("a,b,Fz\n1,2,3\n4,5,\xb06\n".encode("latin-1"))
    with pytest.raises(DatasetError, match=r"not UTF-8 text \(byte 0xb0 on line 3\)"):
        load_any(path)


def test_dataset_info_never_prints_the_files_control_characters(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    crafted = {**GOOD, "unit_id": "u\x1b]0;owned\x07\x1b[2J", "labels": "\x9b31m"}
    path = save_with_meta(tmp_path / "m.npz", crafted)
    assert main(["dataset", "info", str(path)]) == ExitCode.OK
    out = capsys.readouterr().out
    assert "\x1b" not in out and "\x07" not in out and "\x9b" not in out
    assert "\\x1b]0;owned" in out  # shown, escaped


def flag_encrypted(path: Path, member: str) -> None:
    """Set the "encrypted" bit (general purpose flag bit 0) of `member` in both of its zip
    headers, as a flipped byte in a damaged file can."""
    raw = bytearray(path.read_bytes())
    with zipfile.ZipFile(path) as z:
        info = z.getinfo(member)
    local = info.header_offset
    raw[local + 6] |= 0x01  # local file header: flags at offset 6
    central = raw.find(b"PK\x01\x02")
    while central >= 0:  # the central directory entry of the same member
        name_len = int.from_bytes(raw[central + 28 : central + 30], "little")
        if bytes(raw[central + 46 : central + 46 + name_len]) == member.encode():
            raw[central + 8] |= 0x01  # central directory header: flags at offset 8
            break
        central = raw.find(b"PK\x01\x02", central + 4)
    path.write_bytes(bytes(raw))


@pytest.mark.parametrize("member", ["meta.npy", "inputs.npy"])
def test_a_member_flagged_encrypted_is_a_dataset_error_that_says_what_to_do(
    tmp_path: Path, member: str
) -> None:
    path = Dataset.generic(np.ones((3, 2)), np.zeros((3, 1)), ["a", "b"], ["Fz"]).save(
        tmp_path / "d.npz"
    )
    flag_encrypted(path, member)
    with zipfile.ZipFile(path) as z:
        assert z.getinfo(member).flag_bits & 0x1  # the damage took
    with pytest.raises(DatasetError, match=rf"{member}.*encrypted.*(build|save) it again"):
        Dataset.load(path)
