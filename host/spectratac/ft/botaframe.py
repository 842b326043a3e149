"""Bota Systems serial F/T frames, and a parser that resynchronises after damage.

Frame (37 bytes): header 0xAA, 34 data bytes little-endian (uint16 status, six float32
Fx Fy Fz [N] Tx Ty Tz [N*m], uint32 timestamp [µs, wraps], float32 temperature [°C]), then
CRC-16/X-25 of the 34 data bytes (little-endian). Status bits: 0 app took too long (the
sensor skipped measurements), 1 over range, 2 invalid measurements, 3 raw measurements.

The parser checks every run of aligned frames at once (headers and a table CRC vectorised
over frames with NumPy); where a frame is damaged it hunts for the next header whose CRC
holds, so the good frames on both sides of garbage are kept.

>>> FRAME_SIZE, DATA_DTYPE.itemsize, hex(crc16_x25(b"123456789"))
(37, 34, '0x906e')
>>> wire = encode_frames([0, 0], [[1, 2, 3, 4, 5, 6]] * 2, [1000, 2000], [25.0, 25.0])
>>> p = FrameParser()
>>> frames = p.feed(b"junk" + wire[:37] + b"\\xaa\\x00" + wire[37:])
>>> frames["timestamp"].tolist(), p.crc_errors, p.skipped_bytes
([1000, 2000], 1, 6)
"""

from __future__ import annotations

import crcmod.predefined
import numpy as np
from numpy.typing import ArrayLike, NDArray

HEADER = 0xAA
DATA_DTYPE = np.dtype(
    [
        ("status", "<u2"),
        ("forces", "<f4", (6,)),
        ("timestamp", "<u4"),
        ("temperature", "<f4"),
    ]
)
FRAME_DTYPE = np.dtype([("header", "u1"), ("data", DATA_DTYPE), ("crc", "<u2")])
FRAME_SIZE = FRAME_DTYPE.itemsize  # 37
DATA_SIZE = DATA_DTYPE.itemsize  # 34

STATUS_APP_TOOK_TOO_LONG = 1 << 0
STATUS_OVERRANGE = 1 << 1
STATUS_INVALID = 1 << 2
STATUS_RAW = 1 << 3

#: Board temperatures a working sensor can report (°C); anything else is line noise.
TEMPERATURE_RANGE_C = (-100.0, 200.0)
_HEADER_BYTE = bytes([HEADER])

#: CRC-16/X-25: poly 0x1021 reflected, init 0xFFFF, xorout 0xFFFF; check(b"123456789") 0x906E.
crc16_x25 = crcmod.predefined.mkPredefinedCrcFun("x-25")


def _table_entry(byte: int) -> int:
    crc = byte
    for _ in range(8):
        crc = (crc >> 1) ^ 0x8408 if crc & 1 else crc >> 1
    return crc


_TABLE = np.array([_table_entry(i) for i in range(256)], dtype=np.uint16)


_FEW_ROWS = 256  # below this, crcmod's C loop per row beats 34 vectorised table steps


def crc16_x25_rows(data: NDArray[np.uint8]) -> NDArray[np.uint16]:
    """CRC-16/X-25 of every row of a (frames, bytes) uint8 array, vectorised over frames."""
    if data.shape[0] < _FEW_ROWS:
        return np.array([crc16_x25(row.tobytes()) for row in data], dtype=np.uint16)
    crc = np.full(data.shape[0], 0xFFFF, dtype=np.uint16)
    for j in range(data.shape[1]):
        crc = (crc >> 8) ^ _TABLE[(crc ^ data[:, j]) & 0xFF]
    return crc ^ np.uint16(0xFFFF)


def encode_frames(
    status: ArrayLike, forces: ArrayLike, timestamp_us: ArrayLike, temperature: ArrayLike
) -> bytes:
    """Wire bytes of frames (timestamps taken modulo 2**32)."""
    ts = np.asarray(timestamp_us, dtype=np.int64) & 0xFFFF_FFFF
    out = np.empty(len(ts), dtype=FRAME_DTYPE)
    out["header"] = HEADER
    out["data"]["status"] = status
    out["data"]["forces"] = forces
    out["data"]["timestamp"] = ts
    out["data"]["temperature"] = temperature
    raw = out.view(np.uint8).reshape(len(ts), FRAME_SIZE)
    out["crc"] = crc16_x25_rows(raw[:, 1 : 1 + DATA_SIZE])
    return out.tobytes()


def _frame_ok(raw: bytes, pos: int) -> bool:
    """Whether one frame starts at pos: a cheap scalar check before the vectorised run check
    (in line noise most candidate headers fail it)."""
    end = pos + FRAME_SIZE
    return raw[pos] == HEADER and crc16_x25(raw[pos + 1 : end - 2]) == int.from_bytes(
        raw[end - 2 : end], "little"
    )


