"""Digital twin of the SpectraTac sensor: scenes, surrogate physics, VEML3328 model, oracle.

Pure NumPy (the oracle also uses SciPy); never imports torch. See MODEL.md for the physics
and every constant.

>>> from spectratac.twin import generate_session, builtin_scenes
>>> s = generate_session(builtin_scenes.idle(duration_s=1.0), seed=3)
>>> len(s), s.counts.shape
(20, (20, 3, 5))
"""

from __future__ import annotations

from spectratac.twin import builtin_scenes
from spectratac.twin.electronics import SensorConfig
from spectratac.twin.errors import I2CNack, TwinError
from spectratac.twin.generate import (
    DEFAULT_WHITE_DUTY,
    Session,
    generate_session,
    white_step,
)
from spectratac.twin.geometry import region_centre, region_of
from spectratac.twin.scene_model import ContactState, Environment, Presses, Scene
from spectratac.twin.session import SessionConditions
from spectratac.twin.stack import LayerStack
from spectratac.twin.unit import UnitParams

__all__ = [
    "DEFAULT_WHITE_DUTY",
    "ContactState",
    "Environment",
    "I2CNack",
    "LayerStack",
    "Presses",
    "Scene",
    "SensorConfig",
    "Session",
    "SessionConditions",
    "TwinError",
    "UnitParams",
    "builtin_scenes",
    "generate_session",
    "region_centre",
    "region_of",
    "white_step",
]
