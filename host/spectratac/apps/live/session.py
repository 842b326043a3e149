"""`LiveSession`: the decoder running on a live sensor, with its reference F/T, history
and Snake game, publishing one JSON message per sample. No UI: the web server
(`spectratac.apps.live.server`) and the tests subscribe to it.

    session = LiveSession(Decoder.load("model.stac"), "sim://?scene=presses&speed=1")
    session.start(publish=print)      # opens the devices here (errors raise here) ...
    ...                               # ... and decodes on a worker thread
    session.stop()

Without `ft_url` the session uses the F/T sensor the link pairs with the device, if any
(`Sensor.link_info`: a sim:// URL with ``ft=bota``), and the link's clock scale.
Torch is never imported: decoding runs on the model file's NumPy runtime.

Without a decoder (``LiveSession(None, url)``: no model trained yet) the session streams the
device as it is configured and publishes raw counts and the reference F/T only, the
estimate's fields null (`NO_MODEL`); there is nothing to score and no Snake to steer.

``benchmark=True`` is for `tools/bench/live.py` and its tests only: it times every
estimate's way to the browser (the server sends probes and echo pings, the page reports
its latencies back, the session and server time each stage). A user's session sends and
shows none of it; the page measures its own latency to the browser from each estimate's
``arrival_ms``.
"""

from __future__ import annotations

import contextlib
import itertools
import os
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
from spectratac.apps.live.alignment import FT_WINDOW_S, LiveClock, ReferenceTracker
from spectratac.apps.live.geometry import page_geometry
from spectratac.apps.live.history import FORMATS, KEEP_S, History
from spectratac.apps.live.latency import LatencyLog, Stages, unix_ms
from spectratac.apps.live.messages import estimate_message, raw_config
from spectratac.apps.sensor_setup import SampleTap, open_for_decoder
from spectratac.apps.snake.controller import SnakeController
from spectratac.dataset.labels import CONTACT_N
from spectratac.device.streams import DeviceStream
from spectratac.errors import SpectraTacError
from spectratac.hardware.generated import vocabulary as vocab

Publish = Callable[[dict[str, Any]], None]
STATS_EVERY_S = 0.5
#: Estimates at most waiting for their reference while the worker catches up: a worker that
#: never catches up (a machine too slow for the sensor's rate) scores in batches of this many
#: instead of holding every estimate it ever made.
MAX_UNSCORED = 200
#: What a session without a model shows, and how to get one (the page and the CLI say it).
NO_MODEL = "no model: raw counts and reference only"
TRAIN_HINT = (
    "to decode force, record a session with a reference F/T sensor "
    "(spectratac record URL --ft FT_URL -o s.mcap), build its dataset "
    "(spectratac dataset build s.mcap -o d.npz), train (spectratac train d.npz -o model.stac) "
    "and start spectratac live model.stac URL"
)


class ClipSaveError(SpectraTacError):
    """A clip could not be written (disk full, folder not writable); nothing half-written is
    left under a clip's name."""


