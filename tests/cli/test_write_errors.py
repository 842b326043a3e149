"""A read-only folder or a full disk while a verb saves (issue 36): a typed error naming the
output and what to do, exit code 3, no traceback, and nothing partial left behind. Faults are
injected (tests may run as root, whom chmod does not stop), at the write itself and at the
final rename into place."""

from __future__ import annotations

import errno
import os
import sqlite3
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from spectratac.cli import main

from tests.cli.conftest import RIDGE

pytestmark = pytest.mark.train  # the train verb fits a ridge model


FULL = OSError(errno.ENOSPC, "No space left on device")
READ_ONLY = PermissionError(errno.EACCES, "Permission denied")


def failing(monkeypatch: pytest.MonkeyPatch, owner: object, name: str, error: Exception,
            after: int = 0) -> None:  # fmt: skip
    """owner.name raises `error` from its call number after+1 on."""
    real = getattr(owner, name)
    calls = [0]

    def fake(*args: object, **kwargs: object) -> object:
        calls[0] += 1
        if calls[0] > after:
            raise error
        return real(*args, **kwargs)

    monkeypatch.setattr(owner, name, fake)


def at_rename(monkeypatch: pytest.MonkeyPatch, error: Exception) -> None:
    """The rename into place fails (a folder made read-only meanwhile, or no room)."""
    failing(monkeypatch, os, "replace", error)
    failing(monkeypatch, os, "rename", error)


def mid_write(verb: str) -> Callable[[pytest.MonkeyPatch, Exception], None]:
    """The verb's own writer fails halfway."""

    def inject(monkeypatch: pytest.MonkeyPatch, error: Exception) -> None:
        import zipfile

        if verb == "export rosbag":  # sqlite3 fails its own way, a full disk as OperationalError
            from rosbags.rosbag2 import Writer

            failing(monkeypatch, Writer, "write", sqlite3.OperationalError(
                "database or disk is full" if error is FULL else "attempt to write a readonly "
                "database"), after=50)  # fmt: skip
        elif verb == "evaluate":
            import matplotlib.figure

            failing(monkeypatch, matplotlib.figure.Figure, "savefig", error, after=1)
        elif verb == "dataset build":

            def half(file: object, *args: object, **kwargs: object) -> None:
                file.write(b"PK\x03\x04 half a dataset")  # type: ignore[attr-defined]
                raise error

            monkeypatch.setattr(np, "savez_compressed", half)
        else:  # a model (.stac) is a zip
            failing(monkeypatch, zipfile.ZipFile, "writestr", error, after=1)

    return inject


def argv_of(verb: str, made: dict[str, Path], out: Path) -> list[str]:
    return {
        "export rosbag": ["export", "rosbag", str(made["recording"]), "--no-progress"],
        "dataset build": ["dataset", "build", str(made["recording"]), "--no-progress"],
        "train": ["train", str(made["csv"]), *RIDGE],
        "evaluate": ["evaluate", str(made["model"]), str(made["csv"]), "--no-progress"],
    }[verb] + ["-o", str(out)]


OUTPUT = {"export rosbag": "bag", "dataset build": "d.npz", "train": "m.stac", "evaluate": "report"}


@pytest.mark.parametrize("verb", sorted(OUTPUT))
@pytest.mark.parametrize("where", ["mid_write", "at_rename"])
@pytest.mark.parametrize("error", [FULL, READ_ONLY], ids=["full", "read_only"])
def test_a_failed_save_is_typed_names_the_output_and_leaves_nothing(
    verb: str, where: str, error: OSError, made: dict[str, Path], tmp_path: Path,
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch,
) -> None:  # fmt: skip
    out = tmp_path / OUTPUT[verb]
    argv = argv_of(verb, made, out)
    (mid_write(verb) if where == "mid_write" else at_rename)(monkeypatch, error)
    assert main(argv) == 3
    err = capsys.readouterr().err
    assert "Traceback" not in err and err.count("\n") <= 2, err
    assert str(out) in err and ".partial" not in err, err
    says = ("full", "space") if error is FULL else ("writable", "read")
    assert any(s in err for s in says) and "-o" in err, err
    assert list(tmp_path.iterdir()) == [], "a partial output was left"


@pytest.mark.parametrize("verb", sorted(OUTPUT))
def test_a_failed_force_rerun_keeps_the_previous_output(
    verb: str, made: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:  # fmt: skip
    out = tmp_path / OUTPUT[verb]
    argv = argv_of(verb, made, out)
    assert main(argv) == 0
    before = {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()}
    mid_write(verb)(monkeypatch, FULL)
    assert main([*argv, "--force"]) == 3
    assert {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()} == before
