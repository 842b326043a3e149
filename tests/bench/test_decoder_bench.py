"""The decoder benchmarks run end to end on a tiny scale (no timing is asserted)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

pytestmark = pytest.mark.train


def test_speed_bench_quick(run_bench, tmp_path: Path) -> None:
    by = run_bench("decoder", "--quick", "--out", str(tmp_path))
    figs, names = list(by.values()), set(by)
    # quick grid: 2 integration times x 2 LED sequences x 2 models, latency + training each
    assert len(figs) == 2 * 2 * 2 * 2
    ref = next(f for f in figs if f["name"] == "50ms-white/resmlp latency")
    assert ref["ratio"] == 1.0 and "200ms-rgb/linear latency" in names
    slow = next(f for f in figs if f["name"] == "200ms-rgb/linear latency")["extra"]
    assert abs(slow["observations_per_s"] - 1000 / 600) < 1e-9
    assert any(f["extra"].get("pareto") for f in figs if f["name"].endswith("latency"))
    result = json.loads((tmp_path / "decoder_speed.json").read_text())
    assert len(result["rows"]) == 8 and result["config"]["epochs"] == 2
    md = (tmp_path / "decoder_speed.md").read_text()
    assert "| 200 | rgb | linear |" in md
    assert (tmp_path / "decoder_speed_pareto.png").read_bytes()[:4] == b"\x89PNG"


def test_one_point_of_the_grid(run_bench, tmp_path: Path) -> None:
    by = run_bench("decoder", "--quick", "--out", str(tmp_path), "--models",
                   "linear", "--integration", "100", "--sequences", "per-led")  # fmt: skip
    assert set(by) == {"100ms-per-led/linear latency", "100ms-per-led/linear training"}
    (row,) = json.loads((tmp_path / "decoder_speed.json").read_text())["rows"]
    assert row["sequence"] == "per-led" and row["steps"] == 3 and row["latency_ratio"] == 1.0


@pytest.mark.parametrize(
    ("option", "message"),
    [(["--models", "cnn"], "unknown models"), (["--integration", "75"], "choose one of")],
)
def test_a_bad_setting_is_a_usage_error(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], option: list[str],
    message: str,
) -> None:
    from tools.bench import decoder

    monkeypatch.setattr("sys.argv", ["decoder", "--quick", *option])
    with pytest.raises(SystemExit) as exit_:
        decoder.main()
    assert exit_.value.code == 2 and message in capsys.readouterr().err


def test_variants_bench_quick(run_bench, tmp_path: Path) -> None:
    by = run_bench("decoder", "--variants", "--quick", "--out", str(tmp_path), "--only", "contact",
                   "combined")  # fmt: skip
    assert by["paper blocked Fx MAE"]["ratio"] == 1.0
    assert {"contact blocked Fz MAE", "combined random Fy MAE", "combined latency"} <= set(by)
    target = by["target: worst force-axis MAE reduction of the best variant"]["extra"]
    assert isinstance(target["met"], bool) and target["target_pct"] == 25.0
    result = json.loads((tmp_path / "decoder_variants.json").read_text())
    rows = {r["name"]: r for r in result["rows"]}
    assert rows["combined"]["flops"] <= rows["paper"]["flops"]  # cost-matched by design
    assert rows["contact"]["blocked"]["contact_source"] == "head"
    assert rows["paper"]["blocked"]["contact_source"] == "derived from |F|"
    assert set(rows["combined"]["blocked"]["coverage"]) == {"0.68", "0.95"}
    assert "Oracle floor" in (tmp_path / "decoder_variants.md").read_text()
