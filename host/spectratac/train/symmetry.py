"""Training data from the sensor's symmetry: three-fold rotation and mirror (the group D3).

Sensor k sits at 120°·k and LED j at 60° + 120°·j (twin/geometry.py), so a press rotated by
120° about the centre reads, on sensor k + 1, what the original read on sensor k; a press
mirrored in the x axis swaps sensors 1 and 2. Forces rotate or mirror as vectors, torques
about the F/T origin (on the z axis) as pseudovectors: the mirror y -> -y maps
(Tx, Ty, Tz) to (-Tx, Ty, -Tz). So every calibration press also teaches the decoder five
presses it never saw, at other places of the same skin: this is what the blocked split asks
for (the decoder's error there is dominated by presses unlike the training ones).

Region labels follow the keypad numbering: the mirror maps them exactly (1<->7, 2<->8, 3<->9);
a 120° rotation does not map the eight 45° sectors onto each other, so rotated rows keep
only the centre's label 5 and are otherwise unlabelled (-1: left out of the class loss).

Only for SpectraTac inputs under an LED sequence whose every step drives the three LEDs
alike (otherwise a rotation would also change which LED each step lights). Unit-to-unit
variation (placement, binning) breaks the symmetry by a few %; the transformed rows are
training data only.

>>> ft = vocab.FT_AXES
>>> y = np.array([[1.0, 0.0, -2.0, 0.0, 1.0, 0.5]])
>>> rotate_targets(y, ft, turns=1, mirror=False).round(3).tolist()
[[-0.5, 0.866, -2.0, -0.866, -0.5, 0.5]]
>>> [int(v) for v in transform_labels(np.array([1, 5, 6, -1]), turns=0, mirror=True)]
[7, 5, 6, -1]
>>> sensor_permutation(turns=1, mirror=False), sensor_permutation(turns=0, mirror=True)
([2, 0, 1], [0, 2, 1])
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from spectratac.decode.errors import DecoderConfigError
from spectratac.hardware.generated import vocabulary as vocab
from spectratac.train.spec import AUGMENTS

F64 = NDArray[np.float64]
N_SENSORS = vocab.N_SENSORS
CHANNELS_PER_SENSOR = len(vocab.DECODED_CHANNELS)
# (force or torque x, y) pairs and the sign of the z component under the mirror
# (other targets are taken as invariant scalars)
VECTORS = ((*vocab.FORCE_AXES, 1.0), (*vocab.TORQUE_AXES, -1.0))


def transforms(augment: str) -> list[tuple[int, bool]]:
    """The (turns of 120°, mirrored) pairs besides the identity that `augment` adds."""
    if augment not in AUGMENTS:
        raise DecoderConfigError(f"augment={augment!r}: choose one of {', '.join(AUGMENTS)}")
    if augment == "none":
        return []
    mirrors = (False, True) if augment == "rotate+mirror" else (False,)
    return [(t, m) for m in mirrors for t in range(N_SENSORS) if (t, m) != (0, False)]


def sensor_permutation(turns: int, mirror: bool) -> list[int]:
    """perm[k]: the original sensor whose reading the transformed sensor k gets."""
    n = N_SENSORS
    src = [(-k) % n if mirror else k for k in range(n)]  # mirror first: k -> -k
    return [src[(k - turns) % n] for k in range(n)]


def check_symmetric(input_names: Sequence[str], config: dict[str, Any] | None) -> None:
    """DecoderConfigError unless the data has SpectraTac inputs and a symmetric sequence."""
    if tuple(input_names) != vocab.DECODED_INPUTS:
        raise DecoderConfigError(
            "symmetry augmentation needs the 12 SpectraTac inputs (sensor order sets the "
            f"geometry); this data has {', '.join(input_names)}: use augment='none'"
        )
    for i, step in enumerate((config or {}).get("leds") or []):
        if any(list(led) != list(step[0]) for led in step):
            raise DecoderConfigError(
                f"LED step {i} drives the three LEDs differently ({step}): a rotated press "
                "would need another sequence; use augment='none' for this configuration"
            )


def permute_assembled(u: F64, turns: int, mirror: bool) -> F64:
    """Assembled vectors (N, D) with every 12-count group's sensors permuted."""
    perm = sensor_permutation(turns, mirror)
    n, d = u.shape
    g = u.reshape(n, d // (N_SENSORS * CHANNELS_PER_SENSOR), N_SENSORS, CHANNELS_PER_SENSOR)
    return g[:, :, perm, :].reshape(n, d)


def rotate_targets(y: F64, names: Sequence[str], turns: int, mirror: bool) -> F64:
    """Targets (N, T) named `names` as the transformed press would have them."""
    out = np.array(y, dtype=np.float64, copy=True)
    col = {n: i for i, n in enumerate(names)}
    a = 2.0 * np.pi * turns / N_SENSORS
    c, s = np.cos(a), np.sin(a)
    for nx, ny, nz, z_sign in VECTORS:
        if nx in col and ny in col:
            vx, vy = out[:, col[nx]], out[:, col[ny]]
            if mirror:  # y -> -y; a pseudovector's x and z flip instead
                vx, vy = (-vx, vy) if z_sign < 0 else (vx, -vy)
            out[:, col[nx]], out[:, col[ny]] = c * vx - s * vy, s * vx + c * vy
        if mirror and z_sign < 0 and nz in col:
            out[:, col[nz]] = -out[:, col[nz]]
    return out


def transform_labels(region: NDArray[Any], turns: int, mirror: bool) -> NDArray[np.int64]:
    """Keypad region labels of the transformed press (-1 where no region maps)."""
    r = np.asarray(region, dtype=np.int64)
    none = vocab.NO_REGION
    out = np.array([vocab.MIRROR_REGION.get(int(v), none) for v in r]) if mirror else r.copy()
    if turns % N_SENSORS:
        out = np.array([vocab.TURN_REGION.get(int(v), none) for v in out], dtype=np.int64)
    return np.where(r > 0, out, r)
