"""Recording and dataset building: samples/s written, build time of a 60,000-sample session.

    python -m tools.bench.recording [--json] [--samples N] [--ft-rate HZ] [--rounds R]
                                    [--live-samples N]

The session is made, not recorded: a twin calibration session (`--samples` windows of 50 ms,
F/T at `--ft-rate`) encoded as real SAMPLE frames and FT_RECORD rows
(spectratac.sim.synthetic_recording), so 50 minutes of data take seconds. Every figure stands
beside a raw read of the same file (mcap's stream reader over every record, nothing decoded),
alternated in one run:

1. recorder write: the recorder's file path (frames one MCAP message each, F/T batches,
   clock-sync and label messages, a chunk flush per second of data), in samples/s.
2. format 4 against the compact encoding: the same write with the decoded channels any MCAP
   tool reads (JSON counts per sample, wrench per F/T sample, truth per sample; FORMAT.md)
   beside the compact channels alone (format 3's layout, `decoded=False`), in samples/s;
   the extra fields give both file sizes and their ratio.
3. dataset build: `spectratac dataset build` on the format-4 file (bulk decode, two clock
   fits, F/T window averages, scene labels), in samples/s; beside the raw read, and beside
   the build of the compact file (what reading past the decoded channels costs).
4. live recording: Recorder on a simulated device at speed=max (no F/T), samples/s, beside
   the same device read through Sensor without recording (the device is the bottleneck).
"""

from __future__ import annotations

import sys
import tempfile
import time
import warnings
from pathlib import Path

from mcap.stream_reader import StreamReader
from spectratac.dataset.build import build_datasets
from spectratac.device import Sensor
from spectratac.record import Recorder, RecordOptions
from spectratac.sim.synthetic_recording import sample_frames, write_twin_recording
from spectratac.twin import builtin_scenes as scenes
from spectratac.twin import generate_session

from tools.bench.benchlib import Figure, parser, report, side_by_side

INTEGRATION_S = 0.05


def raw_read(path: Path) -> int:
    """Records in the file, read with mcap's stream reader (chunks decompressed, no parsing)."""
    with open(path, "rb") as f:
        return sum(1 for _ in StreamReader(f).records)


def live(n: int) -> tuple[float, float, int]:
    """(samples/s recording, samples/s plain Sensor.read, samples lost while recording)."""
    url = "sim://?scene=tour&seed=1&speed=max"
    with tempfile.TemporaryDirectory() as tmp:
        with Sensor.open(url) as sensor:
            summary = Recorder(sensor, Path(tmp) / "live.mcap", RecordOptions(samples=n)).run()
        rec_rate = summary.samples / summary.duration_s
    with Sensor.open(url) as sensor:
        sensor.configure()
        sensor.start()
        t0, got = time.perf_counter(), 0
        while got < n:
            got += len(sensor.read(n - got, timeout=10.0))
        plain_rate = got / (time.perf_counter() - t0)
        sensor.stop()
    return rec_rate, plain_rate, summary.lost


def main() -> int:
    p = parser(__doc__.splitlines()[0])
    p.add_argument("--samples", type=int, default=60_000, help="optical samples in the session")
    p.add_argument("--ft-rate", type=int, default=200, help="F/T samples per second of data")
    p.add_argument("--rounds", type=int, default=3, help="alternations per figure")
    p.add_argument("--live-samples", type=int, default=3000, help="samples of the live figure")
    args = p.parse_args()
    duration = args.samples * INTEGRATION_S
    scene = scenes.calibration_session(0, duration)
    session = generate_session(scene, seed=0, ft_rate_hz=args.ft_rate)
    frames = sample_frames(session)
    tmp = Path(tempfile.mkdtemp())
    path = tmp / "session.mcap"
    compact_path = tmp / "compact.mcap"
    params = {"duration": f"{duration:g}"}

    def write(decoded: bool = True) -> int:
        write_twin_recording(
            path if decoded else compact_path, session, scene, "calibration",
            scene_params=params, frames=frames, decoded=decoded,
        )  # fmt: skip
        return len(session)

    def write_compact() -> int:
        return write(decoded=False)

    write()
    write_compact()
    records = raw_read(path)
    per_sample = records / len(session)  # to express the raw read in samples/s

    def read() -> int:
        return round(raw_read(path) / per_sample)

    def build(file: Path = path) -> int:
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # a finished synthetic file must read cleanly
            [ds] = build_datasets([file])
        return ds.n

    def build_compact() -> int:
        return build(compact_path)

    w_rate, r_rate = side_by_side(write, read, args.rounds)
    w4_rate, w3_rate = side_by_side(write, write_compact, args.rounds)
    b_rate, r2_rate = side_by_side(build, read, args.rounds)
    b4_rate, b3_rate = side_by_side(build, build_compact, args.rounds)
    rec_rate, plain_rate, lost = live(args.live_samples)
    size = path.stat().st_size
    compact_size = compact_path.stat().st_size
    extra = {
        "samples": len(session),
        "ft_samples": len(session.ft_t),
        "file_bytes": size,
        "records": records,
    }
    figures = [
        Figure("recorder write", w_rate, "samples/s", "raw read", r_rate, w_rate / r_rate, extra),
        Figure(
            "format 4 write",
            w4_rate,
            "samples/s",
            "compact only",
            w3_rate,
            w4_rate / w3_rate,
            {
                "samples": len(session),
                "ft_samples": len(session.ft_t),
                "file_bytes": size,
                "compact_file_bytes": compact_size,
                "size_ratio": size / compact_size,
                "data_s": duration,
                "realtime_factor": w4_rate * INTEGRATION_S,
            },
        ),
        Figure(
            "dataset build",
            b_rate,
            "samples/s",
            "raw read",
            r2_rate,
            b_rate / r2_rate,
            extra | {"build_s": len(session) / b_rate, "raw_read_s": len(session) / r2_rate},
        ),
        Figure(
            "format 4 build",
            b4_rate,
            "samples/s",
            "compact build",
            b3_rate,
            b4_rate / b3_rate,
            {"build_s": len(session) / b4_rate, "compact_build_s": len(session) / b3_rate},
        ),
        Figure(
            "live record, speed=max",
            rec_rate,
            "samples/s",
            "Sensor.read",
            plain_rate,
            rec_rate / plain_rate,
            {"samples": args.live_samples, "lost": lost},
        ),
    ]
    report(figures, args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
