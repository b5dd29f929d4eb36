// Timoshenko shaft element, rigid disks and rotor assembly (docs/rampup-theory.md §1–2).
#include <cmath>
#include <set>

#include "morse/core/error.hpp"
#include "morse/rampup/rampup.hpp"

namespace morse::rampup {

double shear_coefficient(double nu, double d_outer, double d_inner) {
  MORSE_CHECK(d_outer > 0.0 && d_inner >= 0.0 && d_inner < d_outer,
              "shaft section: need 0 <= d_inner < d_outer, got d_outer = ", d_outer, " m, d_inner = ", d_inner, " m");
  const double m = d_inner / d_outer, s = (1.0 + m * m) * (1.0 + m * m);
  return 6.0 * (1.0 + nu) * s / ((7.0 + 6.0 * nu) * s + (20.0 + 12.0 * nu) * m * m);
}

namespace {

// Solves the 4 x 4 system A X = I (partial pivoting): the columns of X are the polynomial
// coefficients of the four shape functions.
void invert4(double A[4][4], double X[4][4]) {
  double B[4][8];
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 8; ++j) B[i][j] = j < 4 ? A[i][j] : (j - 4 == i ? 1.0 : 0.0);
  for (int c = 0; c < 4; ++c) {
    int p = c;
    for (int i = c + 1; i < 4; ++i)
      if (std::fabs(B[i][c]) > std::fabs(B[p][c])) p = i;
    for (int j = 0; j < 8; ++j) std::swap(B[c][j], B[p][j]);
    for (int i = 0; i < 4; ++i) {
      if (i == c) continue;
      const double f = B[i][c] / B[c][c];
      for (int j = 0; j < 8; ++j) B[i][j] -= f * B[c][j];
    }
  }
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) X[i][j] = B[i][j + 4] / B[i][i];
}

void add_outer(std::array<double, 64>& A, double w, const double* a, const double* b) {
  for (int i = 0; i < 8; ++i)
    for (int j = 0; j < 8; ++j) A[8 * i + j] += w * a[i] * b[j];
}

}  // namespace

