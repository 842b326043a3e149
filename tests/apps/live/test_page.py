"""The live page in a real browser (headless Chromium from Debian, driven by selenium):
plots receive data, the region map lights the pressed region, the Snake moves, pause and
save work, and the page loads nothing from outside the package. It works as a tool: every
plot zooms (drag, wheel), pans (shift+drag), reads values out at the cursor and follows the
live data again on a double-click or "Follow live"; references are dashed in the plot and in
the legend; raw counts are plotted per sensor and channel with saturation and dark bands;
the MAE is shown overall and in contact; the link panel shows without scrolling; without a
model the page shows raw counts and the reference. Screenshots of the pages are saved under
build/screenshots/."""

from __future__ import annotations

import re
import time
from pathlib import Path

import pytest
from selenium.webdriver.common.action_chains import ActionChains
from selenium.webdriver.common.actions.wheel_input import ScrollOrigin
from selenium.webdriver.common.keys import Keys
from spectratac.apps.live.server import LiveServer, bind
from spectratac.apps.live.session import NO_MODEL, LiveSession
from spectratac.decode import Decoder
from spectratac.decode.guard import DARK_COUNTS
from spectratac.hardware.generated import veml3328
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
    assert driver.execute_script("return stac.plots.Fz.u.data[0].length") > 10
    wait_for(driver, "stac.refsReceived > 10")
    assert (
        driver.execute_script("return stac.plots.Fz.u.data[2].filter(v => v !== null).length") > 10
    )
    check_raw_counts(driver)
    check_mae(driver)
    check_link_panel_in_view(driver)
    check_legend_marks(driver)
    check_zoom_pan_cursor_follow(driver)
    # the snake moves after the first command
    wait_for(driver, "stac.snake && stac.snake.steps >= 3")
    head = driver.execute_script("return stac.snake.body[0]")
    assert head != [8, 6]
    # pause freezes the plots, resume follows the data again
    # (by the newest time shown: a full window keeps its length while it rolls)
    newest = "stac.plots.Fz.u.data[0][stac.plots.Fz.u.data[0].length - 1]"
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
    check_no_benchmark_instruments(driver, server)
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
    driver.execute_script("window.scrollTo(0, 0)")
    driver.save_screenshot(str(SHOTS / "live.png"))
    driver.find_element("id", "tab-snake").click()
    wait_for(driver, "document.getElementById('snake-commands').children.length >= 2")
    driver.save_screenshot(str(SHOTS / "snake.png"))
    assert not [e for e in driver.get_log("browser") if e["level"] == "SEVERE"]


def check_no_benchmark_instruments(driver, server) -> None:
    """A user's page measures its latency to the browser from the estimates alone: no probe
    or ping reaches it, it sends no latency report or pong (nothing refused, nothing kept by
    the server), and its link panel shows rate, losses and that latency, without the
    benchmark's "WebSocket alone / echo" rows."""
    wait_for(driver, "stac.latency.length > 20 && stac.received > 20")
    time.sleep(1.2)  # a benchmark's page would have reported its latencies by now
    assert js(driver, "[stac.meta.benchmark, stac.bare.length, stac.refused.length]") == [
        False, 0, 0
    ]  # fmt: skip
    assert server.session.latency.values() == [] and server.hub.pings == {}
    wait_for(driver, "document.getElementById('link').textContent.includes('latency to browser')")
    rows = js(driver, "[...document.querySelectorAll('#link dt')].map(dt => dt.textContent)")
    assert rows[0] == "rate" and "lost" in rows and "latency to browser p50 / p99" in rows, rows
    assert not [r for r in rows if "WebSocket" in r or "echo" in r], rows
    shown = js(driver, "document.querySelector('#link dt[title^=\"from a sample\"]')"
               ".nextElementSibling.textContent")  # fmt: skip
    assert re.fullmatch(r"\d+\.\d / \d+\.\d ms", shown), shown


def js(driver, script: str):
    return driver.execute_script("return " + script)


