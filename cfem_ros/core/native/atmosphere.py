# Copyright 2026 the cfem_ros authors
# SPDX-License-Identifier: Apache-2.0
"""
The atmosphere, as the compiled step computes it (``cpp/isa.hpp``).

The U.S. Standard Atmosphere 1976 (the ICAO ISA) to 32 km geopotential, with
a temperature offset for a hot or cold day: the pressure stays ISA, the
density and the speed of sound follow the temperature. This module only
calls the kernel (``kernel.isa``): the formula is written once, in C++.
"""

from __future__ import annotations

#: Reference altitudes a scenario may give, m (the layers of the model, less a margin).
ALTITUDE_RANGE = (-500.0, 20000.0)
#: Where the model is the standard, m geopotential: its three layers to 32 km, and the
#: first continued below sea level to -5 km, as the 1976 tables are. Beyond, the kernel
#: would extend a layer the standard does not have: a body there is refused at t = 0 and
#: told as an ``atmosphere_outside`` event in a run.
STANDARD_RANGE = (-5000.0, 32000.0)
#: Temperature offsets a scenario may give, K (a hot or cold day, not a different planet).
OFFSET_RANGE = (-100.0, 100.0)


def isa(altitude: float, temperature_offset: float = 0.0) -> tuple:
    """
    Return (density kg/m^3, speed of sound m/s) at a geopotential altitude (m).

    ``temperature_offset`` (K) is added to the ISA temperature; the pressure
    stays ISA.
    """
    from cfem_ros.core.native import kernel
    density, sound, _, _ = kernel.isa(float(altitude), float(temperature_offset))
    return density, sound


def isa_state(altitude: float, temperature_offset: float = 0.0) -> tuple:
    """Return (density, speed of sound, temperature K, pressure Pa) at an altitude (m)."""
    from cfem_ros.core.native import kernel
    return kernel.isa(float(altitude), float(temperature_offset))


def isa_density(altitude: float, temperature_offset: float = 0.0) -> float:
    """Return the air density at a geopotential altitude (m), kg/m^3."""
    return isa(altitude, temperature_offset)[0]