class FrameParser:
    """Incremental parser: feed() bytes as they arrive, get DATA_DTYPE rows of good frames.

    Counters: crc_errors (a header where a frame was expected, with a bad CRC), lost_sync
    (no header where a frame was expected), skipped_bytes (bytes that belonged to no good
    frame: garbage, damaged frames, text replies), implausible (frames whose CRC held but
    whose values cannot be measurements: non-finite, beyond `limits`, or a temperature
    outside TEMPERATURE_RANGE_C; they are dropped, since line noise passes a 16-bit CRC once
    in 65536 tries). `limits` is the largest magnitude accepted per axis (Fx Fy Fz in N,
    Tx Ty Tz in N*m); None checks only that values are finite and temperatures plausible.

    Work is linear in the bytes fed: a run of frames is checked in windows that double while
    they hold (so a damaged frame costs one window, not the rest of the buffer), and the
    next header is found by a scan that stops at the first hit.

    >>> wire = encode_frames([0, 0], [[1, 2, 3, 0, 0, 0], [1e35, 0, 0, 0, 0, 0]], [1, 2], [25, 25])
    >>> p = FrameParser(limits=[500, 500, 1000, 20, 20, 20])
    >>> p.feed(wire)["timestamp"].tolist(), p.implausible
    ([1], 1)
    """

    def __init__(self, limits: ArrayLike | None = None) -> None:
        self._pending = b""
        self._synced = False
        self._limits = None if limits is None else np.asarray(limits, dtype=np.float64)
        if self._limits is not None and (
            self._limits.shape != (6,) or not np.all(self._limits > 0)
        ):
            raise ValueError(f"limits {limits!r}: give six positive magnitudes, N and N*m")
        self.crc_errors = 0
        self.lost_sync = 0
        self.skipped_bytes = 0
        self.implausible = 0
        self.frames = 0

    def feed(self, data: bytes) -> np.ndarray:
        raw = self._pending + bytes(data) if self._pending else bytes(data)
        buf = np.frombuffer(raw, dtype=np.uint8)
        out: list[np.ndarray] = []
        pos = 0
        n = len(buf)
        while n - pos >= FRAME_SIZE:
            run = self._good_run(buf, pos) if _frame_ok(raw, pos) else 0
            if run:
                end = pos + run * FRAME_SIZE
                frames = buf[pos:end].reshape(run, FRAME_SIZE)
                out.append(frames[:, 1 : 1 + DATA_SIZE].copy().view(DATA_DTYPE).reshape(run))
                pos = end
                self._synced = True
                continue
            if self._synced:  # the slot right after a good frame is damaged
                if buf[pos] == HEADER:
                    self.crc_errors += 1
                else:
                    self.lost_sync += 1
                self._synced = False
            nxt = raw.find(_HEADER_BYTE, pos + 1)
            nxt = n if nxt < 0 else nxt
            self.skipped_bytes += nxt - pos
            pos = nxt
        self._pending = raw[pos:]
        if not out:
            return np.empty(0, dtype=DATA_DTYPE)
        result = self._plausible(np.concatenate(out) if len(out) > 1 else out[0])
        self.frames += len(result)
        return result

    def _plausible(self, rows: np.ndarray) -> np.ndarray:
        forces = rows["forces"].astype(np.float64)
        temperature = rows["temperature"].astype(np.float64)
        ok = np.isfinite(forces).all(axis=1) & np.isfinite(temperature)
        low, high = TEMPERATURE_RANGE_C
        ok &= (temperature >= low) & (temperature <= high)
        if self._limits is not None:
            ok &= (np.abs(np.nan_to_num(forces)) <= self._limits).all(axis=1)
        if ok.all():
            return rows
        self.implausible += int(np.count_nonzero(~ok))
        return rows[ok]

    @staticmethod
    def _good_run(buf: NDArray[np.uint8], pos: int) -> int:
        """How many consecutive good frames start at pos (0 if the first is bad), checked in
        windows of 1, 2, 4... frames so the work is at most twice the frames accepted + 1."""
        available = (len(buf) - pos) // FRAME_SIZE
        good = 0
        window = 1
        while good < available:
            count = min(window, available - good)
            start = pos + good * FRAME_SIZE
            frames = buf[start : start + count * FRAME_SIZE].reshape(count, FRAME_SIZE)
            ok = frames[:, 0] == HEADER
            crc = frames[:, -2].astype(np.uint16) | (frames[:, -1].astype(np.uint16) << 8)
            ok &= crc16_x25_rows(frames[:, 1 : 1 + DATA_SIZE]) == crc
            bad = np.flatnonzero(~ok)
            if len(bad):
                return good + int(bad[0])
            good += count
            window *= 2
        return good
