"""The dataset file contract: round trip, validation, joining sessions."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from spectratac.dataset import Dataset, DatasetError, concat, split_by_config
from spectratac.sim.twin_dataset import from_twin_session
from spectratac.twin import Scene, generate_session


@pytest.fixture(scope="module")
def twin_ds() -> Dataset:
    scene = Scene.single_press(x=-3.0, normal_n=5.0)
    return from_twin_session(generate_session(scene, seed=2), scene)


def test_round_trip_keeps_arrays_and_meta(tmp_path: Path, twin_ds: Dataset) -> None:
    back = Dataset.load(twin_ds.save(tmp_path / "d.npz"))
    assert back.meta == twin_ds.meta
    for k, v in twin_ds.arrays.items():
        np.testing.assert_array_equal(back.arrays[k], v)
        assert back.arrays[k].dtype == v.dtype
    assert back.meta["config"]["integration_ms"] == 50
    assert set(np.unique(back.press)) == {-1, 0}


def test_bad_files_and_arrays_are_named(tmp_path: Path, twin_ds: Dataset) -> None:
    np.savez(tmp_path / "other.npz", x=np.zeros(3))
    with pytest.raises(DatasetError, match="not a SpectraTac dataset"):
        Dataset.load(tmp_path / "other.npz")
    (tmp_path / "junk.npz").write_bytes(b"not a zip")
    with pytest.raises(DatasetError, match="cannot read"):
        Dataset.load(tmp_path / "junk.npz")
    arrays = dict(twin_ds.arrays, region=twin_ds.region[:-1])
    with pytest.raises(DatasetError, match="'region' has shape"):
        Dataset(arrays, dict(twin_ds.meta))


def test_concat_renumbers_and_refuses_mixed_configs(twin_ds: Dataset) -> None:
    both = concat([twin_ds, twin_ds])
    assert both.n == 2 * twin_ds.n and set(np.unique(both.session)) == {0, 1}
    assert set(np.unique(both.press)) == {-1, 0, 1} and len(both.meta["sessions"]) == 2
    other = twin_ds.subset(slice(None))
    other.meta = {**other.meta, "config": {**other.meta["config"], "integration_ms": 100}}
    with pytest.raises(DatasetError, match="different sensor configurations"):
        concat([twin_ds, other])
    groups = split_by_config([twin_ds, other, twin_ds])
    assert sorted(g.n for g in groups) == [twin_ds.n, 2 * twin_ds.n]