class LiveSession:
    def __init__(
        self,
        decoder: Any | None,
        url: str,
        *,
        ft_url: str | None = None,
        keep_config: bool = False,
        timeout: float = 2.0,
        stall_timeout: float | None = None,
        history_s: float = KEEP_S,
        snake: SnakeController | None = None,
        out_dir: str | Path = "live-clips",
        model_path: str | None = None,
        benchmark: bool = False,
    ) -> None:
        self.decoder = decoder
        self.url = url
        self.ft_url = ft_url
        self.keep_config = keep_config
        self.timeout = timeout
        self.stall_timeout = stall_timeout  # None: the sensor's default (Sensor.stall_timeout)
        self.snake = snake or SnakeController()
        self.history = History(history_s)
        self.out_dir = Path(out_dir)
        self.model_path = model_path
        self.benchmark = benchmark  # the benchmark's instruments below are filled only then
        self.latency = LatencyLog()  # frame arrival -> browser, as the page reports it
        self.echo = LatencyLog()  # the bare WebSocket round trip, halved
        self.bare = LatencyLog()  # a bare message one way, as the page times an estimate
        self.pipeline = LatencyLog()  # frame arrival -> message published (decoding included)
        # frame arrival -> the worker took the sample / its estimate was ready (the parts of
        # `pipeline`; the server's `Hub.stages` times the rest of the way)
        self.stages = Stages(("taken", "decoded"))
        self.scale: float | None = 1.0  # device s per host s: the link's, once open
        self.sensor: DeviceStream | None = None
        self.ft: Any = None
        self.tracker: ReferenceTracker | None = None
        self.estimates = 0
        self.last: dict[str, Any] | None = None
        self._stack = contextlib.ExitStack()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._lock = threading.Lock()  # the snake is driven by the worker and by clients
        self._save_lock = threading.Lock()
        self.error: str | None = None
        self._ft_warned = False

    # ------------------------------------------------------------------ lifecycle
    def start(self, publish: Publish) -> None:
        """Open the sensor (configured as the model was trained) and the F/T sensor, then
        decode on a worker thread, calling `publish(message)` from it."""
        try:
            # no model: nothing to configure the sensor for, so it streams as it is
            keep = self.keep_config or self.decoder is None
            self.sensor = self._stack.enter_context(
                open_for_decoder(
                    self.decoder,
                    self.url,
                    keep_config=keep,
                    timeout=self.timeout,
                    stall_timeout=self.stall_timeout,
                )
            )
            self.sensor.add_listener(lambda frame, t: self.history.add_frame(frame.raw, t))
            link = self.sensor.link_info
            self.scale = link.clock_scale
            if self.ft_url is None:
                self.ft_url = link.paired_ft_url
            if self.ft_url is not None:
                from spectratac.ft import FTSensor

                self.ft = self._stack.enter_context(
                    FTSensor.open(self.ft_url, timeout=self.timeout)
                )
                self.ft.stall_timeout = self.stall_timeout  # None: from its rate
                self.ft.start()
        except BaseException:
            self._stack.close()
            raise
        self._thread = threading.Thread(
            target=self._run, args=(publish,), name="spectratac-live", daemon=True
        )
        self._thread.start()

    def stop(self) -> None:
        """Stop decoding and close the devices (idempotent)."""
        self._stop.set()
        self._stack.close()  # closing the sensor ends the stream the worker waits on
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=5.0)

    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    # ------------------------------------------------------------------ what clients see
    def meta(self) -> dict[str, Any]:
        """Everything the page needs once: model, devices, geometry, game settings."""
        det = self.snake.detector
        dec = self.decoder
        model = None
        if dec is not None:
            model = {"path": self.model_path, "targets": list(dec.target_names),
                     "unit": dec.unit_id, "params": dec.n_params,
                     "regions": int(dec.heads.n_classes)}  # fmt: skip
        return {
            "type": "meta",
            "model": model,
            "no_model": None if dec is not None else {"note": NO_MODEL, "hint": TRAIN_HINT},
            "url": self.url,
            "ft_url": self.ft_url,
            "device": None if self.sensor is None else self.sensor.info.board,
            "config": None if dec is None else dec.config,
            "history_s": self.history.keep_s,
            "formats": list(FORMATS),
            "geometry": page_geometry(),
            "raw": raw_config(),
            "contact_n": CONTACT_N,  # the reference |F| that counts as contact for the MAE
            "snake": self.snake_state(),
            "threshold_n": det.threshold_n,
            "release_n": det.release_n,
            "benchmark": self.benchmark,  # the page reports its latencies only then
            "error": self.error,  # a dead session: why (the page shows it)
        }

    def tare(self) -> None:
        """Zero the decoder's drift baseline on the next sample (the page's Tare button;
        without a model there is no baseline, and the page hides the button)."""
        if self.decoder is not None:
            self.decoder.tare()

    def snake_state(self) -> dict[str, Any]:
        with self._lock:
            return self.snake.state()

    def restart_snake(self) -> dict[str, Any]:
        with self._lock:
            self.snake.restart()
            return self.snake.state()

    def stats(self) -> dict[str, Any]:
        s = self.sensor.stats if self.sensor is not None else None
        out: dict[str, Any] = {
            "type": "stats",
            "estimates": self.estimates,
            "running": self.running,
            "error": self.error,
        }
        if self.benchmark:
            out.update(latency=self.latency.summary(), echo=self.echo.summary(),
                       bare=self.bare.summary(), pipeline=self.pipeline.summary())  # fmt: skip
        if s is not None:
            out["link"] = {
                "samples": s.samples_received,
                "lost": s.sample_gaps,
                "errors": s.crc_errors + s.cobs_errors + s.other_frame_errors,
                "frame_gaps": s.frame_gaps,
                "overflows": s.buffer_overflows,
                "reconnects": s.reconnects,
            }
        if self.ft is not None:
            # a simulated sensor loses samples on purpose (ft_loss): the page says so
            simulated = self.ft.info.extra.get("simulated_loss")
            out["ft"] = {"received": self.ft.stats.received, "lost": self.ft.stats.lost,
                         "stalls": getattr(self.ft.stats, "stalls", 0),
                         "history_thinned": self.history.ft_thinned,
                         "simulated_loss": simulated}  # fmt: skip
        if self.tracker is not None and self.decoder is not None:
            out["mae"] = self.tracker.mae()
            out["mae_contact"] = self.tracker.mae_contact()
            out["windows"] = {"scored": self.tracker.overall.windows,
                              "in_contact": self.tracker.contact.windows}  # fmt: skip
        return out

    def save(self, seconds: float, fmt: str = "mcap") -> dict[str, Any]:
        """Write the last `seconds` as `fmt` (mcap or csv) into the output folder."""
        if fmt not in FORMATS:
            raise SpectraTacError(f"format {fmt!r}: choose one of {', '.join(FORMATS)}")
        if self.sensor is None:
            raise SpectraTacError("the session has not started: nothing to save yet")
        try:
            return self._save(seconds, fmt)
        except OSError as exc:  # a full disk or a folder the server may not write: say where
            raise ClipSaveError(
                f"cannot save the clip into {self.out_dir}: {exc.strerror or exc}; free some "
                f"space or restart `spectratac live` with -o/--output naming a writable folder"
            ) from None

    def _save(self, seconds: float, fmt: str) -> dict[str, Any]:
        self.out_dir.mkdir(parents=True, exist_ok=True)
        stem = f"live-{time.strftime('%Y%m%d-%H%M%S')}-{seconds:g}s"
        # written under a unique temporary name, then linked to the first free clip name:
        # the link fails if the name exists, so concurrent saves (this server or another
        # one on the same folder) never share a name, and a clip is complete once named
        fd, tmp_name = tempfile.mkstemp(prefix=f".{stem}-", suffix=f".{fmt}.partial",
                                        dir=self.out_dir)  # fmt: skip
        os.close(fd)
        tmp = Path(tmp_name)
        try:
            with self._save_lock:  # the MCAP clip queries the device (clock sync, config)
                if fmt == "csv":
                    n = self.history.save_csv(tmp, seconds)
                    what = "rows"
                else:
                    ft_info = None if self.ft is None else self.ft.info.as_dict()
                    session = {"url": self.url, "ft_url": self.ft_url, "clip_s": seconds,
                               "ft_info": ft_info}  # fmt: skip
                    n = self.history.save_mcap(tmp, seconds, self.sensor, session)
                    what = "frames"
            path = _link_unique(tmp, self.out_dir, stem, fmt)
        finally:
            tmp.unlink(missing_ok=True)
        return {"path": str(path.resolve()), "format": fmt, what: n, "seconds": seconds}

    # ------------------------------------------------------------------ the worker
    def _run(self, publish: Publish) -> None:
        """Decode until stopped. A stream that ends otherwise (the device unplugged, an
        error) leaves a dead session: `error` says why, and one "error" message tells the
        pages (a page that joins later gets it in the meta)."""
        why = "the device's stream ended"
        try:
            self._decode(publish)
            why = self._end_reason() or why
        except SpectraTacError as exc:
            why = str(exc)
        except Exception as exc:  # a bug must not leave a page that silently stops moving
            why = f"the session failed: {type(exc).__name__}: {exc}"
        finally:
            if not self._stop.is_set():
                self.error = why
                publish({"type": "error", "message": why})
                publish(self.stats())

    def _end_reason(self) -> str | None:
        """Why the sensor's samples ended (they end quietly when the link is lost; a read
        then raises the loss)."""
        try:
            if self.sensor is not None:
                self.sensor.read(1, timeout=0)
        except SpectraTacError as exc:
            return str(exc)
        return None

    def _samples(self) -> Iterator[tuple[Any, Any | None]]:
        """(sample, its estimate or None without a model), as they arrive."""
        timing = self.benchmark
        if self.decoder is None:
            for sample in self.sensor:
                if timing:
                    self.stages.add("taken", (time.monotonic() - sample.host_time) * 1e3)
                yield sample, None
            return
        tap = SampleTap(self.sensor)
        for est in self.decoder.stream(tap):
            sample = tap.last
            if timing:
                now = time.monotonic()
                self.stages.add("taken", (tap.taken_at - sample.host_time) * 1e3)
                self.stages.add("decoded", (now - sample.host_time) * 1e3)
            yield sample, est

    def _decode(self, publish: Publish) -> None:
        sensor_clock = LiveClock(self.scale, background=True)
        tracker = None
        if self.ft is not None:
            tracker = ReferenceTracker(LiveClock(self.scale, window_s=FT_WINDOW_S, background=True))
            self.tracker = tracker
        # the reference is worked out after an estimate is published (it reads the F/T
        # reader's queue, under its lock, and averages windows: off the page's path); the
        # windows it completes are older estimates', so they go with the next message
        carried = {} if tracker is None else self._scores(tracker, [])
        try:
            self._stream(publish, sensor_clock, tracker, carried)
        finally:
            sensor_clock.close()
            if tracker is not None:
                tracker.clock.close()

    def _stream(
        self,
        publish: Publish,
        sensor_clock: LiveClock,
        tracker: ReferenceTracker | None,
        carried: dict[str, Any],
    ) -> None:
        t0: float | None = None
        t_last = -np.inf
        next_stats = time.monotonic() + STATS_EVERY_S
        unscored: list[tuple[int, Any, Any]] = []  # estimates whose reference waits
        for seq, (sample, est) in enumerate(self._samples()):
            if self._stop.is_set():
                return
            t_end = sample.device_time_us / 1e6
            sensor_clock.add([t_end], [sample.host_time])
            t0 = float(sensor_clock.to_host(t_end)) if t0 is None else t0
            # a refit may move the clock back a little: the page's time axis only advances
            t_plot = max(float(sensor_clock.to_host(t_end)) - t0, t_last + 1e-4)
            t_last = t_plot
            msg = estimate_message(seq, est, sample, t_plot,
                                   unix_ms(sample.host_time))  # fmt: skip
            msg.update(carried)
            carried = {**carried, "refs": []}  # each window goes to the page once
            if est is not None:
                with self._lock:
                    update = self.snake.feed(est, t_end)
                    if update.commands or update.steps:
                        msg["snake"] = self.snake.state()
                        msg["commands"] = [c.as_dict() for c in update.commands]
            self.estimates += 1
            self.last = msg
            publish(msg)  # first: the history and the figures below are not on the page's path
            now = time.monotonic()
            if self.benchmark:
                self.pipeline.add([(now - sample.host_time) * 1e3])
            self.history.add_row(seq, self._row(msg, sample))
            if tracker is not None:
                unscored.append((seq, est, sample))
                # samples waiting to be decoded go first: the reference (the F/T rows read,
                # windows averaged) is off the page's path, so a worker that fell behind on a
                # loaded machine catches up on the estimates first, then scores them at once
                if not self._samples_waiting() or len(unscored) >= MAX_UNSCORED:
                    refs = self._reference(tracker, sensor_clock, unscored, t0)
                    unscored = []
                    carried = self._scores(tracker, refs)
            if now >= next_stats:
                next_stats = now + STATS_EVERY_S
                publish(self.stats())

    def _samples_waiting(self) -> bool:
        """True if the sensor holds samples the worker has not taken yet (it is behind)."""
        return int(getattr(self.sensor, "buffered", 0)) > 0

    def _reference(
        self,
        tracker: ReferenceTracker,
        sensor_clock: LiveClock,
        unscored: list[tuple[int, Any, Any]],
        t0: float,
    ) -> list[list[float]]:
        """Take the F/T rows that came, add the windows of the (seq, estimate, sample) not
        scored yet; the windows now ready."""
        stalled = getattr(self.ft, "stall_message", None)  # a driver's (FTSensor)
        if stalled is not None and not self._ft_warned:
            # the F/T went quiet: said once (stats count it), the estimates go on unscored
            self._ft_warned = True
            print(f"spectratac: warning: {stalled}", file=sys.stderr, flush=True)
        rows = self.ft.read_available()
        tracker.add_ft(rows)
        self.history.add_ft(rows)
        for seq, est, sample in unscored:
            t_start, t_end = sensor_clock.to_host(
                [sample.t_start_us / 1e6, sample.device_time_us / 1e6]
            )
            if est is None:  # no model: the reference of every window, nothing to score
                tracker.add_estimate(seq, float(t_start), float(t_end), np.full(6, np.nan))
            elif not est.invalid:
                wrench = np.r_[est.force, est.torque]
                tracker.add_estimate(seq, float(t_start), float(t_end), wrench)
        refs = []
        for key, t, wrench in tracker.ready():
            self.history.add_reference(key, wrench)
            refs.append([key, round(t - t0, 4), *(round(float(v), 5) for v in wrench)])
        return refs

    def _scores(self, tracker: ReferenceTracker, refs: list[list[float]]) -> dict[str, Any]:
        """What an estimate message carries of the reference: the windows ready since the
        last message, and with a model the running MAE over every window so far."""
        if self.decoder is None:
            return {"refs": refs}
        return {"refs": refs, "mae": tracker.mae(), "mae_contact": tracker.mae_contact()}

    @staticmethod
    def _row(msg: dict[str, Any], sample: Any) -> dict[str, Any]:
        force = msg["force"] or [None] * len(vocab.FORCE_AXES)
        torque = msg["torque"] or [None] * len(vocab.TORQUE_AXES)
        decoded = np.asarray(sample.counts)[:, : len(vocab.DECODED_CHANNELS)].reshape(-1)
        return {
            "t_s": msg["t"],
            "host_time": sample.host_time,
            "device_time_s": sample.device_time_us / 1e6,
            "step": msg["step"],
            **dict(zip(vocab.FT_AXES, [*force, *torque], strict=True)),
            "region": msg["region"],
            "region_prob": msg["p"],
            "contact": None if msg["contact"] is None else int(msg["contact"]),
            "ood": None if msg["ood"] is None else int(msg["ood"]),
            "invalid": None if msg["invalid"] is None else int(msg["invalid"]),
            **dict(zip(vocab.DECODED_INPUTS, decoded.tolist(), strict=True)),
        }


def _link_unique(tmp: Path, folder: Path, stem: str, fmt: str) -> Path:
    """Give the finished `tmp` the first free name ``stem.fmt``, ``stem-2.fmt``, ...
    (a hard link: created only if the name does not exist yet, atomically)."""
    for n in itertools.count(1):
        path = folder / (f"{stem}.{fmt}" if n == 1 else f"{stem}-{n}.{fmt}")
        try:
            os.link(tmp, path)
        except FileExistsError:
            continue
        except OSError as exc:
            raise SpectraTacError(f"cannot write the clip {path}: {exc}") from None
        return path
    raise AssertionError("unreachable")
