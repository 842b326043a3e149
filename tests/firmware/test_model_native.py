"""The on-device decoder (firmware/core/stac_model.c) against the Python decoder, sample by
sample over whole twin sessions, natively under ASan + UBSan (tests/firmware/model_check).

For each recipe (the paper's, TrainSpec.best(), and variants covering every head, feature
kind and a three-step LED sequence; small and briefly trained) and each weight format, the
device must give the Python decoder's outputs for the same stored weights to float32
rounding, and the same estimate/no-estimate decisions, flags and regions."""

from __future__ import annotations

from pathlib import Path

import crcmod.predefined
import numpy as np
import pytest
from spectratac.decode import Decoder
from spectratac.decode.export import model_image as mi
from spectratac.decode.generated.model_image_layout import OFFSETS
from spectratac.train import TrainSpec, train

from tests.firmware.conftest import OUT
from tests.firmware.model_check import model_check_host as harness

pytestmark = [pytest.mark.train, pytest.mark.firmware, pytest.mark.subprocess]

TINY = {"epochs": 1, "hidden": 16, "threads": 1}
RECIPES = {
    "paper": TrainSpec.paper(**TINY, blocks=2),
    "best": TrainSpec.best(**TINY),
    "mlp-contact-unc": TrainSpec.paper(
        **TINY, model="mlp", blocks=2, uncertainty=True, targets=("Fx", "Fz", "contact")
    ),
    "linear-raw": TrainSpec.paper(**TINY, model="linear", features="raw", targets=("Fz",)),
    "rgb-steps": TrainSpec.paper(
        **TINY, blocks=1, context=3, context_dilated=True, context_ema=(20.0,), drift="baseline"
    ),
}
REL_TOL = 1e-4  # of the output's range: float32 rounding of a differently ordered sum
_crc = crcmod.predefined.mkCrcFun("crc-32c")


def twin(seed: int, led_steps: np.ndarray | None = None):
    from spectratac.sim.twin_dataset import from_twin_session
    from spectratac.twin import builtin_scenes as scenes
    from spectratac.twin import generate_session

    scene = scenes.calibration_session(seed=seed, duration_s=60.0)
    return from_twin_session(generate_session(scene, seed=seed, led_steps=led_steps), scene)


@pytest.fixture(scope="module")
def models() -> dict[str, tuple[Decoder, harness.Session]]:
    rgb = np.zeros((3, 3, 3))
    for c in range(3):
        rgb[c, :, c] = 0.6
    data = {"one": twin(3), "rgb": twin(4, rgb)}
    out = {}
    for name, spec in RECIPES.items():
        ds = data["rgb" if name == "rgb-steps" else "one"]
        out[name] = (train(ds, spec, progress=False), with_faults(harness.session_of(ds)))
    return out


def with_faults(s: harness.Session) -> harness.Session:
    """The session with what the live path must survive: a bus fault, a saturated count,
    an LED step the model does not know (no estimate, state unchanged)."""
    counts, status, step = s.counts.copy(), s.status.copy(), s.step.copy()
    status[100, 1] = 0x02  # SENSOR_BUS_FAULT
    counts[200, 0, 0] = 65535
    at = 300
    counts = np.insert(counts, at, counts[at], axis=0)
    status = np.insert(status, at, status[at], axis=0)
    step = np.insert(step, at, 7)
    return harness.Session(counts, status, step)


@pytest.fixture(scope="module")
def checker(native_build) -> Path:
    return native_build.build("model-check", OUT)


def run(checker: Path, image: bytes, session: harness.Session, work: Path):
    result = harness.run_native(checker, image, session, work)
    assert result.returncode == 0, result.stderr
    assert "runtime error" not in result.stderr, result.stderr  # UBSan
    return harness.output_of(work)[0]


def within(err: dict) -> bool:
    return all(err["max_abs"][k] <= REL_TOL * (1.0 + err["max_abs_ref"][k]) for k in err["max_abs"])


@pytest.mark.parametrize("weights", mi.WEIGHT_FORMATS)
@pytest.mark.parametrize("name", list(RECIPES))
def test_device_estimates_equal_python(models, checker, tmp_path, name, weights) -> None:
    dec, session = models[name]
    got = run(checker, mi.encode(dec, weights), session, tmp_path)
    err = harness.errors(dec, got, harness.reference(mi.as_stored(dec, weights), session))
    assert err["estimates_agree"] and err["n_estimates"] > 0.9 * err["n"], err
    assert err["flags_disagree"] == 0 and err["region_disagree"] == 0, err
    assert within(err), err["max_abs"]
    assert got["ret"][session.step == 7].tolist() == [1]
    assert got["flags"][session.step == 7][0] & harness.EST_INVALID
    ood = got["flags"] & harness.EST_OOD > 0
    assert ood[100] and ood[200]  # the bus fault and the saturated count


