"""The layer stack (PCB, PDMS light guide, black skin) and how its thicknesses set the model.

The nominal thicknesses are the built board's (hardware/definitions/params.toml through the
generated `spectratac.hardware.generated.board`): 1.0 mm FR-4, 2.5 mm PDMS, 0.5 mm skin top. Every
thickness-dependent constant of the forward model is computed here from a `LayerStack`, so a
unit drawn with a thicker PDMS layer or a thinner skin really behaves differently:

- elastomer (PDMS + skin, h): a bonded thin layer on a rigid board is stiffer than a half
  space. Dimitriadis et al. (Biophys. J. 2002) give the force correction for a sphere on a
  bonded incompressible layer, 1 + 1.133 x + 1.283 x^2 + 0.769 x^3 + 0.0975 x^4 with
  x = a / h; evaluated at the reference contact (a = 1.3 mm: 1 N on a 4 mm tip) it multiplies
  the material moduli (normal and tangential). The indentation and shear ceilings are half
  of h (the layer cannot compress or shear further than about half its height).
- PDMS (p): the skin/PDMS interface sits p above the PCB; the reflecting patch is seen from the
  sensor apertures (the sensor body is 1.0 mm tall) through p - 1.0 mm of PDMS plus 0.6 mm of
  diffusion (`optical_height_mm`). Guided light spreads over the slab's thickness, so the
  direct transport scales as 1/p; light loses a fraction at each bounce off the pigmented skin
  and bounces ~1/p times per mm, so the in-slab decay length scales as p; a skin dip of depth
  delta blocks delta/p of the guide, so the shadow per mm of indentation scales as 1/p.
- skin (s): ambient light leaks through the black skin by Beer-Lambert absorption with an
  absorption length of 0.08 mm (2e-3 transmission at the nominal 0.5 mm).
- PCB (b): the F/T adapter plate is fixed, so the F/T origin sits b + 8.2 mm below the PCB top.

>>> s = LayerStack.board()
>>> s.pcb_mm, s.pdms_mm, s.skin_mm, s.elastomer_mm
(1.0, 2.5, 0.5, 3.0)
>>> thicker = LayerStack(1.0, 2.8, 0.5)
>>> bool(modulus_factor(thicker) < 1.0 < modulus_factor(LayerStack(1.0, 2.2, 0.5)))
True
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from spectratac.hardware.generated import board
from spectratac.twin.errors import TwinError

# Reference contact for the thin-layer correction: 1 N on a 4 mm tip gives a ~ 1.3 mm.
REFERENCE_CONTACT_RADIUS_MM = 1.3
SENSOR_BODY_HEIGHT_MM = board.PARTS_SENSOR_BODY[2]
OPTICAL_DIFFUSION_MM = 0.6  # added to the PDMS above the apertures (light spreads on its way)
SKIN_ABSORPTION_LENGTH_MM = 0.08  # black-pigmented Ecoflex, Beer-Lambert (assumed)
FT_ADAPTER_MM = 8.2  # adapter plate from the PCB underside to the F/T sensing origin (assumed)


def _bonded_layer_correction(a_over_h: float) -> float:
    """Dimitriadis et al. (2002) force correction, bonded incompressible layer."""
    x = a_over_h
    return 1.0 + 1.133 * x + 1.283 * x**2 + 0.769 * x**3 + 0.0975 * x**4


@dataclass(frozen=True)
class LayerStack:
    """Layer thicknesses in mm: PCB, PDMS light guide, black skin top."""

    pcb_mm: float
    pdms_mm: float
    skin_mm: float

    def __post_init__(self) -> None:
        for name in ("pcb_mm", "pdms_mm", "skin_mm"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise TwinError(f"layer thickness {name} must be a finite value > 0, got {v!r}")
        if self.pdms_mm <= SENSOR_BODY_HEIGHT_MM:
            raise TwinError(
                f"PDMS layer ({self.pdms_mm} mm) must be thicker than the sensor body "
                f"({SENSOR_BODY_HEIGHT_MM} mm) it covers"
            )

    @staticmethod
    def board() -> LayerStack:
        """The built stack, from hardware/definitions/params.toml."""
        return LayerStack(board.BOARD_THICKNESS, board.STACK_PDMS, board.STACK_SKIN_TOP)

    @property
    def elastomer_mm(self) -> float:
        """PDMS plus skin: the layer a press compresses."""
        return self.pdms_mm + self.skin_mm

    @property
    def surface_z_mm(self) -> float:
        """The skin surface above the PCB top."""
        return self.pdms_mm + self.skin_mm


NOMINAL = LayerStack.board()


def modulus_factor(stack: LayerStack) -> float:
    """Effective stiffening of the bonded elastomer relative to the nominal stack."""
    a = REFERENCE_CONTACT_RADIUS_MM
    return _bonded_layer_correction(a / stack.elastomer_mm) / _bonded_layer_correction(
        a / NOMINAL.elastomer_mm
    )


def max_indent_mm(stack: LayerStack) -> float:
    return 0.5 * stack.elastomer_mm


def max_shear_mm(stack: LayerStack) -> float:
    return 0.5 * stack.elastomer_mm


def optical_height_mm(stack: LayerStack) -> float:
    return stack.pdms_mm - SENSOR_BODY_HEIGHT_MM + OPTICAL_DIFFUSION_MM


def guide_spread_factor(stack: LayerStack) -> float:
    """Direct transport relative to nominal: guided light spreads over the slab thickness."""
    return NOMINAL.pdms_mm / stack.pdms_mm


def decay_length_factor(stack: LayerStack) -> float:
    """In-slab decay length relative to nominal: fewer skin bounces per mm in a thicker slab."""
    return stack.pdms_mm / NOMINAL.pdms_mm


def shadow_factor(stack: LayerStack) -> float:
    """Shadow per mm of indentation relative to nominal: a dip blocks delta / p of the guide."""
    return NOMINAL.pdms_mm / stack.pdms_mm


def skin_transmission_factor(stack: LayerStack) -> float:
    """Ambient leakage through the skin relative to nominal (Beer-Lambert)."""
    return float(np.exp(-(stack.skin_mm - NOMINAL.skin_mm) / SKIN_ABSORPTION_LENGTH_MM))


def ft_origin_z_mm(stack: LayerStack) -> float:
    """F/T sensing origin relative to the PCB top (negative: below it)."""
    return -(stack.pcb_mm + FT_ADAPTER_MM)
