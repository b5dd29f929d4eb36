// morse/core/units.hpp: the frequency conversions shared by every module.
//
// omega^2 [(rad/s)^2] (an eigenvalue of K x = omega^2 M x) to f [Hz] and back. One expression
// each, so that a frequency written by one module is bitwise the one printed by another.
#pragma once

#include <algorithm>
#include <cmath>
#include <vector>

namespace morse {

/// 2 pi, the same double as 2 * M_PI.
constexpr double kTwoPi = 6.283185307179586;

/// Frequency [Hz] of an eigenvalue omega^2: sqrt(max(0, omega^2)) / 2 pi (negative round-off of
/// rigid modes clipped to 0). Not collective.
inline double hz(double omega2) { return std::sqrt(std::max(0.0, omega2)) / kTwoPi; }

/// hz() of each eigenvalue. Not collective.
inline std::vector<double> hz(const std::vector<double>& omega2) {
  std::vector<double> f;
  f.reserve(omega2.size());
  for (double l : omega2) f.push_back(hz(l));
  return f;
}

/// Eigenvalue omega^2 [(rad/s)^2] of a frequency f [Hz]: (2 pi f)^2. Not collective.
inline double omega2_of_hz(double f) { return std::pow(kTwoPi * f, 2); }

}  // namespace morse
