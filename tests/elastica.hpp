// Euler elastica reference for a cantilever with a dead tip load.
//
// Problem: cantilever of length L, clamped at x = 0, constant EI, inextensible and
// unshearable (Euler-Bernoulli elastica). A dead point load P, perpendicular to the
// undeformed axis, acts at the free tip. Load parameter alpha = P L^2 / (E I).
// With s in [0,1] the arc length / L and theta(s) the tangent rotation (towards the
// load), equilibrium gives
//   theta'' = -alpha cos(theta),  theta(0) = 0,  theta'(1) = 0,
// first integral theta'^2 = 2 alpha (sin theta0 - sin theta), theta0 = theta(1).
// Substituting 1 + sin(theta) = 2 k^2 sin^2(phi), k^2 = (1 + sin theta0) / 2, gives
// (Bisshopp & Drucker 1945; Frisch-Fay, "Flexible Bars", 1962):
//   sqrt(alpha) = F(pi/2, k) - F(phi1, k),        sin(phi1) = 1 / (k sqrt 2)
//   w / L       = 1 - 2 / sqrt(alpha) [E(pi/2, k) - E(phi1, k)]   (along the load)
//   x_tip / L   = sqrt(2 sin(theta0) / alpha)                      (along the axis)
// F, E are Legendre's incomplete elliptic integrals of the 1st/2nd kind (modulus k),
// evaluated via Carlson's symmetric RF/RD. theta0 is found by bisection.
// Checked against an RK4 shooting solution of the ODE (agreement ~1e-14 for alpha in
// [0.1, 100]) and Mattiasson (1981): alpha = 1 gives w/L = 0.30172, x/L = 0.94357.
// Absolute accuracy ~1e-16 / sqrt(alpha) (cancellation in the w and x formulas), i.e.
// results are only ~1e-13 absolute for alpha ~ 1e-6; use alpha >~ 1e-2 for tight checks.
#pragma once

#include <algorithm>
#include <cmath>

namespace morse::test {

/// Tip response of the elastica cantilever (all dimensionless).
struct ElasticaTip {
  double deflection = 0;  ///< transverse tip displacement w / L, along the load
  double shortening = 0;  ///< axial tip shortening (L - x_tip) / L; x_tip / L = 1 - shortening
  double rotation = 0;    ///< tip rotation theta_tip [rad]
};

/// Carlson's symmetric integral RF(x,y,z) (duplication + 5th-order series, ~1e-16).
inline double carlson_rf(double x, double y, double z) {
  double ave, dx, dy, dz;
  for (;;) {
    const double sx = std::sqrt(x), sy = std::sqrt(y), sz = std::sqrt(z);
    const double lam = sx * (sy + sz) + sy * sz;
    x = 0.25 * (x + lam), y = 0.25 * (y + lam), z = 0.25 * (z + lam);
    ave = (x + y + z) / 3.0;
    dx = (ave - x) / ave, dy = (ave - y) / ave, dz = (ave - z) / ave;
    if (std::max({std::abs(dx), std::abs(dy), std::abs(dz)}) < 1e-3) break;
  }
  const double e2 = dx * dy - dz * dz, e3 = dx * dy * dz;
  return (1.0 + (e2 / 24.0 - 0.1 - 3.0 / 44.0 * e3) * e2 + e3 / 14.0) / std::sqrt(ave);
}

/// Carlson's symmetric integral RD(x,y,z) = RJ(x,y,z,z) (duplication + series).
inline double carlson_rd(double x, double y, double z) {
  double sum = 0, fac = 1, ave, dx, dy, dz;
  for (;;) {
    const double sx = std::sqrt(x), sy = std::sqrt(y), sz = std::sqrt(z);
    const double lam = sx * (sy + sz) + sy * sz;
    sum += fac / (sz * (z + lam));
    fac *= 0.25;
    x = 0.25 * (x + lam), y = 0.25 * (y + lam), z = 0.25 * (z + lam);
    ave = 0.2 * (x + y + 3.0 * z);
    dx = (ave - x) / ave, dy = (ave - y) / ave, dz = (ave - z) / ave;
    if (std::max({std::abs(dx), std::abs(dy), std::abs(dz)}) < 1e-3) break;
  }
  const double c1 = 3.0 / 14.0, c2 = 1.0 / 6.0, c3 = 9.0 / 22.0, c4 = 3.0 / 26.0;
  const double ea = dx * dy, eb = dz * dz, ec = ea - eb, ed = ea - 6.0 * eb, ee = ed + 2.0 * ec;
  return 3.0 * sum + fac *
                         (1.0 + ed * (-c1 + 0.25 * c3 * ed - 1.5 * c4 * dz * ee) +
                          dz * (c2 * ee + dz * (-c3 * ec + dz * c4 * ea))) /
                         (ave * std::sqrt(ave));
}

/// F(phi,k) and E(phi,k) for 0 <= phi <= pi/2, given sin/cos of phi and k^2, with
/// delta2 = 1 - k^2 sin^2(phi) passed in so that it can be formed without cancellation.
inline void legendre_fe(double sphi, double cphi, double k2, double delta2, double& f, double& e) {
  const double rf = carlson_rf(cphi * cphi, delta2, 1.0);
  f = sphi * rf;
  e = f - k2 * sphi * sphi * sphi * carlson_rd(cphi * cphi, delta2, 1.0) / 3.0;
}

/// Elliptic-integral elastica solution for load parameter alpha = P L^2 / (E I) >= 0.
inline ElasticaTip cantilever_tip_load_elastica(double alpha) {
  ElasticaTip r;
  if (!(alpha > 0)) return r;
  const double pi = 3.14159265358979323846;
  // Integrals between phi1 and pi/2 for tip rotation t; kc2 = 1 - k^2 = sin^2(pi/4 - t/2).
  auto integrals = [&](double t, double& df, double& de) {
    const double st = std::sin(t), k2 = 0.5 * (1.0 + st), s = std::sin(0.25 * pi - 0.5 * t);
    double f0, e0, f1, e1;
    legendre_fe(1.0, 0.0, k2, s * s, f0, e0);                                             // complete: K(k), E(k)
    legendre_fe(1.0 / std::sqrt(1.0 + st), std::sqrt(st / (1.0 + st)), k2, 0.5, f1, e1);  // phi1
    df = f0 - f1, de = e0 - e1;
  };
  // K(k) - F(phi1,k) increases monotonically from 0 (t = 0) to infinity (t = pi/2).
  const double sa = std::sqrt(alpha);
  double lo = 0.0, hi = 0.5 * pi, df, de;
  for (int it = 0; it < 1100; ++it) {  // bisect to machine precision (relative, also for tiny alpha)
    const double mid = 0.5 * (lo + hi);
    if (mid <= lo || mid >= hi) break;
    integrals(mid, df, de);
    (df < sa ? lo : hi) = mid;
  }
  r.rotation = 0.5 * (lo + hi);
  integrals(r.rotation, df, de);
  r.deflection = 1.0 - 2.0 * de / sa;
  r.shortening = 1.0 - std::sqrt(2.0 * std::sin(r.rotation) / alpha);
  return r;
}

}  // namespace morse::test
