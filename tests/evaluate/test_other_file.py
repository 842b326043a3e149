"""`spectratac evaluate` on files the model was not trained on, and on held-out sessions
(`train --holdout-sessions`, `evaluate --holdout-sessions`), in every format train reads."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from spectratac.cli import main
from spectratac.dataset.generic_io import load_data
from spectratac.decode import Decoder
from spectratac.evaluate.run import evaluate_model
from spectratac.train.holdout import (
    SessionLeakError,
    SessionSelectionError,
    check_sessions_unseen,
    parse_sessions,
)

pytestmark = pytest.mark.train

COLUMNS = ["a", "b", "c", "Fz", "position", "session", "press", "t"]


def _table(seed: int, sessions: int = 4, n: int = 150, gain: float = 1.0) -> dict[str, list]:
    """A generic sensor: Fz a smooth function of three channels, a position class."""
    rng = np.random.default_rng(seed)
    cols: dict[str, list] = {k: [] for k in COLUMNS}
    for s in range(sessions):
        x = rng.uniform(0.0, 1.0, (n, 3))
        fz = 2.0 * x[:, 0] - x[:, 1] + 0.5 * x[:, 2] ** 2
        cols["a"] += list(gain * x[:, 0])
        cols["b"] += list(x[:, 1])
        cols["c"] += list(x[:, 2])
        cols["Fz"] += list(fz)
        cols["position"] += ["left" if v > 0.5 else "right" for v in x[:, 0]]
        cols["session"] += [s] * n
        cols["press"] += list(np.arange(n) // 10 + 100 * s)
        cols["t"] += list(np.arange(n) * 0.05)
    return cols


def _csv(path: Path, cols: dict[str, list]) -> Path:
    lines = [",".join(COLUMNS)]
    lines += [",".join(str(cols[k][i]) for k in COLUMNS) for i in range(len(cols["a"]))]
    path.write_text("\n".join(lines) + "\n")
    return path


def _column_npz(path: Path, cols: dict[str, list]) -> Path:
    np.savez(path, **{k: np.asarray(v) for k, v in cols.items()})
    return path


TRAIN = ["--inputs", "a,b,c", "--targets", "Fz,position", "--epochs", "3", "--hidden", "16"]
TRAIN += ["--blocks", "1", "--no-progress"]


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("other_file")
    out = {
        "train": _csv(d / "train.csv", _table(0)),
        "other_csv": _csv(d / "other.csv", _table(1, sessions=2)),
        "other_npz": _column_npz(d / "other_columns.npz", _table(2, sessions=2)),
    }
    ds = load_data([out["other_csv"]], ["a", "b", "c"], ["Fz", "position"])
    out["other_dataset"] = ds.save(d / "other_dataset.npz")
    assert main(["train", str(out["train"]), "-o", str(d / "m.stac"), *TRAIN]) == 0
    sessions = [*TRAIN, "--holdout-sessions", "2-3"]
    assert main(["train", str(out["train"]), "-o", str(d / "held.stac"), *sessions]) == 0
    out["model"], out["held"] = d / "m.stac", d / "held.stac"
    return out


def _evaluate(capsys: pytest.CaptureFixture[str], argv: list[str]) -> dict:
    capsys.readouterr()
    assert main(["evaluate", *argv, "--oracle-samples", "0", "--no-progress", "--json"]) == 0
    return json.loads(capsys.readouterr().out)


@pytest.mark.parametrize("kind", ["other_csv", "other_npz", "other_dataset"])
def test_every_row_of_another_file_is_scored(files, tmp_path, capsys, kind) -> None:
    rep = _evaluate(capsys, [str(files["model"]), str(files[kind]), "-o", str(tmp_path / "r")])
    sec = rep["sections"]["all"]
    assert sec["n_rows"] == 300  # two sessions of 150 rows
    assert set(sec["per_session"]) == {"0", "1"}
    assert sum(s["n"] for s in sec["per_session"].values()) == 300
    overall = sec["decoder"]["components"]["Fz"]["mae"]
    per = [s["mae"]["Fz"] for s in sec["per_session"].values()]
    assert min(per) <= overall <= max(per)
    assert "another dataset" in rep["notes"][0] or "does not record" in rep["notes"][0]


def test_train_records_held_out_sessions_and_evaluate_scores_them(files, tmp_path, capsys):
    meta = Decoder.load(files["held"]).meta["holdout"]
    assert meta["sessions"] == {"held_out": [2, 3], "trained": [0, 1]}
    assert meta["n_train"] == 300
    rep = _evaluate(capsys, [str(files["held"]), str(files["train"]), "-o", str(tmp_path / "a")])
    assert list(rep["sections"]) == ["sessions"]
    assert set(rep["sections"]["sessions"]["per_session"]) == {"2", "3"}
    one = _evaluate(
        capsys,
        [
            str(files["held"]),
            str(files["train"]),
            "-o",
            str(tmp_path / "b"),
            *["--holdout-sessions", "3"],
        ],
    )
    assert one["sections"]["sessions"]["n_rows"] == 150
    assert list(one["sections"]["sessions"]["per_session"]) == ["3"]


def test_human_output_lists_sessions(files, tmp_path, capsys) -> None:
    argv = [str(files["held"]), str(files["train"]), "-o", str(tmp_path / "h")]
    assert main(["evaluate", *argv, "--oracle-samples", "0", "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert "session    2 (150 rows)" in out and "session    3 (150 rows)" in out
    assert "| session | unit | rows | Fz MAE |" in (tmp_path / "h" / "report.md").read_text()


@pytest.mark.parametrize(
    ("sessions", "message"),
    [
        ("1,2", "trained on sessions 1 of this dataset"),
        ("0-3", "trained on sessions 0-1 of this dataset"),
        ("9", "sessions 9 are not in this dataset; it has sessions 0-3"),
        ("2-x", "is neither a session id nor a range"),
        ("3-2", "not a range low-high"),
    ],
)
def test_sessions_that_cannot_be_scored_are_refused(files, tmp_path, capsys, sessions, message):
    argv = [str(files["held"]), str(files["train"]), "-o", str(tmp_path / "r")]
    assert main(["evaluate", *argv, "--holdout-sessions", sessions, "--oracle-samples", "0"]) == 3
    assert message in capsys.readouterr().err
    assert not (tmp_path / "r").exists()


def test_a_model_trained_on_every_row_refuses_any_session(files) -> None:
    ds = load_data([files["train"]], ["a", "b", "c"], ["Fz", "position"])
    full = Decoder.load(files["model"])
    # training without a hold-out records the dataset: every session of it was seen
    with pytest.raises(SessionLeakError, match="trained on sessions 2"):
        check_sessions_unseen(full.meta, ds, [2])
    # a model without the record is allowed with a caveat (it could have seen them)
    assert "only meaningful if the model never saw them" in check_sessions_unseen({}, ds, [2])
    held = Decoder.load(files["held"])
    with pytest.raises(SessionLeakError, match="trained on sessions 0"):
        evaluate_model(held, ds, sessions=[0])


def test_a_split_model_refuses_sessions_it_trained_on(files, tmp_path) -> None:
    model = tmp_path / "split.stac"
    split = ["--holdout", "random"]
    assert main(["train", str(files["train"]), "-o", str(model), *TRAIN, *split]) == 0
    ds = load_data([files["train"]], ["a", "b", "c"], ["Fz", "position"])
    with pytest.raises(SessionLeakError, match="trained on sessions 1"):
        check_sessions_unseen(Decoder.load(model).meta, ds, [1])


def test_train_refuses_both_holdouts_and_unknown_sessions(files, tmp_path, capsys) -> None:
    out = str(tmp_path / "x.stac")
    both = ["--holdout", "blocked", "--holdout-sessions", "1"]
    assert main(["train", str(files["train"]), "-o", out, *TRAIN, *both]) == 3
    assert "not both" in capsys.readouterr().err
    assert main(["train", str(files["train"]), "-o", out, *TRAIN, "--holdout-sessions", "7"]) == 3
    assert "sessions 7 are not in this dataset" in capsys.readouterr().err


def test_wrong_columns_are_a_typed_error(files, tmp_path, capsys) -> None:
    bad = _table(3, sessions=1)
    bad["d"] = bad.pop("c")
    path = tmp_path / "bad.csv"
    cols = [k if k != "c" else "d" for k in COLUMNS]
    path.write_text(
        "\n".join([",".join(cols)] + [",".join(str(bad[k][i]) for k in cols) for i in range(150)])
        + "\n"
    )
    assert main(["evaluate", str(files["model"]), str(path), "-o", str(tmp_path / "r")]) == 3
    assert "no column(s) ['c']" in capsys.readouterr().err


def test_class_ids_follow_the_model_labels(files, tmp_path, capsys) -> None:
    only_right = _table(4, sessions=1)
    only_right["position"] = ["right"] * len(only_right["a"])
    path = _csv(tmp_path / "right.csv", only_right)
    rep = _evaluate(capsys, [str(files["model"]), str(path), "-o", str(tmp_path / "r")])
    # "right" is the model's class 2; the file alone would number it 1
    region = rep["sections"]["all"]["decoder"]["region"]
    assert region["n"] == 150
    assert sum(region["confusion"][0]) == 0 and sum(region["confusion"][1]) == 150


def test_parse_sessions_errors() -> None:
    assert parse_sessions(" 1, 3-4 ,") == [1, 3, 4]
    with pytest.raises(SessionSelectionError, match="names no session"):
        parse_sessions(",")
