"""A recording as a ROS 2 bag: the job behind `spectratac export rosbag`.

Topics (frame ids: FT_FRAME_ID, the reference F/T sensor's own axes, for the reference;
BOARD_FRAME_ID, the sensor board's axes, for estimates and counts):

| topic | type | one message per |
|---|---|---|
| /spectratac/reference/wrench | geometry_msgs/msg/WrenchStamped | recorded F/T sample |
| /spectratac/estimate/wrench | geometry_msgs/msg/WrenchStamped | estimate (a model, or recorded) |
| /spectratac/raw/step_K/counts | spectratac_msgs/msg/CountsStamped | optical sample of LED step K |

Times are on the sensor's clock mapped to Unix time (`spectratac.record.timeline`: a 30-s
session spans 30 s whatever a simulation's speed; on hardware, the host's wall clock), from
the clock fits the dataset builder uses (`spectratac.dataset.align`): an F/T sample's stamp
is its own clock fitted to its arrival times; an optical sample's is the end of its
integration window, the device clock fitted per connection epoch. The bag's receive
timestamp of each message equals its stamp, so `ros2 bag play` publishes in measurement
order; the timeline (anchor and scale) is in the bag's metadata (`custom_data`, key
"spectratac.timeline"), which `rosbag://` reads to put the stamps back onto the recording's
host clock. Raw counts have no ROS message of their own (sensor_msgs/Illuminance is one lux
value per message): CountsStamped is a std_msgs/Header beside a UInt16MultiArray's layout and
data, which hold one sample's counts exactly, the layout naming the dimensions "sensor" (3)
and "channel" (R, G, B, C, IR in that order); its definition is stored in the bag (rosbags
decodes it from there; `ros2 bag play` publishes it once a spectratac_msgs package is built
from that definition, and plays the other topics without), one topic per LED step because samples of
different steps are different measurements. Estimates the decoder does
not make (a force-only model's torques) are NaN; invalid samples get no estimate message.
Without a model, the estimates the recording holds (format 4: an on-device model's ESTIMATE
frames, or the live page's decoder in a clip) are written, each stamped with the optical
sample whose integration it ends.

Storage: sqlite3 by default, the storage ROS 2 Humble's `ros2 bag play` reads out of the box
(MCAP needs the rosbag2_storage_mcap plug-in there; it is the default from Iron on), with
bag format version 8; `storage="mcap"` writes MCAP. A bag is written into a hidden folder
beside OUT_DIR and renamed into place when complete, so OUT_DIR never holds half a bag.
"""

from __future__ import annotations

import json
import os
import shutil
import sqlite3
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from spectratac.dataset.align import ft_host_times
from spectratac.dataset.build import session_datasets
from spectratac.dataset.schema import Dataset, concat
from spectratac.fusion import ClockFitError
from spectratac.hardware.generated import vocabulary as vocab
from spectratac.record.reader import Recording, read_recording
from spectratac.record.timeline import KEY as TIMELINE_KEY
from spectratac.record.timeline import Timeline
from spectratac.ros2.errors import BagExportError
from spectratac.ros2.messages import COUNTS_STAMPED, WRENCH_STAMPED, counts_stamped, wrench_stamped

if TYPE_CHECKING:
    from spectratac.decode import Decoder

BOARD_FRAME_ID = "spectratac_board"
#: The reference F/T's wrench is in its own axes (mounted under the board, not rotated to it).
FT_FRAME_ID = "spectratac_ft_sensor"
REFERENCE_TOPIC = "/spectratac/reference/wrench"
ESTIMATE_TOPIC = "/spectratac/estimate/wrench"
COUNTS_LABELS = ("sensor", "channel")
Storage = Literal["sqlite3", "mcap"]
#: Messages written between two progress calls.
_PROGRESS_EVERY = 20_000


def counts_topic(step: int) -> str:
    return f"/spectratac/raw/step_{step}/counts"


@dataclass
class ExportSummary:
    """What was written: the bag folder, its storage, and per topic its type and count."""

    path: Path
    storage: Storage
    topics: dict[str, dict[str, Any]] = field(default_factory=dict)
    start_unix: float = 0.0
    end_unix: float = 0.0
    notes: list[str] = field(default_factory=list)

    @property
    def messages(self) -> int:
        return sum(t["count"] for t in self.topics.values())

    def as_dict(self) -> dict[str, Any]:
        return asdict(self) | {"path": str(self.path), "messages": self.messages}


@dataclass
class _Topic:
    name: str
    msgtype: str
    stamps: np.ndarray  # int64 ns
    payloads: list[bytes]


