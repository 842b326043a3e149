"""The device's model store (protocol 1.1, SPEC.md section 13): read, upload and clear the
decoder a device runs. `Sensor.model_info`, `Sensor.upload_model` and `Sensor.clear_model`
are the public face of this module.

The image is opaque here (the device layer never imports the decoder): the bytes of
`spectratac.decode.export.model_image.encode(decoder)` and its `model_id`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import Any

from spectratac.device.errors import (
    CommandRejectedError,
    DeviceTimeoutError,
    MissingCapabilityError,
    ModelUploadError,
)
from spectratac.device.flash_timing import erase_ack_timeout_s
from spectratac.device.link import Link
from spectratac.protocol import crc32c
from spectratac.protocol.generated import messages as m

CHUNK = 224  # MODEL_CHUNK.data: every chunk but the last is full
PRESENT = ("none", "uploaded", "builtin")
WEIGHT_FORMATS = ("f32", "f16", "i8")
#: Flash erase and programming block the device's loop: MODEL_BEGIN, MODEL_COMMIT and
#: MODEL_CLEAR get at least the datasheet's worst-case erase of the whole store, with margin.
FLASH_TIMEOUT = erase_ack_timeout_s()
#: NACKs a second attempt cannot cure: the image or the device's limits are the problem.
FINAL = frozenset({"MODEL_TOO_LARGE", "MODEL_INVALID"})

Progress = Callable[[int, int], None]  # (bytes acknowledged, image size)


@dataclass(frozen=True)
class ModelInfo:
    """MODEL_INFO in host terms: which model the device runs and its limits.

    >>> info = ModelInfo.from_message(m.ModelInfo(present=1, model_id=7, size=4096,
    ...     weight_format=1, led_steps=1, capacity=458688))
    >>> info.present, info.weight_format, info.has_model
    ('uploaded', 'f16', True)
    """

    present: str  # "none" | "uploaded" | "builtin"
    model_id: int
    size: int
    crc: int
    weight_format: str  # "f32" | "f16" | "i8" ("" without a model)
    led_steps: int
    n_inputs: int
    capacity: int  # largest image MODEL_BEGIN accepts
    max_inputs: int
    max_hidden: int
    #: the image's own CRC-32C (its trailing four bytes), which tells models and weight
    #: formats apart; None without a model or from a device older than protocol 1.2
    image_crc: int | None = None

    @property
    def has_model(self) -> bool:
        return self.present != "none"

    @classmethod
    def from_message(cls, msg: m.ModelInfo) -> ModelInfo:
        present = PRESENT[msg.present] if msg.present < len(PRESENT) else f"?{msg.present}"
        if msg.present == 0:
            weights = ""
        elif msg.weight_format < len(WEIGHT_FORMATS):
            weights = WEIGHT_FORMATS[msg.weight_format]
        else:
            weights = f"?{msg.weight_format}"
        return cls(
            present,
            msg.model_id,
            msg.size,
            msg.crc,
            weights,
            msg.led_steps,
            msg.n_inputs,
            msg.capacity,
            msg.max_inputs,
            msg.max_hidden,
            # zero-filled by a 1.1 device; a real image CRC of 0 is a 1 in 2^32 chance
            msg.image_crc if msg.present and msg.image_crc else None,
        )

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


def require(link: Link, capability: m.Capabilities, wanted: str) -> None:
    """Raise MissingCapabilityError unless the device reported `capability` in INFO."""
    if link.info.capabilities & capability:
        return
    version = f"{link.info.protocol_major}.{link.info.protocol_minor}"
    raise MissingCapabilityError(
        f"{link.url} cannot {wanted}: it does not report {capability.name} (protocol "
        f"{version}, firmware {'.'.join(map(str, link.info.firmware_version))}); flash a "
        f"firmware with on-device decoding (protocol 1.1 or later) or decode on the host",
        str(capability.name),
    )


def read_info(link: Link) -> ModelInfo:
    require(link, m.Capabilities.CAP_ESTIMATE, "report its model (GET_MODEL)")
    return ModelInfo.from_message(link.request(m.GetModel(), m.ModelInfo))


def tare(link: Link) -> None:
    """TARE (protocol 1.3): the device's model takes its next sample as the baseline's zero.
    Raises MissingCapabilityError, saying what to do, for a device older than 1.3."""
    require(link, m.Capabilities.CAP_ESTIMATE, "tare its model (TARE)")
    if link.info.protocol_minor < m.Tare.SINCE:
        raise MissingCapabilityError(
            f"{link.url} cannot tare its model: TARE is protocol 1.{m.Tare.SINCE}, the device "
            f"speaks {link.info.protocol_major}.{link.info.protocol_minor}; flash a newer "
            f"firmware, or decode on the host (estimates='off') and tare the host's decoder",
            "TARE",
        )
    link.command(m.Tare())


def clear(link: Link) -> None:
    require(link, m.Capabilities.CAP_MODEL_UPLOAD, "erase its model (MODEL_CLEAR)")
    link.command(m.ModelClear(), timeout=max(link.timeout, FLASH_TIMEOUT))


def upload(link: Link, image: bytes, model_id: int, progress: Progress | None = None) -> None:
    """Upload `image` as model `model_id`; on a NACK or a timeout start again from
    MODEL_BEGIN once (uploads are not resumable). Raises ModelUploadError naming the error."""
    require(link, m.Capabilities.CAP_MODEL_UPLOAD, "take an uploaded model (MODEL_BEGIN)")
    image = bytes(image)
    if not image:
        raise ValueError("image is empty: give the bytes of model_image.encode(decoder)")
    if not 0 <= model_id <= 0xFFFF_FFFF:
        raise ValueError(f"model_id={model_id}: must fit u32 (0..4294967295)")
    capacity = read_info(link).capacity
    if len(image) > capacity:
        raise ModelUploadError(
            f"the model image is {len(image)} B but {link.url}'s model store holds {capacity} B",
            "MODEL_TOO_LARGE",
            m.ERROR_TEXT[m.Error.MODEL_TOO_LARGE][1],
        )
    crc = crc32c(image)
    for attempt in (1, 2):
        try:
            _send(link, image, model_id, crc, progress)
            break
        except CommandRejectedError as exc:
            if exc.name in FINAL or attempt == 2:
                raise ModelUploadError(
                    f"{link.url} refused the model upload ({exc.command}: {exc.name}, "
                    f"{exc.meaning})",
                    exc.name,
                    exc.action,
                ) from exc
        except DeviceTimeoutError as exc:
            if attempt == 2:
                raise ModelUploadError(
                    f"the model upload to {link.url} failed twice: {exc}",
                    "TIMEOUT",
                    "Check the link (STATUS rx_errors) and retry; the device keeps no "
                    "half-written model",
                ) from exc
        link.stats.model_upload_retries += 1
    stored = read_info(link)
    if (stored.model_id, stored.size, stored.crc) != (model_id, len(image), crc):
        raise ModelUploadError(
            f"{link.url} acknowledged the upload but reports model 0x{stored.model_id:08X} "
            f"({stored.size} B, CRC 0x{stored.crc:08X}) instead of 0x{model_id:08X} "
            f"({len(image)} B, CRC 0x{crc:08X})",
            "MISMATCH",
            "Upload again; if it persists, report a firmware bug",
        )


def _send(link: Link, image: bytes, model_id: int, crc: int, progress: Progress | None) -> None:
    flash = max(link.timeout, FLASH_TIMEOUT)
    # one attempt per command: a resent chunk would be out of order (SPEC.md section 13)
    link.command(
        m.ModelBegin(model_id=model_id, size=len(image), crc=crc), attempts=1, timeout=flash
    )
    if progress is not None:
        progress(0, len(image))
    for offset in range(0, len(image), CHUNK):
        data = image[offset : offset + CHUNK]
        chunk = m.ModelChunk(offset=offset, length=len(data), data=data.ljust(CHUNK, b"\x00"))
        link.command(chunk, attempts=1)
        if progress is not None:
            progress(offset + len(data), len(image))
    link.command(m.ModelCommit(model_id=model_id), attempts=1, timeout=flash)
