"""`Decoder`: a trained decoder that predicts, saves, loads, exports and streams (no torch).

>>> import numpy as np
>>> from spectratac.dataset import Dataset
>>> from spectratac.decode.layout import Layout
>>> ds = Dataset.generic(np.eye(3) + 1, np.zeros((3, 1)), ["a", "b", "c"], ["Fz"])
>>> dec = Decoder.untrained(ds, features="generic", targets=("Fz",))
>>> est = dec.predict(ds)
>>> est.force.shape, est.target_names, bool(est.invalid.any())
((3, 3), ('Fz',), False)
"""

from __future__ import annotations

import warnings
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from spectratac.dataset.schema import Dataset
from spectratac.decode import sensor_config
from spectratac.decode.assemble import Assembler, assemble
from spectratac.decode.errors import (
    DecoderConfigError,
    DecoderOodWarning,
    DecoderUnitWarning,
    SensorNotStreamingError,
)
from spectratac.decode.estimates import CONTACT_FORCE_N, FORCE, TORQUE, Estimate, Estimates
from spectratac.decode.export import export as export_to
from spectratac.decode.export import model_image
from spectratac.decode.export.model_image import ModelImageError
from spectratac.decode.feature_matrices import build_features
from spectratac.decode.guard import Guard
from spectratac.decode.heads import Heads
from spectratac.decode.layout import Layout
from spectratac.decode.networks import flops, init_weights, n_params
from spectratac.decode.ood_watch import OodWatch
from spectratac.decode.runtime import Runtime
from spectratac.decode.stac_file import read_model, write_model
from spectratac.decode.unit_check import UnitPolicy, check_sensor_unit, device_unit_ids
from spectratac.device.records import Sample
from spectratac.device.streams import EstimateStream, SampleStream
from spectratac.hardware.generated import vocabulary as vocab

F64 = NDArray[np.float64]


