"""Every writing verb keeps what a user owns (issue 36): `-o` naming a folder that holds the
verb's input and another file leaves both intact, with and without --force (exit code 3, a
message naming the input), and the verb's own --force rerun still replaces its output."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

import pytest
from spectratac.cli import main
from spectratac.cli.outputs import MARKER, MCAP_MAGIC
from spectratac.dataset import Dataset

from tests.cli.conftest import RIDGE

pytestmark = pytest.mark.train  # the train verb fits a ridge model



def tree(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in folder.rglob("*") if p.is_file()}


def user_folder(tmp_path: Path, *inputs: Path) -> Path:
    """data/ holding copies of `inputs`, the user's notes and a sub-folder."""
    data = tmp_path / "data"
    (data / "sub").mkdir(parents=True)
    (data / "notes.txt").write_text("the user's notes")
    (data / "sub" / "more.txt").write_text("more")
    for p in inputs:
        (data / p.name).write_bytes(p.read_bytes())
    return data


def refused(argv: list[str], capsys: pytest.CaptureFixture[str], says: str) -> None:
    """`argv` exits 3 with and without --force, saying `says` (without: the first refusal)."""
    for force in ([], ["--force"]):
        assert main([*argv, *force]) == 3, (argv, force)
        err = capsys.readouterr().err
        assert says in err or (force and "--force replaces only" in err), err
        assert "Traceback" not in err, err


