"""Other sensors: CSV / column .npz in, generic decoder out, CLI included."""

from __future__ import annotations

import io
import json

import numpy as np
import pytest
from spectratac.cli import main
from spectratac.dataset import DatasetError
from spectratac.dataset.generic_io import load_any, load_table
from spectratac.decode import Decoder
from spectratac.train import TrainSpec, train

pytestmark = pytest.mark.train

POSITIONS = ("left", "center", "right")


def four_channel(n: int = 900, seed: int = 0) -> dict[str, np.ndarray]:
    """A 4-channel optical sensor: the channels respond to Fz with a position pattern."""
    rng = np.random.default_rng(seed)
    pos = rng.integers(0, 3, n)
    fz = rng.uniform(0, 5, n)
    pattern = np.array([[1, 0.2, 0.1, 0.5], [0.1, 1, 0.2, 0.5], [0.2, 0.1, 1, 0.5]])
    ch = 1000 + fz[:, None] * 100 * pattern[pos] + rng.normal(0, 2, (n, 4))
    label = np.where(fz > 0.5, np.array(POSITIONS)[pos], "")
    return {"t": np.arange(n) * 0.05, **{f"ch{i}": ch[:, i] for i in range(4)},
            "Fz": fz, "position": label}  # fmt: skip


def write_csv(path, cols: dict[str, np.ndarray]) -> None:
    names = list(cols)
    lines = [",".join(names)]
    for i in range(len(cols["t"])):
        lines.append(",".join(str(cols[k][i]) for k in names))
    path.write_text("# a comment line\n" + "\n".join(lines) + "\n")


def test_csv_and_npz_load_the_same_dataset(tmp_path) -> None:
    cols = four_channel(50)
    write_csv(tmp_path / "a.csv", cols)
    np.savez(tmp_path / "a.npz", **cols)
    a = load_any(tmp_path / "a.csv", targets=["Fz", "position"])
    b = load_any(tmp_path / "a.npz", targets=["Fz", "position"])
    assert a.input_names == ["ch0", "ch1", "ch2", "ch3"] == b.input_names
    np.testing.assert_allclose(a.inputs, b.inputs)
    np.testing.assert_array_equal(a.region, b.region)
    assert a.meta["region_labels"] == ["center", "left", "right"]
    assert a.meta["kind"] == "generic" and a.meta["region_name"] == "position"
    np.testing.assert_allclose(a.t_end, cols["t"])


def test_class_columns_by_suffix_or_integers_and_dropouts(tmp_path) -> None:
    (tmp_path / "b.csv").write_text("a,b,Fz,zone:class\n1,2,0.1,7\n2,3,,7\n3,4,0.3,-1\n")
    ds = load_table(tmp_path / "b.csv")
    assert ds.input_names == ["a", "b"] and ds.target_names == ["Fz"]
    assert ds.region.tolist() == [1, 1, -1] and ds.target_valid.tolist() == [True, False, True]
    (tmp_path / "c.csv").write_text("a,Fz,slot\n1,0.5,0\n2,1.5,2\n3,2.5,1\n")
    ds = load_table(tmp_path / "c.csv", inputs=["a"])
    assert ds.meta["region_labels"] == ["0", "1", "2"] and ds.region.tolist() == [1, 3, 2]
    with pytest.raises(DatasetError, match=r"'x' is not a number"):
        (tmp_path / "d.csv").write_text("a,Fz\n1,x\n")
        load_table(tmp_path / "d.csv", inputs=["a"], targets=["Fz"], classes=[])
    with pytest.raises(DatasetError, match=r"lines \[3\]"):
        (tmp_path / "e.csv").write_text("a,Fz\n1,2\n1\n")
        load_table(tmp_path / "e.csv")


def test_generic_decoder_learns_fz_and_position(tmp_path) -> None:
    cols = four_channel()
    write_csv(tmp_path / "s.csv", cols)
    ds = load_table(tmp_path / "s.csv", inputs=[f"ch{i}" for i in range(4)],
                    targets=["Fz", "position"])  # fmt: skip
    for features in ("generic", "raw"):
        spec = TrainSpec(features=features, targets=("Fz", "position"), epochs=40,
                         batch_size=64, hidden=32, blocks=1, threads=1)  # fmt: skip
        dec = train(ds, spec, rows=np.arange(700), progress=False)
        est = dec.predict(ds, rows=np.arange(700, 900))
        assert np.mean(np.abs(est.targets[:, 0] - cols["Fz"][700:])) < 0.5
        lab = ds.region[700:]
        assert np.mean(est.region[lab > 0] == lab[lab > 0]) > 0.8
        assert np.isnan(est.force[:, 0]).all() and dec.heads.n_classes == 3


def test_cli_trains_a_csv_sensor_and_exports(tmp_path, capsys) -> None:
    write_csv(tmp_path / "other.csv", four_channel(300))
    out = tmp_path / "other.stac"
    rc = main([
        "train", str(tmp_path / "other.csv"), "--inputs", "ch0,ch1,ch2,ch3",
        "--targets", "Fz,position", "-o", str(out), "--epochs", "3", "--hidden", "16",
        "--blocks", "1", "--threads", "1", "--export", "numpy,c", "--json", "--no-progress",
    ])  # fmt: skip
    assert rc == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["spec"]["features"] == "generic" and summary["n_train"] == 300
    assert set(summary["written"]) == {"model", "numpy", "c"}
    assert (tmp_path / "other.h").exists() and (tmp_path / "other.runtime.npz").exists()
    dec = Decoder.load(out)
    assert dec.meta["class_name"] == "position" and dec.target_names == ("Fz",)


