"""Physical constants and literature defaults in otgym units (um, s, pN, K).

Conversions: 1 J = 1e18 pN*um, and 1 Pa*s = 1 pN*s/um^2, so viscosities in Pa*s
can be used unchanged.
"""

BOLTZMANN_PN_UM_PER_K = 1.380649e-5
"""Boltzmann constant k_B = 1.380649e-23 J/K expressed in pN*um/K."""

ROOM_TEMPERATURE_K = 298.15
WATER_VISCOSITY_PA_S = 8.9e-4
"""Dynamic viscosity of water at 25 C (CRC Handbook), equal to pN*s/um^2."""


def thermal_energy_pn_um(temperature_k: float) -> float:
    """kT in pN*um (4.11e-3 at 298.15 K)."""
    return BOLTZMANN_PN_UM_PER_K * temperature_k
