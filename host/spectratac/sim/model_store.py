"""Where a simulated device keeps its model store (the flash holding an uploaded decoder).

The native library mirrors the store to a file (stac_sim_model_store), so an uploaded model
survives what survives on hardware: closing and re-opening the device, which boots the firmware
again. A sim URL names the file with ``model_store=PATH``; without it every seed gets its own
file in a temporary folder of this process, removed when the process ends, so re-opening
``sim://?seed=3`` finds seed 3's model while other processes and seeds start empty.

>>> path = default_store_path(3)
>>> path == default_store_path(3) != default_store_path(4)
True
>>> path.name
'seed3.flash'
"""

from __future__ import annotations

import atexit
import shutil
import tempfile
import threading
from pathlib import Path

from spectratac.errors import SpectraTacError

_lock = threading.Lock()
_folder: Path | None = None


class ModelStoreError(SpectraTacError):
    """The model store file of a simulated device cannot be used."""


def default_store_path(seed: int) -> Path:
    """This process's model store file for the device of `seed` (the folder is made once)."""
    global _folder
    with _lock:
        if _folder is None:
            _folder = Path(tempfile.mkdtemp(prefix="spectratac-sim-store-"))
            atexit.register(shutil.rmtree, _folder, True)
        return _folder / f"seed{seed}.flash"


def store_path(model_store: str | None, seed: int) -> Path:
    """The model store file of a sim URL's device: its ``model_store``, else the default.

    >>> store_path("/tmp/a.flash", 1).name, store_path(None, 1) == default_store_path(1)
    ('a.flash', True)
    """
    return Path(model_store) if model_store else default_store_path(seed)
