"""Oil viscosity against temperature from two catalogue viscosities: Walther's equation (ASTM D341).

ASTM D341 / Walther: log10 log10(nu + 0.7) = A - B log10 T, nu the kinematic viscosity [mm^2/s = cSt], T the
absolute temperature [K]; A and B from two points (the catalogue's 40 and 100 degC viscosities). The D341 extra
terms for nu < 2 cSt are left out (guide oils are far above). Dynamic viscosity eta = nu rho(T), with the
density falling linearly with temperature, rho(T) = rho_15 (1 - beta (T - 15 degC)), beta = 6.4e-4 1/K (the
usual mineral-oil value; a 6 K error in T moves rho by 0.4 %, eta by ~25 %: only the viscosity matters).

Seed 000 (Table 1) gives its 68# guide oil as 65.4 / 8.83 cSt at 40 / 100 degC. Walther then
gives 186.1 cSt at 21 degC, and with rho_15 = 880 kg/m^3 (876.6 at 21 degC) eta = 0.1631 Pa s: the viscosity
with which Hamrock-Dowson puts lambda = 1 at 0.5 m/s on the seed 001 LH45 contact, as seed 001's Fig. 9 does
(docs/physics.md). At 40 degC the same oil is 65.4 cSt, eta = 0.0566 Pa s.

Pure physics: SI at the boundary except the catalogue inputs named in mm^2/s and degC.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

WALTHER_OFFSET_MM2_S = 0.7          # ASTM D341: log log (nu + 0.7)
DENSITY_EXPANSION_PER_K = 6.4e-4    # mineral oil, linear density fall with temperature
DENSITY_REFERENCE_C = 15.0
KELVIN_OFFSET = 273.15


@dataclass(frozen=True)
class WaltherOil:
    """An oil given by two catalogue kinematic viscosities (ASTM D341 line through them) and its density."""

    nu_40c_mm2_s: float
    nu_100c_mm2_s: float
    density_15c_kg_m3: float
    walther_a: float = math.nan
    walther_b: float = math.nan

    @classmethod
    def from_catalogue(cls, nu_40c_mm2_s: float, nu_100c_mm2_s: float, density_15c_kg_m3: float,
                       t1_c: float = 40.0, t2_c: float = 100.0) -> WaltherOil:
        """The D341 line through (t1, nu_40) and (t2, nu_100); ValueError unless nu_40 > nu_100 > 0."""
        for name, value in (("nu_40c_mm2_s", nu_40c_mm2_s), ("nu_100c_mm2_s", nu_100c_mm2_s),
                            ("density_15c_kg_m3", density_15c_kg_m3)):
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"oil {name} must be a finite number > 0, got {value!r}")
        if not nu_40c_mm2_s > nu_100c_mm2_s:
            raise ValueError(f"oil viscosity at 40 degC ({nu_40c_mm2_s}) must exceed that at 100 degC "
                             f"({nu_100c_mm2_s})")
        y1 = math.log10(math.log10(nu_40c_mm2_s + WALTHER_OFFSET_MM2_S))
        y2 = math.log10(math.log10(nu_100c_mm2_s + WALTHER_OFFSET_MM2_S))
        x1, x2 = math.log10(t1_c + KELVIN_OFFSET), math.log10(t2_c + KELVIN_OFFSET)
        b = (y1 - y2) / (x2 - x1)
        return cls(nu_40c_mm2_s, nu_100c_mm2_s, density_15c_kg_m3, y1 + b * x1, b)

    def kinematic_viscosity_mm2_s(self, temperature_c: float) -> float:
        """nu(T) [mm^2/s]: ASTM D341, nu = 10^(10^(A - B log10 T)) - 0.7."""
        t_k = temperature_c + KELVIN_OFFSET
        if not (math.isfinite(t_k) and t_k > 0):
            raise ValueError(f"oil temperature must be finite and above absolute zero, got {temperature_c!r}")
        return 10.0 ** (10.0 ** (self.walther_a - self.walther_b * math.log10(t_k))) - WALTHER_OFFSET_MM2_S

    def density_kg_m3(self, temperature_c: float) -> float:
        """rho(T) = rho_15 (1 - 6.4e-4 (T - 15))."""
        return self.density_15c_kg_m3 * (1.0 - DENSITY_EXPANSION_PER_K * (temperature_c - DENSITY_REFERENCE_C))

    def dynamic_viscosity_pa_s(self, temperature_c: float) -> float:
        """eta(T) = nu(T) rho(T) [Pa s]."""
        return self.kinematic_viscosity_mm2_s(temperature_c) * 1e-6 * self.density_kg_m3(temperature_c)


def catalogue_oil(nu_40c_mm2_s: float, nu_100c_mm2_s: float, density_15c_kg_m3: float) -> WaltherOil | None:
    """The Walther oil of the catalogue viscosities (the wear_monitor parameters ``oil_viscosity_40c_mm2_s``,
    ``oil_viscosity_100c_mm2_s``, ``oil_density_15c_kg_m3``), None when the 40 degC value is 0 (a constant
    ``oil_viscosity_pa_s`` at every temperature)."""
    nu40 = float(nu_40c_mm2_s or 0.0)
    if nu40 == 0.0:
        return None
    return WaltherOil.from_catalogue(nu40, float(nu_100c_mm2_s), float(density_15c_kg_m3))
