"""Liquid catalogue: density and kinematic viscosity, with temperature dependence.

Sources and choices
-------------------
- Water, olive oil (~64 cSt, log10 1.81), corn oil (~52 cSt, log10 1.72),
  mirin (~22 cSt, log10 1.34) and dish detergent (~440 cSt) are the paper's
  measured viscosities (Huang et al., RSS 2022), taken here as values at the
  reference temperature of 20 °C.
- Sugar water: the paper's concentration ``c`` is grams of sugar per 100 g of
  water, so the mass fraction is ``w = 100 c / (100 + c)`` [%]. Kinematic
  viscosity and density of sucrose solutions at 20 °C follow the CRC handbook
  table (``ln ν`` and density interpolated linearly in ``w``); c = 160 gives
  ~59 cSt (the paper measured 62.6 cSt).
- Temperature: ``ν(T) = ν(20 °C)·exp(s·(T − 20))``. The slope ``s`` is −2.4 %/°C
  for water, rising linearly in ``w`` to −5 %/°C at 60 % sucrose; oils about
  −4.2 %/°C (olive oil: 84 mPa·s at 20 °C, 36 at 40 °C), mirin and detergent
  are choices (−4 and −3 %/°C). Density is taken temperature-independent
  (< 0.1 %/°C, irrelevant here).
- Detergent is shear-thinning: a Cross model
  ``ν(γ̇) = ν∞ + (ν0 − ν∞) / (1 + (γ̇/γ̇c)^m)`` with ν0 the catalogue value,
  ν∞ = ν0/3, γ̇c = 20 1/s, m = 0.6 (a choice typical of surfactant solutions).
  Labels report the zero-shear viscosity.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from liquidtouch.errors import CatalogueError

REFERENCE_TEMPERATURE_C = 20.0

# CRC handbook, aqueous sucrose at 20 °C: mass fraction w [%] -> kinematic viscosity [cSt]
_SUCROSE_W = np.array([0.0, 10.0, 20.0, 30.0, 40.0, 50.0, 56.0, 60.0, 62.0])
_SUCROSE_NU_CST = np.array([1.00, 1.29, 1.80, 2.83, 5.24, 12.6, 25.4, 45.5, 63.5])
# density [kg/m³] of the same solutions (CRC, 20 °C)
_SUCROSE_RHO_W = np.array([0.0, 10.0, 20.0, 30.0, 40.0, 50.0, 60.0, 62.0])
_SUCROSE_RHO = np.array([998.2, 1038.1, 1081.0, 1127.0, 1176.4, 1229.6, 1286.5, 1298.2])
MAX_SUGAR_CONCENTRATION = 100.0 * 62.0 / 38.0  # w = 62 %, the end of the table (c ≈ 163)


@dataclass(frozen=True)
class LiquidSpec:
    """A catalogue entry (properties at the reference temperature, 20 °C)."""

    name: str
    density_kg_m3: float
    viscosity_cst: float
    temperature_slope_per_c: float
    shear_thinning: bool = False
    note: str = ""


@dataclass(frozen=True)
class LiquidProperties:
    """A liquid at a given temperature (and sugar concentration, for sugar water).

    ``viscosity_cst`` is the zero-shear kinematic viscosity [cSt = mm²/s].
    """

    name: str
    density_kg_m3: float
    viscosity_cst: float
    temperature_c: float
    sugar_concentration: float | None = None
    shear_thinning: bool = False

    @property
    def log10_viscosity_cst(self) -> float:
        """μ = log10 of the kinematic viscosity [log10 cSt] (the paper's target)."""
        return math.log10(self.viscosity_cst)

    @property
    def viscosity_m2_s(self) -> float:
        """Kinematic viscosity [m²/s]."""
        return self.viscosity_cst * 1e-6

    def effective_viscosity_m2_s(self, shear_rate_1_s: float | np.ndarray) -> float | np.ndarray:
        """Kinematic viscosity [m²/s] at the shear rate ``shear_rate_1_s`` [1/s].

        The zero-shear value if Newtonian; for a shear-thinning liquid the Cross
        model ``ν∞ + (ν0 − ν∞) / (1 + (|γ̇|/γ̇c)^m)`` with ``ν∞ = ν0/3``,
        ``γ̇c = 20 1/s``, ``m = 0.6`` (module docstring). Works on floats and arrays.
        """
        nu0 = self.viscosity_m2_s
        if not self.shear_thinning:
            return nu0
        # ν∞ = ν0/3 and ν0 − ν∞ = 2ν0/3
        return nu0 / 3.0 + (2.0 * nu0 / 3.0) / (1.0 + (abs(shear_rate_1_s) / 20.0) ** 0.6)


LIQUIDS: dict[str, LiquidSpec] = {
    "water": LiquidSpec("water", 998.2, 1.00, -0.024, note="CRC"),
    "olive-oil": LiquidSpec("olive-oil", 911.0, 64.0, -0.042, note="paper, ~64 cSt"),
    "corn-oil": LiquidSpec("corn-oil", 919.0, 52.0, -0.042, note="paper, ~52 cSt"),
    "mirin": LiquidSpec("mirin", 1160.0, 22.0, -0.040, note="paper, ~22 cSt; density a choice"),
    "detergent": LiquidSpec(
        "detergent", 1030.0, 440.0, -0.030, shear_thinning=True, note="paper, ~440 cSt"
    ),
    "sugar-water": LiquidSpec("sugar-water", 998.2, 1.00, -0.024, note="CRC sucrose table"),
}


def sugar_mass_fraction(sugar_concentration: float) -> float:
    """Mass fraction w [%] of sugar for ``c`` grams of sugar per 100 g of water."""
    return 100.0 * sugar_concentration / (100.0 + sugar_concentration)


def _sucrose_at_20c(w_percent: float) -> tuple[float, float]:
    nu = float(np.exp(np.interp(w_percent, _SUCROSE_W, np.log(_SUCROSE_NU_CST))))
    rho = float(np.interp(w_percent, _SUCROSE_RHO_W, _SUCROSE_RHO))
    return rho, nu


def get_liquid(
    name: str,
    *,
    sugar_concentration: float | None = None,
    temperature_c: float = REFERENCE_TEMPERATURE_C,
) -> LiquidProperties:
    """The properties of liquid ``name`` at ``temperature_c`` [°C].

    ``sugar_concentration`` (g sugar per 100 g water) is required for
    ``sugar-water`` and not allowed otherwise; ``water`` is sugar water at c = 0.
    Raises :class:`CatalogueError` for unknown names or out-of-range values.
    """
    spec = LIQUIDS.get(name)
    if spec is None:
        raise CatalogueError(f"unknown liquid {name!r}; known liquids: {', '.join(LIQUIDS)}")
    if not (math.isfinite(temperature_c) and 0.0 <= temperature_c <= 60.0):
        raise CatalogueError(
            f"temperature {temperature_c} °C is outside the catalogue's 0-60 °C range"
        )
    dt = temperature_c - REFERENCE_TEMPERATURE_C
    if name == "sugar-water":
        c = sugar_concentration
        if c is None:
            raise CatalogueError(
                "sugar-water needs a sugar concentration (g sugar per 100 g water), "
                f"between 0 and {MAX_SUGAR_CONCENTRATION:.0f}"
            )
        if not (math.isfinite(c) and 0.0 <= c <= MAX_SUGAR_CONCENTRATION + 1e-9):
            raise CatalogueError(
                f"sugar concentration {c} is outside 0-{MAX_SUGAR_CONCENTRATION:.0f} "
                "g per 100 g water (the end of the sucrose viscosity table)"
            )
        w = sugar_mass_fraction(c)
        rho, nu20 = _sucrose_at_20c(w)
        slope = -0.024 + (-0.050 + 0.024) * min(w, 62.0) / 60.0
        return LiquidProperties(
            name, rho, nu20 * math.exp(slope * dt), temperature_c, sugar_concentration=float(c)
        )
    if sugar_concentration is not None and not (name == "water" and sugar_concentration == 0):
        raise CatalogueError(f"a sugar concentration only applies to sugar-water, not to {name!r}")
    return LiquidProperties(
        name,
        spec.density_kg_m3,
        spec.viscosity_cst * math.exp(spec.temperature_slope_per_c * dt),
        temperature_c,
        sugar_concentration=0.0 if name == "water" else None,
        shear_thinning=spec.shear_thinning,
    )
