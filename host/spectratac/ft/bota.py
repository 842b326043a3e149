"""Bota Systems serial F/T driver: bota:///dev/ttyUSB0?baud=460800&rate=&sinc=&configure=1
&force_range=&torque_range=.

Opening follows the vendor's serial procedure: send 'C' (configuration mode, the sensor
stops streaming and answers "r,0,C,0"; retried every 0.5 s, FTTimeoutError after `timeout`),
then the communication setup "c,<temperature compensation>,1 (calibrated),0 (binary),<baud
code>" and, with sinc=, the filter setup "f,<sinc>,0,0,1"; start() sends 'R' (run: binary
frames follow) and returns once the sensor has acknowledged it, so a stream started next
(the optical sensor's, in a recording) starts after the F/T's, whatever the scheduler does;
stop() sends 'C', and its acknowledgement, which follows the last frame, sets
`stream_stopped`. configure=0 skips all commands and parses a sensor that
already streams. Frames are parsed by spectratac.ft.botaframe (resynchronises after damage,
counts CRC errors).

Records: sensor_time is the frame timestamp (µs, unwrapped) in s; the sensor has no sample
counter, so sequence is the timestamp divided by the sample period (rate=, or 51200/sinc
with sinc=, else estimated from the first frames), and a lost or damaged frame shows as a
gap; status holds the sensor's status bits (botaframe.STATUS_*). The latest board
temperature is in `temperature_c`.

Plausibility: force_range= (N) and torque_range= (N*m) are the sensor's rated measurement
range from its datasheet (default DEFAULT_FORCE_RANGE_N / DEFAULT_TORQUE_RANGE_NM, 5 kN and
500 N*m: generous, so that no real reading is lost when the range is not given). A frame
whose CRC holds but whose values are non-finite or beyond RANGE_MARGIN times the range is line
noise that passed the 16-bit CRC (one in 65536 damaged frames does): it is dropped and
counted in stats.implausible. Readings slightly beyond the rating still pass; the sensor
flags those itself (botaframe.STATUS_OVERRANGE).
"""

from __future__ import annotations

import errno
import os
import select
import time
from typing import Any
from urllib.parse import parse_qsl, urlsplit

import numpy as np
import serial
from serial.tools import list_ports

from spectratac.ft.base import FTSensor
from spectratac.ft.botaframe import FrameParser
from spectratac.ft.errors import (
    FTDisconnectedError,
    FTError,
    FTNotFoundError,
    FTTimeoutError,
    FTURLError,
)
from spectratac.ft.options import RATE, Options, Param
from spectratac.ft.records import FT_RECORD, FTInfo
from spectratac.ft.sequence import SequenceTracker, Unwrapper

BAUD_CODES = {9600: 0, 57600: 1, 115200: 2, 230400: 3, 460800: 4}
SINC_CLOCK_HZ = 51200.0  # sample period = sinc length / 51200 s (vendor example)
#: Defaults for force_range= / torque_range=: deliberately generous, so a sensor opened
#: without its datasheet range loses no reading; give the range to catch smaller noise.
DEFAULT_FORCE_RANGE_N = 5000.0
DEFAULT_TORQUE_RANGE_NM = 500.0
#: Strain gauges saturate not far past the rating; values beyond this multiple are not readings.
RANGE_MARGIN = 4.0
#: bota:// options (spectratac.ft.options).
URL_PARAMS = {
    "baud": Param("choice", meaning="serial baud rate", choices=tuple(map(str, BAUD_CODES))),
    "rate": RATE,
    "sinc": Param("integer", 1, 4096, "the filter's sinc length (sets the rate)"),
    "configure": Param("flag", meaning="write the sensor's configuration on open"),
    "temperature_compensation": Param("flag", meaning="the sensor's own compensation"),
    "force_range": Param("number", 1e-3, 1e6, "the rated range of force from the datasheet, N"),
    "torque_range": Param("number", 1e-3, 1e5, "the rated range of torque from the datasheet, N*m"),
}


def plausible_limits(force_range_n: float, torque_range_nm: float) -> np.ndarray:
    """Largest magnitude accepted per axis (Fx Fy Fz N, Tx Ty Tz N*m) for a rated range.

    >>> plausible_limits(500, 10).tolist()
    [2000.0, 2000.0, 2000.0, 40.0, 40.0, 40.0]
    """
    return RANGE_MARGIN * np.repeat([float(force_range_n), float(torque_range_nm)], 3)


