"""The output rule every writing verb shares (spectratac.cli.outputs): --force replaces only
what the verb wrote, never an input or a folder holding anything else; writes land under
their name only once complete, and a failed write leaves nothing behind."""

from __future__ import annotations

import errno
import json
import os
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from spectratac.cli.outputs import (
    MARKER,
    OutputExistsError,
    OutputIsInputError,
    OutputNotOursError,
    OutputWriteError,
    check_output,
    new_file,
    new_folder,
    url_input,
)

VERB = "export rosbag"


def tree(folder: Path) -> dict[str, str]:
    """Every file under `folder` (relative path -> text)."""
    return {str(p.relative_to(folder)): p.read_text() for p in folder.rglob("*") if p.is_file()}


def test_a_folder_holding_an_input_is_refused_even_with_force(tmp_path: Path) -> None:
    data = tmp_path / "data"
    (data / "sub").mkdir(parents=True)
    (data / "rec1.mcap").write_text("recording")
    (data / "notes.txt").write_text("notes")
    for force in (False, True):
        with pytest.raises(OutputIsInputError, match="holds the input"):
            check_output(data, force, verb=VERB, inputs=[data / "rec1.mcap"], folder=True)
        with pytest.raises(OutputIsInputError, match="is the input"):
            check_output(data / "rec1.mcap", force, verb="train", inputs=[data / "rec1.mcap"])
    # a folder inside an input folder (a bag read as rosbag://) is refused as well
    with pytest.raises(OutputIsInputError):
        check_output(data / "sub" / "out", True, verb=VERB, inputs=[data], folder=True)
    assert tree(data) == {"rec1.mcap": "recording", "notes.txt": "notes"}


def test_force_replaces_a_marked_folder_of_the_same_verb_only(tmp_path: Path) -> None:
    out = tmp_path / "bag"
    with new_folder(out, VERB) as staged:
        staged.mkdir()
        (staged / "bag.db3").write_text("first")
    assert json.loads((out / MARKER).read_text()) == {"verb": VERB, "entries": ["bag.db3"]}
    with pytest.raises(OutputExistsError, match="pass --force"):
        check_output(out, False, verb=VERB, folder=True)
    assert check_output(out, True, verb=VERB, folder=True) == out
    with new_folder(out, VERB) as staged:
        staged.mkdir()
        (staged / "bag.db3").write_text("second")
    assert tree(out) == {"bag.db3": "second", MARKER: (out / MARKER).read_text()}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bag"]  # no hidden leftovers
    # another verb's folder, or the verb's own with something added, is not replaced
    with pytest.raises(OutputNotOursError, match="spectratac export rosbag"):
        check_output(out, True, verb="evaluate", folder=True)
    (out / "notes.txt").write_text("mine")
    with pytest.raises(OutputNotOursError, match=r"notes\.txt"):
        check_output(out, True, verb=VERB, folder=True)


NAMES = st.lists(
    st.text(st.characters(codec="ascii", categories=("L", "N")), min_size=1, max_size=8),
    min_size=1,
    max_size=6,
    unique=True,
)


