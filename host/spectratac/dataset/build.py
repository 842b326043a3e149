"""Recorded sessions (MCAP) to datasets: the job behind `spectratac dataset build`.

Per recording: the SAMPLE frames are bulk-decoded; device time goes onto the host clock with
fit_clock (TIME_SYNC exchanges + frame arrival times), once per connection epoch (a reconnect
may restart the device clock: times are never stitched across one), and so does the F/T clock
(arrival times); the F/T is averaged over each integration window (targets; NaN and target_valid
False wherever the F/T has a gap, never interpolated); labels come from the ground truth the
recorder stored (simulated links) or from the guided protocol's events (LABELS.md): read
from the recording alone, the same way for every recording. A session's rows are grouped by
configuration; groups with different configurations are refused together unless split.

>>> import tempfile
>>> from spectratac.record import RecordOptions, record_url
>>> path = tempfile.mkdtemp() + "/s.mcap"
>>> _ = record_url("sim://?scene=tour&speed=5", path, RecordOptions(samples=30))  # 1000 s scene
>>> [ds] = build_datasets([path])
>>> ds.n >= 30, ds.meta["labels"], ds.meta["unit_id"] == ds.meta["sessions"][0]["unit_id"]
(True, 'scene', True)
"""

from __future__ import annotations

import hashlib
import json
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from spectratac.dataset.align import Windows, device_windows, ft_targets
from spectratac.dataset.coverage import check_coverage
from spectratac.dataset.external_ft import ExternalFT
from spectratac.dataset.frames import recorded_samples
from spectratac.dataset.labels import (
    CONTACT_N,
    ft_contact,
    guided_labels,
    optical_guided_labels,
    truth_labels,
    truth_rows,
)
from spectratac.dataset.schema import (
    FT_NAMES,
    SPECTRATAC_INPUTS,
    Dataset,
    DatasetError,
    concat,
    split_by_config,
)
from spectratac.fusion import ClockFitError, window_average
from spectratac.record.reader import Recording, read_recording


class UnlabelledSamplesWarning(UserWarning):
    """Samples of a damaged recording whose scene labels were in a skipped chunk: left out;
    `count` says how many."""

    def __init__(self, message: str, count: int) -> None:
        super().__init__(message)
        self.count = count


class MixedUnitsWarning(UserWarning):
    """The sessions joined into one dataset were recorded on different sensor units."""


@dataclass
class BuildOptions:
    """max_gap_ms: the longest F/T gap (host clock) a window may straddle; default 3 F/T
    periods. contact_n: |F| for in_contact in real sessions. ft: a reference F/T recorded
    apart (`spectratac.dataset.external_ft`)."""

    max_gap_ms: float | None = None
    contact_n: float = CONTACT_N
    #: the reference F/T from outside the recordings (dataset build --ft), replacing theirs
    ft: ExternalFT | None = None


def build_datasets(
    paths: Sequence[str | Path],
    *,
    split: bool = False,
    options: BuildOptions | None = None,
    progress: Callable[[str], None] | None = None,
) -> list[Dataset]:
    """One dataset of all sessions, or with `split` one per sensor configuration. A
    truncated file contributes its readable prefix (TruncatedRecordingWarning)."""
    if not paths:
        raise DatasetError("no recordings given: name at least one .mcap file")
    parts: list[Dataset] = []
    for path in paths:
        rec = read_recording(path)
        if options is not None and options.ft is not None:
            rec.ft = options.ft.on_clock(rec.clock.unix_minus_monotonic_ns)
            rec.session = {**rec.session, "ft_url": options.ft.url}
        mine = session_datasets(rec, options)
        _check_coverage(rec, mine)
        parts += mine
        if progress is not None:
            progress(str(path))  # this file is done
    units = sorted({str(p.meta.get("unit_id")) for p in parts})
    if len(units) > 1:
        warnings.warn(
            f"the sessions come from {len(units)} units ({', '.join(units)}); a decoder is "
            f"calibrated per unit: build one dataset per unit unless you mean to mix them",
            MixedUnitsWarning,
            stacklevel=2,
        )
    if split:
        return split_by_config(parts)
    return [concat(parts)]


