"""Pieces of the decoder benchmarks: acquisition settings, Pareto front, target check."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from spectratac.hardware.generated.veml3328 import INTEGRATION_MS
from spectratac.studies.bench.acquisition import Acquisition, AcquisitionError, grid
from spectratac.studies.bench.latency import side_by_side_latency
from spectratac.studies.bench.speed import batch_for, pareto_front
from spectratac.studies.bench.variants import add_improvements, merge_seeds, target_check
from spectratac.twin import builtin_scenes as scenes
from spectratac.twin import generate_session


def test_every_acquisition_is_fairly_exposed_and_unsaturated() -> None:
    scene = scenes.single_press(6, 8.0, (2.0, 1.0), hold_s=1.0)
    levels = []
    for a in grid():
        steps = a.led_steps()
        assert steps.shape == (a.steps, 3, 3) and steps.min() >= 0 and steps.max() <= 1
        s = generate_session(scene, seed=1, **a.settings())
        assert not s.saturated.any(), a.name
        levels.append(s.counts[:, :, 3].mean())
        assert a.observations_per_s == pytest.approx(1000 / (a.integration_ms * a.steps))
    # The resting clear level stays within a factor 1.5 of the paper's setting everywhere.
    assert max(levels) / min(levels) < 1.5
    assert [a.observations_per_s for a in grid()] == sorted(
        (a.observations_per_s for a in grid()), reverse=True
    )
    with pytest.raises(AcquisitionError, match="choose one of"):
        Acquisition(75)
    with pytest.raises(AcquisitionError, match="choose one of"):
        Acquisition(50, "uv")


def test_batch_keeps_steps_per_epoch() -> None:
    for it in INTEGRATION_MS:
        assert batch_for(it) * it == batch_for(50) * 50


@given(st.lists(st.tuples(st.floats(0.1, 100), st.floats(0.01, 5)), min_size=1, max_size=30))
def test_pareto_front_is_exactly_the_undominated_points(pts) -> None:
    front = set(pareto_front(pts))
    assert front
    for i, (r, e) in enumerate(pts):
        beaten = any(
            (r2 >= r and e2 <= e) and (r2 > r or e2 < e) for j, (r2, e2) in enumerate(pts) if j != i
        )
        assert (i in front) != beaten


def _row(name: str, mae: tuple[float, float, float], flops: int) -> dict:
    m = dict(zip(("Fx", "Fy", "Fz"), mae, strict=True))
    return {"name": name, "flops": flops, "blocked": {"mae": m}, "random": {"mae": dict(m)}}


def test_target_check_needs_every_axis_and_the_cost() -> None:
    paper = _row("paper", (0.2, 0.2, 0.4), 100)
    ok = _row("good", (0.14, 0.15, 0.3), 100)
    costly = _row("costly", (0.1, 0.1, 0.2), 103)  # beyond the 2 % tolerance
    head = _row("head", (0.14, 0.15, 0.3), 101)  # one more output: within it
    one_axis = _row("fz_only", (0.2, 0.19, 0.1), 90)
    assert target_check([paper, ok])["met"] and target_check([paper, head])["met"]
    assert not target_check([paper, one_axis])["met"]
    chk = target_check([paper, costly, one_axis])
    assert not chk["met"] and chk["best"] == "fz_only" and chk["within_cost"]
    assert chk["best_overall"] == "costly"
    assert not target_check([paper, costly])["within_cost"]
    rows = [paper, ok]
    add_improvements(rows)
    assert ok["blocked"]["improvement_pct"]["Fx"] == pytest.approx(30.0)
    assert paper["random"]["improvement_pct"]["Fz"] == 0.0


def test_latency_is_measured_for_every_function() -> None:
    x = np.ones((3, 4))
    r = side_by_side_latency({"sum": np.sum, "copy": np.copy}, x, calls=20, rounds=2)
    assert r["sum"]["calls"] == 40 and r["copy"]["p99_us"] >= r["copy"]["median_us"] > 0


def test_seeds_are_merged_into_means_with_spread() -> None:
    a = _row("x", (0.2, 0.2, 0.4), 100)
    b = _row("x", (0.4, 0.2, 0.4), 100)
    for r in (a, b):
        for k in ("r2_mean", "r2_min", "region_accuracy", "contact_accuracy", "train_s"):
            r["blocked"][k] = r["random"][k] = 1.0
    del b["random"]  # extra seeds run the blocked split only
    m = merge_seeds([a, b])
    assert m["blocked"]["mae"]["Fx"] == pytest.approx(0.3) and m["blocked"]["seeds"] == 2
    assert m["blocked"]["mae_std"]["Fx"] == pytest.approx(np.std([0.2, 0.4], ddof=1))
    assert m["blocked"]["mae_std"]["Fy"] == 0.0
    assert m["random"]["seeds"] == 1 and m["random"]["mae"] == a["random"]["mae"]
