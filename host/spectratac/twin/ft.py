"""Reference six-axis F/T sensor: the wrench the contact applies, plus the sensor's own noise.

The calibration rig mounts the tactile sensor on the F/T sensor, whose sensing origin lies
`ft_origin_z_mm` below the PCB top on the board axis. The contact pushes on the skin at the
indented, sheared surface point r = (x + ux, y + uy, z_surface - delta); the F/T reads the force
the contact applies to the sensor, F = (Fx, Fy, -normal) (z out of the skin, so a press reads
Fz < 0), and the moment M = r x F about its origin, in N and N·m.

>>> import numpy as np
>>> u = UnitParams.nominal()
>>> w = wrench(*(np.array([v]) for v in (0.0, 0.0, 10.0, 5.0, 0.0, 0.0, 0.0, 0.0)), unit=u)
>>> [round(float(v), 3) + 0.0 for v in w[0]]
[0.0, 0.0, -10.0, 0.0, 0.05, 0.0]
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from spectratac.hardware.generated import vocabulary as vocab
from spectratac.twin.unit import UnitParams

F64 = NDArray[np.float64]

AXES = vocab.FT_AXES
_BLOCK = 16384  # rows per block of a long stream (16384 x 6 float64: 768 KiB)


def wrench(
    fx: F64,
    fy: F64,
    normal: F64,
    x: F64,
    y: F64,
    delta: F64,
    ux: F64,
    uy: F64,
    *,
    unit: UnitParams,
    add_to: F64 | None = None,
) -> F64:
    """Noise-free F/T reading (N, 6) for contact loads and deformation at N instants, in the
    F/T's axes: a sensor mounted with a tilt (`unit.mount_tilt_rad`) has its wrench rotated.
    With `add_to` (N, 6) the reading is added to it in place (a noise stream becomes the
    sensor's output without a second stream-sized array) and `add_to` is returned."""
    n = np.shape(fx)[0]
    if add_to is not None and add_to.shape != (n, 6):
        raise ValueError(f"add_to has shape {add_to.shape}, expected {(n, 6)}")
    out = np.empty((n, 6)) if add_to is None else np.empty((min(n, _BLOCK), 6))
    rot = mount_rotation(unit) if np.any(unit.mount_tilt_rad) else None
    surface, origin = unit.stack.surface_z_mm, unit.ft_origin_z_mm
    # In cache-sized row blocks: the columns of a long (n, 6) stream, written one by one
    # over the whole stream, would each sweep all of its memory.
    for a in range(0, n, _BLOCK):
        b = min(a + _BLOCK, n)
        fz = -normal[a:b]
        rx = (x[a:b] + ux[a:b]) * 1e-3
        ry = (y[a:b] + uy[a:b]) * 1e-3
        rz = (surface - delta[a:b] - origin) * 1e-3
        o = out[a:b] if add_to is None else out[: b - a]
        o[:, 0] = fx[a:b]
        o[:, 1] = fy[a:b]
        o[:, 2] = fz
        o[:, 3] = ry * fz - rz * fy[a:b]
        o[:, 4] = rz * fx[a:b] - rx * fz
        o[:, 5] = rx * fy[a:b] - ry * fx[a:b]
        if rot is not None:
            o[:, :3] = o[:, :3] @ rot.T
            o[:, 3:] = o[:, 3:] @ rot.T
        if add_to is not None:
            add_to[a:b] += o
    return out if add_to is None else add_to


def mount_rotation(unit: UnitParams) -> NDArray[np.float64]:
    """Rotation (3, 3) from the sensor's axes to the F/T's: tilt about x, then about y.

    >>> u = UnitParams.nominal()
    >>> bool(np.allclose(mount_rotation(u), np.eye(3)))
    True
    """
    ax, ay = (float(v) for v in unit.mount_tilt_rad)
    cx, sx, cy, sy = np.cos(ax), np.sin(ax), np.cos(ay), np.sin(ay)
    rot_x = np.array([[1.0, 0.0, 0.0], [0.0, cx, -sx], [0.0, sx, cx]])
    rot_y = np.array([[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]])
    return rot_y @ rot_x


def ft_noise(
    n: int, rate_hz: float, unit: UnitParams, rng: np.random.Generator
) -> NDArray[np.float64]:
    """Sensor noise (n, 6): white noise at the stream rate plus a slow Ornstein-Uhlenbeck bias
    (thermal drift of the gauges) that starts from the offset the tare left
    (`unit.ft_bias_offset`, zero for a unit that has not been re-mounted)."""
    # White noise drawn block by block straight into the output (the generator's stream is
    # the same as one draw of all n rows), then the bias on top.
    out = np.empty((n, 6))
    scale = unit.ft_noise.astype(np.float32)
    for r0 in range(0, n, _BLOCK):
        white = rng.standard_normal((min(_BLOCK, n - r0), 6), dtype=np.float32)
        white *= scale
        out[r0 : r0 + white.shape[0]] = white
    seconds = int(np.ceil(n / rate_hz)) + 2
    a = np.exp(-1.0 / unit.ft_bias_tau_s)
    steps = rng.standard_normal((seconds, 6)) * unit.ft_bias_std * np.sqrt(1.0 - a * a)
    bias = np.zeros((seconds, 6))
    for i in range(1, seconds):
        bias[i] = a * bias[i - 1] + steps[i]
    # Each second's bias added to its rows (a broadcast, not a gather of n rows), a block of
    # whole seconds at a time.
    offset = bias + unit.ft_bias_offset
    per = max(int(rate_hz), 1)
    secs = max(1, _BLOCK // per)
    for s0 in range(0, -(-n // per), secs):
        a, b = s0 * per, min((s0 + secs) * per, n)
        block = out[a:b]
        whole = (b - a) // per
        block[: whole * per].reshape(whole, per, 6)[...] += offset[s0 : s0 + whole, None, :]
        block[whole * per :] += offset[s0 + whole]
    return out
