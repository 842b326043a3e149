"""When most estimates of a stream are out of distribution, `decode`, `snake` (and `live`, on
the same `Decoder.stream`) say so once, plainly: how many, why, and the commands that adapt
the model to this sensor without a reference F/T (issue 35)."""

from __future__ import annotations

import warnings
from pathlib import Path

import pytest
from spectratac.cli import main
from spectratac.decode import Decoder, DecoderOodWarning
from spectratac.decode.ood_watch import MIN_ESTIMATES, OodWatch
from spectratac.device import Sensor
from spectratac.train import TrainSpec, train

pytestmark = pytest.mark.train


def url(seed: int) -> str:
    return f"sim://?scene=idle&seed={seed}&speed=max"


@pytest.fixture(scope="module")
def model(twin_ds, tmp_path_factory) -> Path:
    """Trained on twin unit 3 (twin_ds): every estimate of unit 1 is out of distribution."""
    spec = TrainSpec.paper(epochs=2, hidden=16, blocks=1, threads=1, context=2, drift="baseline")
    return train(twin_ds, spec, progress=False).save(tmp_path_factory.mktemp("m") / "m.stac")


def ood_lines(err: str) -> list[str]:
    return [line for line in err.splitlines() if "out of distribution (flagged" in line]


def test_decode_says_it_once_with_how_many_why_and_what_to_do(model, capsys) -> None:
    n = 3 * MIN_ESTIMATES
    assert main(["decode", str(model), url(1), "--count", str(n), "--format", "jsonl"]) == 0
    out, err = capsys.readouterr()
    [line] = ood_lines(err)
    assert line.startswith(f"spectratac: warning: {MIN_ESTIMATES} of the first {MIN_ESTIMATES}")
    assert "(twin-1)" in line and "'twin-3'" in line  # why: another unit
    # the same simulated unit, in the scene of a person who follows the prompts
    assert (
        'record "sim://?scene=guided&seed=1&speed=max" --guided 9' in line
        and f"--finetune {model}" in line
    )
    assert len(out.splitlines()) == n  # and it decodes on


def test_the_unit_it_was_trained_on_hears_nothing(model, capsys) -> None:
    assert main(["decode", str(model), url(3), "--count", str(2 * MIN_ESTIMATES)]) == 0
    assert ood_lines(capsys.readouterr().err) == []


def test_snake_says_it_once(model, capsys) -> None:
    assert main(["snake", str(model), url(1), "--json", "--duration", "6"]) == 0
    assert len(ood_lines(capsys.readouterr().err)) == 1


def test_each_stream_of_the_api_says_it_once(model) -> None:
    dec = Decoder.load(model)
    dec.unit_policy = "off"
    for _ in range(2):  # a second stream of the same decoder is watched anew
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            with Sensor.open(url(1)) as sensor:
                sensor.configure(integration_ms=50, leds=[[[250] * 3] * 3])
                sensor.start()
                for k, _est in enumerate(dec.stream(sensor)):
                    if k >= 3 * MIN_ESTIMATES:
                        break
        said = [w for w in caught if issubclass(w.category, DecoderOodWarning)]
        assert len(said) == 1 and "--guided 9" in str(said[0].message)


def test_a_few_flags_are_not_most() -> None:
    w = OodWatch("a", ("a",))
    said = [w.see(k % 3 == 0) for k in range(10 * MIN_ESTIMATES)]  # a third flagged
    assert said == [None] * len(said)
    w = OodWatch("a", ("a",))
    said = [w.see(k >= MIN_ESTIMATES) for k in range(4 * MIN_ESTIMATES)]  # later most
    assert sum(s is not None for s in said) == 1 and "the inputs lie outside" in next(
        s for s in said if s
    )