def _check_coverage(rec: Recording, parts: list[Dataset]) -> None:
    """The reference's coverage of the session's windows (`spectratac.dataset.coverage`),
    kept in each part's session record; a build checks it, an export does not need it."""
    arrays = {k: np.concatenate([p.arrays[k] for p in parts])
              for k in ("t_start", "t_end", "target_valid", "ft_count")}  # fmt: skip
    scale = rec.link.clock_scale or 1.0
    figures = check_coverage(
        str(rec.path), rec.ft, arrays["t_start"], arrays["t_end"], arrays["target_valid"],
        arrays["ft_count"], scale, truncated=rec.truncated,
    )  # fmt: skip
    for p in parts:
        p.meta["sessions"][0]["ft_coverage"] = figures


def session_datasets(rec: Recording, options: BuildOptions | None = None) -> list[Dataset]:
    """One recording as datasets, one per configuration its samples were taken under."""
    opts = options or BuildOptions()
    link = rec.link  # a device clock not tied to the host's (clock_scale None) is used as is
    scale = 1.0 if link.clock_scale is None else link.clock_scale
    samples, windows, epochs = _timed_samples(rec, scale, device_clock=link.clock_scale is None)
    source = rec.session.get("labels", "none")
    if source == "scene":  # (the samples' epochs serve guided sessions only)
        samples, windows = _with_truth_rows(rec, samples, windows)
    max_gap = None if opts.max_gap_ms is None else opts.max_gap_ms / 1e3
    targets, valid, count, ft_clock = ft_targets(rec.ft, windows, scale, max_gap)
    declared = rec.truth.get("ft_clock") if opts.ft is None else None
    if declared and rec.ft is not None and len(rec.ft) >= 2:
        gap = None if max_gap is None else max_gap * scale  # host s to device s
        targets, valid, count, ft_clock = _declared_ft_targets(rec.ft, samples, declared, gap)
    valid &= samples["flags"] == 0  # a window the device timed wrongly has no true target
    force = targets[:, :3]
    if source == "scene":
        region, in_contact, press = truth_labels(rec.path, rec.ground_truth, samples)
    elif source == "guided":
        region, press, in_contact = _guided(rec, samples, windows, epochs, force, opts)
    else:
        region = np.full(len(samples), -1, np.int8)
        press = np.full(len(samples), -1, np.int32)
        in_contact = ft_contact(force, opts.contact_n)
    arrays = {
        "inputs": samples["counts"][:, :, :4].reshape(-1, 12).astype(np.float64),
        "targets": targets,
        "target_valid": valid,
        "region": region,
        "in_contact": in_contact,
        "t_start": windows.t_start,
        "t_end": windows.t_end,
        "step": samples["step"],
        "config_id": samples["config_id"],
        "session": np.zeros(len(samples)),
        "press": press,
        "counts": samples["counts"],
        "status": samples["status"],
        "sequence": samples["sequence"],
        "device_time_us": samples["t_end_us"],
        "ft_count": count,
    }
    info = rec.info or {}
    base = {
        "kind": "spectratac",
        "input_names": list(SPECTRATAC_INPUTS),
        "target_names": list(FT_NAMES),
        "unit_id": info.get("unit_id"),
        "firmware_version": info.get("firmware"),
        "protocol_version": info.get("protocol"),
        "definition_hash": info.get("definition_hash_hex"),
        "labels": source,
        # no reference F/T recorded: targets are NaN (a guided session's labels only)
        "force_targets": "reference" if rec.ft is not None else "none",
    }
    out = []
    for cid in np.unique(samples["config_id"]):
        rows = samples["config_id"] == cid
        recorded = rec.configs.get(int(cid))
        session = _session_meta(rec, samples[rows], valid[rows], windows, ft_clock, int(cid))
        meta = {**base, "config": recorded["config"] if recorded else None, "sessions": [session]}
        out.append(Dataset({k: v[rows] for k, v in arrays.items()}, meta))
    return out


