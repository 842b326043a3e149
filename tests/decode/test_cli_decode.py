"""`spectratac decode MODEL URL`: a trained decoder run live on the simulated sensor."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from spectratac.cli import main
from spectratac.decode import Decoder
from spectratac.train import TrainSpec, train

from tests.decode.conftest import synthetic

pytestmark = pytest.mark.train

TOUR = "sim://?scene=tour&seed=1&speed=max"


@pytest.fixture(scope="module")
def model(twin_ds, tmp_path_factory) -> Path:
    spec = TrainSpec.paper(epochs=2, hidden=16, blocks=1, threads=1, context=2, drift="baseline")
    return train(twin_ds, spec, progress=False).save(tmp_path_factory.mktemp("m") / "m.stac")


def test_streams_estimates_as_jsonl(model, capsys) -> None:
    assert main(["decode", str(model), TOUR, "--count", "15", "--format", "jsonl"]) == 0
    out, err = capsys.readouterr()
    rows = [json.loads(line) for line in out.splitlines()]
    assert len(rows) == 15 and "15 estimates" in err
    t = np.array([r["t_s"] for r in rows])
    assert t[0] == 0.0 and (np.diff(t) >= 0).all()
    for r in rows:
        assert len(r["force"]) == 3 and len(r["torque"]) == 3 and not r["invalid"]
        assert all(isinstance(v, float) for v in r["force"])
        assert 1 <= r["region"] <= 9 and 0.0 < r["region_prob"] <= 1.0


def test_table_and_csv_have_one_row_per_estimate(model, capsys) -> None:
    assert main(["decode", str(model), TOUR, "--count", "4", "--format", "csv"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("t_s,host_s,Fx,Fy,Fz") and len(lines) == 5
    assert main(["decode", str(model), TOUR, "--count", "4"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].split()[:2] == ["t_s", "host_s"] and len(lines) == 5


def test_configures_the_sensor_as_trained_or_refuses_its_own(model, tmp_path, capsys) -> None:
    dec = Decoder.load(model)
    dec.meta["config"] = dict(dec.config, integration_ms=100)
    other = dec.save(tmp_path / "100ms.stac")
    # Configured as trained (100 ms): decodes.
    assert main(["decode", str(other), TOUR, "--count", "3", "--format", "jsonl"]) == 0
    assert len(capsys.readouterr().out.splitlines()) == 3
    # The device's own configuration (50 ms) is not the model's: refused, exit 3, reason given.
    assert main(["decode", str(other), TOUR, "--count", "3", "--keep-config"]) == 3
    err = capsys.readouterr().err
    assert "integration_ms: trained 100, got 50" in err


def test_bad_arguments_and_models_without_a_configuration(tmp_path, capsys) -> None:
    ds = synthetic()
    ds.meta["config"] = None
    dec = train(ds, TrainSpec.paper(epochs=1, hidden=8, blocks=1, threads=1), progress=False)
    path = dec.save(tmp_path / "noconfig.stac")
    assert main(["decode", str(path), TOUR, "--count", "2"]) == 3
    assert "--keep-config" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exit_:  # a usage error (cli.values), before any open
        main(["decode", str(path), TOUR, "--count", "-1"])
    assert exit_.value.code == 2 and "--count: -1 is" in capsys.readouterr().err
    assert main(["decode", str(tmp_path / "missing.stac"), TOUR]) == 3


@pytest.mark.parametrize("speed", ["10", "max"])
def test_duration_is_the_sensors_clock(model, capsys, speed) -> None:
    """--duration 1.5 is exactly the 30 samples of 50 ms whose windows it spans, at any speed
    (it was wall seconds: 300 samples at speed=10), as for record, stream and snake."""
    url = f"sim://?scene=tour&seed=1&speed={speed}"
    assert main(["decode", str(model), url, "--duration", "1.5", "--format", "jsonl"]) == 0
    rows = capsys.readouterr().out.splitlines()
    assert len(rows) == 30, f"{len(rows)} estimates for 1.5 s of 50 ms windows, not 30"


def test_duration_holds_when_samples_arrive_in_bursts(model, capsys) -> None:
    """A host that reads late (a loaded machine; here a link that holds the device's output
    for 0.1 s every 0.05 s) receives samples in bursts: host seconds times the clock scale
    stopped early or late (a 0.1 s stall is a whole sensor second at speed=10). The span is
    counted on the device's own timestamps."""
    url = "sim://?scene=tour&seed=1&speed=10&fault=stall&fault_stall=0.1&fault_every=0.05"
    assert main(["decode", str(model), url, "--duration", "1.5", "--format", "jsonl"]) == 0
    rows = capsys.readouterr().out.splitlines()
    assert len(rows) == 30, f"{len(rows)} estimates for 1.5 s of 50 ms windows, not 30"


def test_t_s_is_the_sensors_clock_and_host_time_stands_beside_it(
    model: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """At speed=10 consecutive estimates are 50 ms apart on the sensor's clock; before, t_s
    was the host's arrival time (0.000, 0.000, 0.001, 0.001, 0.007: clumped)."""
    from spectratac.cli.decode_cmd import SensorClock

    url = "sim://?scene=tour&seed=1&speed=10"
    assert main(["decode", str(model), url, "--count", "8", "--format", "jsonl"]) == 0
    rows = [json.loads(line) for line in capsys.readouterr().out.splitlines() if line]
    t = [r["t_s"] for r in rows]
    assert t[0] == 0.0 and np.allclose(np.diff(t), 0.05, atol=1e-6)
    assert all("host_s" in r for r in rows)
    clock = SensorClock()  # across a reconnect, sensor time goes on
    assert [clock(100, 0), clock(50_100, 0), clock(7, 1), clock(50_007, 1)] == [0, 0.05, 0.05, 0.1]
