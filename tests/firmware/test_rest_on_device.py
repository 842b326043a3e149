"""The on-device decoder joined under load, through the simulated device (the firmware core
over its wire protocol): a tour that starts mid-press, decoded on the device and on the host
from the same samples. The device never learns its zero on the pressed skin, says so with
EST_NO_REST exactly while the host says `no_rest`, and TARE (protocol 1.3) zeroes it where
`Decoder.tare()` does (issue 22 item 1)."""

from __future__ import annotations

import numpy as np
import pytest
from spectratac.apps.sensor_setup import sensor_settings
from spectratac.decode import Decoder
from spectratac.decode.assemble import Assembler
from spectratac.decode.export import model_image as mi
from spectratac.device import Sensor
from spectratac.device.errors import CommandRejectedError, MissingCapabilityError
from spectratac.protocol.generated import messages as m

pytestmark = [pytest.mark.train, pytest.mark.firmware]

#: 226 ms into the tour's first press (it starts at 0.056 s): where the issue's live run joined.
MID_PRESS = "sim://?scene=tour&seed=0&speed=max&start=0.282"
N = 160  # 8 s of the tour at 50 ms: past its first release


@pytest.fixture(scope="module")
def model() -> Decoder:
    from spectratac.sim.twin_dataset import from_twin_session
    from spectratac.train import TrainSpec, train
    from spectratac.twin import builtin_scenes as scenes
    from spectratac.twin import generate_session

    scene = scenes.calibration_session(seed=0, duration_s=90.0)
    ds = from_twin_session(generate_session(scene, seed=0), scene)
    spec = TrainSpec.paper(
        targets=("Fx", "Fy", "Fz"), epochs=2, hidden=16, blocks=1, threads=1, context=1,
        drift="baseline",
    )  # fmt: skip
    dec = train(ds, spec, progress=False)
    assert dec.layout.rest and dec.layout.press  # the rest signature the device needs
    return dec


def stream_beside(model: Decoder, url: str, tare_after: int | None = None):
    """(samples, device estimates) of the first N samples of `url`, the model decoding on the
    device beside them; TARE sent once `tare_after` samples have arrived (streaming stops
    first so that the tare lands on a known sample: the first after the restart)."""
    with Sensor.open(url) as sensor:
        sensor.upload_model(mi.encode(model), model.model_id())
        sensor.configure(**sensor_settings(model.config), estimates="beside")
        sensor.start()
        if tare_after is None:
            samples, est = sensor.read(N, timeout=20.0), sensor.read_estimates(N, timeout=20.0)
        else:
            first = sensor.read(tare_after, timeout=20.0)
            first_est = sensor.read_estimates(tare_after, timeout=20.0)
            sensor.stop()
            extra = sensor.read(1000, timeout=0.5)  # what was on its way when STOP came
            extra_est = sensor.read_estimates(1000, timeout=0.5)
            sensor.tare()
            sensor.start()
            rest = sensor.read(N - tare_after, timeout=20.0)
            rest_est = sensor.read_estimates(N - tare_after, timeout=20.0)
            samples = np.concatenate([first, extra, rest])
            est = np.concatenate([first_est, extra_est, rest_est])
            tare_after += len(extra)
        sensor.stop()
    assert len(samples) == len(est)  # one estimate beside each sample, in the same order
    assert np.array_equal(samples["sequence"], est["sequence"])
    return samples, est, tare_after


def host_path(model: Decoder, samples: np.ndarray, tare_at: int | None, restart: bool):
    """Host outputs (Fx, Fy, Fz) and rest-seen flags for the same samples (Decoder.stream's
    assembler, another unit's search as the device runs it); a START resets the session."""
    asm = Assembler(model.layout)
    x = samples["counts"][:, :, :4].reshape(len(samples), -1).astype(np.float64)
    u = np.full((len(samples), model.layout.size), np.nan)
    seen = np.zeros(len(samples), bool)
    for i in range(len(samples)):
        if i == tare_at:
            if restart:
                asm.reset()
            asm.tare()
        v, ok = asm.push(int(samples["step"][i]), x[i])
        u[i] = v if ok else np.nan
        seen[i] = asm.rest_seen
    stored = mi.as_stored(model, "f32")
    return stored.runtime.run(u)[:, :3], seen, u


