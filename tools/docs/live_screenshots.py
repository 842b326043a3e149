"""The live page's screenshots in its guide (host/spectratac/apps/live/README.md), taken as a
user would see them.

    python -m tools.docs.live_screenshots [-o host/spectratac/apps/live/screenshots] [--model M]

Serves `spectratac live` on the simulated sensor (the scripted presses scene with a simulated
Bota F/T, at real time) and photographs it in headless Chromium (Debian's chromium +
chromium-driver, driven by selenium) at 1400 x 1000: the force tracking page with a model
(live.png), its Snake tab (snake.png), and the page without a model (live-no-model.png),
each the whole page with the mouse over a plot (the cursor read-out in the legends).
Everything a user would see is neutral: the model is shown as ``model.stac`` and clips would
go to ``live-clips/`` of a scratch folder, so no temporary path of this machine appears.
Each PNG carries the page's visible text in an iTXt chunk (`PAGE_TEXT_KEY`), so a test can
check what the committed picture shows without reading pixels.

Without --model, a small decoder is trained first on twin presses (a few seconds).
"""

from __future__ import annotations

import argparse
import contextlib
import os
import shutil
import struct
import sys
import tempfile
import time
import zlib
from collections.abc import Iterator
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "host" / "spectratac" / "apps" / "live" / "screenshots"
PAGE_TEXT_KEY = "spectratac:page-text"
ORDER = ("up", "right", "down", "left", "centre", "up", "left", "5", "down", "right")
URL = f"sim://?scene=presses&order={','.join(ORDER)}&force=2.5&seed=0&speed=1&ft=bota"
SIZE = (1400, 1000)


def train_model(path: Path) -> Path:
    """A decoder of Fx, Fy, Fz, region and contact, trained on twin presses of every region
    on the unit the scene plays (seed 0)."""
    import numpy as np
    from spectratac.hardware.generated import vocabulary as vocab
    from spectratac.sim.twin_dataset import from_twin_session
    from spectratac.train import TrainSpec, train
    from spectratac.twin import generate_session
    from spectratac.twin.scripted_presses import scripted_presses

    regions = list(vocab.REGIONS) * 6
    np.random.default_rng(5).shuffle(regions)
    scene = scripted_presses(regions, np.tile([0.6, 1.5, 3.0, 2.0, 4.0, 1.0], 9))
    ds = from_twin_session(generate_session(scene, seed=0), scene)
    spec = TrainSpec.paper(targets=("Fx", "Fy", "Fz", "region", "contact"), epochs=60,
                           hidden=64, blocks=2, threads=1, context=2, drift="baseline")  # fmt: skip
    return train(ds, spec, progress=False).save(path)


def with_page_text(png: bytes, text: str) -> bytes:
    """`png` with an iTXt chunk (UTF-8, uncompressed) holding `text`, before IEND."""
    data = PAGE_TEXT_KEY.encode() + b"\0\0\0\0\0" + text.encode()
    chunk = struct.pack(">I", len(data)) + b"iTXt" + data
    chunk += struct.pack(">I", zlib.crc32(b"iTXt" + data) & 0xFFFFFFFF)
    iend = png.rindex(b"IEND") - 4
    return png[:iend] + chunk + png[iend:]


@contextlib.contextmanager
def browser() -> Iterator[object]:
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    profile = tempfile.mkdtemp(prefix="stac-shots-chromium-")
    options = webdriver.ChromeOptions()
    options.binary_location = "/usr/bin/chromium"
    for flag in ("--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
                 "--disable-background-networking", "--disable-dev-shm-usage",
                 "--hide-scrollbars", f"--user-data-dir={profile}",
                 f"--window-size={SIZE[0]},{SIZE[1]}"):  # fmt: skip
        options.add_argument(flag)
    driver = webdriver.Chrome(service=Service("/usr/bin/chromedriver"), options=options)
    try:
        yield driver
    finally:
        driver.quit()
        shutil.rmtree(profile, ignore_errors=True)


def wait_for(driver, script: str, timeout: float = 60.0) -> None:
    deadline = time.monotonic() + timeout
    while not driver.execute_script("return " + script):
        if time.monotonic() > deadline:
            raise SystemExit(f"the page never showed {script!r} within {timeout:g} s")
        time.sleep(0.1)


def shoot(driver, path: Path, hover: str | None = None) -> None:
    """The whole page (the window grown to its height) with the mouse over the plot `hover`
    (its cursor read-out in every legend)."""
    from selenium.webdriver.common.action_chains import ActionChains

    chrome = driver.execute_script("return window.outerHeight - window.innerHeight")
    height = driver.execute_script("return document.documentElement.scrollHeight")
    driver.set_window_size(SIZE[0], max(SIZE[1], height + chrome))
    driver.execute_script("window.scrollTo(0, 0)")
    time.sleep(0.5)  # the plots resize and draw on animation frames
    if hover is not None:
        over = driver.find_element("css selector", f"#{hover} .u-over")
        ActionChains(driver).move_to_element_with_offset(over, over.size["width"] // 4, 0).perform()
        time.sleep(0.2)
    text = driver.execute_script("return document.body.innerText")
    path.write_bytes(with_page_text(driver.get_screenshot_as_png(), text))
    driver.set_window_size(*SIZE)
    print(f"wrote {path}")


def serve(decoder, model_path: str | None):
    from spectratac.apps.live.server import LiveServer, bind
    from spectratac.apps.live.session import LiveSession

    session = LiveSession(decoder, URL, out_dir="live-clips", model_path=model_path)
    return LiveServer(session, bind(0)).start()


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("-o", "--output", type=Path, default=OUT, help="folder (default: %(default)s)")
    p.add_argument("--model", type=Path, help="decoder file (default: train a small one)")
    args = p.parse_args()
    from spectratac.decode import Decoder

    out = args.output.resolve()
    out.mkdir(parents=True, exist_ok=True)
    scratch = Path(tempfile.mkdtemp(prefix="stac-shots-"))
    here = Path.cwd()
    try:
        os.chdir(scratch)  # what the page shows of paths is relative to here
        model = Path("model.stac")
        if args.model:
            shutil.copy(args.model, model)
        else:
            train_model(model)
        with browser() as driver:
            server = serve(Decoder.load(model), str(model))
            try:
                driver.get(server.url)
                # the third press (down, 4-6 s) held in the middle of the window, the MAE filled
                wait_for(driver, "stac.last && stac.last.t > 5.2 && stac.refsReceived > 60")
                wait_for(driver, "stac.last.contact === true")
                shoot(driver, out / "live.png", hover="plot-Fz")
                driver.find_element("id", "tab-snake").click()
                wait_for(driver, "document.getElementById('snake-commands').children.length >= 3")
                shoot(driver, out / "snake.png")
            finally:
                server.stop()
            server = serve(None, None)
            try:
                driver.get(server.url)
                wait_for(driver, "stac.last && stac.last.t > 5.2 && stac.refsReceived > 60")
                shoot(driver, out / "live-no-model.png", hover="plot-S0")
            finally:
                server.stop()
    finally:
        os.chdir(here)
        shutil.rmtree(scratch, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
