"""A guided session recorded without a reference F/T builds into region labels and no force
targets (issue 35): the prompts give the region, the optical counts confirm the press."""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from spectratac.cli import main
from spectratac.dataset.build import build_datasets
from spectratac.dataset.labels import optical_guided_labels, truth_labels
from spectratac.record import GuidedProtocol, RecordOptions, read_recording, record_url


@pytest.fixture(scope="module")
def guided_recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("guided") / "g.mcap"
    record_url(
        "sim://?scene=guided&seed=3&prompts=4&speed=max",
        path,
        RecordOptions(),
        guided=GuidedProtocol(4, out=io.StringIO()),
    )
    return path


def test_no_targets_and_region_labels_that_agree_with_the_truth(guided_recording: Path) -> None:
    [ds] = build_datasets([guided_recording])
    assert ds.meta["labels"] == "guided" and ds.meta["force_targets"] == "none"
    assert np.isnan(ds.targets).all() and not ds.target_valid.any()
    rec = read_recording(guided_recording)
    rows = np.zeros(ds.n, [("sequence", "<u4"), ("t_end_us", "<i8")])
    rows["sequence"], rows["t_end_us"] = ds.arrays["sequence"], ds.arrays["device_time_us"]
    truth, contact, _ = truth_labels(rec.path, rec.ground_truth, rows)
    labelled = ds.region > 0
    assert set(np.unique(ds.region[labelled])) == {e["region"] for e in rec.labels
                                                   if e["source"] == "guided"}  # fmt: skip
    assert labelled.sum() >= 4 * 20  # most of each hold
    assert np.mean(truth[labelled] == ds.region[labelled]) >= 0.97  # firm, in that region
    assert np.mean(contact == ds.in_contact) >= 0.95
    assert set(np.unique(ds.press)) == {-1, 0, 1, 2, 3}


def test_the_cli_says_there_are_no_force_targets(
    guided_recording: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["dataset", "build", str(guided_recording), "-o", str(tmp_path / "g.npz")]) == 0
    out = capsys.readouterr().out
    assert "no force targets" in out and "--finetune" in out
    assert main(["dataset", "info", str(tmp_path / "g.npz"), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["force_targets"] is False


@settings(max_examples=40, deadline=None)
@given(
    level=st.floats(100.0, 60000.0),
    depth=st.floats(0.05, 0.8),
    noise=st.floats(0.0, 0.002),
    seed=st.integers(0, 2**16),
)
def test_optical_labels_take_the_held_press_not_the_prompt_span(
    level: float, depth: float, noise: float, seed: int
) -> None:
    """A press inside a prompt's span, whatever the light level and press depth: labelled
    where it is held, never before the finger arrives or outside the span."""
    rng = np.random.default_rng(seed)
    t = np.arange(200) * 0.05
    counts = np.full((200, 12), level) * (1 + noise * rng.standard_normal((200, 12)))
    held = (t >= 4.0) & (t < 6.0)
    counts[held] *= 1 - depth  # a press darkens the channels
    events = [{"index": 0, "region": 4, "t_start": 3.0, "t_end": 7.0}]
    region, press, contact = optical_guided_labels(events, t, counts, np.zeros(200, int))
    assert np.all(region[held] == 4) and np.all(region[~held] == -1)
    assert np.all(press[(t >= 3.0) & (t < 7.0)] == 0) and contact[held].all()
    assert not contact[~held].any()