def test_the_device_joined_mid_press_matches_the_host_and_flags_no_rest(model: Decoder) -> None:
    samples, est, _ = stream_beside(model, MID_PRESS)
    out, seen, u = host_path(model, samples, None, False)
    no_rest = (est["flags"] & m.EstimateFlags.EST_NO_REST) > 0
    assert no_rest[0] and not seen[0]  # joined on a pressed skin: not rest, and said so
    assert not no_rest[-1] and seen[-1]  # the first release was found
    np.testing.assert_array_equal(no_rest, ~seen)
    b = model.layout.base
    first = samples["counts"][0, :, :4].reshape(-1).astype(np.float64)
    assert not np.allclose(u[0, -b:], first)  # the pressed skin is not the zero
    force = est["force"].astype(np.float64)
    assert np.all(np.abs(force - out) <= 1e-4 * (1.0 + np.abs(out).max(axis=0)))


def test_tare_zeroes_the_device_where_the_host_tare_does(model: Decoder) -> None:
    samples, est, at = stream_beside(model, MID_PRESS, tare_after=40)
    assert at is not None
    out, seen, u = host_path(model, samples, at, restart=True)
    no_rest = (est["flags"] & m.EstimateFlags.EST_NO_REST) > 0
    np.testing.assert_array_equal(no_rest, ~seen)
    assert not no_rest[at:].any()  # the tare says: rest, from its sample on
    b = model.layout.base
    tared = samples["counts"][at, :, :4].reshape(-1).astype(np.float64)
    np.testing.assert_allclose(u[at, -b:], tared)  # that sample is the zero
    force = est["force"].astype(np.float64)
    assert np.all(np.abs(force - out) <= 1e-4 * (1.0 + np.abs(out).max(axis=0)))


#: 5 s into a 20-s tour's first press, whose hold lasts until 15 s: 10 s of pressed skin
#: (200 samples) before anything but a tare can show the device rest
LONG_PRESS = "sim://?scene=tour&seed=0&speed=1&period=20&start=6"


def test_decoder_stream_reports_no_rest_from_the_device_and_tares_it(model: Decoder) -> None:
    """Decoder.stream uses the device's estimates of this very model: `no_rest` comes from
    EST_NO_REST, and Decoder.tare() reaches the device (TARE). The skin stays pressed for
    200 samples, so however far a loaded host runs behind the device (CI at load 10 was ten
    samples behind when the tour's short press was used), rest seen before then is the
    tare's doing, and from then on the device keeps it."""
    with Sensor.open(LONG_PRESS) as sensor:
        sensor.upload_model(mi.encode(model), model.model_id())
        sensor.configure(**sensor_settings(model.config), estimates="instead")
        sensor.start()
        flags: list[bool] = []
        for i, e in enumerate(model.stream(sensor)):
            flags.append(e.no_rest)
            if i == 2:
                model.tare()
            if i == 180 or (False in flags and len(flags) - flags.index(False) >= 20):
                break
        sensor.stop()
    assert flags[0]  # joined pressed
    assert False in flags, "the tare never reached the device"
    assert not any(flags[flags.index(False) :])  # and the device keeps its new zero


def test_tare_without_a_model_is_refused_with_the_devices_reason() -> None:
    with (
        Sensor.open("sim://?seed=3&speed=max") as sensor,
        pytest.raises(CommandRejectedError, match="NO_MODEL"),
    ):
        sensor.tare()


def test_tare_on_a_device_older_than_1_3_is_a_typed_error(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import dataclasses

    with Sensor.open("sim://?seed=3&speed=max") as sensor:
        older = dataclasses.replace(sensor.info, protocol_minor=2)
        monkeypatch.setattr(sensor.link, "info", older)  # what the device told the link
        with pytest.raises(MissingCapabilityError, match=r"TARE is protocol 1\.3.*1\.2"):
            sensor.tare()