def check_raw_counts(driver) -> None:
    """Three plots, one per sensor, of R, G, B, C and IR, fed with the counts the page got,
    over the saturation and dark bands at the definitions' thresholds."""
    # below the force plots at this window size: a person scrolls down to them
    driver.execute_script("document.getElementById('panel-raw').scrollIntoView()")
    raw = js(driver, "stac.meta.raw")
    assert raw["full_scale"] == veml3328.FULL_SCALE and raw["dark_counts"] == DARK_COUNTS
    labels = js(driver, "['S0', 'S1', 'S2'].map(k => stac.plots[k].u.series.map(s => s.label))")
    assert labels == [["time (s)", "R", "G", "B", "C", "IR"]] * 3
    # every plot drawn with its counts before reading one: plots are only drawn once in view,
    # and S1 could still be on its first, empty draw when S2 was not (a JS error seen in CI)
    drawn = "stac.plots[k].u.data.every(a => a && a.length > 10)"
    wait_for(driver, f"['S0', 'S1', 'S2'].every(k => stac.plots[k].u.data.length === 6 && {drawn})")
    last = js(driver, "[stac.plots.S1.u.data.slice(1).map(a => a[a.length - 1]), stac.last.counts]")
    # what sensor 1's plot ends on is sensor 1's counts of a sample the page received
    assert all(isinstance(v, int) and v > 0 for v in last[0])
    colours = js(
        driver,
        """(() => {
        const u = stac.plots.S0.u, b = u.bbox, raw = stac.meta.raw;
        const px = (x, y) => Array.from(u.ctx.getImageData(x, y, 1, 1).data);
        const xs = [0.3, 0.5, 0.7].map(f => Math.round(b.left + f * b.width));
        const sat = u.valToPos(raw.full_scale, 'y', true);
        const dark = u.valToPos(raw.dark_counts, 'y', true);
        return {sat: xs.map(x => px(x, Math.round((b.top + sat) / 2))),
                dark: xs.map(x => px(x, Math.round((dark + u.valToPos(0, 'y', true)) / 2))),
                clear: xs.map(x => px(x, Math.round(u.valToPos(3, 'y', true) - 2)))};
        })()""",
    )
    reddish = [c for c in colours["sat"] if c[0] > c[1] + 8 and c[0] > c[2] + 8]
    bluish = [c for c in colours["dark"] if c[2] > c[0] + 6]
    assert len(reddish) >= 2 and len(bluish) >= 2, colours
    # "fit to data" trades the bands for the counts' own range, and back
    full = [0, 1.5 * veml3328.FULL_SCALE]
    assert js(driver, "[stac.plots.S0.u.scales.y.min, stac.plots.S0.u.scales.y.max]") == full
    driver.find_element("id", "counts-fit").click()
    wait_for(driver, f"stac.plots.S0.u.scales.y.max < {veml3328.FULL_SCALE}")
    lo, hi, shown = js(  # in one go: the y range, and the counts in the time span on screen
        driver,
        """(() => { const u = stac.plots.S0.u, x = u.scales.x, t = u.data[0];
           return [u.scales.y.min, u.scales.y.max, u.data.slice(1).flatMap(a => a.filter(
               (v, i) => v !== null && t[i] >= x.min && t[i] <= x.max))]; })()""",
    )
    assert 0 <= lo <= min(shown) and max(shown) <= hi, (lo, hi)
    driver.find_element("id", "counts-fit").click()
    wait_for(driver, f"stac.plots.S0.u.scales.y.max === {full[1]}")
    driver.execute_script("window.scrollTo(0, 0)")


def check_mae(driver) -> None:
    """Overall and in-contact MAE side by side, the contact threshold named."""
    wait_for(driver, "document.querySelectorAll('#mae tbody tr').length === 2")
    rows = js(driver, "[...document.querySelectorAll('#mae tbody tr')].map(r => r.innerText)")
    assert rows[0].startswith("overall") and rows[1].startswith("in contact (reference |F|")
    assert all(re.search(r"\t\d+\.\d{3}\t", r) for r in rows), rows


def check_link_panel_in_view(driver) -> None:
    """At 1400 x 1000 the link panel shows whole without scrolling."""
    assert js(driver, "[window.outerWidth, window.outerHeight]") == [1400, 1000]
    box = js(driver, "(() => { window.scrollTo(0, 0); const r = document.getElementById("
             "'panel-link').getBoundingClientRect(); return [r.top, r.bottom, r.left, r.right, "
             "innerHeight, innerWidth, scrollY]; })()")  # fmt: skip
    top, bottom, left, right, height, width, scrolled = box
    assert scrolled == 0 and 0 <= top < bottom <= height and 0 <= left < right <= width, box


