"""The live page guide's screenshots of the page show what a user sees, nothing of the machine
that took them: each PNG carries the page's visible text (written beside the pixels by
tools/docs/live_screenshots.py), which must name no temporary or home path."""

from __future__ import annotations

import re
import struct
from pathlib import Path

import pytest
from spectratac.apps.live.session import NO_MODEL

ROOT = Path(__file__).resolve().parents[3]
SHOTS = ROOT / "host" / "spectratac" / "apps" / "live" / "screenshots"
KEY = b"spectratac:page-text"
REGENERATE = "regenerate them: python -m tools.docs.live_screenshots"
MACHINE_PATHS = re.compile(r"/tmp/|/var/folders/|/home/|/root/|pytest-of-|\\Temp\\")


def page_text(png: bytes) -> str | None:
    """The page text of an iTXt chunk keyed KEY, if any."""
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    pos = 8
    while pos < len(png):
        (length,) = struct.unpack(">I", png[pos : pos + 4])
        kind, data = png[pos + 4 : pos + 8], png[pos + 8 : pos + 8 + length]
        if kind == b"iTXt" and data.startswith(KEY + b"\0"):
            # keyword, compression flag and method, language tag, translated keyword
            _, _, rest = data.partition(b"\0")
            rest = rest[2:]
            _, _, rest = rest.partition(b"\0")
            _, _, text = rest.partition(b"\0")
            return text.decode()
        pos += 12 + length
    return None


@pytest.mark.parametrize("name", ["live.png", "live-no-model.png", "snake.png"])
def test_committed_screenshots_name_no_path_of_the_machine_that_took_them(name: str) -> None:
    text = page_text((SHOTS / name).read_bytes())
    assert text is not None, f"{name} does not carry its page's text: {REGENERATE}"
    assert not MACHINE_PATHS.search(text), (
        f"{name} shows {MACHINE_PATHS.search(text)}: {REGENERATE}"
    )


def test_the_screenshots_show_the_page_the_readme_describes() -> None:
    live = page_text((SHOTS / "live.png").read_bytes()) or ""
    assert "Fz estimate" in live and "Fz reference" in live and "in contact (reference |F|" in live
    assert "model model.stac" in live  # a neutral name, not where the tool trained it
    bare = page_text((SHOTS / "live-no-model.png").read_bytes()) or ""
    assert NO_MODEL in bare and "spectratac train" in bare and "IR" in bare
    guide = (ROOT / "host/spectratac/apps/live/README.md").read_text()  # the page's guide
    for name in ("live.png", "live-no-model.png", "snake.png"):
        assert f"](screenshots/{name})" in guide, name


@pytest.mark.parametrize("name", ["live.png", "live-no-model.png"])
def test_the_screenshots_link_panel_shows_what_a_user_needs(name: str) -> None:
    """Rate, losses and the latency to the browser; not the benchmark's WebSocket rows,
    which a user's page no longer has (issue 37)."""
    text = page_text((SHOTS / name).read_bytes()) or ""
    for row in ("rate", "lost", "frame errors", "latency to browser p50 / p99"):
        assert row in text.splitlines(), (name, row, REGENERATE)
    assert "WebSocket" not in text and "echo" not in text, f"{name}: {REGENERATE}"


def test_page_text_reads_what_the_tool_writes() -> None:
    import importlib.util

    spec = importlib.util.spec_from_file_location("shots", ROOT / "tools/docs/live_screenshots.py")
    assert spec is not None and spec.loader is not None
    tool = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(tool)
    from io import BytesIO

    from PIL import Image

    buf = BytesIO()
    Image.new("RGB", (4, 3), "white").save(buf, "PNG")
    png = buf.getvalue()
    assert page_text(png) is None
    assert page_text(tool.with_page_text(png, "saved live-clips/a.csv · ≥ 0.5 N")) == (
        "saved live-clips/a.csv · ≥ 0.5 N"
    )
