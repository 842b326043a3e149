"""The model store on the board's flash: upload the conformance suite's small model image,
timing MODEL_BEGIN (the erase), the chunks and MODEL_COMMIT on the host, read it back, erase it
again with MODEL_CLEAR; on protocol 1.4 the device's own measure of each erase
(`erase_us_last`, `erase_us_max`). A model a user uploaded is never replaced: the check is
skipped, saying how to run it."""

from __future__ import annotations

import time
from typing import Any

from spectratac.conformance.bringup.bench import Bench
from spectratac.conformance.bringup.report import FAIL, PASS, SKIPPED, Row
from spectratac.conformance.model_checks import TestModel
from spectratac.device import DeviceError
from spectratac.device.boot_report import SINCE_MINOR
from spectratac.protocol import crc32c
from spectratac.protocol.generated import messages as m

#: bound on a flash command's ACK (s): the worst erase (four sectors) takes seconds; a bound,
#: not an expectation
ERASE_WAIT_S = 30.0
CHUNK = 224  # MODEL_CHUNK.data


def _timed(bench: Bench, msg: Any, timeout: float | None = None) -> float:
    started = time.monotonic()
    bench.sensor.link.command(msg, attempts=1, timeout=timeout or bench.timeout)
    return time.monotonic() - started


def _erase_us(bench: Bench) -> dict[str, int]:
    if not bench.speaks(SINCE_MINOR):
        return {}
    status = bench.sensor.status()
    return {"erase_us_last": int(status.erase_us_last), "erase_us_max": int(status.erase_us_max)}


def model_store(bench: Bench) -> Row:
    s = bench.sensor
    if not s.info.capabilities & m.Capabilities.CAP_MODEL_UPLOAD:
        return Row("model store", SKIPPED, "no uploaded models here (no CAP_MODEL_UPLOAD)")
    before = s.model_info()
    if before.present == "uploaded":
        return Row(
            "model store",
            SKIPPED,
            f"the board holds an uploaded model (0x{before.model_id:08X}, {before.size} B), "
            "which bring-up would erase: run `spectratac model clear URL` first if it may go",
        )
    model = TestModel.packaged()
    image = model.image
    values: dict[str, Any] = {"image_bytes": len(image), "capacity": before.capacity}
    try:
        values["begin_s"] = _timed(
            bench, m.ModelBegin(model_id=model.model_id, size=len(image), crc=crc32c(image)),
            ERASE_WAIT_S,
        )  # fmt: skip
        values |= {f"begin_{k}": v for k, v in _erase_us(bench).items()}
        started = time.monotonic()
        for offset in range(0, len(image), CHUNK):
            data = image[offset : offset + CHUNK]
            chunk = m.ModelChunk(offset=offset, length=len(data), data=data.ljust(CHUNK, b"\0"))
            s.link.command(chunk, attempts=1)
        values["chunks_s"] = time.monotonic() - started
        values["commit_s"] = _timed(bench, m.ModelCommit(model_id=model.model_id), ERASE_WAIT_S)
        stored = s.model_info()
        values["clear_s"] = _timed(bench, m.ModelClear(), ERASE_WAIT_S)
        values |= {f"clear_{k}": v for k, v in _erase_us(bench).items()}
        after = s.model_info()
    except DeviceError as exc:
        return Row("model store", FAIL, f"{type(exc).__name__}: {exc}", values)
    problems = []
    crc = crc32c(image)
    if (stored.model_id, stored.size, stored.crc) != (model.model_id, len(image), crc):
        problems.append(
            f"read back model 0x{stored.model_id:08X} ({stored.size} B, CRC "
            f"0x{stored.crc:08X}) after uploading 0x{model.model_id:08X} ({len(image)} B, CRC "
            f"0x{crc:08X}): the flash did not keep what was written"
        )
    if after.present == "uploaded":
        problems.append("MODEL_CLEAR was acknowledged but the model is still there")
    values = {k: round(v, 4) if isinstance(v, float) else v for k, v in values.items()}
    erase = (
        f"; device-measured erase {values['begin_erase_us_last'] / 1000:.1f} ms (begin), "
        f"{values['clear_erase_us_last'] / 1000:.1f} ms (clear)"
        if "begin_erase_us_last" in values
        else f"; erase durations are STATUS fields of protocol 1.{SINCE_MINOR}"
    )
    said = (
        f"{len(image)} B uploaded and erased: MODEL_BEGIN {values['begin_s']:.3f} s, chunks "
        f"{values['chunks_s']:.3f} s, MODEL_COMMIT {values['commit_s']:.3f} s, MODEL_CLEAR "
        f"{values['clear_s']:.3f} s (host time){erase}"
    )
    return Row("model store", FAIL if problems else PASS, "; ".join(problems) or said, values)
