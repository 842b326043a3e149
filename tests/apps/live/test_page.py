"""The live page in a real browser (headless Chromium from Debian, driven by selenium):
plots receive data, the region map lights the pressed region, the Snake moves, pause and
save work, and the page loads nothing from outside the package. Screenshots of both tabs
are saved under build/screenshots/."""

from __future__ import annotations

import time
from pathlib import Path

import pytest
from spectratac.apps.live.server import LiveServer, bind
from spectratac.apps.live.session import LiveSession
from spectratac.decode import Decoder
from spectratac.twin.scripted_presses import parse_order

from tests.apps.conftest import ORDER, PRESSES_URL
from tests.apps.live.browser import chromium, missing

pytestmark = pytest.mark.subprocess  # drives Debian's Chromium

SHOTS = Path(__file__).resolve().parents[3] / "build" / "screenshots"
LIT = "(document.querySelector('#face .region.lit') || {dataset: {}}).dataset.region || null"


def sustained_lit_regions(driver, seconds: float, bound_s: float = 240.0) -> list[int]:
    """Regions lit on the face for 0.25 s or more in a row, in order, over `seconds`, both
    on the sensor's clock (the time of the estimate the page shows): a loaded machine polls
    the page slowly and late, so polls and wall seconds would measure the scheduler."""
    runs: list[list] = []  # [region, first seen at t, last seen at t]
    first = None
    deadline = time.monotonic() + bound_s
    while True:
        region, t = driver.execute_script(f"return [{LIT}, stac.last ? stac.last.t : null]")
        if t is not None:
            first = t if first is None else first
            if runs and runs[-1][0] == region:
                runs[-1][2] = t
            else:
                runs.append([region, t, t])
            if t - first >= seconds:
                break
        covered = 0.0 if first is None else t - first
        assert time.monotonic() < deadline, (
            f"the page showed {covered:.1f} of {seconds} sensor seconds within {bound_s:g} s"
        )
        time.sleep(0.05)
    out: list[int] = []
    for region, t0, t1 in runs:
        if region is not None and t1 - t0 >= 0.25 and (not out or out[-1] != int(region)):
            out.append(int(region))
    return out


def wait_for(driver, script: str, timeout: float = 60.0):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = driver.execute_script("return " + script)
        if value:
            return value
        time.sleep(0.1)
    raise AssertionError(f"timed out waiting for {script!r}")


@pytest.mark.slow
def test_page_plots_lights_regions_plays_snake_and_saves(press_model, tmp_path) -> None:
    if (why := missing()) is not None:
        pytest.fail(why)
    SHOTS.mkdir(parents=True, exist_ok=True)
    url = PRESSES_URL + "&speed=1&ft=bota"
    session = LiveSession(Decoder.load(press_model), url, ft_url=url, out_dir=tmp_path,
                          model_path=press_model.name)  # fmt: skip
    with chromium() as driver:  # the browser first: the scene starts with the server
        server = LiveServer(session, bind(0)).start()
        try:
            check_page(driver, server)
        finally:
            server.stop()
    assert (SHOTS / "live.png").stat().st_size > 20_000


def check_page(driver, server) -> None:
    driver.get(server.url)
    # the pressed regions light up: over 10.5 s (five presses of the scene, from wherever the
    # page joined it: a loaded machine starts the browser late) the face lights at least two
    # of the regions the scene pressed, and mostly pressed ones (the small press model
    # mislabels some presses, so the exact order is the pipeline tests' job)
    lit = sustained_lit_regions(driver, 10.5)
    played = set(parse_order(",".join(ORDER)))
    pressed = [r for r in lit if r in played]
    assert len(set(pressed)) >= 2 and len(pressed) >= 0.6 * len(lit), (lit, sorted(played))
    wait_for(driver, "document.getElementById('region-label').textContent.startsWith('region')")
    # plots receive data: predictions and the time-aligned reference
    assert driver.execute_script("return stac.plots.Fz.data[0].length") > 10
    wait_for(driver, "stac.refsReceived > 10")
    assert driver.execute_script("return stac.plots.Fz.data[2].filter(v => v !== null).length") > 10
    wait_for(driver, "document.getElementById('mae').textContent.includes('Fz 0.')")
    # raw counts: 12 per LED step
    assert len(driver.find_elements("css selector", "#raw tbody tr")) == 12
    # the snake moves after the first command
    wait_for(driver, "stac.snake && stac.snake.steps >= 3")
    head = driver.execute_script("return stac.snake.body[0]")
    assert head != [8, 6]
    # pause freezes the plots, resume follows the data again
    # (by the newest time shown: a full window keeps its length while it rolls)
    newest = "stac.plots.Fz.data[0][stac.plots.Fz.data[0].length - 1]"
    driver.find_element("id", "pause").click()
    frozen = driver.execute_script("return " + newest)
    time.sleep(0.6)
    assert driver.execute_script("return " + newest) == frozen
    driver.find_element("id", "pause").click()
    wait_for(driver, f"{newest} > {frozen}")
    # save the last 2 s as CSV; the button waits for the answer (one save at a time)
    driver.find_element("id", "save-seconds").clear()
    driver.find_element("id", "save-seconds").send_keys("2")
    driver.find_element("css selector", "#save-format option[value=csv]").click()
    save = "document.getElementById('save')"
    assert driver.execute_script(f"{save}.click(); return {save}.disabled") is True
    result = "document.getElementById('save-result').textContent"
    saved = wait_for(driver, f"{result}.startsWith('saved') && {result}")
    assert Path(saved.removeprefix("saved ")).is_file()
    wait_for(driver, f"!{save}.disabled")
    # the page's token reached the server: its latency reports were accepted
    wait_for(driver, "stac.refused.length === 0 && stac.latency.length > 20")
    deadline = time.monotonic() + 30
    while server.session.latency.summary()["n"] == 0:
        assert time.monotonic() < deadline, "the page's latency reports were not accepted"
        time.sleep(0.1)
    # references are matched by sequence number across gaps; a repeated estimate is ignored
    found = "return [7, 5, 12, 3, 13].map(k => stac.indexOfSeq([3, 4, 7, 9, 12], k))"
    assert driver.execute_script(found) == [2, -1, 4, 0, -1]
    kept = driver.execute_script(
        "const n = stac.xs.length, d = stac.duplicates; stac.onEstimate({...stac.last});"
        "return [stac.xs.length - n, stac.duplicates - d]"
    )
    assert kept == [0, 1]
    # nothing loaded from outside the package (the page works offline)
    resources = driver.execute_script(
        "return performance.getEntriesByType('resource').map(e => e.name)"
    )
    assert resources and all(r.startswith(server.url) for r in resources)
    wait_for(driver, "stac.latency.length > 20")
    driver.save_screenshot(str(SHOTS / "live.png"))
    driver.find_element("id", "tab-snake").click()
    wait_for(driver, "document.getElementById('snake-commands').children.length >= 2")
    driver.save_screenshot(str(SHOTS / "snake.png"))
    assert not [e for e in driver.get_log("browser") if e["level"] == "SEVERE"]