def check_legend_marks(driver) -> None:
    """Every plot's legend: time, then its series; a reference's mark is dashed like its
    line, an estimate's solid, and each mark is a line sample."""
    marks = js(
        driver,
        """[...document.querySelectorAll('.u-legend tr.u-series')]
           .filter(tr => tr.querySelector('.u-marker'))
           .map(tr => { const el = tr.querySelector('.u-marker'), r = el.getBoundingClientRect();
                        return [tr.querySelector('.u-label').textContent,
                                getComputedStyle(el).borderTopStyle, r.width / r.height]; })""",
    )
    by_label = {label: style for label, style, _ in marks if label != "time (s)"}
    assert by_label["Fz estimate"] == "solid" and by_label["Fz reference"] == "dashed"
    assert by_label["Tx"] == "solid" and by_label["Tx ref"] == "dashed"
    assert all(aspect >= 5 for label, _, aspect in marks if label != "time (s)"), marks
    x_labels = js(driver, "Object.values(stac.plots).map(p => p.u.axes[0].label)")
    assert len(x_labels) == 7 and set(x_labels) == {"time (s)"}


def scale_x(driver, key: str = "Fz") -> tuple[float, float]:
    lo, hi = js(driver, f"[stac.plots.{key}.u.scales.x.min, stac.plots.{key}.u.scales.x.max]")
    return lo, hi