def test_export_rosbag_never_deletes_the_folder_of_its_input(
    made: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The reproducer of issue 36: `export rosbag data/rec1.mcap -o data --force`."""
    data = user_folder(tmp_path, made["recording"])
    before = tree(data)
    rec = str(data / "rec1.mcap")
    refused(["export", "rosbag", rec, "-o", str(data)], capsys, "holds the input")
    refused(["export", "rosbag", rec, "-o", str(data / "sub")], capsys, "more.txt")
    assert tree(data) == before
    bag = tmp_path / "bag"
    assert main(["export", "rosbag", rec, "-o", str(bag)]) == 0
    assert main(["export", "rosbag", rec, "-o", str(bag), "--force"]) == 0  # its own: replaced
    assert sorted(p.name for p in bag.iterdir()) == [MARKER, "bag.db3", "metadata.yaml"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bag", "data"]


def test_dataset_build_keeps_its_input_and_the_folder(
    made: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data = user_folder(tmp_path, made["recording"])
    (data / "notes.npz").write_text("the user's, not a dataset")
    (data / "dir.npz").mkdir()
    before = tree(data)
    rec = str(data / "rec1.mcap")
    refused(["dataset", "build", rec, "-o", str(data / "dir.npz")], capsys, "is a folder")
    refused(["dataset", "build", rec, "-o", str(data / "notes")], capsys, "pass --force")
    assert "it is not a NumPy .npz archive" in "".join(_err_with_force(capsys, [
        "dataset", "build", rec, "-o", str(data / "notes")]))  # fmt: skip
    assert tree(data) == before
    for force in ([], ["--force"]):  # its own output, replaced
        assert main(["dataset", "build", rec, "-o", str(data / "d"), "--no-progress", *force]) == 0
    assert Dataset.load(data / "d.npz").n > 0
    assert sorted(tree(data)) == sorted([*before, "d.npz"])


def _err_with_force(capsys: pytest.CaptureFixture[str], argv: list[str]) -> str:
    assert main([*argv, "--force"]) == 3
    return capsys.readouterr().err


def test_train_keeps_its_input_and_the_folder(
    made: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data = user_folder(tmp_path, made["csv"])
    before = tree(data)
    csv = str(data / "data.csv")
    refused(["train", csv, "-o", str(data), *RIDGE], capsys, "is a folder")
    refused(["train", csv, "-o", csv, *RIDGE], capsys, "is the input")
    refused(["train", csv, "-o", str(data / "notes.txt"), *RIDGE], capsys, "pass --force")
    assert tree(data) == before
    for force in ([], ["--force"]):
        assert main(["train", csv, "-o", str(data / "m.stac"), *RIDGE, *force]) == 0
    assert sorted(tree(data)) == sorted([*before, "m.stac"])


def test_evaluate_keeps_its_inputs_and_the_folder(
    made: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data = user_folder(tmp_path, made["csv"], made["model"])
    before = tree(data)
    argv = ["evaluate", str(data / "m.stac"), str(data / "data.csv"), "--no-progress"]
    refused([*argv, "-o", str(data)], capsys, "holds the input")
    refused([*argv, "-o", str(data / "sub")], capsys, "more.txt")
    assert tree(data) == before
    report = tmp_path / "report"
    for force in ([], ["--force"]):
        assert main([*argv, "-o", str(report), *force]) == 0
    assert {"report.json", "report.md", MARKER} <= {p.name for p in report.iterdir()}
    # a report folder made before the marker existed is still the verb's own
    (report / MARKER).unlink()
    assert main([*argv, "-o", str(report), "--force"]) == 0


def test_record_keeps_its_input_and_replaces_a_recording_only_when_finished(
    made: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data = user_folder(tmp_path)
    (data / "ft.csv").write_text("t,Fx,Fy,Fz,Tx,Ty,Tz\n")
    before = tree(data)
    argv = ["record", "sim://?scene=tour&speed=max", "--count", "20", "--no-progress"]
    refused([*argv, "--ft", f"csv://{data / 'ft.csv'}", "-o", str(data / "ft.csv")], capsys,
            "is the input")  # fmt: skip
    refused([*argv, "-o", str(data)], capsys, "is a folder")
    refused([*argv, "-o", str(data / "notes.txt")], capsys, "pass --force")
    assert tree(data) == before
    out = data / "s.mcap"
    assert main([*argv, "-o", str(out)]) == 0
    first = out.read_bytes()
    capsys.readouterr()
    assert main([*argv, "--count", "40", "-o", str(out), "--force", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["path"] == str(out)
    assert out.read_bytes() != first
    assert sorted(tree(data)) == sorted([*before, "s.mcap"])  # no hidden recording left


def test_record_that_could_not_start_leaves_no_file_and_keeps_the_old_one(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    from spectratac.device.errors import DeviceError
    from spectratac.record.recorder import Recorder

    def refuses(self: Recorder, writer: object) -> int:  # e.g. a device refusing the config
        raise DeviceError("the device refused the configuration")

    monkeypatch.setattr(Recorder, "_start", refuses)
    out = tmp_path / "s.mcap"
    old = MCAP_MAGIC + b" the old recording"
    out.write_bytes(old)
    argv = ["record", "sim://?scene=idle&speed=max", "--count", "5", "--no-progress"]
    assert main([*argv, "-o", str(out), "--force"]) == 3
    assert "could not start" in capsys.readouterr().err
    assert out.read_bytes() == old
    assert main([*argv, "-o", str(tmp_path / "new.mcap")]) == 3
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.mcap"]


def test_record_that_records_nothing_keeps_the_old_recording(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    from spectratac.record.recorder import Recorder

    real = Recorder.run

    def stopped_at_once(self: Recorder, *args: Any) -> Any:  # Ctrl-C before the first sample
        return dataclasses.replace(real(self, *args), samples=0, stopped_by="interrupt")

    monkeypatch.setattr(Recorder, "run", stopped_at_once)
    out = tmp_path / "s.mcap"
    old = MCAP_MAGIC + b" the old recording"
    out.write_bytes(old)
    argv = ["record", "sim://?scene=idle&speed=max", "--count", "5", "--no-progress"]
    assert main([*argv, "-o", str(out), "--force"]) == 0
    assert "no sample was recorded" in capsys.readouterr().err
    assert out.read_bytes() == old
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.mcap"]


def _quick_demo(monkeypatch: pytest.MonkeyPatch) -> list[Path]:
    """The demo's stages replaced by writing its file set (the stages have tests of their
    own); returns the folders it wrote into."""
    import spectratac.apps.calibration_demo as demo
    import spectratac.studies.cost_model as cost
    from spectratac.apps.estimates import Estimate

    wrote: list[Path] = []

    def run_demo(opts: Any, say: Any = print) -> dict[str, Any]:
        opts.out.mkdir(parents=True, exist_ok=True)
        for name in ("session.mcap", "data.npz", "paper.stac", "best.stac"):
            (opts.out / name).write_text(f"new {name}")
        (opts.out / "report-best").mkdir()
        (opts.out / "report-best" / "report.md").write_text("new report")
        wrote.append(opts.out)
        return {"out": str(opts.final), "timings_s": {"total_s": 0, "record_s": 0,
                "dataset_s": 0, "train_evaluate_s": 0}}  # fmt: skip

    monkeypatch.setattr(demo, "run_demo", run_demo)
    monkeypatch.setattr(cost, "demo_estimate", lambda *a, **k: Estimate({"all": 1.0}, {}, 0.0))
    return wrote


def test_demo_replaces_only_its_own_folder(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    wrote = _quick_demo(monkeypatch)
    data = user_folder(tmp_path)
    before = tree(data)
    refused(["demo", "-o", str(data), "--json"], capsys, "notes.txt")
    assert tree(data) == before and wrote == []
    out = tmp_path / "demo-output"
    for force in ([], ["--force"]):  # `make demo` reruns with --force
        assert main(["demo", "-o", str(out), "--json", *force]) == 0
    assert (out / "report-best" / "report.md").read_text() == "new report"
    assert json.loads((out / MARKER).read_text())["verb"] == "demo"
    assert wrote[-1] != out  # written beside it, renamed into place
    # a demo-output from before the marker: the demo's own files, replaced
    (out / MARKER).unlink()
    (out / "session.mcap").write_text("old")
    assert main(["demo", "-o", str(out), "--json", "--force"]) == 0
    assert (out / "session.mcap").read_text() == "new session.mcap"
    # ...but not once the user put something of theirs in it
    (out / MARKER).unlink()
    (out / "notes.txt").write_text("mine")
    refused(["demo", "-o", str(out), "--json"], capsys, "notes.txt")
    assert (out / "notes.txt").read_text() == "mine"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["data", "demo-output"]


@pytest.mark.parametrize(
    "argv",
    [
        ["twin", "generate", "--scene", "idle", "--duration", "1", "--json"],
        ["twin", "population", "--units", "0", "--sessions", "1", "--duration", "5",
         "--scene", "idle", "--no-progress", "--json"],
    ],
    ids=["generate", "population"],
)  # fmt: skip
def test_twin_verbs_write_a_file_never_over_a_folder(
    argv: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data = user_folder(tmp_path)
    (data / "dir.npz").mkdir()
    (data / "notes.npz").write_text("the user's")
    before = tree(data)
    refused([*argv, "-o", str(data / "dir.npz")], capsys, "is a folder")
    refused([*argv, "-o", str(data / "notes.npz")], capsys, "pass --force")
    assert tree(data) == before
    for force in ([], ["--force"]):
        assert main([*argv, "-o", str(data / "t.npz"), *force]) == 0
    assert sorted(tree(data)) == sorted([*before, "t.npz"])


def test_live_clips_never_touch_what_their_folder_holds(
    made: dict[str, Path], tmp_path: Path
) -> None:
    """`live -o DIR` only adds clips under new names (no --force): a folder holding the
    model and the user's files keeps them."""
    import time

    from spectratac.apps.live.session import LiveSession
    from spectratac.decode import Decoder

    data = user_folder(tmp_path, made["model"])
    before = tree(data)
    url = "sim://?scene=idle&speed=4"
    session = LiveSession(Decoder.load(data / "m.stac"), url, keep_config=True, out_dir=data)
    session.start(lambda msg: None)
    try:
        deadline = time.monotonic() + 120
        clips = []
        for fmt in ("csv", "mcap"):
            while True:
                try:
                    clips.append(Path(session.save(0.5, fmt)["path"]))
                    break
                except Exception:
                    assert time.monotonic() < deadline, "no history to save within 120 s"
                    time.sleep(0.1)
    finally:
        session.stop()
    assert {k: v for k, v in tree(data).items() if k in before} == before
    assert sorted(tree(data)) == sorted([*before, *(c.name for c in clips)])