@dataclass
class Decoder:
    runtime: Runtime
    layout: Layout
    guard: Guard
    meta: dict[str, Any] = field(default_factory=dict)
    #: what `stream` does when the sensor is another unit (decode.unit_check): "warn",
    #: "strict" (DecoderUnitError) or "off"
    unit_policy: UnitPolicy = field(default="warn", compare=False)
    # running streams' assemblers (tare reaches them); not copied by dataclasses.replace
    _streams: set[Assembler] = field(default_factory=set, init=False, repr=False, compare=False)
    # sensors streaming this decoder's on-device estimates (tare sends them TARE)
    _devices: list[Any] = field(default_factory=list, init=False, repr=False, compare=False)
    _tare_next: bool = field(default=False, init=False, repr=False, compare=False)
    #: the file it was loaded from (None: made in this process); named in advice
    source: str | None = field(default=None, init=False, repr=False, compare=False)

    # ------------------------------------------------------------------ facts
    @property
    def heads(self) -> Heads:
        return self.runtime.heads

    @property
    def target_names(self) -> tuple[str, ...]:
        return self.heads.regression

    @property
    def config(self) -> dict[str, Any] | None:
        return self.meta.get("config")

    @property
    def unit_id(self) -> str | None:
        return self.meta.get("unit_id")

    @property
    def n_params(self) -> int:
        return n_params(self.runtime.weights)

    @property
    def flops_per_sample(self) -> int:
        """Network multiply-adds x 2 plus the feature arithmetic, per sample."""
        fs = self.runtime.features
        feat = 2 * int(np.count_nonzero(fs.L)) + 2 * int(
            np.count_nonzero(fs.P) + np.count_nonzero(fs.Q)
        )
        mon = int(np.count_nonzero(fs.M >= 0)) - fs.M.shape[0]  # products per monomial
        return flops(self.runtime.arch, fs.n_features, self.heads.n_out) + feat + mon

    def __repr__(self) -> str:
        spec = self.meta.get("spec", {})
        return (
            f"Decoder({spec.get('model', '?')}, features={spec.get('features', '?')}, "
            f"targets={list(self.meta.get('targets', []))}, unit={self.unit_id!r}, "
            f"params={self.n_params})"
        )

    # ------------------------------------------------------------------ checks
    def check_config(self, config: Any, what: str = "the data") -> None:
        """Raise DecoderConfigError if `config` differs from the training configuration."""
        diffs = sensor_config.differences(self.config, sensor_config.normalise(config))
        if diffs:
            raise DecoderConfigError(
                f"{what} was recorded under another sensor configuration than this decoder "
                f"was trained under ({'; '.join(diffs)}): reconfigure the sensor to the "
                f"decoder's configuration, or train a decoder for this one"
            )

    def check_unit(self, unit_id: str | None, what: str = "the data") -> None:
        """Warn (DecoderUnitWarning) when `unit_id` is another unit than the training one."""
        if unit_id is not None and self.unit_id is not None and unit_id != self.unit_id:
            warnings.warn(
                f"{what} comes from unit {unit_id!r} but this decoder was trained on "
                f"{self.unit_id!r}: expect larger errors; calibrate a decoder for this unit",
                DecoderUnitWarning,
                stacklevel=3,
            )

    def _check_inputs(self, names: list[str]) -> None:
        if tuple(names) != self.layout.channels:
            raise DecoderConfigError(
                f"inputs {names} differ from the decoder's {list(self.layout.channels)}: "
                f"give the same channels in the same order"
            )

    # ------------------------------------------------------------------ prediction
    def predict(self, dataset: Dataset, rows: ArrayLike | None = None) -> Estimates:
        """Estimates for `rows` (mask, indices or None for all) of a Dataset.

        Samples are assembled over the whole dataset per session in time order, so rows see
        their real past (temporal context, baseline) even when their neighbours are not
        selected. Raises DecoderConfigError on other inputs or sensor configuration; warns on
        another unit.
        """
        self._check_inputs(dataset.input_names)
        self.check_config(dataset.meta.get("config"), "the dataset")
        self.check_unit(dataset.meta.get("unit_id"), "the dataset")
        status = dataset.arrays.get("status")
        unit = dataset.meta.get("unit_id")
        est = self.predict_inputs(
            dataset.inputs,
            step=dataset.step,
            session=dataset.session,
            t=dataset.t_end,
            status=status,
            rows=rows,
            same_unit=unit is not None and unit == self.unit_id,
        )
        return est

    def predict_inputs(
        self,
        inputs: Any,
        step: Any = None,
        session: Any = None,
        t: Any = None,
        status: Any = None,
        rows: Any = None,
        same_unit: bool = False,
    ) -> Estimates:
        """Estimates for raw input rows (N, C) in the decoder's channel order.

        step, session, t (time order) matter for LED sequences, temporal context and the
        baseline; status (N, ...) SENSOR_* bits mark saturated or faulty rows OOD;
        same_unit: the rows come from the decoder's own unit (see assemble._Baseline).
        """
        x = np.asarray(inputs, dtype=np.float64)
        if x.ndim != 2 or x.shape[1] != len(self.layout.channels):
            raise DecoderConfigError(
                f"inputs have shape {x.shape}; this decoder takes (N, "
                f"{len(self.layout.channels)}) columns {list(self.layout.channels)}"
            )
        seen = np.zeros(x.shape[0], bool)
        u, valid = assemble(self.layout, x, step, session, t, seen=seen, same_unit=same_unit)
        sel = np.arange(x.shape[0]) if rows is None else np.asarray(rows)
        if sel.dtype == bool:
            sel = np.flatnonzero(sel)
        st = None if status is None else np.asarray(status)[sel]
        est = self._estimates(u[sel], valid[sel], st)
        est.no_rest = valid[sel] & ~seen[sel]
        return est

    def _estimates(self, u: F64, valid: NDArray[np.bool_], status: Any) -> Estimates:
        n = u.shape[0]
        heads = self.heads
        est = Estimates.empty(self.target_names, n)
        est.invalid = ~valid
        if n == 0:
            return est
        out = np.full((n, heads.n_out), np.nan)
        if valid.any():
            out[valid] = self.runtime.run(u[valid])
            # absurd inputs (1e30) overflow the features to inf/NaN: decode them clipped to
            # the guard's bounds instead (flagged by the guard either way); in range, the
            # inputs are used as they are, exactly as the exports and the device use them
            redo = valid & ~np.all(np.isfinite(out), axis=1)
            if redo.any():
                out[redo] = self.runtime.run(self.guard.bound_inputs(u[redo]))
        # a non-finite output (damaged weights, overflow) is no estimate: invalid, all NaN
        valid = valid & np.all(np.isfinite(out), axis=1)
        out[~valid] = np.nan
        est.invalid = ~valid
        s = heads.slices()
        est.targets = self.guard.bound_targets(out[:, s["targets"]].astype(np.float64))
        if heads.uncertainty:
            est.std = out[:, s["std"]].astype(np.float64)
        if heads.n_classes:
            p = out[:, s["classes"]].astype(np.float64)
            est.region_probs = p
            pv = np.where(np.isnan(p), -np.inf, p)
            est.region = np.where(valid, np.argmax(pv, axis=1) + 1, -1)
            est.region_prob = np.where(valid, np.max(pv, axis=1), np.nan)
        if heads.contact:
            est.contact_prob = out[:, s["contact"]][:, 0].astype(np.float64)
            est.contact = valid & (est.contact_prob > 0.5)
        else:
            f = [i for i, t in enumerate(self.target_names) if t in FORCE]
            if f:
                with np.errstate(invalid="ignore"):
                    mag = np.sqrt(np.sum(est.targets[:, f] ** 2, axis=1))
                est.contact = valid & (mag > CONTACT_FORCE_N)
        x = u[:, : self.layout.base]
        ood = self.guard.check(x, est.targets, status)
        est.ood = valid & ood
        return est

    # ------------------------------------------------------------------ live
    def tare(self) -> None:
        """Zero the drift baseline of every running `stream` on its next sample: call it
        while nothing touches the skin (as the bias button of an F/T sensor's software).

        >>> import numpy as np
        >>> from spectratac.dataset import Dataset
        >>> ds = Dataset.generic(np.ones((2, 3)), np.zeros((2, 1)), ["a", "b", "c"], ["Fz"])
        >>> dec = Decoder.untrained(ds)
        >>> dec.tare()  # the next sample of each stream() becomes the zero

        Called before any stream runs, it zeroes the next stream on its first sample. A
        stream of the device's own estimates of this decoder is tared on the device (TARE,
        protocol 1.3: `Sensor.tare`).
        """
        streams, devices = list(self._streams), list(self._devices)
        for asm in streams:
            asm.tare()
        for sensor in devices:
            sensor.tare()
        self._tare_next = not streams and not devices

    def stream(self, sensor: SampleStream, check_config: bool = True) -> Iterator[Estimate]:
        """Estimates of a live, streaming sensor (a `spectratac.device.SampleStream` such as
        `spectratac.device.Sensor`), one per sample.

        When the sensor streams on-device estimates (configured with estimates="beside" or
        "instead", protocol 1.1) of this very decoder (the device's model_id is this
        decoder's model image id, see spectratac.decode.export.model_image), those are
        yielded instead of decoding on the host (contact_prob and std are then not known);
        otherwise the samples are decoded here. Checks the sensor's configuration first
        (DecoderConfigError on mismatch) and again whenever the configuration id changes;
        compares the sensor's unit with the model's on open (`unit_policy`: warns, or raises
        DecoderUnitError when "strict"). With a drift baseline, each estimate's `no_rest` says the
        baseline has not yet seen the skin at rest; `tare()` zeroes it on the next sample.

        The sensor must stream: one open but not started (or stopped) raises
        SensorNotStreamingError at the first estimate asked for, at once (after the checks
        above), instead of waiting for samples that never come; the stream's start and stop
        stay the caller's.
        """
        if self.layout.channels != vocab.DECODED_INPUTS:
            raise DecoderConfigError("stream() decodes SpectraTac sensors; this decoder is not")
        check_sensor_unit(self.unit_id, sensor, self.unit_policy)
        ids = device_unit_ids(sensor)
        same = self.unit_id is not None and self.unit_id in ids
        on_device = isinstance(sensor, EstimateStream) and self._decoded_by(sensor)
        require_streaming(sensor)
        watch = OodWatch(self.unit_id, ids, url=getattr(sensor, "url", None), model=self.source)
        for estimate in self._stream_estimates(sensor, check_config, on_device, same):
            said = watch.see(estimate.ood)
            if said is not None:
                warnings.warn(said, DecoderOodWarning, stacklevel=2)
            yield estimate

    def _stream_estimates(
        self, sensor: SampleStream, check_config: bool, on_device: bool, same: bool
    ) -> Iterator[Estimate]:
        """`stream`'s estimates, on the device or decoded here."""
        if on_device:
            yield from self._device_estimates(sensor, check_config)  # type: ignore[arg-type]
            return
        config_id = None
        asm = Assembler(self.layout, same_unit=same)
        if self._tare_next:
            asm.tare()
            self._tare_next = False
        self._streams.add(asm)
        run1 = self.runtime.run1
        s = self.heads.slices()
        fi = [self.target_names.index(n) if n in self.target_names else -1 for n in FORCE]
        ti = [self.target_names.index(n) if n in self.target_names else -1 for n in TORQUE]
        try:
            for sample in sensor:
                if sample.config_id != config_id:
                    if check_config:
                        self.check_config(sensor.get_config(), "the sensor")
                    config_id = sample.config_id
                    asm.reset()
                counts = np.asarray(sample.counts, dtype=np.float64)
                x = counts[:, :4].reshape(-1)
                u, ok = asm.push(int(sample.step), x)
                yield self._one(sample, u, ok, run1, s, fi, ti, not asm.rest_seen)
        finally:
            self._streams.discard(asm)

    def model_id(self, weights: str = "f32") -> int:
        """The id of this decoder's model image with `weights` (what a device that runs it
        reports in MODEL_INFO and every ESTIMATE)."""
        return model_image.model_id(model_image.encode(self, weights=weights))

    def _image_id(self, weights: str) -> int | None:
        """`model_id`, or None for a decoder no model image can carry (a linear skip, a
        polynomial ridge, other inputs): no device runs it, so the host decodes."""
        try:
            return self.model_id(weights)
        except ModelImageError:
            return None

    def _decoded_by(self, sensor: EstimateStream) -> bool:
        """True if `sensor` streams on-device estimates of this decoder."""
        mode = sensor.estimates
        if mode == "off":
            return False
        info = sensor.model_info()
        if info.has_model and info.model_id == self._image_id(info.weight_format):
            return True
        if mode == "instead":
            raise DecoderConfigError(
                f"the sensor streams only the estimates of its own model 0x{info.model_id:08X}, "
                f"not of this decoder: upload this decoder (spectratac model upload) or "
                f"configure the sensor with estimates='beside' or 'off' to decode on the host"
            )
        return False

    def _device_estimates(self, sensor: EstimateStream, check_config: bool) -> Iterator[Estimate]:
        config_id = None
        tare = getattr(sensor, "tare", None)  # a device of protocol 1.3 (Sensor.tare)
        if self._tare_next and tare is not None:
            tare()
            self._tare_next = False
        if tare is not None:
            self._devices.append(sensor)
        try:
            for row in sensor.iter_estimates():
                if check_config and row.config_id != config_id:
                    self.check_config(sensor.get_config(), "the sensor")
                config_id = row.config_id
                yield Estimate.from_device(row, self.target_names)
        finally:
            if tare is not None:
                self._devices.remove(sensor)

    def _one(
        self,
        sample: Sample,
        u: F64,
        ok: bool,
        run1: Any,
        s: Any,
        fi: Any,
        ti: Any,
        no_rest: bool = False,
    ) -> Estimate:
        heads = self.heads
        out = run1(u).astype(np.float64) if ok else None
        if out is not None and not np.all(np.isfinite(out)):  # overflow: see _estimates
            out = run1(self.guard.bound_inputs(u[None, :])[0]).astype(np.float64)
        if out is None or not np.all(np.isfinite(out)):  # no estimate: invalid, all NaN
            nan3 = np.full(3, np.nan)
            return Estimate(
                float(sample.host_time),
                nan3,
                nan3.copy(),
                -1,
                float("nan"),
                False,
                float("nan"),
                False,
                True,
                np.full(heads.n_reg, np.nan),
                device_time_us=int(sample.device_time_us),
                epoch=int(sample.epoch),
            )
        tg = self.guard.bound_targets(out[None, s["targets"]])[0]
        force = np.array([tg[i] if i >= 0 else np.nan for i in fi])
        torque = np.array([tg[i] if i >= 0 else np.nan for i in ti])
        region, rprob = -1, float("nan")
        if heads.n_classes:
            p = out[s["classes"]]
            region, rprob = int(np.argmax(p)) + 1, float(np.max(p))
        if heads.contact:
            cprob = float(out[s["contact"]][0])
            contact = cprob > 0.5
        else:
            cprob = float("nan")
            f = force[~np.isnan(force)]
            contact = bool(f.size and np.sqrt(np.sum(f * f)) > CONTACT_FORCE_N)
        ood = bool(
            self.guard.check(
                u[None, : self.layout.base], tg[None, :], np.asarray(sample.status)[None, :]
            )[0]
        )
        std = out[s["std"]].copy() if heads.uncertainty else None
        return Estimate(
            float(sample.host_time),
            force,
            torque,
            region,
            rprob,
            contact,
            cprob,
            ood,
            False,
            tg.copy(),
            std,
            no_rest,
            device_time_us=int(sample.device_time_us),
            epoch=int(sample.epoch),
        )

    # ------------------------------------------------------------------ files
    def save(self, path: str | Path) -> Path:
        """Write the single-file model (.stac): weights, normalisation, features, config."""
        return write_model(self, path)

    @classmethod
    def load(
        cls,
        path: str | Path,
        expect_config: Any = None,
        expect_unit: str | None = None,
    ) -> Decoder:
        """Read a .stac file. Refuses (DecoderConfigError) if `expect_config` (a config
        dict or a device CONFIG message) differs from the training configuration; warns
        (DecoderUnitWarning) if `expect_unit` is another unit."""
        dec = read_model(path, cls)
        dec.source = str(path)
        if expect_config is not None:
            dec.check_config(expect_config, "the expected configuration")
        dec.check_unit(expect_unit, "the expected unit")
        return dec

    def export(self, fmt: str, path: str | Path) -> Path:
        """Write the stateless part (assembled vector -> outputs) as onnx, numpy,
        torchscript or c. See spectratac.decode.export."""
        return export_to(self, fmt, path)

    # ------------------------------------------------------------------ tests and docs
    @classmethod
    def untrained(
        cls,
        dataset: Dataset,
        features: str = "generic",
        targets: tuple[str, ...] = ("Fz",),
        arch: tuple[str, int, int] = ("resmlp", 8, 1),
        seed: int = 0,
    ) -> Decoder:
        """A decoder with random weights for `dataset`'s inputs (tests, documentation)."""
        layout = Layout(tuple(dataset.input_names))
        fs = build_features(features, layout)
        heads = Heads(
            tuple(t for t in targets if t not in ("region", "contact")),
            n_classes=vocab.N_REGIONS if "region" in targets else 0,
            contact="contact" in targets,
        )
        w = init_weights(arch, fs.n_features, heads.n_out, np.random.default_rng(seed))
        u, _ = assemble(layout, dataset.inputs)
        rt = Runtime.create(fs, arch, w, heads, u)
        guard = Guard.fit(u, np.zeros((u.shape[0], heads.n_reg)))
        guard.t_lo[:], guard.t_hi[:] = -np.inf, np.inf
        guard.center = guard.whiten = guard.dist_max = None  # untrained: no distance check
        meta = {
            "spec": {"features": features, "model": arch[0]},
            "targets": list(targets),
            "config": dataset.meta.get("config"),
            "unit_id": dataset.meta.get("unit_id"),
        }
        return cls(rt, layout, guard, meta)


def require_streaming(sensor: object) -> None:
    """Raise SensorNotStreamingError if `sensor` (a `spectratac.device.Sensor`) is open but
    not streaming. The host's belief (`Sensor.streaming`) is confirmed with the device's
    STATUS first: a device left streaming by an earlier session is fine. Sample streams
    that know nothing of starting (recordings, taps, test doubles) pass."""
    if getattr(sensor, "streaming", True):
        return
    status = getattr(sensor, "status", None)
    if callable(status) and status().streaming:
        return
    name = getattr(sensor, "url", "the sensor")
    raise SensorNotStreamingError(
        f"{name} is open but not streaming, so no sample would come: call sensor.start() "
        "before decoder.stream(sensor) (and sensor.stop() when done)"
    )
