"""A guided session without a reference F/T (issue 35): the simulated person of
`sim://?scene=guided` presses what the recorder prompts, and the recorder writes its prompts
as labels on the sensor's clock (LABELS.md)."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest
from spectratac.record import GuidedProtocol, RecordOptions, read_recording, record_url
from spectratac.record.guided import HOLD_S, schedule
from spectratac.sim.guided_person import FORCE_N, REACT_S, guided_scene
from spectratac.sim.named_scenes import make_scene
from spectratac.sim.url import SimURLError, parse_sim_url
from spectratac.twin.errors import TwinError
from spectratac.twin.geometry import region_of


@pytest.mark.parametrize("seed", [1, 4])
def test_the_person_presses_each_prompt_in_its_region_after_it(seed: int) -> None:
    scene = guided_scene(seed)
    plan = schedule(9)
    p = scene.presses
    assert [int(r) for r in region_of(p.x, p.y)] == [q.region for q in plan]
    assert sorted(q.region for q in plan) == list(range(1, 10))  # one press per region
    go = np.array([q.go for q in plan])
    release = np.array([q.release for q in plan])
    assert np.all(p.start >= go + REACT_S[0]) and np.all(p.start <= go + REACT_S[1])
    assert np.all(p.start + p.rise < release) and np.all(p.end > release)  # holds past it
    assert np.all((FORCE_N[0] <= p.normal_peak) & (p.normal_peak <= FORCE_N[1]))
    assert 60.0 <= scene.duration_s <= 80.0  # about a minute of sensor time


def test_the_scene_is_named_and_takes_the_prompt_count() -> None:
    assert len(make_scene("guided", seed="2", prompts="3").presses) == 3
    assert parse_sim_url("sim://?scene=guided&prompts=12&rest=1").scene_params == {
        "prompts": "12",
        "rest": "1",
    }
    with pytest.raises(SimURLError, match="prompts"):
        parse_sim_url("sim://?scene=guided&prompts=0")
    with pytest.raises(TwinError, match="guided scene"):
        guided_scene(prompts=0)


def _record(tmp_path: Path, n: int, url: str) -> tuple[Path, str]:
    out = io.StringIO()
    path = tmp_path / "g.mcap"
    summary = record_url(url, path, RecordOptions(), guided=GuidedProtocol(n, out=out))
    assert summary.stopped_by == "guided"
    return path, out.getvalue()


def test_prompts_are_labels_on_the_sensor_clock_and_match_what_was_pressed(
    tmp_path: Path,
) -> None:
    path, text = _record(tmp_path, 3, "sim://?scene=guided&seed=2&prompts=3&speed=max")
    rec = read_recording(path)
    assert rec.session["labels"] == "guided" and rec.ft is None
    guided = [e for e in rec.labels if e["source"] == "guided"]
    scene = {e["index"]: e for e in rec.labels if e["source"] == "scene"}
    plan = schedule(3)
    assert [(e["index"], e["region"]) for e in guided] == [(q.index, q.region) for q in plan]
    for e, q in zip(guided, plan, strict=True):
        assert e["clock"] == "device" and e["epoch"] == rec.epochs[0]["epoch"]
        assert e["t_end"] - e["t_start"] == pytest.approx(HOLD_S)
        # the schedule starts with the first sample's integration, on the device clock
        assert e["t_start"] == pytest.approx(q.go, abs=0.06)
        truth = scene[e["index"]]  # what the person did: later than the prompt, same region
        assert truth["region"] == e["region"] and truth["scene_start"] > e["t_start"]
    assert text.count("release") == 3 and f"PRESS region {plan[1].region}" in text


def test_the_protocol_runs_on_the_sensor_clock_not_the_hosts() -> None:
    g = GuidedProtocol(2, regions=[3, 7], countdown_s=1, hold_s=1.0, rest_s=1.0, out=io.StringIO())
    g.start_at(0.0)
    assert g.poll(1.5) == [] and not g.done(5.9)
    events = g.poll(100.0)  # polled late (a fast device): both labels, at their schedule
    assert [(e["region"], e["t_start"], e["t_end"]) for e in events] == [
        (3, 1.0, 2.0),
        (7, 4.0, 5.0),
    ]
    assert g.done(6.0)