ShaftElement shaft_element(double L, double d_outer, double d_inner, const Material& mat) {
  MORSE_CHECK(L > 0.0 && std::isfinite(L), "shaft element: length must be positive, got ", L, " m");
  MORSE_CHECK(mat.E > 0.0, "shaft material: E must be positive, got ", mat.E, " Pa");
  MORSE_CHECK(mat.nu > -1.0 && mat.nu < 0.5, "shaft material: nu must be in (-1, 0.5), got ", mat.nu);
  MORSE_CHECK(mat.rho >= 0.0, "shaft material: rho must be >= 0, got ", mat.rho, " kg/m^3");
  ShaftElement e;
  e.kappa = shear_coefficient(mat.nu, d_outer, d_inner);
  const double ro = d_outer / 2, ri = d_inner / 2;
  const double A = M_PI * (ro * ro - ri * ri), I = M_PI * (ro * ro * ro * ro - ri * ri * ri * ri) / 4.0;
  const double G = mat.E / (2.0 * (1.0 + mat.nu));
  e.phi = 12.0 * mat.E * I / (e.kappa * G * A * L * L);
  const double phi = e.phi;

  // Planar element (w, beta) with w cubic in xi = z / L and the section rotation
  // beta = w' - gamma. Stationarity of U = 1/2 int EI beta'^2 + 1/2 int kappa G A (w' - beta)^2
  // in beta gives EI beta'' = -kappa G A gamma, so gamma = -EI w''' / (kappa G A) is constant:
  //   w = b0 + b1 xi + b2 xi^2 + b3 xi^3,  L beta = b1 + 2 b2 xi + 3 b3 xi^2 + b3 phi / 2.
  // Rows: w(0), L beta(0), w(1), L beta(1); nodal DOFs (w1, beta1, w2, beta2) are mapped by
  // scaling the beta columns with L.
  double Amat[4][4] = {{1, 0, 0, 0}, {0, 1, 0, phi / 2}, {1, 1, 1, 1}, {0, 1, 2, 3 + phi / 2}};
  double Cf[4][4];
  invert4(Amat, Cf);
  for (int i = 0; i < 4; ++i) {
    Cf[i][1] *= L;
    Cf[i][3] *= L;
  }
  // Planar DOF a -> element DOF and sign: x-z plane (w = u_x, beta = theta_y); y-z plane
  // (w = u_y, beta = -theta_x).
  const int ix[4] = {0, 3, 4, 7}, iy[4] = {1, 2, 5, 6};
  const double sy[4] = {1, -1, 1, -1};
  // 5-point Gauss–Legendre on [0, 1] (exact to degree 9; the mass integrands are degree 6).
  const double gx[5] = {-0.9061798459386640, -0.5384693101056831, 0.0, 0.5384693101056831, 0.9061798459386640};
  const double gw[5] = {0.2369268850561891, 0.4786286704993665, 0.5688888888888889, 0.4786286704993665,
                        0.2369268850561891};
  const double rhoA = mat.rho * A, rhoI = mat.rho * I, EI = mat.E * I, kGA = e.kappa * G * A, rhoIp = 2.0 * mat.rho * I;
  for (int g = 0; g < 5; ++g) {
    const double xi = 0.5 * (gx[g] + 1.0), w = 0.5 * gw[g] * L;
    double Nw[4], dNw[4], Nb[4], dNb[4];
    for (int a = 0; a < 4; ++a) {
      const double b0 = Cf[0][a], b1 = Cf[1][a], b2 = Cf[2][a], b3 = Cf[3][a];
      Nw[a] = b0 + xi * (b1 + xi * (b2 + xi * b3));
      dNw[a] = (b1 + xi * (2 * b2 + xi * 3 * b3)) / L;
      Nb[a] = (b1 + 2 * b2 * xi + 3 * b3 * xi * xi + b3 * phi / 2) / L;
      dNb[a] = (2 * b2 + 6 * b3 * xi) / (L * L);
    }
    double Ux[8] = {}, Uy[8] = {}, Tx[8] = {}, Ty[8] = {}, dTx[8] = {}, dTy[8] = {}, Gx[8] = {}, Gy[8] = {};
    for (int a = 0; a < 4; ++a) {
      Ux[ix[a]] = Nw[a];
      Ty[ix[a]] = Nb[a];
      dTy[ix[a]] = dNb[a];
      Gx[ix[a]] = dNw[a] - Nb[a];  // gamma_xz = u_x' - theta_y
      Uy[iy[a]] = sy[a] * Nw[a];
      Tx[iy[a]] = -sy[a] * Nb[a];
      dTx[iy[a]] = -sy[a] * dNb[a];
      Gy[iy[a]] = sy[a] * (dNw[a] - Nb[a]);  // gamma_yz = u_y' + theta_x
    }
    add_outer(e.Mt, w * rhoA, Ux, Ux);
    add_outer(e.Mt, w * rhoA, Uy, Uy);
    add_outer(e.Mr, w * rhoI, Tx, Tx);
    add_outer(e.Mr, w * rhoI, Ty, Ty);
    add_outer(e.K, w * EI, dTx, dTx);
    add_outer(e.K, w * EI, dTy, dTy);
    add_outer(e.K, w * kGA, Gx, Gx);
    add_outer(e.K, w * kGA, Gy, Gy);
    add_outer(e.G, w * rhoIp, Tx, Ty);
    add_outer(e.G, -w * rhoIp, Ty, Tx);
  }
  // Exact symmetry / skew-symmetry (the quadrature sums are equal only to round-off).
  for (int i = 0; i < 8; ++i)
    for (int j = i; j < 8; ++j) {
      for (auto* S : {&e.Mt, &e.Mr, &e.K}) {
        const double s = 0.5 * ((*S)[8 * i + j] + (*S)[8 * j + i]);
        (*S)[8 * i + j] = (*S)[8 * j + i] = s;
      }
      const double k = i == j ? 0.0 : 0.5 * (e.G[8 * i + j] - e.G[8 * j + i]);
      e.G[8 * i + j] = k;
      e.G[8 * j + i] = -k;
    }
  return e;
}

