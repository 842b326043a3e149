"""Replay an F/T recording from CSV: csv://PATH[?rate=HZ|realtime=1&speed=S&host_time=file|now].

Format: a header row, then one sample per row. Columns by name, any order:
  t (or sensor_time)     sensor clock, s (required)
  Fx Fy Fz               N (required)
  Tx Ty Tz (or Mx My Mz) N*m (required)
  host_time              s, host monotonic time it arrived (optional; used when host_time=file,
                         the default when present, so recorded sessions keep their alignment)
  sequence, status       integers (optional; default: row number and 0)
Pacing: as fast as possible by default; rate=HZ paces rows at HZ; realtime=1 paces them by
their t column (times speed=S). Rows that do not parse are skipped and counted in
stats.bad_frames (so are rows with a byte that is not UTF-8, a non-finite value, or a
`sequence`/`status` that is not a whole number >= 0); gaps in `sequence` count as lost. A file
without a single good row is refused (FTConfigError).

>>> import tempfile, os
>>> path = os.path.join(tempfile.mkdtemp(), "ft.csv")
>>> text = "t,Fx,Fy,Fz,Mx,My,Mz,sequence\\n0,1,0,0,0,0,0,7\\nbad\\n0.1,2,0,0,0,0,0,9\\n"
>>> _ = open(path, "w").write(text)
>>> with CsvFTSensor.connect("csv://" + path, timeout=1, buffer_size=10) as ft:
...     rows = ft.read(5, timeout=1)
>>> rows["sequence"].tolist(), ft.stats.bad_frames, ft.stats.lost
([7, 9], 1, 1)
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from spectratac.ft.errors import FTConfigError, FTNotFoundError, FTURLError
from spectratac.ft.options import RATE, REALTIME, SPEED, Options, Param
from spectratac.ft.records import FT_RECORD, FTInfo
from spectratac.ft.replay import ReplayFTSensor

_ALIASES = {
    "sensor_time": "t",
    "time": "t",
    "mx": "tx",
    "my": "ty",
    "mz": "tz",
}
_WRENCH = ("fx", "fy", "fz", "tx", "ty", "tz")
#: Largest sequence number taken as is; the FT_RECORD field is u8 but a float column holds
#: integers exactly only up to 2**53.
_MAX_SEQUENCE = 2**53
#: csv:// options (spectratac.ft.options).
URL_PARAMS = {
    "rate": RATE,
    "realtime": REALTIME,
    "speed": SPEED,
    "host_time": Param(
        "choice",
        meaning="host times: the file's host_time column, or now",
        choices=("auto", "file", "now"),
    ),
}


def csv_path(url: str) -> tuple[Path, str]:
    """The file path and query of a csv:// URL (relative paths allowed: csv://data/ft.csv)."""
    rest = url[len("csv://") :]
    path, _, query = rest.partition("?")
    if not path:
        raise FTURLError(f"{url}: no file; example: csv://session_ft.csv")
    return Path(path), query


def load_csv(path: Path) -> tuple[np.ndarray, int, bool]:
    """FT_RECORD rows of a CSV file (host_time NaN where absent), bad row count, and whether
    it had a host_time column."""
    try:  # a stray non-UTF-8 byte spoils its row only (it no longer parses as a number)
        text = path.read_bytes().decode("utf-8", errors="replace")
    except FileNotFoundError:
        raise FTNotFoundError(f"no such F/T CSV file: {path}") from None
    except OSError as exc:
        raise FTNotFoundError(f"cannot read F/T CSV file {path}: {exc}") from None
    header, _, body = text.partition("\n")
    names = [_ALIASES.get(h.strip().lower(), h.strip().lower()) for h in header.split(",")]
    missing = [c for c in ("t", *_WRENCH) if c not in names]
    if missing:
        raise FTConfigError(
            f"{path}: header {header.strip()!r} lacks column(s) {', '.join(missing)}; "
            f"need t, Fx, Fy, Fz, Tx, Ty, Tz (optional host_time, sequence, status)"
        )
    lines = [ln for ln in body.splitlines() if ln.strip()]
    if not lines:
        raise FTConfigError(f"{path}: has a header but no sample rows; nothing to replay")
    try:
        table = np.loadtxt(io.StringIO("\n".join(lines)), delimiter=",", ndmin=2)
        bad = 0
    except ValueError:  # some rows are damaged: parse row by row, skipping them
        good = []
        for ln in lines:
            try:
                row = [float(v) for v in ln.split(",")]
            except ValueError:
                continue
            if len(row) == len(names):
                good.append(row)
        bad = len(lines) - len(good)
        table = np.array(good, dtype=np.float64).reshape(-1, len(names))
    if table.shape[1] != len(names):
        raise FTConfigError(f"{path}: rows have {table.shape[1]} values, header {len(names)}")
    good = np.all(np.isfinite(table[:, [names.index(c) for c in ("t", *_WRENCH)]]), axis=1)
    for counter, top in (("sequence", _MAX_SEQUENCE), ("status", 2**32 - 1)):
        if counter in names:
            v = table[:, names.index(counter)]
            with np.errstate(invalid="ignore"):
                good &= np.isfinite(v) & (v >= 0) & (v <= top) & (v == np.round(v))
    bad += int(np.count_nonzero(~good))
    table = table[good]
    if not len(table):
        raise FTConfigError(
            f"{path}: none of its {len(lines)} rows is a valid sample (numbers, finite, "
            f"one per header column); check the file's columns and encoding"
        )
    col = {n: table[:, i] for i, n in enumerate(names)}
    rows = np.zeros(len(table), dtype=FT_RECORD)
    rows["sensor_time"] = col["t"]
    rows["wrench"] = np.stack([col[c] for c in _WRENCH], axis=1)
    rows["host_time"] = col.get("host_time", np.nan)
    rows["sequence"] = col["sequence"] if "sequence" in col else np.arange(len(table))
    if "status" in col:
        rows["status"] = col["status"]
    return rows, bad, "host_time" in col


class CsvFTSensor(ReplayFTSensor):
    """Replays a CSV file (see the module documentation for columns and pacing)."""

    scheme = "csv"

    @classmethod
    def connect(
        cls, url: str, *, timeout: float, buffer_size: int, **options: object
    ) -> CsvFTSensor:
        from urllib.parse import parse_qsl

        path, query = csv_path(url)
        opts = Options(url, {**dict(parse_qsl(query)), **options}, URL_PARAMS)
        rate = opts.number("rate")
        realtime = opts.flag("realtime")
        speed = opts.number("speed", 1.0)
        host_mode = opts.text("host_time", "auto")
        rows, bad, has_host = load_csv(path)
        if host_mode == "file" and not has_host:
            raise FTConfigError(f"{path} has no host_time column: use host_time=now")
        dt = np.diff(rows["sensor_time"])
        nominal = float(1.0 / np.median(dt)) if len(dt) and np.median(dt) > 0 else 0.0
        info = FTInfo("csv", model="CSV replay", serial=str(path), rate_hz=rate or nominal)
        info.extra.update(rows=len(rows), path=str(path), has_host_time=has_host)
        sensor = cls(url, info, timeout=timeout, buffer_size=buffer_size)
        sensor.stats.bad_frames = bad
        keep_host = host_mode == "file" or (host_mode == "auto" and has_host)
        sensor._setup(rows, keep_host=keep_host, rate=rate, realtime=realtime, speed=speed)
        return sensor