@settings(
    max_examples=40,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(names=NAMES, marked_by=st.sampled_from([None, "evaluate", "{}", "not json"]))
def test_force_never_replaces_a_folder_another_verb_or_the_user_filled(
    tmp_path_factory: pytest.TempPathFactory, names: list[str], marked_by: str | None
) -> None:
    out = tmp_path_factory.mktemp("out") / "o"
    out.mkdir()
    for n in names:
        (out / n).write_text(n)
    if marked_by is not None:
        text = (
            marked_by
            if marked_by in ("{}", "not json")
            else json.dumps({"verb": marked_by, "entries": names})
        )
        (out / MARKER).write_text(text)
    before = tree(out)
    with pytest.raises(OutputNotOursError, match="--force replaces only a folder"):
        check_output(out, True, verb=VERB, folder=True)
    assert tree(out) == before


def test_a_file_output_is_never_a_folder_and_a_folder_output_never_a_file(tmp_path: Path) -> None:
    (tmp_path / "d").mkdir()
    (tmp_path / "f").write_text("x")
    for force in (False, True):
        with pytest.raises(OutputNotOursError, match="is a folder"):
            check_output(tmp_path / "d", force, verb="train")
        with pytest.raises(OutputNotOursError, match="is a file"):
            check_output(tmp_path / "f", force, verb="evaluate", folder=True)
    os.mkfifo(tmp_path / "pipe")
    with pytest.raises(OutputNotOursError, match="not a regular file"):
        check_output(tmp_path / "pipe", True, verb="train")


def test_force_replaces_a_file_only_of_the_kind_the_verb_writes(tmp_path: Path) -> None:
    from spectratac.cli.outputs import MCAP_MAGIC, is_mcap, is_npz, is_stac

    notes = tmp_path / "notes.txt"
    notes.write_text("the user's notes")
    for kind in (is_mcap, is_npz, is_stac):
        with pytest.raises(OutputNotOursError, match="not one: it is not"):
            check_output(notes, True, verb="train", kind=kind)
    (tmp_path / "s.mcap").write_bytes(MCAP_MAGIC + b"cut short by a crash")
    (tmp_path / "empty.stac").write_bytes(b"")  # nothing in it to lose
    assert check_output(tmp_path / "s.mcap", True, verb="record", kind=is_mcap)
    assert check_output(tmp_path / "empty.stac", True, verb="train", kind=is_stac)


def test_an_unmarked_folder_is_replaced_only_when_recognised(tmp_path: Path) -> None:
    out = tmp_path / "demo-output"
    out.mkdir()
    (out / "session.mcap").write_text("old")
    assert check_output(out, True, verb="demo", folder=True, recognise=lambda n: True) == out
    with pytest.raises(OutputNotOursError, match="not marked"):
        check_output(out, True, verb="demo", folder=True)


@pytest.mark.parametrize(
    ("error", "says"),
    [
        (PermissionError(errno.EACCES, "Permission denied"), "not writable"),
        (OSError(errno.ENOSPC, "No space left on device"), "disk is full"),
        (OSError(errno.EROFS, "Read-only file system"), "not writable"),
    ],
)
def test_a_failed_write_is_typed_and_leaves_nothing(
    tmp_path: Path, error: OSError, says: str
) -> None:
    (tmp_path / "m.stac").write_text("the old model")
    with (
        pytest.raises(OutputWriteError, match=f"cannot write .*m.stac: .*{says}"),
        new_file(tmp_path / "m.stac") as tmp,
    ):
        tmp.write_text("half")
        raise error
    assert tree(tmp_path) == {"m.stac": "the old model"}
    with pytest.raises(OutputWriteError, match=says), new_folder(tmp_path / "r", "evaluate") as s:
        s.mkdir()
        (s / "report.md").write_text("half")
        raise error
    assert tree(tmp_path) == {"m.stac": "the old model"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.stac"]


def test_a_failed_replacement_puts_the_old_folder_back(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    out = tmp_path / "r"
    with new_folder(out, "evaluate") as staged:
        staged.mkdir()
        (staged / "report.md").write_text("old")
    real = os.rename
    failed = []

    def rename(src: object, dst: object) -> None:  # the new folder's rename fails, once
        if Path(str(dst)) == out and not failed:
            failed.append(src)
            raise OSError(errno.ENOSPC, "No space left on device")
        real(src, dst)  # type: ignore[arg-type]

    monkeypatch.setattr(os, "rename", rename)
    with pytest.raises(OutputWriteError, match="disk is full"), new_folder(out, "evaluate") as s:
        s.mkdir()
        (s / "report.md").write_text("new")
    assert (out / "report.md").read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r"]


def test_reader_urls_name_their_inputs() -> None:
    assert url_input("csv://ft.csv") == "ft.csv"
    assert url_input("rosbag:///bags/a?topic=/w") == "/bags/a"
    assert url_input("sim://?scene=idle") is None and url_input(None) is None
