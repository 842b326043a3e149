"""`sim serve --pty --link PATH` replaces only a symlink there and removes it when it stops."""

from __future__ import annotations

import signal
import threading
from pathlib import Path

import pytest
from spectratac.cli import main
from spectratac.cli.exit_codes import ExitCode
from spectratac.sim.serve import LinkPathTaken, serve_pty
from spectratac.sim.url import parse_sim_url

from tests.device.conftest import serve

OPTS = parse_sim_url("sim://?scene=idle&seed=0&speed=1")


def serve_until_announced(link: Path) -> list[str]:
    """Run serve_pty in a thread that stops as soon as the pty is announced."""
    stop = threading.Event()
    announced: list[str] = []
    errors: list[BaseException] = []

    def announce(path: str) -> None:
        announced.append(path)
        stop.set()

    def run() -> None:
        try:
            serve_pty(OPTS, link=link, announce=announce, stop=stop)
        except BaseException as exc:  # handed to the test thread
            errors.append(exc)

    thread = threading.Thread(target=run)
    thread.start()
    thread.join()
    if errors:
        raise errors[0]
    return announced


def test_a_regular_file_at_the_link_path_is_kept(tmp_path: Path) -> None:
    precious = tmp_path / "notes.txt"
    precious.write_text("keep me")
    with pytest.raises(LinkPathTaken, match="not a symlink"):
        serve_until_announced(precious)
    assert not precious.is_symlink() and precious.read_text() == "keep me"


def test_the_verb_refuses_a_regular_file_with_exit_3(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    precious = tmp_path / "notes.txt"
    precious.write_text("keep me")
    assert main(["sim", "serve", "--pty", "--link", str(precious)]) == ExitCode.ERROR
    assert "not a symlink" in capsys.readouterr().err
    assert precious.read_text() == "keep me"


def test_a_stale_symlink_is_replaced_and_removed_when_serving_stops(tmp_path: Path) -> None:
    link = tmp_path / "ttySPECTRA"
    link.symlink_to(tmp_path / "gone")
    announced = serve_until_announced(link)
    assert len(announced) == 1
    assert not link.is_symlink() and not link.exists()


@pytest.mark.subprocess
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT], ids=["SIGTERM", "SIGINT"])
def test_the_link_is_removed_on_a_signal(tmp_path: Path, sig: int) -> None:
    link = tmp_path / "ttySPECTRA"
    served = serve(tmp_path, "--pty", "--link", str(link), "--scene", "idle")
    assert link.is_symlink()
    served.signal(sig)
    assert served.process.wait(timeout=30) == 0
    assert not link.is_symlink()