RotorMatrices rotor_matrices(const RotorSpec& r) {
  const std::string who = cat("rotor '", r.name, "': ");
  const int ns = static_cast<int>(r.z.size());
  MORSE_CHECK(ns >= 1, who, "needs at least one station");
  for (int k = 0; k + 1 < ns; ++k)
    MORSE_CHECK(r.z[k + 1] > r.z[k], who, "stations must be strictly increasing in z: z[", k, "] = ", r.z[k], ", z[",
                k + 1, "] = ", r.z[k + 1], " m");
  const std::size_t ne = static_cast<std::size_t>(ns - 1);
  MORSE_CHECK(ne == 0 || r.sections.size() == ne || r.sections.size() == 1, who, "needs ", ne,
              " shaft sections (one per element) or 1 (uniform), got ", r.sections.size());
  MORSE_CHECK(std::isfinite(r.speed_ratio), who, "speed ratio must be finite");
  MORSE_CHECK(r.rayleigh_alpha >= 0.0 && r.rayleigh_beta >= 0.0, who, "Rayleigh damping must be >= 0");
  RotorMatrices m;
  m.n = 4 * ns;
  const std::size_t n = static_cast<std::size_t>(m.n);
  m.M.assign(n * n, 0.0);
  m.K.assign(n * n, 0.0);
  m.G.assign(n * n, 0.0);
  for (std::size_t k = 0; k < ne; ++k) {
    const ShaftSection& s = r.sections.size() == 1 ? r.sections[0] : r.sections[k];
    ShaftElement e;
    try {
      e = shaft_element(r.z[k + 1] - r.z[k], s.d_outer, s.d_inner, s.material);
    } catch (const Error& err) {
      throw Error(cat(who, "element ", k, ": ", err.what()));
    }
    for (std::size_t i = 0; i < 8; ++i)
      for (std::size_t j = 0; j < 8; ++j) {
        const std::size_t g = (4 * k + i) * n + 4 * k + j;
        m.M[g] += e.Mt[8 * i + j] + e.Mr[8 * i + j];
        m.K[g] += e.K[8 * i + j];
        m.G[g] += e.G[8 * i + j];
      }
  }
  std::set<std::string> names;
  for (const Disk& d : r.disks) {
    MORSE_CHECK(!d.name.empty(), who, "a disk has no name");
    MORSE_CHECK(names.insert(d.name).second, who, "two disks are named '", d.name, "'");
    MORSE_CHECK(d.station >= 0 && d.station < ns, who, "disk '", d.name, "' is at station ", d.station, ", not in 0..",
                ns - 1);
    MORSE_CHECK(d.mass >= 0.0 && d.Ip >= 0.0 && d.Id >= 0.0, who, "disk '", d.name, "': mass, Ip and Id must be >= 0");
    const std::size_t b = 4 * static_cast<std::size_t>(d.station);
    m.M[b * n + b] += d.mass;
    m.M[(b + 1) * n + b + 1] += d.mass;
    m.M[(b + 2) * n + b + 2] += d.Id;
    m.M[(b + 3) * n + b + 3] += d.Id;
    m.G[(b + 2) * n + b + 3] += d.Ip;
    m.G[(b + 3) * n + b + 2] -= d.Ip;
  }
  for (const Unbalance& u : r.unbalances) {
    MORSE_CHECK(names.count(u.disk), who, "unbalance on disk '", u.disk, "': the rotor has no such disk");
    MORSE_CHECK(std::isfinite(u.me) && std::isfinite(u.phase), who, "unbalance on disk '", u.disk, "' is not finite");
  }
  m.C.resize(n * n);
  for (std::size_t i = 0; i < n * n; ++i) m.C[i] = r.rayleigh_alpha * m.M[i] + r.rayleigh_beta * m.K[i];
  return m;
}

RotorMatrices torsion_matrices(const RotorSpec& r) {
  rotor_matrices(r);  // validates the spec (stations, sections, disks, damping)
  const int ns = static_cast<int>(r.z.size());
  RotorMatrices m;
  m.n = ns;
  const std::size_t n = static_cast<std::size_t>(ns);
  m.M.assign(n * n, 0.0);
  m.K.assign(n * n, 0.0);
  for (std::size_t k = 0; k + 1 < n; ++k) {
    const ShaftSection& s = r.sections.size() == 1 ? r.sections[0] : r.sections[k];
    const double L = r.z[k + 1] - r.z[k];
    const double J = M_PI * (std::pow(s.d_outer, 4) - std::pow(s.d_inner, 4)) / 32.0;
    const double kt = s.material.E / (2.0 * (1.0 + s.material.nu)) * J / L, mt = s.material.rho * J * L / 6.0;
    const std::size_t a = k * n + k, b = k * n + k + 1, c = (k + 1) * n + k, d = (k + 1) * n + k + 1;
    m.K[a] += kt, m.K[d] += kt, m.K[b] -= kt, m.K[c] -= kt;
    m.M[a] += 2 * mt, m.M[d] += 2 * mt, m.M[b] += mt, m.M[c] += mt;
  }
  for (const Disk& d : r.disks) {
    const std::size_t i = static_cast<std::size_t>(d.station);
    m.M[i * n + i] += d.Ip;
  }
  m.C.resize(n * n);
  for (std::size_t i = 0; i < n * n; ++i) m.C[i] = r.rayleigh_alpha * m.M[i] + r.rayleigh_beta * m.K[i];
  return m;
}

}  // namespace morse::rampup
