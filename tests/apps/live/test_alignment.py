"""The live page's clock alignment: a background refit lands the same model a synchronous one
does, and the decoding thread keeps mapping times (offset first, the fit once it lands)."""

from __future__ import annotations

import numpy as np
from spectratac.apps.live.alignment import LiveClock


def _pairs(seconds: float, rate: float = 200.0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(3)
    device = np.arange(0.0, seconds, 1.0 / rate)
    host = 50.0 + device * (1 + 2e-4) + rng.exponential(0.003, device.size)  # latencies >= 0
    return device, host


def test_background_refit_lands_the_synchronous_model() -> None:
    device, host = _pairs(6.0)
    sync, background = LiveClock(1.0), LiveClock(1.0, background=True)
    for lo in range(0, device.size, 50):  # in batches, as rows arrive
        sync.add(device[lo : lo + 50], host[lo : lo + 50])
        background.add(device[lo : lo + 50], host[lo : lo + 50])
        background.wait()
    probe = np.array([0.0, 3.0, 6.0])
    assert np.allclose(background.to_host(probe), sync.to_host(probe), atol=1e-9)
    # the fit follows the drift: 2e-4 over 6 s is 1.2 ms, far more than the tolerance
    assert np.allclose(sync.to_host(probe), 50.0 + probe * (1 + 2e-4), atol=5e-4)


def test_times_map_while_a_background_fit_is_running() -> None:
    device, host = _pairs(3.0)
    clock = LiveClock(1.0, background=True)
    clock.add(device, host)  # starts a fit; to_host answers at once all the same
    assert np.all(np.isfinite(clock.to_host(device[:5])))
    clock.wait()
    assert abs(float(clock.to_host(1.5)) - (50.0 + 1.5 * (1 + 2e-4))) < 5e-4
