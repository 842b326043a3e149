"""Host side of the model check (model_check.h): write a session's samples as input records,
run the check natively or in QEMU, read its estimates back and compare them sample by
sample with the Python decoder. Used by tests/firmware/test_model_*.py and
tools/bench/ondevice.py.

QEMU: the image is the env `model_check` of platformio.ini (the Black Pill board and linker
script; netduinoplus2, whose STM32F405 has 1 MiB of flash, runs it unchanged). The model
image goes into flash at IMAGE_ADDR through QEMU's generic loader; inputs and outputs are
files opened through semihosting in QEMU's working directory.
"""

from __future__ import annotations

import subprocess
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

RECORD = np.dtype(
    [
        ("ret", "<i4"),
        ("flags", "<u4"),
        ("region", "<u4"),
        ("ticks", "<u4"),
        ("force", "<f4", 3),
        ("torque", "<f4", 3),
        ("region_prob", "<f4"),
        ("contact_prob", "<f4"),
        ("out", "<f4", 32),
    ]
)
INPUT = np.dtype([("step", "u1"), ("status", "u1", 3), ("counts", "<u2", (3, 5))])
TRAILER = -2
MC_REF_LEN = 1024  # model_check.h: multiply-adds of the reference dot product
MC_CALIB_ITERS = 4096  # iterations of the two-instruction calibration loop
IMAGE_ADDR = 0x08080000  # the F405's second half-megabyte: beyond the F411 image's flash
IMAGE_REGION = 0x80000
IN_NAME, OUT_NAME = "model_check.in", "model_check.out"
EST_CONTACT, EST_INVALID, EST_OOD, EST_WARMUP, EST_NO_REST = 1, 2, 4, 8, 16
TARE_STEP = 0xFE  # model_check.h MC_TARE_STEP: an input record that tares, no output
RUN_TIMEOUT_S = 900


@dataclass
class Session:
    """One session's samples in time order, as the device would see them."""

    counts: NDArray[np.uint16]  # (N, 3, 5)
    status: NDArray[np.uint8]  # (N, 3)
    step: NDArray[np.uint8]  # (N,)

    @property
    def raw12(self) -> NDArray[np.float64]:
        return self.counts[:, :, :4].reshape(-1, 12).astype(np.float64)

    def records(self) -> bytes:
        rec = np.zeros(len(self.step), INPUT)
        rec["step"], rec["status"], rec["counts"] = self.step, self.status, self.counts
        return rec.tobytes()

    def head(self, n: int) -> Session:
        return Session(self.counts[:n], self.status[:n], self.step[:n])


def session_of(ds: Any, index: int = 0) -> Session:
    """Session `index` of a SpectraTac dataset (one with `counts`), in time order."""
    ses = np.unique(ds.session)[index]
    rows = np.flatnonzero(ds.session == ses)
    rows = rows[np.argsort(ds.t_end[rows], kind="stable")]
    counts = np.asarray(ds.arrays["counts"])[rows]
    status = np.asarray(ds.arrays.get("status", np.zeros(len(ds.session))))[rows]
    status = np.broadcast_to(status.reshape(len(rows), -1), (len(rows), 3))
    return Session(
        np.clip(counts, 0, 65535).astype(np.uint16),
        status.astype(np.uint8),
        np.asarray(ds.step)[rows].astype(np.uint8),
    )


def parse(raw: bytes) -> tuple[NDArray[Any], NDArray[Any]]:
    """(per-sample records, trailer record) of a model check's output."""
    rec = np.frombuffer(raw, RECORD)
    if rec.size == 0 or rec["ret"][-1] != TRAILER:
        raise RuntimeError(f"model check output has no trailer ({len(raw)} bytes)")
    return rec[:-1], rec[-1]


def run_native(
    binary: Path, image: bytes, session: Session, work: Path
) -> subprocess.CompletedProcess:
    work.mkdir(parents=True, exist_ok=True)
    (work / "model.bin").write_bytes(image)
    (work / IN_NAME).write_bytes(session.records())
    out = work / OUT_NAME
    out.unlink(missing_ok=True)
    return subprocess.run(
        [str(binary), str(work / "model.bin"), str(work / IN_NAME), str(out)],
        capture_output=True,
        text=True,
        timeout=RUN_TIMEOUT_S,
    )


