"""Readers of users' files stay within bounds (issue 36): a zip bomb posing as a model, or JSON
nested deeper than any file of the toolkit, is a typed error found before anything is inflated
or parsed, never a MemoryError, a RecursionError or gigabytes of memory."""

from __future__ import annotations

import io
import json
import tracemalloc
import zipfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from spectratac.bounds import MAX_JSON_DEPTH, BoundsError, json_depth, loads_bounded
from spectratac.cli import main
from spectratac.dataset import Dataset
from spectratac.dataset.schema import DatasetError
from spectratac.decode.decoder import Decoder
from spectratac.decode.errors import DecoderFileError
from spectratac.decode.stac_file import MAX_ARRAYS_BYTES

from tests.decode.test_model_file import tiny_decoder

#: What reading any of these hostile files may cost at most (the bombs inflate to > 256 MB).
PEAK_BYTES = 64 * 2**20


def nested(depth: int) -> str:
    return '{"a": ' * depth + "1" + "}" * depth


@pytest.fixture(scope="module")
def good(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tiny_decoder().save(tmp_path_factory.mktemp("m") / "m.stac")


def members(path: Path) -> dict[str, bytes]:
    with zipfile.ZipFile(path) as z:
        return {n: z.read(n) for n in z.namelist()}


def zeros_member(z: zipfile.ZipFile, name: str, size: int) -> None:
    """A member of `size` zero bytes, deflated (about a thousandth of its size on disk)."""
    chunk = bytes(2**20)
    info = zipfile.ZipInfo(name)
    info.compress_type = zipfile.ZIP_DEFLATED
    with z.open(info, "w", force_zip64=True) as f:
        for _ in range(size // len(chunk)):
            f.write(chunk)


def with_member(good: Path, out: Path, name: str, size: int) -> Path:
    parts = members(good)
    with zipfile.ZipFile(out, "w", compression=zipfile.ZIP_DEFLATED) as z:
        for n, data in parts.items():
            if n != name:
                z.writestr(n, data)
        zeros_member(z, name, size)
    return out


def loads_within_bounds(path: Path, match: str) -> None:
    tracemalloc.start()
    try:
        with pytest.raises(DecoderFileError, match=match):
            Decoder.load(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < PEAK_BYTES, f"{peak / 2**20:.0f} MB to refuse {path.name}"


def test_a_zip_bomb_model_is_refused_from_its_directory(good: Path, tmp_path: Path) -> None:
    bomb = with_member(good, tmp_path / "bomb.stac", "arrays.npz", MAX_ARRAYS_BYTES + 2**20)
    assert bomb.stat().st_size < 2 * 2**20  # the 1.0 MB file
    loads_within_bounds(bomb, "arrays.npz declares .* bytes inflated")
    meta_bomb = with_member(good, tmp_path / "meta.stac", "meta.json", 64 * 2**20)
    loads_within_bounds(meta_bomb, "meta.json declares")


def test_a_bomb_inside_the_arrays_is_refused_too(good: Path, tmp_path: Path) -> None:
    inner = io.BytesIO()
    with zipfile.ZipFile(inner, "w", compression=zipfile.ZIP_DEFLATED) as z:
        zeros_member(z, "w.npy", MAX_ARRAYS_BYTES + 2**20)
    parts = members(good) | {"arrays.npz": inner.getvalue()}
    path = tmp_path / "inner.stac"
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_STORED) as z:
        for n, data in parts.items():
            z.writestr(n, data)
    loads_within_bounds(path, "declares .* bytes inflated")


@pytest.mark.parametrize("depth", [MAX_JSON_DEPTH + 10, 100_000])
def test_deeply_nested_meta_is_a_typed_error(good: Path, tmp_path: Path, depth: int) -> None:
    parts = members(good) | {"meta.json": nested(depth).encode()}
    path = tmp_path / "deep.stac"
    with zipfile.ZipFile(path, "w") as z:
        for n, data in parts.items():
            z.writestr(n, data)
    loads_within_bounds(path, f"nests {depth + 0} levels deep; at most {MAX_JSON_DEPTH}")


def test_decode_and_model_upload_refuse_the_deep_model_with_exit_3(
    good: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    parts = members(good) | {"meta.json": nested(100_000).encode()}
    path = tmp_path / "deep.stac"
    with zipfile.ZipFile(path, "w") as z:
        for n, data in parts.items():
            z.writestr(n, data)
    for argv in (["decode", str(path), "sim://?seed=1", "--count", "1"],
                 ["model", "upload", "sim://?seed=1", str(path)]):  # fmt: skip
        assert main(argv) == 3, argv
        err = capsys.readouterr().err
        assert "nests 100000 levels deep" in err and "Traceback" not in err, err


def test_a_dataset_with_deep_meta_is_a_dataset_error(tmp_path: Path) -> None:
    x = np.zeros((4, 2))
    ds = Dataset.generic(x, x[:, :1], ["a", "b"], ["Fz"])
    path = ds.save(tmp_path / "d.npz")
    arrays = dict(np.load(path, allow_pickle=False))
    arrays["meta"] = np.array(nested(MAX_JSON_DEPTH + 10))
    np.savez(path, **arrays)
    with pytest.raises(DatasetError, match="its meta nests 74 levels deep"):
        Dataset.load(path)


def test_a_recording_with_a_deep_json_message_reads_the_rest(tmp_path: Path) -> None:
    from spectratac.record import RecordOptions, record_url
    from spectratac.record.errors import CorruptedRecordingWarning
    from spectratac.record.format import LABELS
    from spectratac.record.reader import read_recording
    from spectratac.record.writer import RecordingWriter

    path = tmp_path / "s.mcap"
    real = RecordingWriter.close

    def close(self: RecordingWriter) -> None:  # a hostile label message before the end
        self._mcap.add_message(self._channels[LABELS], 1, nested(100_000).encode(), 1)
        real(self)

    RecordingWriter.close = close  # type: ignore[method-assign]
    try:
        record_url("sim://?scene=tour&speed=max", path, RecordOptions(samples=20))
    finally:
        RecordingWriter.close = real  # type: ignore[method-assign]
    with pytest.warns(CorruptedRecordingWarning, match="messages lost: 1 /labels"):
        rec = read_recording(path)
    assert len(rec.frames) > 0 and rec.lost_messages.get(LABELS) == 1


JSON = st.recursive(
    st.none() | st.booleans() | st.integers() | st.text(alphabet='[]{}"\\ab,:'),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=3), inner,
                                                                max_size=3),
    max_leaves=30,
)  # fmt: skip


def true_depth(v: object) -> int:
    if isinstance(v, dict):
        return 1 + max(map(true_depth, v.values()), default=0)
    if isinstance(v, list):
        return 1 + max(map(true_depth, v), default=0)
    return 0


@settings(max_examples=300, deadline=None)
@given(JSON)
def test_the_depth_is_counted_outside_strings(value: object) -> None:
    text = json.dumps(value)
    assert json_depth(text) == true_depth(value)
    assert loads_bounded(text, what="x", max_depth=max(true_depth(value), 1)) == value
    if true_depth(value) > 1:
        with pytest.raises(BoundsError, match="levels deep"):
            loads_bounded(text, what="x", max_depth=true_depth(value) - 1)