def test_train_export_force_replaces_only_its_own_exports(
    made: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """--export's files get the kind check of the model file: --force never replaces a
    user's file that happens to bear an export's name (before, any such file was replaced)."""
    data = user_folder(tmp_path, made["csv"])
    csv = str(data / "data.csv")
    for name in ("m.runtime.npz", "m.h"):
        (data / name).write_text("the user's file, not an export")
    before = tree(data)
    for export in ("numpy", "c"):
        argv = ["train", csv, "-o", str(data / "m.stac"), "--export", export, *RIDGE, "--force"]
        assert main(argv) == 3, export
        err = capsys.readouterr().err
        assert "--force replaces only a file train wrote" in err and "Traceback" not in err
    assert tree(data) == before  # nothing written, the model neither
    for name in ("m.runtime.npz", "m.h"):
        (data / name).unlink()
    argv = ["train", csv, "-o", str(data / "m.stac"), "--export", "numpy,c", *RIDGE]
    assert main(argv) == 0
    assert main([*argv, "--force"]) == 0  # its own exports: replaced


def test_the_kinds_of_the_exports(tmp_path: Path) -> None:
    import zipfile

    import onnx  # pinned (requirements/lock.txt): the export's own dependency
    from spectratac.cli.outputs import is_c_header, is_onnx, is_torchscript

    graph = onnx.helper.make_graph([], "g", [], [])
    model = onnx.helper.make_model(graph, producer_name="pytorch")
    (tmp_path / "m.onnx").write_bytes(model.SerializeToString())
    with zipfile.ZipFile(tmp_path / "m.pt", "w") as z:
        z.writestr("m/data.pkl", b"")
        z.writestr("m/code/__torch__/m.py", b"")
    (tmp_path / "m.h").write_text("/* Generated by spectratac (spectratac.decode.export...) */")
    (tmp_path / "notes.txt").write_text("\x08 the user's notes")
    assert is_onnx(tmp_path / "m.onnx") and not is_onnx(tmp_path / "notes.txt")
    assert is_torchscript(tmp_path / "m.pt") and not is_torchscript(tmp_path / "notes.txt")
    assert is_c_header(tmp_path / "m.h") and not is_c_header(tmp_path / "notes.txt")
    assert not is_onnx(tmp_path / "m.h") and not is_torchscript(tmp_path / "m.onnx")