def qemu_command(elf: Path, image_path: Path, icount_shift: int = 4) -> list[str]:
    """QEMU for the check image: instruction counting (virtual time advances 2^shift ns per
    instruction, so SysTick stamps count instructions), semihosting for files and exit."""
    return [
        "qemu-system-arm", "-M", "netduinoplus2", "-nographic", "-monitor", "none",
        "-serial", "null", "-kernel", str(elf),
        "-device", f"loader,file={image_path},addr={IMAGE_ADDR:#x},force-raw=on",
        "-icount", f"shift={icount_shift},align=off,sleep=off",
        "-semihosting-config", "enable=on,target=native",
    ]  # fmt: skip


def run_qemu(elf: Path, image: bytes, session: Session, work: Path) -> subprocess.CompletedProcess:
    if len(image) > IMAGE_REGION:
        raise ValueError(f"{len(image)} bytes do not fit the check image's model region")
    work.mkdir(parents=True, exist_ok=True)
    (work / "model.bin").write_bytes(image)
    (work / IN_NAME).write_bytes(session.records())
    (work / OUT_NAME).unlink(missing_ok=True)
    return subprocess.run(
        qemu_command(elf.resolve(), (work / "model.bin").resolve()),
        cwd=work,
        capture_output=True,
        text=True,
        timeout=RUN_TIMEOUT_S,
    )


def output_of(work: Path) -> tuple[NDArray[Any], NDArray[Any]]:
    return parse((work / OUT_NAME).read_bytes())


# ---------------------------------------------------------------------------- comparison
@dataclass
class Reference:
    """What the Python decoder gives for each sample of a session."""

    valid: NDArray[np.bool_]  # an estimate exists (every LED step seen)
    out: NDArray[np.float64]  # (N, n_out) all outputs, NaN where not valid
    flags: NDArray[np.uint32]  # EST_CONTACT | EST_OOD | EST_INVALID
    region: NDArray[np.int64]  # 0 without a region head or invalid


def reference(dec: Any, session: Session) -> Reference:
    """The Python decoder over the session: its outputs on the vectors the live path
    assembles (decode/assemble.Assembler, as Decoder.stream runs it) and its estimates
    (Decoder.predict_inputs, whose batch assembly gives the same vectors)."""
    from spectratac.decode.assemble import Assembler

    x, step = session.raw12, session.step.astype(np.int64)
    asm = Assembler(dec.layout)
    u = np.full((len(step), dec.layout.size), np.nan)
    valid = np.zeros(len(step), bool)
    for i in range(len(step)):
        v, valid[i] = asm.push(int(step[i]), x[i])
        u[i] = v
    est = dec.predict_inputs(x, step, status=session.status)
    out = np.full((len(step), dec.heads.n_out), np.nan)
    out[valid] = dec.runtime.run(u[valid])
    flags = (est.contact * EST_CONTACT + est.ood * EST_OOD + est.invalid * EST_INVALID).astype(
        np.uint32
    )
    region = np.where(est.region > 0, est.region, 0)
    return Reference(valid, out, flags, region)


def errors(dec: Any, got: NDArray[Any], ref: Reference) -> dict[str, Any]:
    """Max abs error per output over the samples with an estimate, and whether the
    device's returns, flags and regions agree with Python's."""
    n_out = dec.heads.n_out
    ret = got["ret"]
    have = (ret == 1) & (got["flags"] & EST_INVALID == 0)
    diff = np.abs(got["out"][:, :n_out].astype(np.float64) - ref.out)
    ok = ref.valid & have
    names = dec.heads.output_names()
    per_out = {n: float(np.max(diff[ok, i], initial=0.0)) for i, n in enumerate(names)}
    scale = {n: float(np.max(np.abs(ref.out[ok, i]), initial=0.0)) for i, n in enumerate(names)}
    flag_mask = EST_CONTACT | EST_OOD | EST_INVALID
    return {
        "n": len(ret),
        "n_estimates": int(ok.sum()),
        "estimates_agree": bool(np.array_equal(have, ref.valid)),
        "flags_disagree": int(np.sum((got["flags"][ok] & flag_mask) != ref.flags[ok])),
        "region_disagree": int(np.sum(got["region"][ok] != ref.region[ok])),
        "max_abs": per_out,
        "max_abs_ref": scale,
        "mae": {n: float(np.mean(diff[ok, i])) if ok.any() else 0.0 for i, n in enumerate(names)},
    }
