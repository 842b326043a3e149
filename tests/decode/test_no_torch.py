"""Loading, predicting and streaming must not import torch (it costs ~1.5 s to import)."""

from __future__ import annotations

import subprocess
import sys

import pytest
from spectratac.train import TrainSpec, train

from tests.decode.conftest import synthetic

pytestmark = [pytest.mark.train, pytest.mark.subprocess]


def test_load_and_predict_without_torch(tmp_path) -> None:
    ds = synthetic(200)
    path = tmp_path / "m.stac"
    train(ds, TrainSpec.paper(epochs=1, hidden=8, blocks=1), progress=False).save(path)
    ds_path = ds.save(tmp_path / "d.npz")
    code = (
        "import sys\n"
        "import spectratac.decode\n"
        "from spectratac.dataset import Dataset\n"
        "from spectratac.decode import Decoder\n"
        f"dec = Decoder.load({str(path)!r})\n"
        f"ds = Dataset.load({str(ds_path)!r})\n"
        "est = dec.predict(ds)\n"
        "dec.runtime.run1(ds.inputs[0])\n"
        "from spectratac.device.records import Sample\n"
        "class Replay:\n"
        "    def __iter__(self):\n"
        "        for i in range(5):\n"
        "            c = ds.inputs[i].reshape(3, 4)\n"
        "            counts = tuple(tuple(int(v) for v in (*row, 0)) for row in c)\n"
        "            yield Sample(i, i, float(i), i, 0, 1, counts, (0, 0, 0))\n"
        "    def get_config(self):\n"
        "        return None\n"
        "assert len(list(dec.stream(Replay()))) == 5\n"
        "dec.export('numpy', " + repr(str(tmp_path / "rt.npz")) + ")\n"
        "print(len(est), 'torch' in sys.modules)\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout
    assert out.split() == ["200", "False"]


def test_live_and_snake_apps_do_not_import_torch() -> None:
    code = (
        "import sys\n"
        "from spectratac.cli import build_parser\n"
        "import spectratac.cli.live_cmd, spectratac.cli.snake_cmd\n"
        "import spectratac.apps.live.server, spectratac.apps.live.session\n"
        "import spectratac.apps.snake.play, spectratac.apps.snake.terminal\n"
        "build_parser().parse_args(['live', 'm.stac', 'sim://'])\n"
        "print('torch' in sys.modules)\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout
    assert out.split() == ["False"]


def test_the_model_part_imports_neither_torch_nor_training() -> None:
    code = (
        "import sys\n"
        "import spectratac.decode, spectratac.decode.export\n"
        "from spectratac.decode import Decoder\n"
        "trained = any(m.startswith('spectratac.train') for m in sys.modules)\n"
        "print('torch' in sys.modules, trained)\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout
    assert out.split() == ["False", "False"]
