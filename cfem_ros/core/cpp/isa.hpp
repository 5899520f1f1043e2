// Copyright 2026 the cfem_ros authors
// SPDX-License-Identifier: Apache-2.0
//
// The International Standard Atmosphere to 32 km (ICAO Doc 7488): density and
// speed of sound at a geopotential altitude. The same numbers as
// cfem_ros.core.aero.isa (Python), which the tests compare.
#pragma once

#include <cmath>

namespace cfem {

struct IsaLayer { double base, temperature, lapse, pressure; };

// base altitude (m), base temperature (K), lapse rate (K/m), base pressure (Pa)
constexpr IsaLayer kIsaLayers[3] = {{0.0, 288.15, -0.0065, 101325.0},
                                    {11000.0, 216.65, 0.0, 22632.06},
                                    {20000.0, 216.65, 0.001, 5474.889}};
constexpr double kIsaGas = 287.05287, kIsaGamma = 1.4, kIsaG0 = 9.80665;

// Density (kg/m^3) and speed of sound (m/s) at altitude (m); above 32 km the
// third layer goes on, below 0 the first.
inline void isa(double altitude, double& density, double& sound) {
  IsaLayer layer = kIsaLayers[0];
  for (int k = 1; k < 3; ++k) {
    if (altitude > kIsaLayers[k].base) layer = kIsaLayers[k];
  }
  double height = altitude - layer.base;
  double temperature = layer.temperature + layer.lapse * height;
  double pressure;
  if (layer.lapse == 0.0) {
    pressure = layer.pressure * std::exp(-kIsaG0 * height / (kIsaGas * layer.temperature));
  } else {
    pressure = layer.pressure * std::pow(temperature / layer.temperature,
                                         -kIsaG0 / (kIsaGas * layer.lapse));
  }
  density = pressure / (kIsaGas * temperature);
  sound = std::sqrt(kIsaGamma * kIsaGas * temperature);
}

}  // namespace cfem