def _guided(
    rec: Recording,
    samples: np.ndarray,
    windows: Windows,
    epochs: np.ndarray,
    force: np.ndarray,
    opts: BuildOptions,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(region, press, in_contact) of a guided session. Prompt spans on the device clock
    (clock "device", with their epoch) are matched to the samples' device times, older ones
    (host monotonic) to their host windows; the F/T confirms each press, or without one the
    counts do (`optical_guided_labels`)."""
    events = [e for e in rec.labels if e.get("source") == "guided"]
    on_device = [e for e in events if e.get("clock") == "device"]
    if on_device:
        t_mid = (samples["t_start_us"] + samples["t_end_us"]) / 2e6
        # a reconnect may restart the device clock: each epoch's spans only on its samples
        t_mid = t_mid + np.where(epochs >= 0, epochs, 0) * _EPOCH_APART_S
        events = [_apart(e) for e in on_device]
    else:
        t_mid = (windows.t_start + windows.t_end) / 2
    if rec.ft is None:
        counts = samples["counts"][:, :, :4].reshape(-1, 12)
        return optical_guided_labels(events, t_mid, counts, samples["step"])
    region, press = guided_labels(events, t_mid, force)
    return region, press, ft_contact(force, opts.contact_n)


#: Device times of different connection epochs are set this far apart to match spans.
_EPOCH_APART_S = 1e7


def _apart(event: dict[str, Any]) -> dict[str, Any]:
    shift = (event.get("epoch") or 0) * _EPOCH_APART_S
    return event | {"t_start": event["t_start"] + shift, "t_end": event["t_end"] + shift}


def _epoch_frames(rec: Recording) -> list[tuple[int | None, np.ndarray]]:
    """(epoch, indices of its frames) per connection epoch of the recording, in order; one
    epoch (None) for files without epoch messages."""
    everything = np.arange(len(rec.frames))
    if not rec.epochs:
        return [(None, everything)]
    marks = sorted(rec.epochs, key=lambda e: e["host_time"])
    starts = np.array([e["host_time"] for e in marks])
    which = np.clip(np.searchsorted(starts, rec.frame_host_times, side="right") - 1, 0, None)
    return [(int(e["epoch"]), everything[which == k]) for k, e in enumerate(marks)]


def _timed_samples(
    rec: Recording, scale: float, device_clock: bool
) -> tuple[np.ndarray, Windows, np.ndarray]:
    """The recording's samples, their windows on the host clock, the device clock fitted
    per epoch, and each sample's epoch (-1: a file without epochs). `device_clock`: keep
    device (scene) time (an unpaced simulation, whose device time races ahead of the host
    clock)."""
    parts: list[tuple[int | None, np.ndarray, Windows]] = []
    for epoch, idx in _epoch_frames(rec):
        samples = recorded_samples([rec.frames[i] for i in idx], rec.frame_host_times[idx])
        if len(samples) == 0:
            continue
        if device_clock:
            clock = {"method": "device clock"}
            windows = Windows(samples["t_start_us"] / 1e6, samples["t_end_us"] / 1e6, clock)
            parts.append((epoch, samples, windows))
            continue
        exchanges = [x for x in rec.time_sync if epoch is None or x.get("epoch", 0) == epoch]
        try:
            parts.append((epoch, samples, device_windows(samples, exchanges, scale)))
        except ClockFitError as exc:
            raise DatasetError(
                f"{rec.path}: cannot put the device clock of connection epoch {epoch} "
                f"({len(samples)} samples after a reconnect) on the host clock: {exc}. Device "
                f"times are not stitched across a reconnect; record that part again"
            ) from exc
    if not parts:
        raise DatasetError(f"{rec.path} holds no samples: was the device streaming?")
    epochs = np.concatenate([np.full(len(s), -1 if e is None else e) for e, s, _ in parts])
    if len(parts) == 1:
        return parts[0][1], parts[0][2], epochs
    clock = {"method": "per epoch", "epochs": [{"epoch": e, **w.clock} for e, _, w in parts]}
    windows = Windows(
        np.concatenate([w.t_start for _, _, w in parts]),
        np.concatenate([w.t_end for _, _, w in parts]),
        clock,
    )
    return np.concatenate([s for _, s, _ in parts]), windows, epochs


def _with_truth_rows(
    rec: Recording, samples: np.ndarray, windows: Windows
) -> tuple[np.ndarray, Windows]:
    """The samples that have a ground-truth row: all of an intact recording's (else
    DatasetError); a damaged one loses those whose row was in a skipped chunk, said once."""
    damaged = bool(rec.corrupted_chunks or rec.truncated)
    keep = truth_rows(rec.path, rec.ground_truth, samples, damaged) >= 0
    if keep.all():
        return samples, windows
    lost = int((~keep).sum())
    message = (
        f"{rec.path}: {lost} of {len(keep)} samples lost their scene labels with the damaged "
        f"part of the file; they are left out"
    )
    warnings.warn(UnlabelledSamplesWarning(message, lost), stacklevel=2)
    return samples[keep], Windows(windows.t_start[keep], windows.t_end[keep], windows.clock)


def _declared_ft_targets(
    ft: np.ndarray, samples: np.ndarray, clock: dict[str, float], max_gap_s: float | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
    """Targets of a simulated F/T whose clock the recording declares against the device's
    (F/T time = offset + (1 + drift) x device time): averaged over each window on the device
    clock, so they depend on the scene alone, not on how the host clocks were fitted."""
    t_device = (ft["sensor_time"] - clock["offset_s"]) / (1.0 + clock["drift"])
    mean, valid, count = window_average(
        t_device,
        ft["wrench"],
        samples["t_start_us"] / 1e6,
        samples["t_end_us"] / 1e6,
        max_gap_s=max_gap_s,
    )
    return mean, valid, count, {"method": "declared", **clock}


def _session_meta(
    rec: Recording,
    samples: np.ndarray,
    valid: np.ndarray,
    windows: Windows,
    ft_clock: dict[str, Any] | None,
    config_id: int,
) -> dict[str, Any]:
    s = rec.session
    truth = rec.truth
    seq = samples["sequence"].astype(np.int64)
    return {
        "source": "record",
        "path": str(rec.path),
        "url": s.get("url"),
        "ft_url": s.get("ft_url"),
        "scene": truth.get("scene"),
        "seed": truth.get("seed"),
        "speed": truth.get("speed"),
        "unit_id": (rec.info or {}).get("unit_id"),
        "started_unix": s.get("started_unix"),
        "library_version": s.get("library_version"),
        "n": len(samples),
        "config_id": config_id,
        "lost": int(np.sum(np.clip(np.diff(seq) - 1, 0, None))),
        "ft_samples": 0 if rec.ft is None else len(rec.ft),
        "target_valid": float(valid.mean()) if len(valid) else 0.0,
        "labels": s.get("labels", "none"),
        "label_events": len(rec.labels),
        "clock": windows.clock,
        "epochs": len({int(e["epoch"]) for e in rec.epochs}) or 1,
        "ft_clock": ft_clock,
        "truncated": rec.truncated,
        "stopped_by": (rec.end or {}).get("stopped_by"),
    }


def config_tag(config: dict[str, Any] | None) -> str:
    """A readable, unique file-name tag for a configuration.

    >>> config_tag({"integration_ms": 50, "gain": 1.0, "digital_gain": 1,
    ...             "sensitivity": "high", "leds": [[[500] * 3] * 3], "settle_us": 1000})
    '50ms-g1-dg1-high-1step-...'
    """
    if not config:
        return "unknown-config"
    digest = hashlib.sha1(json.dumps(config, sort_keys=True).encode()).hexdigest()[:6]
    steps = len(config.get("leds") or [])
    return (
        f"{config['integration_ms']}ms-g{config['gain']:g}-dg{config['digital_gain']}-"
        f"{config['sensitivity']}-{steps}step-{digest}"
    )


def split_paths(out: str | Path, datasets: Sequence[Dataset]) -> list[Path]:
    """Output file per dataset: `out` itself for one, else out's stem + config tag."""
    out = Path(out)
    if len(datasets) == 1:
        return [out]
    suffix = out.suffix or ".npz"
    return [
        out.with_name(f"{out.stem}.{config_tag(ds.meta.get('config'))}{suffix}") for ds in datasets
    ]
