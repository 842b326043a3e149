"""The live page's zero (issue 22 item 1): joined while the skin is held pressed, the page
says the zero is not confirmed; the Tare button zeroes the baseline and clears the flag."""

from __future__ import annotations

from pathlib import Path

import pytest
from spectratac.apps.live.server import LiveServer, bind
from spectratac.apps.live.session import LiveSession
from spectratac.decode import Decoder

from tests.apps.live.browser import chromium, missing
from tests.apps.live.test_page import SHOTS, wait_for

pytestmark = pytest.mark.subprocess  # drives Debian's Chromium

#: one press on the centre held for ten minutes, joined 5 s in: pressed from the first sample
HELD = "sim://?scene=presses&order=5&force=3&hold=600&start=5&speed=1&seed=0"
FLAG = "document.getElementById('flag-no-rest').classList.contains('on')"


def test_tare_button_zeroes_a_skin_joined_under_load(press_model: Path, tmp_path) -> None:
    if (why := missing()) is not None:
        pytest.fail(why)
    SHOTS.mkdir(parents=True, exist_ok=True)
    session = LiveSession(Decoder.load(press_model), HELD, out_dir=tmp_path,
                          model_path=press_model.name)  # fmt: skip
    with chromium() as driver:
        server = LiveServer(session, bind(0)).start()
        try:
            driver.get(server.url)
            wait_for(driver, f"{FLAG} && stac.last && stac.last.no_rest")
            badge = driver.find_element("id", "flag-no-rest")
            assert badge.is_displayed() and badge.text == "zero not confirmed"
            driver.save_screenshot(str(SHOTS / "live-no-rest.png"))
            driver.find_element("id", "tare").click()
            wait_for(driver, f"!{FLAG} && stac.last && !stac.last.no_rest")
            driver.save_screenshot(str(SHOTS / "live-tared.png"))
            assert not [e for e in driver.get_log("browser") if e["level"] == "SEVERE"]
        finally:
            server.stop()
