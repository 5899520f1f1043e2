// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// The atmosphere of the aerodynamic loads, in one place: the U.S. Standard
// Atmosphere 1976 (the ICAO ISA) to 32 km geopotential, with a temperature
// offset (a hot or cold day). Python reads it through cfem_ros.core.native.atmosphere
// (the _kernel binding ``isa``); there is no second formula.
//
// The layers' base pressures are computed from the hydrostatic equation and
// the gas law with the 1976 constants (not the rounded values of its tables),
// so the figures match the standard's formulas to the last bits. A
// temperature offset dT is added to the ISA temperature at every height while
// the pressure stays ISA: density = p / (R (T + dT)) and speed of sound =
// sqrt(gamma R (T + dT)).
#pragma once

#include <cmath>

namespace cfem {

struct IsaLayer { double base, temperature, lapse, pressure; };

// 1976: R* (J/(kmol K)), M0 (kg/kmol), g0 (m/s^2), gamma; R = R* / M0 (J/(kg K))
constexpr double kIsaRstar = 8314.32, kIsaM0 = 28.9644, kIsaG0 = 9.80665, kIsaGamma = 1.4;
constexpr double kIsaGas = kIsaRstar / kIsaM0;
// base altitude (m), base temperature (K), lapse rate (K/m); the base pressures follow
constexpr double kIsaBase[3] = {0.0, 11000.0, 20000.0};
constexpr double kIsaLapse[3] = {-0.0065, 0.0, 0.001};
constexpr double kIsaSeaLevelTemperature = 288.15, kIsaSeaLevelPressure = 101325.0;

// Pressure (Pa) at `height` m above a layer's base, from its base values.
inline double isa_pressure_in(const IsaLayer& layer, double height) {
  if (layer.lapse == 0.0)
    return layer.pressure * std::exp(-kIsaG0 * height / (kIsaGas * layer.temperature));
  double temperature = layer.temperature + layer.lapse * height;
  return layer.pressure *
         std::pow(temperature / layer.temperature, -kIsaG0 / (kIsaGas * layer.lapse));
}

// The three layers with their base temperatures and pressures (computed once).
inline const IsaLayer* isa_layers() {
  static const struct Table {
    IsaLayer layers[3];
    Table() {
      layers[0] = {kIsaBase[0], kIsaSeaLevelTemperature, kIsaLapse[0], kIsaSeaLevelPressure};
      for (int k = 1; k < 3; ++k) {
        const IsaLayer& below = layers[k - 1];
        double height = kIsaBase[k] - below.base;
        layers[k] = {kIsaBase[k], below.temperature + below.lapse * height, kIsaLapse[k],
                     isa_pressure_in(below, height)};
      }
    }
  } table;
  return table.layers;
}

// ISA temperature (K) and pressure (Pa) at a geopotential altitude (m); above 32 km the
// third layer goes on, below 0 the first.
inline void isa_temperature_pressure(double altitude, double& temperature, double& pressure) {
  const IsaLayer* layers = isa_layers();
  const IsaLayer* layer = layers;
  for (int k = 1; k < 3; ++k) {
    if (altitude > layers[k].base) layer = layers + k;
  }
  double height = altitude - layer->base;
  temperature = layer->temperature + layer->lapse * height;
  pressure = isa_pressure_in(*layer, height);
}

// Density (kg/m^3) and speed of sound (m/s) at altitude (m), the temperature offset by
// `offset` K (pressure ISA).
inline void isa(double altitude, double offset, double& density, double& sound) {
  double temperature, pressure;
  isa_temperature_pressure(altitude, temperature, pressure);
  temperature += offset;
  density = pressure / (kIsaGas * temperature);
  sound = std::sqrt(kIsaGamma * kIsaGas * temperature);
}

}  // namespace cfem
