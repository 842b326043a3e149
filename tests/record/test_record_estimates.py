"""`record --estimates`: a device that decodes on board (a model uploaded into the simulated
firmware's model store) has its ESTIMATE frames kept, and they reach /spectratac/estimates
with the clips' schema, each matching the sample it ends."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from spectratac.cli import main
from spectratac.record import read_recording

from tests.lichtblick_rules import check_mcap


@pytest.fixture(scope="module")
def board(tmp_path_factory: pytest.TempPathFactory) -> str:
    """A simulated board's flash holding an uploaded decoder (as `spectratac model upload`)."""
    from spectratac.dataset import SPECTRATAC_INPUTS, Dataset
    from spectratac.decode import Decoder
    from spectratac.decode.export import model_image
    from spectratac.device import Sensor

    store = tmp_path_factory.mktemp("board") / "flash.bin"
    ds = Dataset.generic(np.arange(1.0, 37.0).reshape(3, 12) * 100.0, np.zeros((3, 1)),
                         list(SPECTRATAC_INPUTS), ["Fz"])  # fmt: skip
    decoder = Decoder.untrained(ds, features="paper33", seed=0)
    with Sensor.open(f"sim://?seed=1&speed=max&model_store={store}") as sensor:
        sensor.upload_model(model_image.encode(decoder, weights="f32"), decoder.model_id())
    return f"sim://?scene=tour&seed=1&speed=max&model_store={store}"


@pytest.mark.parametrize("flag", [[], ["--estimates"]])
def test_record_keeps_the_devices_estimates_when_asked(
    board: str, tmp_path: Path, flag: list[str]
) -> None:
    out = tmp_path / "s.mcap"
    assert main(["record", board, "-o", str(out), "--count", "60", "--no-progress", *flag]) == 0
    rec = read_recording(out)
    if not flag:
        assert rec.estimates == []  # the device was not asked to decode
        return
    assert len(rec.estimates) >= 55 and {e["source"] for e in rec.estimates} == {"device"}
    from spectratac.dataset.frames import recorded_samples

    samples = recorded_samples(rec.frames, rec.frame_host_times)
    by_seq = dict(zip(samples["sequence"].tolist(), samples["t_end_us"].tolist(), strict=True))
    assert all(by_seq[e["sequence"]] % 2**32 == e["t_end_us"] for e in rec.estimates)
    assert all(e["decoded"] and list(e["force"]) == ["z"] for e in rec.estimates)  # an Fz model
    assert check_mcap(out)["/spectratac/estimates"] > 0