def export_rosbag(
    recording: str | Path,
    out_dir: str | Path,
    *,
    decoder: Decoder | None = None,
    storage: Storage = "sqlite3",
    progress: Callable[[int, int], None] | None = None,
) -> ExportSummary:
    """Write `recording` as a ROS 2 bag folder `out_dir` (see the module documentation).

    `out_dir` must not exist yet (or be an empty folder): nothing is ever deleted here
    (`spectratac export rosbag --force` replaces only a bag folder it wrote). Raises
    RecordingError for a file that is no recording, BagExportError when there is nothing to
    export or writing fails, DecoderConfigError when `decoder` does not fit the recording.
    `progress(done, total)` is called as messages are written."""
    if storage not in ("sqlite3", "mcap"):
        raise BagExportError(f"storage {storage!r}: use sqlite3 or mcap")
    out = Path(out_dir)
    if out.exists() and not (out.is_dir() and not any(out.iterdir())):
        raise BagExportError(f"{out} exists; choose another folder")
    rec = read_recording(recording)
    timeline = Timeline.of_session(rec.session, rec.link.clock_scale)
    topics, notes = _topics(rec, decoder, timeline)
    if not any(len(t.stamps) for t in topics):
        raise BagExportError(
            f"{recording}: no optical samples and no F/T samples; nothing to export"
        )
    summary = ExportSummary(out, storage, notes=notes)
    _write(topics, out, storage, progress, timeline)
    stamps = np.concatenate([t.stamps for t in topics])
    summary.start_unix = float(stamps.min()) / 1e9
    summary.end_unix = float(stamps.max()) / 1e9
    for t in topics:
        summary.topics[t.name] = {"type": t.msgtype, "count": len(t.stamps)}
    return summary


def _topics(
    rec: Recording, decoder: Decoder | None, timeline: Timeline
) -> tuple[list[_Topic], list[str]]:
    scale = 1.0 if rec.link.clock_scale is None else rec.link.clock_scale
    topics: list[_Topic] = []
    notes: list[str] = []
    parts = session_datasets(rec) if rec.frames else []
    if rec.ft is not None and len(rec.ft):
        try:
            t_ft = _declared_ft_times(rec, parts)
            if t_ft is None:
                t_ft, _ = ft_host_times(rec.ft, scale)
        except ClockFitError as exc:  # too few samples to fit: their arrival times
            t_ft = rec.ft["host_time"]
            notes.append(f"F/T stamps are arrival times: its clock could not be fitted ({exc})")
        ns = timeline.ns_array(t_ft)
        topics.append(
            _Topic(
                REFERENCE_TOPIC,
                WRENCH_STAMPED,
                ns,
                wrench_stamped(ns, rec.ft["wrench"], FT_FRAME_ID),
            )
        )
    elif decoder is None:
        notes.append("the recording has no reference F/T: no reference topic")
    if rec.frames:
        if rec.link.clock_scale is None:
            notes.append(
                "the device clock is not tied to the host's (an unpaced simulation): optical "
                "stamps are device time after the recording's start, not when it happened"
            )
        ds = concat(parts) if len(parts) > 1 else parts[0]
        ns = timeline.ns_array(ds.t_end)
        for step in np.unique(ds.step):
            rows = ds.step == step
            payloads = counts_stamped(
                ns[rows], ds.arrays["counts"][rows], COUNTS_LABELS, BOARD_FRAME_ID
            )
            topics.append(_Topic(counts_topic(int(step)), COUNTS_STAMPED, ns[rows], payloads))
        if decoder is not None:
            topics.append(_estimates(decoder, parts, timeline))
        elif rec.estimates:
            topic = _recorded_estimates(rec.estimates, parts, timeline)
            if topic is not None:
                topics.append(topic)
                notes.append(f"estimates as recorded ({', '.join(_sources(rec.estimates))})")
    elif decoder is not None:
        raise BagExportError(f"{rec.path}: no optical samples to decode with the model")
    return topics, notes


def _declared_ft_times(rec: Recording, parts: list[Dataset]) -> np.ndarray | None:
    """Host times of a simulated F/T whose clock the recording declares against the device's
    (the dataset builder's targets use it): through the optical windows' own fit, so the bag
    puts each F/T sample where the builder does. None: no declared clock, or several epochs."""
    declared = rec.truth.get("ft_clock")
    if not declared or rec.ft is None or len(parts) != 1 or len(rec.epochs) > 1:
        return None
    ds = parts[0]
    device = ds.arrays["device_time_us"] / 1e6
    if len(device) < 2 or np.ptp(device) <= 0:
        return None
    t_dev = (rec.ft["sensor_time"] - declared["offset_s"]) / (1.0 + declared["drift"])
    slope, intercept = np.polyfit(device - device[0], ds.t_end, 1)  # the fit is linear
    host: np.ndarray = intercept + slope * (t_dev - device[0])
    return host


