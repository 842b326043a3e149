"""Which sessions began on a re-mounted skin: a step in the light at rest from one session to
the next, channel against channel.

A re-mounting moves each photodiode's gain and ambient light a little, each its own way; the
skin's ageing and the LEDs' dimming and warm-up move every channel together. So per session:
each channel's light at rest in log counts (`rest_light`), less its mean over the channels
(what they share); a step between consecutive sessions (in time order) larger than
STEP_FACTOR times the median step, and than MIN_STEP, is a re-mounting. The forward check
counts the re-mountings its folds' models did not see, and how often the history re-mounts,
to say what the next sessions may cost (`train/check.py` `remount_figure`).

>>> from spectratac.sim.ageing_skin import ageing_skin
>>> ds = ageing_skin(sessions=16, session_s=4.0, seed=2)
>>> truth = [m["session_index"] for m in ds.meta["sessions"] if m["remounted"]]
>>> remounted_sessions(ds, list(range(16))) == truth, truth
(True, [2, 9])
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from spectratac.dataset.schema import Dataset

STEP_FACTOR = 3.5  # a re-mounting's step against the median session-to-session step
MIN_STEP = 0.006  # ... and at least this (log counts: 0.6 %): the LEDs' warm-up lifts
# channels of different ambient share by up to a few tenths of a percent
MIN_SESSIONS = 4  # sessions needed for a median step to judge against
CONTACT_N = 0.3  # reference force (N) taken as contact where a dataset has no contact labels
REST_QUANTILE = 98.0  # the light furthest from any press (module docstring of `rest_light`)


def rest_light(inputs: NDArray[np.float64], contact: NDArray[np.bool_]) -> NDArray[np.float64]:
    """Each channel's light at rest, in log counts, from one session's rows: among the rows
    out of contact, the REST_QUANTILE-th percentile in a channel a press dims and the
    (100 - REST_QUANTILE)-th in one it brightens, the light furthest from any press (the
    elastomer's creep carries a press on after contact ends, which a median of the idle rows
    would average in). NaN per channel without idle rows.

    >>> x = np.array([[100.0, 10.0], [101.0, 10.0], [60.0, 20.0], [99.0, 11.0]])
    >>> np.exp(rest_light(x, np.array([False, False, True, False]))).round(1).tolist()
    [101.0, 10.0]
    """
    x = np.log(np.maximum(np.asarray(inputs, np.float64), 1.0))
    idle, pressed = x[~contact], x[contact]
    if idle.shape[0] == 0:
        return np.full(x.shape[1], np.nan)
    brightens = (
        np.median(pressed, axis=0) > np.median(idle, axis=0)
        if pressed.shape[0]
        else np.zeros(x.shape[1], bool)
    )
    high = np.percentile(idle, REST_QUANTILE, axis=0)
    low = np.percentile(idle, 100.0 - REST_QUANTILE, axis=0)
    return np.where(brightens, low, high)


def contact_rows(dataset: Dataset) -> NDArray[np.bool_]:
    """Rows where something touches the skin: the dataset's contact labels, or where it has
    none, a reference force beyond CONTACT_N."""
    contact = np.asarray(dataset.in_contact, bool).copy()
    names = [i for i, t in enumerate(dataset.target_names) if t.startswith("F")]
    if names:
        f = np.abs(np.asarray(dataset.targets, np.float64).reshape(dataset.n, -1)[:, names])
        valid = np.asarray(dataset.target_valid, bool)
        contact |= valid & (np.nan_to_num(f, nan=0.0).max(axis=1) > CONTACT_N)
    return contact


def session_rest(dataset: Dataset, order: Sequence[int]) -> NDArray[np.float64]:
    """(sessions, channels x LED steps): `rest_light` of each session of `order`, each LED
    step's rows apart (a step lights the skin its own way)."""
    x = np.asarray(dataset.inputs, np.float64)
    ses = np.asarray(dataset.session, np.int64)
    step = np.asarray(dataset.step, np.int64)
    contact = contact_rows(dataset)
    steps = np.unique(step)
    out = []
    for s in order:
        mine = ses == s
        out.append(np.concatenate(
            [rest_light(x[mine & (step == k)], contact[mine & (step == k)]) for k in steps]
        ))  # fmt: skip
    return np.stack(out)


def remounted_sessions(dataset: Dataset, order: Sequence[int]) -> list[int]:
    """The session ids of `order` (ids in time order) that began on a re-mounted skin: a
    channel-against-channel step in `rest_light` from the session before (module
    docstring). Empty with fewer than MIN_SESSIONS sessions or a single channel."""
    if len(order) < MIN_SESSIONS or np.asarray(dataset.inputs).shape[1] < 2:
        return []
    rest = session_rest(dataset, order)
    rest = rest - rest.mean(axis=1, keepdims=True)  # what every channel shares is not a step
    step = np.diff(rest, axis=0)
    ok = np.isfinite(step).all(axis=1)
    if ok.sum() < MIN_SESSIONS - 1:
        return []
    size = np.full(step.shape[0], np.nan)
    size[ok] = np.linalg.norm(step[ok] - np.median(step[ok], axis=0), axis=1)
    limit = max(STEP_FACTOR * float(np.median(size[ok])), MIN_STEP)
    return [int(order[j + 1]) for j in np.flatnonzero(ok & (size > limit))]