def test_cli_errors_exit_3_with_the_reason(tmp_path, capsys) -> None:
    write_csv(tmp_path / "o.csv", four_channel(20))
    rc = main(["train", str(tmp_path / "o.csv"), "--targets", "Fz,Tq", "-o",
               str(tmp_path / "m.stac"), "--no-progress"])  # fmt: skip
    assert rc == 3 and "no column(s) ['Tq']" in capsys.readouterr().err
    rc = main(["train", str(tmp_path / "o.csv"), "-o", str(tmp_path / "m.stac"),
               "--export", "tflite"])  # fmt: skip
    assert rc == 3 and "--export tflite" in capsys.readouterr().err


def test_cli_trains_a_spectratac_dataset(twin_ds, tmp_path, capsys) -> None:
    path = twin_ds.subset(slice(0, 600)).save(tmp_path / "d.npz")
    rc = main(["train", str(path), "-o", str(tmp_path / "m.stac"), "--epochs", "2",
               "--hidden", "16", "--blocks", "1", "--context", "2", "--drift", "baseline",
               "--targets", "Fz,region,contact", "--no-progress"])  # fmt: skip
    text = capsys.readouterr().out
    assert rc == 0 and "paper33 features (context 2, drift baseline)" in text
    dec = Decoder.load(tmp_path / "m.stac")
    assert dec.layout.lags == (1, 2) and dec.layout.drift and dec.heads.contact


def test_cli_recipe_best_with_a_blocked_holdout(twin_ds, tmp_path, capsys) -> None:
    from spectratac.train.holdout import resolve

    path = twin_ds.save(tmp_path / "d.npz")
    rc = main(["train", str(path), "-o", str(tmp_path / "m.stac"), "--recipe", "best",
               "--epochs", "2", "--hidden", "16", "--holdout", "blocked", "--json",
               "--no-progress"])  # fmt: skip
    assert rc == 0
    summary = json.loads(capsys.readouterr().out)
    spec = summary["spec"]
    # best()'s fields survive unless an option replaces them
    assert (spec["context"], spec["blocks"], spec["hidden"], spec["epochs"]) == (8, 2, 16, 2)
    assert summary["mae_rows"] == "held-out" and summary["holdout"]["kind"] == "blocked"
    assert 0 < summary["n_test"] < twin_ds.n and summary["n_train"] < twin_ds.n - summary["n_test"]
    held = resolve(Decoder.load(tmp_path / "m.stac").meta, twin_ds)
    assert held.status == "split" and held.split.n_test == summary["n_test"]


def test_torque_columns_spelled_m_load_as_t(tmp_path) -> None:
    text = "ch0,ch1,Fz,Mx,Mz:class\n1,2,0.5,0.1,1\n3,4,0.7,0.2,2\n"
    ds = load_table(io.StringIO(text), inputs=["ch0", "ch1"], targets=["Fz", "Mx", "Mz"])
    assert ds.target_names == ["Fz", "Tx"] and ds.meta["region_name"] == "Tz"
    assert ds.targets[:, 1].tolist() == [0.1, 0.2]
    auto = load_table(io.StringIO("ch0,Fz,My\n1,0.5,0.1\n2,0.6,0.3\n"))
    assert auto.input_names == ["ch0"] and auto.target_names == ["Fz", "Ty"]
    with pytest.raises(DatasetError, match="columns Ty and My are the same torque"):
        load_table(io.StringIO("ch0,Ty,My\n1,0.5,0.1\n"))


def test_evaluate_reads_every_format_train_reads(tmp_path, capsys) -> None:
    write_csv(tmp_path / "train.csv", four_channel(300))
    out = tmp_path / "m.stac"
    argv = ["train", str(tmp_path / "train.csv"), "--targets", "Fz,position", "-o", str(out),
            "--epochs", "3", "--hidden", "16", "--blocks", "1", "--threads", "1", "--no-progress",
            "--inputs", "ch0,ch1,ch2,ch3"]  # fmt: skip
    assert main(argv) == 0
    assert main(argv) == 3 and "already exists; pass --force" in capsys.readouterr().err
    assert main([*argv, "--force"]) == 0
    capsys.readouterr()
    fresh = four_channel(120, seed=1)
    write_csv(tmp_path / "fresh.csv", fresh)
    np.savez(tmp_path / "fresh_columns.npz", **fresh)
    for data in ("fresh.csv", "fresh_columns.npz"):
        rc = main(["evaluate", str(out), str(tmp_path / data), "-o", str(tmp_path / data[:-4]),
                   "--oracle-samples", "0", "--no-progress", "--json"])  # fmt: skip
        assert rc == 0, capsys.readouterr().err
        rep = json.loads(capsys.readouterr().out)
        assert rep["sections"]["all"]["n_rows"] == 120
        assert rep["sections"]["all"]["decoder"]["components"]["Fz"]["mae"] < 2.5
    del fresh["ch3"]
    write_csv(tmp_path / "short.csv", fresh)
    rc = main(["evaluate", str(out), str(tmp_path / "short.csv"), "-o", str(tmp_path / "s")])
    assert rc == 3 and "['ch3']" in capsys.readouterr().err
