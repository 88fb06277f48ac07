"""Elastic constants of a contact: ONE convention for the whole package.

Every contact formula in guide_health is written with the contact (effective, composite, plane-strain)
modulus of Johnson, *Contact Mechanics* (1985), Eq. 4.22:

    1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2        (two equal steels: E* = E / (2 (1 - nu^2)))

e.g. 113.2 GPa for E = 206 GPa, nu = 0.3 (seed 001) and 115.4 GPa for E = 210 GPa, nu = 0.3 (seed 003, its
Eq. 3). Formulas published with Hamrock's reduced modulus E' = 2 / ((1 - nu1^2)/E1 + (1 - nu2^2)/E2) = 2 E*
(the Hamrock-Dowson film fits, the Greenwood-Tripp asperity pressure) are written here with ``2 E*``
explicitly; there is no function returning E', so the factor of 2 cannot be lost between two call sites.
"""
from __future__ import annotations


def effective_modulus_pa(youngs_modulus_pa: float, poisson: float,
                         youngs_modulus_2_pa: float | None = None, poisson_2: float | None = None) -> float:
    """Contact modulus E* [Pa]: 1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2.

    Body 2 defaults to the same material as body 1 (two equal steels: E* = E / (2 (1 - nu^2))).
    Johnson, *Contact Mechanics* (1985), Eq. 4.22; seed 003 Eq. 3. Hamrock's E' is 2 E*.
    """
    e2 = youngs_modulus_pa if youngs_modulus_2_pa is None else youngs_modulus_2_pa
    n2 = poisson if poisson_2 is None else poisson_2
    if youngs_modulus_pa <= 0 or e2 <= 0:
        raise ValueError("Young's moduli must be positive")
    return 1.0 / ((1.0 - poisson ** 2) / youngs_modulus_pa + (1.0 - n2 ** 2) / e2)