def test_warmup_until_the_context_is_filled(models, checker, tmp_path) -> None:
    dec, session = models["best"]
    got = run(checker, mi.encode(dec, "i8"), session, tmp_path)
    warm = (got["flags"] & harness.EST_WARMUP) > 0
    assert warm[:8].all() and not warm[8:].any()  # lags 1..8


def test_quantised_weights_report_their_extra_error(models, checker, tmp_path) -> None:
    """Extra mean absolute error of float16 and int8 weights against float32 (printed for
    the report); float16 is near-lossless, int8 costs more but stays a fraction of the
    outputs' range."""
    for name in ("paper", "best"):
        dec, session = models[name]
        ref = harness.reference(dec, session)
        for weights, bound in (("f16", 1e-3), ("i8", 3e-2)):
            got = run(checker, mi.encode(dec, weights), session, tmp_path / weights)
            err = harness.errors(dec, got, ref)
            for k in dec.target_names:
                extra = err["mae"][k] / (err["max_abs_ref"][k] or 1.0)
                print(f"{name} {weights} {k}: extra MAE {err['mae'][k]:.3g} ({extra:.2%} of range)")
                assert extra < bound, (name, weights, k, err["mae"])


def reseal(image: bytearray) -> bytes:
    image[-4:] = _crc(bytes(image[:-4])).to_bytes(4, "little")
    return bytes(image)


def weights_offset(image: bytes | bytearray) -> int:
    """Where the weights section starts (its entry in the section table)."""
    entry = mi.HEADER_SIZE + mi.ENTRY.size * mi.SECTIONS.index("weights")
    return int(mi.ENTRY.unpack_from(image, entry)[0])