def ack(command: str) -> bytes:
    """The sensor's acknowledgement of a command: r,0,<letter>,0."""
    return f"r,0,{command[0]},0".encode()


class BotaSensor(FTSensor):
    """Bota Systems serial F/T sensor (see the module documentation)."""

    scheme = "bota"

    @classmethod
    def connect(cls, url: str, *, timeout: float, buffer_size: int, **options: Any) -> BotaSensor:
        parts = urlsplit(url)
        path = parts.path
        if not path:
            raise FTURLError(f"{url}: no serial port; example: bota:///dev/ttyUSB0?baud=460800")
        opts = Options(url, {**dict(parse_qsl(parts.query)), **options}, URL_PARAMS)
        baud = opts.integer("baud", 460800)
        rate = opts.number("rate")
        sinc = opts.integer("sinc")
        configure = opts.flag("configure", True)
        temp_comp = opts.flag("temperature_compensation", False)
        force_range = opts.number("force_range", DEFAULT_FORCE_RANGE_N)
        torque_range = opts.number("torque_range", DEFAULT_TORQUE_RANGE_NM)
        if rate is None and sinc is not None:
            rate = SINC_CLOCK_HZ / sinc
        port = _open_port(url, path, baud)
        info = FTInfo("bota", model="Bota Systems serial F/T", serial=path, rate_hz=rate or 0.0)
        info.extra.update(
            path=path,
            baud=baud,
            configured=configure,
            force_range_n=force_range,
            torque_range_nm=torque_range,
        )
        sensor = cls(url, info, timeout=timeout, buffer_size=buffer_size)
        sensor._port = port
        sensor._fd = port.fileno()
        sensor._parser = FrameParser(plausible_limits(force_range, torque_range))
        sensor._unwrap = Unwrapper(32)
        sensor._tracker = SequenceTracker(sensor.stats)
        sensor._configure = configure
        sensor._held = []
        sensor._t0_us = None
        sensor._after_ack = b""
        sensor._text_tail = b""
        sensor.confirms_stop = configure
        sensor.temperature_c = float("nan")
        try:
            if configure:
                sensor._command("C", timeout, retry=0.5)
                sensor._command(f"c,{int(temp_comp)},1,0,{BAUD_CODES[baud]}", timeout)
                if sinc is not None:
                    sensor._command(f"f,{sinc},0,0,1", timeout)
        except BaseException:
            sensor.close()
            raise
        return sensor

    _port: serial.Serial
    _fd: int
    _parser: FrameParser
    _unwrap: Unwrapper
    _tracker: SequenceTracker
    _configure: bool
    _held: list[tuple[np.ndarray, float]]
    _t0_us: int | None
    _after_ack: bytes
    _text_tail: bytes  # the last bytes read, for an acknowledgement split across reads
    temperature_c: float

    # ------------------------------------------------------------------ commands
    def _command(self, command: str, timeout: float, retry: float | None = None) -> bytes:
        """Send a text command and wait for its acknowledgement (while no reader thread runs);
        returns the bytes read after the acknowledgement (frames, once streaming)."""
        want = ack(command)
        deadline = time.monotonic() + timeout
        seen = b""
        sent_at = -1e9
        while True:
            now = time.monotonic()
            if now - sent_at >= (retry or 1e9):
                os.write(self._fd, command.encode())
                sent_at = now
            if now >= deadline:
                raise FTTimeoutError(
                    f"no reply {want.decode()!r} to command {command!r} from {self.url} within "
                    f"{timeout:.1f} s: is a Bota serial sensor connected and powered, at "
                    f"baud={self.info.extra['baud']}?"
                )
            readable, _, _ = select.select([self._fd], [], [], min(0.05, deadline - now))
            if readable:
                chunk = self._read_fd()
                seen = (seen + chunk)[-4096:]
                if want in seen:
                    return seen[seen.rindex(want) + len(want) :]

    def _read_fd(self) -> bytes:
        try:
            data = os.read(self._fd, 1 << 16)
        except BlockingIOError:
            return b""
        except OSError as exc:
            raise FTDisconnectedError(f"lost {self.url}: {exc}; check the cable, reopen") from None
        if not data:
            raise FTDisconnectedError(f"{self.url} closed (end of file); reopen it")
        return data

    def _send_start(self) -> None:
        if not self._configure:
            return
        if self._thread is not None:  # a restart: the reader owns the port and skips the reply
            os.write(self._fd, b"R")
            return
        # the first start: wait for "r,0,R,0" (no reader competes for the port yet); frames
        # read with it go to the parser first
        self._after_ack = self._command("R", self.timeout)

    def _send_stop(self) -> None:
        if self._configure:
            os.write(self._fd, b"C")

    def _close_link(self) -> None:
        self._port.close()

    # ------------------------------------------------------------------ receiving
    def _poll(self, timeout: float) -> np.ndarray:
        data, self._after_ack = self._after_ack, b""
        if not data:
            readable, _, _ = select.select([self._fd], [], [], timeout)
            if not readable:
                return np.empty(0, dtype=FT_RECORD)
            data = self._read_fd()
        now = time.monotonic()
        if not self._streaming:  # stopping: the acknowledgement ends the stream
            seen = self._text_tail + data
            self._stop_seen = self._stop_seen or ack("C") in seen
            self._text_tail = seen[-len(ack("C")) :]
        frames = self._parser.feed(data)
        self.stats.crc_errors = self._parser.crc_errors
        self.stats.bad_frames = self._parser.lost_sync
        self.stats.implausible = self._parser.implausible
        if len(frames) == 0:
            return np.empty(0, dtype=FT_RECORD)
        self.temperature_c = float(frames["temperature"][-1])
        if not self.info.rate_hz:  # learn the period from the first frames
            self._held.append((frames, now))
            if sum(len(f) for f, _ in self._held) < 8:
                return np.empty(0, dtype=FT_RECORD)
            frames, times = self._release_held()
        else:
            times = np.full(len(frames), now)
        return self._records(frames, times)

    def _release_held(self) -> tuple[np.ndarray, np.ndarray]:
        frames = np.concatenate([f for f, _ in self._held])
        times = np.concatenate([np.full(len(f), t) for f, t in self._held])
        self._held.clear()
        steps = np.mod(np.diff(frames["timestamp"].astype(np.int64)), 1 << 32)
        steps = steps[steps > 0]
        period_us = float(np.min(steps)) if len(steps) else 1000.0
        # the shortest step is one period unless every pair lost frames in between
        self.info.rate_hz = 1e6 / period_us
        self.info.extra["rate_source"] = "estimated from timestamps"
        return frames, times

    def _records(self, frames: np.ndarray, times: np.ndarray) -> np.ndarray:
        t_us = self._unwrap(frames["timestamp"])
        if self._t0_us is None:
            self._t0_us = int(t_us[0])
        period_us = 1e6 / self.info.rate_hz
        seq = np.rint((t_us - self._t0_us) / period_us).astype(np.int64)
        keep = self._tracker.update(seq)
        out = np.empty(len(frames), dtype=FT_RECORD)
        out["sensor_time"] = t_us * 1e-6
        out["host_time"] = times
        out["sequence"] = seq
        out["wrench"] = frames["forces"]
        out["status"] = frames["status"]
        return out if keep.all() else out[keep]


def _open_port(url: str, path: str, baud: int) -> serial.Serial:
    try:
        port = serial.Serial(path, baudrate=baud, timeout=0, exclusive=True)
    except FileNotFoundError:
        raise FTNotFoundError(_not_found(url, path)) from None
    except serial.SerialException as exc:
        code = exc.errno if isinstance(exc.errno, int) else None
        if code == errno.ENOENT:
            raise FTNotFoundError(_not_found(url, path)) from None
        if code in (errno.EACCES, errno.EPERM):
            raise FTError(
                f"{url}: permission denied on {path}: add yourself to the 'dialout' group "
                f"(then log in again) or fix the device's permissions"
            ) from None
        raise FTError(f"{url}: cannot open {path}: {exc}") from None
    return port


def _not_found(url: str, path: str) -> str:
    ports = ", ".join(p.device for p in list_ports.comports()) or "none"
    return f"{url}: no serial port {path}; ports present: {ports}"