def check_zoom_pan_cursor_follow(driver) -> None:
    over = driver.find_element("css selector", "#plot-Fz .u-over")
    w = over.size["width"]
    # cursor read-out: the legend shows the values under the mouse
    ActionChains(driver).move_to_element_with_offset(over, w // 4, 0).perform()
    values = js(
        driver,
        "[...document.querySelectorAll('#plot-Fz .u-legend .u-value')].map(e => e.textContent)",
    )
    assert re.fullmatch(r"-?\d+\.\d{2}", values[0]) and re.fullmatch(r"-?\d+\.\d{3}", values[1]), (
        values
    )
    # drag across a quarter of the plot: every plot zooms to that span and stays there
    lo0, hi0 = scale_x(driver)
    drag = ActionChains(driver).move_to_element_with_offset(over, -w // 4, 0).click_and_hold()
    drag.move_by_offset(w // 4, 0).release().perform()
    assert js(driver, "stac.follow") is False
    assert not driver.find_element("id", "follow").get_attribute("disabled")
    lo, hi = scale_x(driver)
    assert hi - lo == pytest.approx((hi0 - lo0) / 4, rel=0.15), (lo0, hi0, lo, hi)
    assert scale_x(driver, "T") == (lo, hi)
    # a plot out of view is not drawn; scrolled into view it shows the same span
    driver.execute_script("document.getElementById('plot-S2').scrollIntoView()")
    wait_for(
        driver, f"stac.plots.S2.u.scales.x.min === {lo} && stac.plots.S2.u.scales.x.max === {hi}"
    )
    driver.execute_script("window.scrollTo(0, 0)")
    n = js(driver, "stac.xs.length")
    wait_for(driver, f"stac.xs.length > {n + 5}")  # data keep arriving ...
    assert scale_x(driver) == (lo, hi)  # ... and the zoomed view stays put
    # the wheel zooms in around the mouse
    ActionChains(driver).scroll_from_origin(ScrollOrigin.from_element(over), 0, -100).perform()
    wait_for(
        driver, f"stac.plots.Fz.u.scales.x.max - stac.plots.Fz.u.scales.x.min < {0.9 * (hi - lo)}"
    )
    lo, hi = scale_x(driver)
    # shift+drag pans: dragging to the left shows later times, the span kept
    ActionChains(driver).key_down(Keys.SHIFT).move_to_element(over).click_and_hold().move_by_offset(
        -w // 5, 0).release().key_up(Keys.SHIFT).perform()  # fmt: skip
    plo, phi = scale_x(driver)
    assert plo > lo and phi - plo == pytest.approx(hi - lo, rel=1e-6)
    assert plo - lo == pytest.approx((hi - lo) / 5, rel=0.15)
    # a double-click follows the live data again: the newest sample at the right edge
    ActionChains(driver).double_click(over).perform()
    assert js(driver, "stac.follow") is True
    wait_for(
        driver, "Math.abs(stac.plots.Fz.u.scales.x.max - stac.plots.Fz.u.data[0].at(-1)) < 1e-9"
    )
    # and so does the button, after another zoom
    ActionChains(driver).move_to_element_with_offset(over, 0, 0).click_and_hold().move_by_offset(
        w // 5, 0).release().perform()  # fmt: skip
    assert js(driver, "stac.follow") is False
    driver.find_element("id", "follow").click()
    assert js(driver, "stac.follow") is True
    assert driver.find_element("id", "follow").get_attribute("disabled")


@pytest.mark.slow
def test_page_without_a_model_shows_raw_counts_and_the_reference(tmp_path) -> None:
    if (why := missing()) is not None:
        pytest.fail(why)
    SHOTS.mkdir(parents=True, exist_ok=True)
    url = PRESSES_URL + "&speed=1&ft=bota"
    session = LiveSession(None, url, ft_url=url, out_dir=tmp_path)
    with chromium() as driver:
        server = LiveServer(session, bind(0)).start()
        try:
            driver.get(server.url)
            wait_for(
                driver,
                "stac.refsReceived > 20 && stac.plots.S0 && stac.plots.S0.u.data[0].length > 20",
            )
            note = driver.find_element("id", "no-model")
            assert note.is_displayed() and note.text.startswith(NO_MODEL)
            assert "spectratac train" in note.text
            for hidden in ("panel-region", "tab-snake", "mae"):
                assert not driver.find_element("id", hidden).is_displayed(), hidden
            labels = js(
                driver, "['Fz', 'T'].map(k => stac.plots[k].u.series.slice(1).map(s => s.label))"
            )
            assert labels == [["Fz reference"], ["Tx ref", "Ty ref", "Tz ref"]]
            wait_for(driver, "stac.plots.Fz.u.data[1].filter(v => v !== null).length > 10")
            assert js(driver, "stac.plots.S1.u.data[5].filter(v => v !== null).length") > 10  # IR
            assert "no model" in driver.find_element("id", "source").text
            check_link_panel_in_view(driver)
            check_simulated_ft_loss_named(driver)
            driver.execute_script("window.scrollTo(0, 0)")
            driver.save_screenshot(str(SHOTS / "live-no-model.png"))
            assert not [e for e in driver.get_log("browser") if e["level"] == "SEVERE"]
            server.stop()  # nothing else arrives: the page gets only the burst below
            check_a_burst_is_stamped_at_once_and_handled_in_one_frame(driver)
        finally:
            server.stop()


def check_simulated_ft_loss_named(driver) -> None:
    """The simulated F/T sensor loses samples on purpose (ft_loss, 0.001 by default): the link
    panel says so, as a row a person reads, and does not flag it as the link's fault."""
    wait_for(driver, "document.getElementById('link').textContent.includes('F/T samples')")
    rows = js(
        driver,
        "[...document.querySelectorAll('#link dt')].map(dt => [dt.textContent, "
        "dt.nextElementSibling.textContent, dt.nextElementSibling.className, dt.title])",
    )
    lost = [r for r in rows if r[0].startswith("F/T lost")]
    assert len(lost) == 1 and lost[0][0] == "F/T lost on purpose (simulated)", rows
    assert lost[0][1].isdigit() and lost[0][2] == "", rows  # a count, not flagged as a fault
    assert "ft_loss=0.001" in lost[0][3], rows  # the hover says how often
    assert "F/T lost on purpose (simulated)" in driver.find_element("id", "link").text


def check_a_burst_is_stamped_at_once_and_handled_in_one_frame(driver) -> None:
    """Estimates that reach the page together (after the machine stalled the browser) are
    each stamped as their message is handed over and handled once, at the next frame: no
    estimate's stamp waits for the work of the ones before it."""
    wait_for(driver, "stac.pending.length === 0")
    before = js(driver, "[stac.received, stac.batches]")
    burst = js(driver, """(() => {
        const n = stac.latency.length, last = stac.last;
        const now = () => performance.timeOrigin + performance.now();
        const msgs = [1, 2, 3].map((k) => ({...last, seq: last.seq + k, t: last.t + 0.05 * k,
                                             arrival_ms: now()}));
        socket.onmessage({data: JSON.stringify(msgs[0])});
        socket.onmessage({data: JSON.stringify(msgs.slice(1))});  // the server's batch: an array
        return [stac.latency.length - n, stac.pending.length, stac.received];
      })()""")  # fmt: skip
    assert burst == [3, 3, before[0]], burst  # stamped; nothing handled within their task
    wait_for(driver, f"stac.received === {before[0] + 3}")
    assert js(driver, "[stac.batches, stac.pending.length]") == [before[1] + 1, 0]