def test_damaged_images_do_not_open(models, checker, tmp_path) -> None:
    dec, session = models["paper"]
    good = mi.encode(dec)
    short = session.head(50)
    flipped = bytearray(good)
    flipped[len(good) // 2] ^= 0x10  # one weight bit: the CRC no longer matches
    beyond = bytearray(good)
    hidden = OFFSETS["hidden"]
    beyond[hidden : hidden + 2] = (300).to_bytes(2, "little")  # > STAC_MODEL_MAX_HIDDEN
    section = bytearray(good)
    off = mi.HEADER_SIZE + mi.ENTRY.size * mi.SECTIONS.index("bias") + 4
    section[off] += 4  # a section one float longer than the dimensions say
    nan = bytearray(good)
    first = weights_offset(good)
    nan[first : first + 4] = np.float32(np.nan).tobytes()  # a NaN weight
    for bad in (bytes(flipped), reseal(beyond), reseal(section), reseal(nan), good[:-4]):
        result = harness.run_native(checker, bad, short, tmp_path)
        assert result.returncode == 2, result.stderr
        assert "image is invalid" in result.stderr
        assert not (tmp_path / harness.OUT_NAME).read_bytes()


def test_a_perturbed_weight_is_caught_by_the_comparison(models, checker, tmp_path) -> None:
    dec, session = models["paper"]
    image = bytearray(mi.encode(dec))
    first = weights_offset(image)
    w = np.frombuffer(image, "<f4", count=1, offset=first)[0]
    image[first : first + 4] = np.float32(w + 0.05).tobytes()
    got = run(checker, reseal(image), session, tmp_path)
    err = harness.errors(dec, got, harness.reference(dec, session))
    assert not within(err)


@pytest.mark.parametrize("recipe", ["paper", "best"])
def test_full_size_recipes_fit_the_limits(checker, tmp_path, recipe) -> None:
    """The paper's model (33 features, ResMLP 128 x 3) and TrainSpec.best() (156 inputs, 189
    features, ResMLP 128 x 2) at full size: within the interpreter's limits, within the
    STM32 model store in every weight format, and exact."""
    ds = twin(5)
    make = TrainSpec.paper if recipe == "paper" else TrainSpec.best
    dec = train(ds, make(epochs=1, threads=1), progress=False)
    assert dec.runtime.arch[1] == 128
    session = harness.session_of(ds).head(300)
    for weights in mi.WEIGHT_FORMATS:
        image = mi.encode(dec, weights, limit=None)
        assert len(image) <= mi.MAX_IMAGE_BYTES
        got = run(checker, image, session, tmp_path / weights)
        err = harness.errors(dec, got, harness.reference(mi.as_stored(dec, weights), session))
        assert err["estimates_agree"] and err["flags_disagree"] == 0 and within(err), err


def test_mutated_headers_and_tables_never_crash(models, checker, tmp_path) -> None:
    """Random bytes in the header and section table, CRC made valid again: the interpreter
    refuses the image or runs it, and ASan/UBSan see no bad access either way."""
    dec, session = models["best"]
    good = mi.encode(dec, "i8")
    short = session.head(20)
    rng = np.random.default_rng(7)
    outcomes = set()
    for _ in range(120):
        image = bytearray(good)
        for at in rng.integers(0, mi.TABLE_END, rng.integers(1, 4)):
            image[at] = int(rng.integers(0, 256))
        result = harness.run_native(checker, reseal(image), short, tmp_path)
        assert result.returncode in (0, 2), result.stderr
        assert "runtime error" not in result.stderr and "Sanitizer" not in result.stderr
        outcomes.add(result.returncode)
    assert outcomes == {0, 2}  # some mutations are harmless (padding), most are refused


def joined_mid_press(ds) -> tuple[harness.Session, int]:
    """Session 0 from its first firm press on (the stream joins under load), and the row of
    the first release after it."""
    session = harness.session_of(ds)
    rows = np.flatnonzero(ds.session == np.unique(ds.session)[0])
    rows = rows[np.argsort(ds.t_end[rows], kind="stable")]
    fz = -ds.targets[rows, ds.target_names.index("Fz")]
    start = int(np.flatnonzero(fz > 2.0)[0])
    release = start + int(np.flatnonzero(~ds.in_contact[rows[start:]])[0])
    n = len(rows) - start
    return (
        harness.Session(session.counts[start:], session.status[start:], session.step[start:]),
        release - start if release - start < n else n,
    )


def host_live(dec: Decoder, session: harness.Session, tare_at: int) -> tuple[np.ndarray, ...]:
    """The host's live path (Assembler as Decoder.stream runs it for another unit) with
    Decoder.tare() before row `tare_at`: assembled vectors and rest seen, per row."""
    from spectratac.decode.assemble import Assembler

    asm = Assembler(dec.layout)
    x, n = session.raw12, len(session.step)
    u = np.full((n, dec.layout.size), np.nan)
    seen = np.zeros(n, bool)
    for i in range(n):
        if i == tare_at:
            asm.tare()
        v, ok = asm.push(int(session.step[i]), x[i])
        u[i] = v if ok else np.nan
        seen[i] = asm.rest_seen
    return u, seen


@pytest.mark.parametrize("weights", ["f32", "i8"])
def test_device_baseline_searches_for_rest_when_joined_mid_press(
    models, checker, tmp_path, weights
) -> None:
    """A stream that starts on a pressed skin: the device never takes it as its zero, flags
    EST_NO_REST on exactly the estimates where the host's baseline has not seen rest, gives
    the host's outputs, and TARE (stac_model_tare) zeroes it where Decoder.tare() does."""
    dec, _ = models["best"]
    assert dec.layout.drift and dec.layout.rest  # the image carries the rest signature
    assert mi.describe(mi.encode(dec))["sections"]["rest"] == 8 * dec.layout.base
    session, release = joined_mid_press(twin(3))
    n = min(len(session.step), release + 300)
    session = session.head(n)
    tare_at = release + 150
    u, seen = host_live(dec, session, tare_at)
    assert not seen[0] and seen[release + 100]  # joined pressed; rest found after the release
    b = dec.layout.base
    assert not np.allclose(u[0, -b:], session.raw12[0])  # the pressed skin is not the zero
    taring = harness.Session(
        np.insert(session.counts, tare_at, 0, axis=0),
        np.insert(session.status, tare_at, 0, axis=0),
        np.insert(session.step, tare_at, harness.TARE_STEP),
    )
    got = run(checker, mi.encode(dec, weights), taring, tmp_path)
    assert len(got) == n
    no_rest = (got["flags"] & harness.EST_NO_REST) > 0
    np.testing.assert_array_equal(no_rest, ~seen)
    out = mi.as_stored(dec, weights).runtime.run(u)  # the host's outputs, its own vectors
    diff = np.abs(got["out"][:, : dec.heads.n_out].astype(np.float64) - out)
    scale = np.max(np.abs(out), axis=0)
    assert np.all(diff <= REL_TOL * (1.0 + scale)), diff.max(axis=0)