def _estimates(decoder: Decoder, parts: list[Dataset], timeline: Timeline) -> _Topic:
    stamps, wrenches = [], []
    for ds in parts:  # one configuration each: the decoder checks it fits
        est = decoder.predict(ds)
        keep = ~est.invalid
        stamps.append(timeline.ns_array(ds.t_end[keep]))
        wrenches.append(np.stack([est.column(a) for a in vocab.FT_AXES], axis=1)[keep])
    ns = np.concatenate(stamps)
    order = np.argsort(ns, kind="stable")
    wrench = np.concatenate(wrenches)[order]
    ns = ns[order]
    return _Topic(ESTIMATE_TOPIC, WRENCH_STAMPED, ns, wrench_stamped(ns, wrench, BOARD_FRAME_ID))


def _recorded_estimates(
    estimates: list[dict[str, Any]], parts: list[Dataset], timeline: Timeline
) -> _Topic | None:
    """The recording's own estimates (None: none matches an optical sample), each stamped as
    the sample whose integration window it ends: its device time is that sample's."""
    host_of: dict[int, float] = {}
    for ds in parts:
        if "device_time_us" not in ds.arrays:
            continue
        for dev, host in zip(ds.arrays["device_time_us"].tolist(), ds.t_end.tolist(), strict=True):
            host_of.setdefault(int(dev), float(host))
    stamps, wrenches = [], []
    for e in estimates:
        host = host_of.get(int(e.get("t_end_us", -1)))
        if host is None or e.get("invalid"):
            continue
        stamps.append(host)
        wrenches.append(
            [_axis(e, "force", a) for a in "xyz"] + [_axis(e, "torque", a) for a in "xyz"]
        )
    if not stamps:
        return None
    ns = timeline.ns_array(np.asarray(stamps))
    order = np.argsort(ns, kind="stable")
    ns, wrench = ns[order], np.asarray(wrenches, np.float64)[order]
    return _Topic(ESTIMATE_TOPIC, WRENCH_STAMPED, ns, wrench_stamped(ns, wrench, BOARD_FRAME_ID))


def _axis(estimate: dict[str, Any], part: str, axis: str) -> float:
    value = (estimate.get(part) or {}).get(axis)
    return float("nan") if value is None else float(value)


def _sources(estimates: list[dict[str, Any]]) -> list[str]:
    names = {"device": "the on-device model", "host": "the live page's decoder"}
    return sorted({names.get(str(e.get("source")), str(e.get("source"))) for e in estimates})


def _write(
    topics: list[_Topic],
    out: Path,
    storage: Storage,
    progress: Callable[[int, int], None] | None,
    timeline: Timeline,
) -> None:
    from rosbags.interfaces import (
        Qos,
        QosDurability,
        QosHistory,
        QosLiveliness,
        QosReliability,
        QosTime,
    )
    from rosbags.rosbag2 import StoragePlugin, Writer, WriterError

    from spectratac.ros2.messages import TYPESTORE

    # what a reliable publisher offers (times 0: unspecified, i.e. infinite); Humble's player
    # adapts its publishers to the recorded offers and cannot parse an empty list
    unspecified = QosTime(0, 0)
    qos = Qos(
        QosHistory.KEEP_LAST,
        10,
        QosReliability.RELIABLE,
        QosDurability.VOLATILE,
        unspecified,
        unspecified,
        QosLiveliness.AUTOMATIC,
        unspecified,
        False,
    )

    staging = out.parent / f".{out.name}.partial-{os.getpid()}"
    shutil.rmtree(staging, ignore_errors=True)
    staging.mkdir(parents=True)
    bag = staging / out.name  # the storage file inside is named after the bag folder
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    # every message in time order across topics, as a recorder would have logged them
    which = np.concatenate([np.full(len(t.stamps), k) for k, t in enumerate(topics)])
    index = np.concatenate([np.arange(len(t.stamps)) for t in topics])
    stamps = np.concatenate([t.stamps for t in topics])
    order = np.lexsort((which, stamps))
    total = len(order)
    try:
        with Writer(bag, version=8, storage_plugin=plugin) as writer:
            writer.set_custom_data(TIMELINE_KEY, json.dumps(timeline.as_dict()))
            conns = [
                writer.add_connection(
                    t.name, t.msgtype, typestore=TYPESTORE, offered_qos_profiles=[qos]
                )
                for t in topics
            ]
            for done, k in enumerate(order, 1):
                t, i = which[k], index[k]
                writer.write(conns[t], int(stamps[k]), topics[t].payloads[i])
                if progress is not None and (done % _PROGRESS_EVERY == 0 or done == total):
                    progress(done, total)
        if out.is_dir():
            out.rmdir()  # empty (checked above); fails rather than delete anything else
        bag.rename(out)
    except (WriterError, OSError, sqlite3.Error) as exc:
        raise BagExportError(
            f"cannot write the bag {out}: {exc}; a read-only folder or a full disk? choose "
            f"a folder with room you may write to (-o)"
        ) from None
    finally:
        shutil.rmtree(staging, ignore_errors=True)
