"""Reliability soak: many simulated devices streaming under random faults, and one recording.

    python -m tools.bench.reliability [--json] [--devices 16] [--seconds S] [--seed N]

S (simulated seconds per device) defaults to $SPECTRATAC_SOAK_SECONDS, else 300. Every
device is the real firmware core (sim://, speed=10) behind a fault layer
(spectratac.sim.faults) that corrupts bytes, stalls the link and unplugs the device at random;
the host reads them all through Sensor.open(reconnect=True) in one process. The fault layer
counts what each device really sent, so the accounting is exact:

    sent = delivered + counted lost (sample gaps + buffer overflows) + lost at unplug

where "lost at unplug" are samples corrupted after the last intact one before the cable was
pulled: no host can know of them (the next boot starts a new sequence). Anything else missing
is "unaccounted" and must be 0. The recording (a device with a simulated Bota F/T that drops
samples, bytes corrupted on the link) must read back complete: every frame the recorder wrote
is read back, and the dataset builds from it.

Prints the reliability table; --json prints one figure line: the samples lost unaccounted
against the samples sent (must be 0), with every count of the table in `extra`.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
import warnings
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from spectratac.dataset.build import build_datasets
from spectratac.device import Sensor
from spectratac.device.errors import DeviceError
from spectratac.protocol.framing import parse_body
from spectratac.protocol.generated import messages as m
from spectratac.record import RecordOptions, record_url
from spectratac.record.reader import read_recording
from spectratac.sim.faults import ledger

from tools.bench.benchlib import Figure

INTEGRATION_MS = 50
RATE_HZ = 1000 / INTEGRATION_MS
WHITE = [[[500, 500, 500]] * 3]
DEVICE_FAULTS = "fault=corrupt,stall,unplug&fault_rate=1e-4&fault_stall=0.05&fault_every=2"
SPEED = 10  # simulated seconds per wall second: 16 devices at 10x fit one loaded core
STUCK_S = 15.0  # wall seconds without a new sample before a device counts as stuck
STOP_S = 60.0  # wall seconds to get a device stopped (reconnects included) before it fails


@dataclass
class DeviceTally:
    url: str
    sent: int = 0
    delivered: int = 0
    sample_gaps: int = 0
    buffer_overflows: int = 0
    lost_at_unplug: int = 0
    crc_errors: int = 0
    bytes_corrupted: int = 0
    stalls: int = 0
    unplugs: int = 0
    reconnects: int = 0
    stall_reconnects: int = 0  # the host's stall watch reopened the link (a starved host)
    stuck: bool = False  # stopped sending for STUCK_S of wall time (streaming not restored)
    error: str = ""  # what went wrong ending its stream (it is then not tallied complete)

    @property
    def unaccounted(self) -> int:
        return (
            self.sent
            - self.delivered
            - self.sample_gaps
            - self.buffer_overflows
            - self.lost_at_unplug
        )


@dataclass
class RecordingTally:
    samples: int = 0  # the recorder's summary
    frames: int = 0
    ft_samples: int = 0
    ft_lost: int = 0
    lost: int = 0
    crc_errors: int = 0
    read_frames: int = 0  # what reads back
    read_samples: int = 0
    read_ft_samples: int = 0
    dataset_samples: int = 0
    complete: bool = False
    error: str = ""  # an exception recording or reading back


@dataclass
class Soak:
    devices: list[DeviceTally] = field(default_factory=list)
    recording: RecordingTally = field(default_factory=RecordingTally)
    seconds: float = 0.0
    wall_s: float = 0.0

    def summary(self) -> dict[str, Any]:
        d = self.devices
        total = sum
        return {
            "name": "reliability",
            "load": {
                "devices": len(d),
                "rate_hz": RATE_HZ,
                "simulated_s_per_device": round(
                    total(t.sent for t in d) / max(len(d), 1) / RATE_HZ, 1
                ),
                "samples_sent": total(t.sent for t in d),
                "wall_s": round(self.wall_s, 1),
            },
            "faults": {
                "bytes_corrupted": total(t.bytes_corrupted for t in d),
                "frames_rejected_crc": total(t.crc_errors for t in d),
                "stalls": total(t.stalls for t in d),
                "unplugs": total(t.unplugs for t in d),
                "reconnects": total(t.reconnects for t in d),
                "stall_reconnects": total(t.stall_reconnects for t in d),
                "stuck_devices": total(t.stuck for t in d),
                "ft_dropouts": self.recording.ft_lost,
            },
            "bad_inputs": total(t.crc_errors for t in d) + self.recording.crc_errors,
            "samples": {
                "delivered": total(t.delivered for t in d),
                "counted_lost": total(t.sample_gaps + t.buffer_overflows for t in d),
                "lost_at_unplug": total(t.lost_at_unplug for t in d),
                "unaccounted": total(t.unaccounted for t in d),
            },
            "recording": asdict(self.recording),
            "per_device": [asdict(t) | {"unaccounted": t.unaccounted} for t in d],
        }


def soak_devices(n: int, seconds: float, seed: int) -> list[DeviceTally]:
    """Stream `n` faulty devices until each has sent `seconds` of samples; then stop
    injecting, stop streaming, drain, and tally."""
    urls = [
        f"sim://?scene=idle&seed={seed * 1000 + k}&speed={SPEED}&{DEVICE_FAULTS}&fault_unplug="
        f"{seconds / 3:g}"
        for k in range(n)
    ]
    sensors = [Sensor.open(u, reconnect=True, buffer_size=1 << 20, timeout=5.0) for u in urls]
    delivered = [0] * n
    target = int(seconds * RATE_HZ)
    stuck: list[str] = []
    errors: dict[str, str] = {}
    try:
        for s in sensors:
            _retry(lambda s=s: s.configure(integration_ms=INTEGRATION_MS, leds=WHITE))
            _retry(s.start)
        running = set(range(n))
        progress = {k: (0, time.monotonic()) for k in running}
        while running:
            for k in sorted(running):
                u, s = urls[k], sensors[k]
                delivered[k] += len(s.read(1 << 20, timeout=0))
                sent = ledger(u).samples_sent
                if sent != progress[k][0]:
                    progress[k] = (sent, time.monotonic())
                elif time.monotonic() - progress[k][1] > STUCK_S:
                    stuck.append(u)  # streaming did not come back: tallied, and reported
                if sent >= target or u in stuck:
                    ledger(u).paused = True  # end cleanly: no fault hides the last samples
                    try:
                        _stop(s)
                    except Exception as exc:  # reported with the device, the others go on
                        errors[u] = f"{type(exc).__name__}: {exc}"
                    delivered[k] += _drain(s)
                    running.discard(k)
            time.sleep(0.01)
    finally:
        for s in sensors:
            s.close()
    tallies = []
    for k, (u, s) in enumerate(zip(urls, sensors, strict=True)):
        book, st = ledger(u), s.stats
        tallies.append(
            DeviceTally(
                u,
                sent=book.samples_sent,
                delivered=delivered[k],
                sample_gaps=st.sample_gaps,
                buffer_overflows=st.buffer_overflows,
                lost_at_unplug=book.samples_lost_at_unplug,
                crc_errors=st.crc_errors,
                bytes_corrupted=book.bytes_corrupted,
                stalls=book.stalls,
                unplugs=book.unplugs,
                reconnects=st.reconnects,
                stall_reconnects=st.stalls,
                stuck=u in stuck,
                error=errors.get(u, ""),
            )
        )
    return tallies


def _retry(command: Callable[[], object]) -> None:
    """A command sent while the device is being unplugged fails: send it again once the
    link is back (the reconnect restores configuration and streaming by itself)."""
    for _ in range(50):
        try:
            command()
            return
        except DeviceError:
            time.sleep(0.2)
    command()


def _stop(s: Sensor) -> None:
    """STOP, asked again until STATUS confirms it: a reconnect may be under way (its resume
    restarts streaming), which a loaded host may take seconds to finish."""
    deadline = time.monotonic() + STOP_S
    last = "no attempt"
    while time.monotonic() < deadline:
        try:
            s.stop()
            time.sleep(0.2)
            if not s.status().streaming:
                return
            last = "STATUS said streaming after STOP's ACK"
        except DeviceError as exc:  # the link is coming back: ask again
            last = f"{type(exc).__name__}: {exc}"
            time.sleep(0.2)
    raise RuntimeError(f"{s.url} would not stop streaming within {STOP_S:g} s (last: {last})")


def _drain(s: Sensor) -> int:
    got = 0
    while True:
        n = len(s.read(1 << 20, timeout=0.5))
        if not n:
            return got
        got += n


def soak_recording(seconds: float, seed: int, out: Path) -> RecordingTally:
    url = (
        f"sim://?scene=idle&seed={seed}&speed={SPEED}&ft=bota&ft_loss=0.01"
        f"&fault=corrupt&fault_rate=2e-5"
    )
    path = out / "soak.mcap"
    summary = record_url(
        url,
        path,
        RecordOptions(samples=int(seconds * RATE_HZ), integration_ms=INTEGRATION_MS, leds=WHITE),
        sensor_options={"timeout": 5.0},
    )
    rec = read_recording(path)
    read_samples = sum(isinstance(decode_frame_raw(f), m.Sample) for f in rec.frames)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        datasets = build_datasets([path])
    tally = RecordingTally(
        samples=summary.samples,
        frames=summary.frames,
        ft_samples=summary.ft_samples,
        ft_lost=summary.ft_lost,
        lost=summary.lost,
        crc_errors=summary.crc_errors,
        read_frames=len(rec.frames),
        read_samples=read_samples,
        read_ft_samples=0 if rec.ft is None else len(rec.ft),
        dataset_samples=sum(len(d) for d in datasets),
    )
    tally.complete = (
        rec.end is not None
        and not rec.truncated
        and tally.read_frames == tally.frames
        and tally.read_samples == tally.samples
        and tally.read_ft_samples == tally.ft_samples
        and tally.dataset_samples > 0
    )
    return tally


def decode_frame_raw(raw: bytes) -> m.Message:
    """A recorded frame (decoded bytes: header, payload, CRC) as its message."""
    return parse_body(raw[:-4]).message


def run(devices: int, seconds: float, seed: int) -> Soak:
    started = time.monotonic()
    soak = Soak(seconds=seconds)
    soak.devices = soak_devices(devices, seconds, seed)
    with tempfile.TemporaryDirectory() as tmp:
        try:
            soak.recording = soak_recording(seconds, seed, Path(tmp))
        except Exception as exc:  # reported as the recording's failure, with the devices'
            soak.recording = RecordingTally(error=f"{type(exc).__name__}: {exc}")
    soak.wall_s = time.monotonic() - started
    return soak


def problems(s: dict[str, Any]) -> list[str]:
    """What failed, device by device and for the recording, and how: one line each (empty
    when the soak passed)."""
    out = []
    for d in s["per_device"]:
        how = []
        if d["unaccounted"]:
            how.append(
                f"{d['unaccounted']} samples unaccounted (sent {d['sent']} = delivered "
                f"{d['delivered']} + gaps {d['sample_gaps']} + overflows "
                f"{d['buffer_overflows']} + lost at unplug {d['lost_at_unplug']} + "
                f"{d['unaccounted']}; {d['unplugs']} unplugs, {d['reconnects']} reconnects)"
            )
        if d["stuck"]:
            how.append(f"stuck: no new sample for {STUCK_S:g} s of wall time")
        if d["error"]:
            how.append(f"ending its stream raised {d['error']}")
        if how:
            out.append(f"device {d['url']}: {'; '.join(how)}")
    rec = s["recording"]
    if not rec["complete"]:
        if rec["error"]:
            how = [f"raised {rec['error']}"]
        else:
            how = [f"{what} {rec['read_' + key]} read back of {rec[key]} written"
                   for key, what in (("frames", "frames"), ("samples", "samples"),
                                     ("ft_samples", "F/T rows"))
                   if rec["read_" + key] != rec[key]]  # fmt: skip
            how += ["no dataset built"] if not rec["dataset_samples"] else []
            how = how or ["no end record, or truncated"]
        out.append(f"recording: incomplete: {'; '.join(how)}")
    return out


def table(s: dict[str, Any]) -> str:
    load, faults, samples, rec = s["load"], s["faults"], s["samples"], s["recording"]
    rows = [
        (
            "Load held",
            f"{load['devices']} devices x {load['rate_hz']:g} samples/s x "
            f"{load['simulated_s_per_device']:g} s simulated ({load['samples_sent']} samples, "
            f"{load['wall_s']} s wall) + 1 recording with F/T",
        ),
        (
            "Bytes corrupted",
            f"{faults['bytes_corrupted']} ({faults['frames_rejected_crc']} frames rejected by CRC)",
        ),
        (
            "Unplug / replug",
            f"{faults['unplugs']} unplugs, {faults['reconnects']} reconnects, "
            f"{faults['stuck_devices']} devices left stuck",
        ),
        ("Link stalls", str(faults["stalls"])),
        ("F/T dropouts", str(faults["ft_dropouts"])),
        ("Bad inputs tried", str(s["bad_inputs"])),
        ("Samples delivered", str(samples["delivered"])),
        (
            "Samples counted lost",
            f"{samples['counted_lost']} (+{samples['lost_at_unplug']} "
            "corrupted just before an unplug)",
        ),
        ("Samples lost unaccounted", str(samples["unaccounted"])),
        (
            "Recording read back",
            f"{rec['read_frames']}/{rec['frames']} frames, "
            f"{rec['read_ft_samples']}/{rec['ft_samples']} F/T rows, dataset "
            f"{rec['dataset_samples']} samples: {'complete' if rec['complete'] else 'INCOMPLETE'}",
        ),
    ]
    width = max(len(r[0]) for r in rows)
    return "\n".join(f"| {a:<{width}} | {b} |" for a, b in rows)


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--devices", type=int, default=16)
    p.add_argument(
        "--seconds",
        type=float,
        default=float(os.environ.get("SPECTRATAC_SOAK_SECONDS", "300")),
        help="simulated seconds per device (default $SPECTRATAC_SOAK_SECONDS or 300)",
    )
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--json", action="store_true", help="one JSON line")
    args = p.parse_args()
    summary = run(args.devices, args.seconds, args.seed).summary()
    if args.json:
        sent = summary["load"]["samples_sent"]
        lost = summary["samples"]["unaccounted"]
        print(json.dumps(asdict(Figure(
            "reliability", lost, "samples", "samples sent", sent, lost / max(sent, 1), summary
        ))))  # fmt: skip
    else:
        print(table(summary))
    failed = problems(summary)
    for line in failed:  # stderr: beside the figures, in a test's failure report
        print(f"soak FAILED: {line}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
