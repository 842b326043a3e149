"""ROS 2 bag export: messages/s written by `spectratac export rosbag`, beside dataset build.

    python -m tools.bench.rosbag [--json] [--samples N] [--ft-rate HZ] [--rounds R]

The session is made, not recorded, as in recording.py: a twin calibration session of
`--samples` 50 ms windows with F/T at `--ft-rate`, written as a real recording. Figures,
each alternated in one run with its reference:

1. export, sqlite3 / mcap storage: the whole verb's job (read the recording, fit both clocks,
   encode, write the bag), in messages/s; the reference is `dataset build` of the same file
   (the same reading and clock fits, no bag), in the same unit (its samples + F/T rows /s).
2. WrenchStamped payloads: the exporter's vectorised CDR encoding, in messages/s, beside
   rosbags' typestore serialising message by message (what a script using rosbags does).
"""

from __future__ import annotations

import shutil
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np
from spectratac.dataset.build import build_datasets
from spectratac.ros2 import export_rosbag
from spectratac.ros2.messages import TYPESTORE, WRENCH_STAMPED, wrench_stamped
from spectratac.sim.synthetic_recording import sample_frames, write_twin_recording
from spectratac.twin import builtin_scenes as scenes
from spectratac.twin import generate_session

from tools.bench.benchlib import Figure, parser, report, side_by_side

INTEGRATION_S = 0.05


def typestore_payloads(stamps: np.ndarray, wrench: np.ndarray) -> int:
    t = TYPESTORE.types
    v, w_type = t["geometry_msgs/msg/Vector3"], t["geometry_msgs/msg/Wrench"]
    for ns, w in zip(stamps.tolist(), wrench.tolist(), strict=True):
        sec, nanosec = divmod(ns, 1_000_000_000)
        header = t["std_msgs/msg/Header"](
            stamp=t["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec),
            frame_id="spectratac_board",
        )
        msg = t[WRENCH_STAMPED](
            header=header,
            wrench=w_type(force=v(x=w[0], y=w[1], z=w[2]), torque=v(x=w[3], y=w[4], z=w[5])),
        )
        TYPESTORE.serialize_cdr(msg, WRENCH_STAMPED)
    return len(stamps)


def main() -> int:
    p = parser(__doc__.splitlines()[0])
    p.add_argument("--samples", type=int, default=6000, help="optical samples in the session")
    p.add_argument("--ft-rate", type=int, default=1000, help="F/T samples per second of data")
    p.add_argument("--rounds", type=int, default=3, help="alternations per figure")
    args = p.parse_args()
    duration = args.samples * INTEGRATION_S
    scene = scenes.calibration_session(0, duration)
    session = generate_session(scene, seed=0, ft_rate_hz=args.ft_rate)
    tmp = Path(tempfile.mkdtemp())
    path = tmp / "session.mcap"
    write_twin_recording(
        path,
        session,
        scene,
        "calibration",
        scene_params={"duration": f"{duration:g}"},
        frames=sample_frames(session),
    )
    figures = []
    for storage in ("sqlite3", "mcap"):
        out = tmp / f"bag_{storage}"
        messages = 0

        def export(storage: str = storage, out: Path = out) -> int:
            nonlocal messages
            shutil.rmtree(out, ignore_errors=True)
            with warnings.catch_warnings():
                warnings.simplefilter("error")  # a finished synthetic file must read cleanly
                messages = export_rosbag(path, out, storage=storage).messages  # type: ignore[arg-type]
            return messages

        def build() -> int:
            [ds] = build_datasets([path])
            return ds.n + int(ds.meta["sessions"][0]["ft_samples"])

        e_rate, b_rate = side_by_side(export, build, args.rounds)
        size = sum(f.stat().st_size for f in out.iterdir())
        extra = {
            "messages": messages,
            "samples": len(session),
            "ft_samples": len(session.ft_t),
            "recording_bytes": path.stat().st_size,
            "bag_bytes": size,
            "export_s": messages / e_rate,
        }
        figures.append(
            Figure(
                f"export rosbag, {storage}",
                e_rate,
                "msgs/s",
                "dataset build",
                b_rate,
                e_rate / b_rate,
                extra,
            )
        )
    n = min(len(session.ft_t), 50_000)
    stamps = 1_795_000_000_000_000_000 + np.arange(n, dtype=np.int64) * 1_000_000
    wrench = np.random.default_rng(0).normal(size=(n, 6))
    v_rate, t_rate = side_by_side(
        lambda: len(wrench_stamped(stamps, wrench, "spectratac_board")),
        lambda: typestore_payloads(stamps, wrench),
        args.rounds,
    )
    figures.append(
        Figure(
            "WrenchStamped payloads",
            v_rate,
            "msgs/s",
            "typestore per message",
            t_rate,
            v_rate / t_rate,
            {"messages": n},
        )
    )
    shutil.rmtree(tmp, ignore_errors=True)
    report(figures, args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
