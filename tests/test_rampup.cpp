// Rotor–stator assembly and unbalance ramp-up (rampup/rampup.hpp) against closed forms: the
// Timoshenko shaft element (exact stiffness, pinned–pinned Timoshenko and free–free
// Euler–Bernoulli frequencies, h^4 convergence), the Campbell diagram of a disk on a massless
// shaft, the Jeffcott unbalance response, Newmark's second order and energy conservation, the
// clamped modal basis of a spring-chain superelement, the condensed step against the dense one,
// the frequency-domain steady state of a rotor on a stator, the errors, intershaft bearings (2-DOF
// closed form) and the torsion (a shaft with an end disk, a geared ramp's closed form). Every rank runs the
// same serial computation; the numbers are checked to be identical on every rank.
#include <gtest/gtest.h>
#include <mpi.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <complex>
#include <cstdio>

#include "morse/core/session.hpp"
#include "morse/eigen/eigen.hpp"
#include "morse/io/h5.hpp"
#include "morse/rampup/rampup.hpp"
#include "scratch.hpp"

using namespace morse;
using namespace morse::rampup;

namespace {

// The value is bitwise the same on every rank.
void expect_same_on_ranks(double v, const char* what) {
  double lo = v, hi = v;
  MPI_Allreduce(MPI_IN_PLACE, &lo, 1, MPI_DOUBLE, MPI_MIN, PETSC_COMM_WORLD);
  MPI_Allreduce(MPI_IN_PLACE, &hi, 1, MPI_DOUBLE, MPI_MAX, PETSC_COMM_WORLD);
  EXPECT_EQ(lo, hi) << what << " differs between ranks";
}

struct Section {
  double A, I, kGA, EI, rhoA, rhoI;
};
Section section(double d, const Material& m) {
  Section s;
  s.A = M_PI * d * d / 4;
  s.I = M_PI * std::pow(d, 4) / 64;
  s.EI = m.E * s.I;
  s.kGA = 6 * (1 + m.nu) / (7 + 6 * m.nu) * m.E / (2 * (1 + m.nu)) * s.A;
  s.rhoA = m.rho * s.A;
  s.rhoI = m.rho * s.I;
  return s;
}

// Lower root of the pinned–pinned Timoshenko frequency equation for wavenumber k = n pi / L:
// (kGA k^2 - rhoA w^2)(EI k^2 + kGA - rhoI w^2) = (kGA k)^2.
double timoshenko_pinned(const Section& s, double L, int n) {
  const double k = n * M_PI / L;
  const double a = s.rhoA * s.rhoI, b = -(s.rhoA * (s.EI * k * k + s.kGA) + s.rhoI * s.kGA * k * k),
               c = s.kGA * k * k * s.EI * k * k;
  return std::sqrt((-b - std::sqrt(b * b - 4 * a * c)) / (2 * a));
}

// First pinned–pinned frequencies of n_el elements in the x–z plane (DOFs u_x, theta_y).
std::vector<double> pinned_frequencies(double L, double d, const Material& m, int n_el) {
  const ShaftElement e = shaft_element(L / n_el, d, 0.0, m);
  const int nd = 2 * (n_el + 1);
  std::vector<double> K(nd * nd, 0.0), M(nd * nd, 0.0);
  const int loc[4] = {0, 3, 4, 7};
  for (int el = 0; el < n_el; ++el)
    for (int a = 0; a < 4; ++a)
      for (int b = 0; b < 4; ++b) {
        const int i = 2 * el + a, j = 2 * el + b;
        K[i * nd + j] += e.K[8 * loc[a] + loc[b]];
        M[i * nd + j] += e.Mt[8 * loc[a] + loc[b]] + e.Mr[8 * loc[a] + loc[b]];
      }
  std::vector<int> keep;
  for (int i = 0; i < nd; ++i)
    if (i != 0 && i != 2 * n_el) keep.push_back(i);
  const int nr = static_cast<int>(keep.size());
  std::vector<double> Kr(nr * nr), Mr(nr * nr);
  for (int i = 0; i < nr; ++i)
    for (int j = 0; j < nr; ++j) {
      Kr[i * nr + j] = K[keep[i] * nd + keep[j]];
      Mr[i * nr + j] = M[keep[i] * nd + keep[j]];
    }
  auto lam = eigen::dense_eigenvalues(nr, Kr, Mr);
  for (double& l : lam) l = std::sqrt(l);
  return lam;
}

// Jeffcott rotor: one station, a disk, a ground bearing.
Assembly jeffcott(double m, double k, double c, double me) {
  RotorSpec r;
  r.name = "jeffcott";
  r.z = {0.0};
  r.disks = {{"disk", 0, m, 0.2, 0.1}};
  r.unbalances = {{"disk", me, 0.0}};
  Bearing b;
  b.name = "b";
  b.kxx = b.kyy = k;
  b.cxx = b.cyy = c;
  return Assembly({r}, {}, {b});
}

// A spring-chain superelement: nodes 101..106 on three independent chains (x, y, z; springs kc
// between consecutive nodes, unit masses), boundary nodes 101, 103, 106, interior nodes reduced
// by an exact invertible change of coordinates u_i = Psi u_b + V p (Craig–Bampton without
// truncation), so the clamped eigenfrequencies are those of the chains.
const double kChain[3] = {1.0e6, 2.0e6, 3.3e6};
Superelement chain_superelement(bool with_C) {
  const int P = 6;
  const std::int64_t ids[P] = {101, 102, 103, 104, 105, 106};
  const std::vector<int> bnodes = {0, 2, 5}, inodes = {1, 3, 4};
  const int n = 3 * P;
  std::vector<double> K(n * n, 0.0), M(n * n, 0.0);
  for (int p = 0; p < P; ++p)
    for (int c = 0; c < 3; ++c) M[(3 * p + c) * n + 3 * p + c] = 1.0;
  for (int p = 0; p + 1 < P; ++p)
    for (int c = 0; c < 3; ++c) {
      const int i = 3 * p + c, j = 3 * (p + 1) + c;
      K[i * n + i] += kChain[c];
      K[j * n + j] += kChain[c];
      K[i * n + j] -= kChain[c];
      K[j * n + i] -= kChain[c];
    }
  std::vector<int> order;  // physical DOF of each reduced position: boundary then interior
  for (int p : bnodes)
    for (int c = 0; c < 3; ++c) order.push_back(3 * p + c);
  for (int p : inodes)
    for (int c = 0; c < 3; ++c) order.push_back(3 * p + c);
  const int nb = 9, ni = 9;
  // T: physical (in `order`) = T q, T = [I 0; Psi V].
  std::vector<double> T(n * n, 0.0);
  for (int i = 0; i < nb; ++i) T[i * n + i] = 1.0;
  for (int i = 0; i < ni; ++i) {
    for (int j = 0; j < nb; ++j) T[(nb + i) * n + j] = 0.1 * std::sin(1.0 + i + 2.0 * j);
    for (int j = 0; j < ni; ++j) T[(nb + i) * n + nb + j] = (i == j ? 1.0 : 0.0) + 0.05 * std::cos(3.0 * i + j);
  }
  auto project = [&](const std::vector<double>& A) {
    std::vector<double> Ap(n * n), AT(n * n, 0.0), R(n * n, 0.0);
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) Ap[i * n + j] = A[order[i] * n + order[j]];
    for (int i = 0; i < n; ++i)
      for (int k = 0; k < n; ++k)
        for (int j = 0; j < n; ++j) AT[i * n + j] += Ap[i * n + k] * T[k * n + j];
    for (int i = 0; i < n; ++i)
      for (int k = 0; k < n; ++k)
        for (int j = 0; j < n; ++j) R[i * n + j] += T[k * n + i] * AT[k * n + j];
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < i; ++j) R[i * n + j] = R[j * n + i] = 0.5 * (R[i * n + j] + R[j * n + i]);
    return R;
  };
  Superelement se;
  se.source = "chain";
  se.n = n;
  se.n_b = nb;
  se.K = project(K);
  se.M = project(M);
  if (with_C) {
    std::vector<double> C(K);
    for (double& v : C) v *= 1e-5;  // Rayleigh: modal damping 1e-5 omega^2, diagonal in any modal basis
    se.C = project(C);
  }
  for (int p : bnodes)
    for (int c = 0; c < 3; ++c) {
      se.dof_node.push_back(ids[p]);
      se.dof_component.push_back(c + 1);
    }
  se.boundary_nodes = {101, 103, 106};
  return se;
}

// Fixed–free chains of 5 unit masses (node 101 clamped): 2 sqrt(k) sin((2j - 1) pi / 22), sorted.
std::vector<double> chain_frequencies() {
  std::vector<double> w;
  for (double k : kChain)
    for (int j = 1; j <= 5; ++j) w.push_back(2.0 * std::sqrt(k) * std::sin((2 * j - 1) * M_PI / 22.0));
  std::sort(w.begin(), w.end());
  return w;
}

void write_rom(const std::string& path, const Superelement& se) {
  io::H5Output out(MPI_COMM_SELF, path);
  const auto n = static_cast<hsize_t>(se.n);
  out.write("/rom/K", se.K, {n, n});
  out.write("/rom/M", se.M, {n, n});
  if (!se.C.empty()) out.write("/rom/C", se.C, {n, n});
  std::vector<std::int64_t> labels;
  for (int j = 0; j < se.n_b; ++j) {
    labels.push_back(se.dof_node[j]);
    labels.push_back(se.dof_component[j]);
  }
  out.write("/rom/boundary_dofs", labels, {static_cast<hsize_t>(se.n_b), 2});
  out.write("/rom/boundary_nodes", se.boundary_nodes);
  out.commit();
}

// A flexible rotor on two bearings on the chain stator (nodes 103 and 106), a disk with an
// unbalance, modest damping everywhere.
Assembly rotor_on_chain(double f_cut_hz = 1e4) {
  StatorModes sm = stator_modes(chain_superelement(false), {101}, f_cut_hz, 0.02);
  RotorSpec r;
  r.name = "hp";
  r.z = {0.0, 0.12, 0.24, 0.36, 0.48, 0.6};
  r.sections = {{0.05, 0.02, Material{}}};
  r.disks = {{"fan", 3, 5.0, 0.02, 0.01}};
  r.unbalances = {{"fan", 1e-4, 0.3}};
  r.speed_ratio = 1.5;
  r.rayleigh_beta = 2e-6;
  Bearing b1{"front", 0, 0, 0, 103, 5e6, 4e6, 500.0, 400.0, {}};
  Bearing b2{"rear", 0, 5, 0, 106, 3e6, 3e6, 300.0, 300.0, {}};
  return Assembly({r}, {sm}, {b1, b2});
}

// The bearing forces of a 0.05 s ramp to 600 rad/s (HHT alpha = -0.05, 2e-5 s) with the condensed
// step and with the dense one.
void condensed_and_dense_forces(const Assembly& a, std::vector<double>* fc, std::vector<double>* fd) {
  const std::size_t nf = 2 * a.bearings().size();
  LoadCase lc;
  lc.omega_max = 600;
  lc.ramp_time = 0.05;
  IntegratorSettings s;
  s.dt = 2e-5;
  s.alpha = -0.05;
  integrate(a, lc, s, [&](const StepOutput& o) { fc->insert(fc->end(), o.force, o.force + nf); });
  s.dense = true;
  integrate(a, lc, s, [&](const StepOutput& o) { fd->insert(fd->end(), o.force, o.force + nf); });
}

class Rampup : public test::ScratchDirTest {
 protected:
  Rampup() : ScratchDirTest("rampup") {}
};

}  // namespace

// ------------------------------------------------------------------------------------------

TEST(RampupElement, StiffnessIsTheExactTimoshenkoMatrix) {
  const Material m;
  const double L = 0.1, d = 0.06, di = 0.02;
  const ShaftElement e = shaft_element(L, d, di, m);
  const double A = M_PI * (d * d - di * di) / 4, I = M_PI * (std::pow(d, 4) - std::pow(di, 4)) / 64;
  const double mr = di / d, kappa = 6 * (1 + m.nu) * std::pow(1 + mr * mr, 2) /
                                    ((7 + 6 * m.nu) * std::pow(1 + mr * mr, 2) + (20 + 12 * m.nu) * mr * mr);
  EXPECT_NEAR(e.kappa, kappa, 1e-15);
  const double phi = 12 * m.E * I / (kappa * m.E / (2 * (1 + m.nu)) * A * L * L);
  EXPECT_NEAR(e.phi / phi, 1.0, 1e-14);
  // Przemieniecki's closed form in (w1, beta1, w2, beta2).
  const double c = m.E * I / ((1 + phi) * L * L * L);
  const double Kp[4][4] = {{12, 6 * L, -12, 6 * L},
                           {6 * L, (4 + phi) * L * L, -6 * L, (2 - phi) * L * L},
                           {-12, -6 * L, 12, -6 * L},
                           {6 * L, (2 - phi) * L * L, -6 * L, (4 + phi) * L * L}};
  const int ix[4] = {0, 3, 4, 7}, iy[4] = {1, 2, 5, 6};
  const double sy[4] = {1, -1, 1, -1};  // beta = -theta_x in the y-z plane
  for (int a = 0; a < 4; ++a)
    for (int b = 0; b < 4; ++b) {
      const double ref = c * Kp[a][b], tol = 1e-11 * c * 12 * L * L;
      EXPECT_NEAR(e.K[8 * ix[a] + ix[b]], ref, tol) << a << " " << b;
      EXPECT_NEAR(e.K[8 * iy[a] + iy[b]], sy[a] * sy[b] * ref, tol) << a << " " << b;
      EXPECT_EQ(e.K[8 * ix[a] + iy[b]], 0.0);
    }
  // Translational and rotary mass terms of the shear-deformable element (Nelson 1980; Archer's
  // consistent mass for phi = 0), x-z plane, in closed form.
  const double f2 = (1 + phi) * (1 + phi), rAL = m.rho * A * L, rIL = m.rho * I / L;
  EXPECT_NEAR(e.Mt[0] / (rAL * (13.0 / 35 + 7 * phi / 10 + phi * phi / 3) / f2), 1.0, 1e-12);
  EXPECT_NEAR(e.Mt[3] / (rAL * L * (11.0 / 210 + 11 * phi / 120 + phi * phi / 24) / f2), 1.0, 1e-12);
  EXPECT_NEAR(e.Mt[4] / (rAL * (9.0 / 70 + 3 * phi / 10 + phi * phi / 6) / f2), 1.0, 1e-12);
  EXPECT_NEAR(e.Mt[8 * 3 + 3] / (rAL * L * L * (1.0 / 105 + phi / 60 + phi * phi / 120) / f2), 1.0, 1e-12);
  EXPECT_NEAR(e.Mr[0] / (rIL * 6.0 / 5 / f2), 1.0, 1e-12);
  EXPECT_NEAR(e.Mr[3] / (rIL * L * (1.0 / 10 - phi / 2) / f2), 1.0, 1e-12);
  EXPECT_NEAR(e.Mr[8 * 3 + 3] / (rIL * L * L * (2.0 / 15 + phi / 6 + phi * phi / 3) / f2), 1.0, 1e-12);
  // Rigid translation carries the element's mass; a rigid rotation of the element (u_x = z,
  // theta_y = 1, a static solution the shape functions reproduce exactly) carries the rotary
  // inertia rho I L; G is skew-symmetric exactly.
  double mt = 0;
  for (int i : {0, 4})
    for (int j : {0, 4}) mt += e.Mt[8 * i + j];
  EXPECT_NEAR(mt / (m.rho * A * L), 1.0, 1e-13);
  double qy[8] = {0, 0, 0, 1, L, 0, 0, 1}, qx[8] = {0, 0, 1, 0, 0, -L, 1, 0};  // theta_y = 1; theta_x = 1
  double mrot = 0, g = 0;
  for (int i = 0; i < 8; ++i)
    for (int j = 0; j < 8; ++j) {
      mrot += qy[i] * e.Mr[8 * i + j] * qy[j];
      g += qx[i] * e.G[8 * i + j] * qy[j];
      EXPECT_EQ(e.G[8 * i + j], -e.G[8 * j + i]);
      EXPECT_EQ(e.Mt[8 * i + j], e.Mt[8 * j + i]);
    }
  EXPECT_NEAR(mrot / (m.rho * I * L), 1.0, 1e-13);
  // ... and the gyroscopic coupling of those two tilts is the polar inertia rho Ip L = 2 rho I L.
  EXPECT_NEAR(g / (2 * m.rho * I * L), 1.0, 1e-13);
}

TEST(RampupElement, PinnedPinnedFrequenciesConvergeToTimoshenko) {
  // The element reproduces static solutions exactly, but its shear strain gamma = u' - theta is
  // constant per element: the eigenvalue error is O(h^4) while bending dominates (slender) and
  // O(h^2) times the shear energy fraction when shear matters (thick; docs/rampup-theory.md §1.4).
  const Material m;
  auto errors = [&](double L, double d) {
    const Section s = section(d, m);
    std::vector<double> err;
    for (int ne : {2, 4, 8})
      err.push_back(std::fabs(pinned_frequencies(L, d, m, ne)[0] / timoshenko_pinned(s, L, 1) - 1));
    return err;
  };
  // Slender shaft (L/d = 50).
  const auto es = errors(1.0, 0.02);
  const double rs1 = std::log2(es[0] / es[1]), rs2 = std::log2(es[1] / es[2]);
  EXPECT_NEAR(rs1, 4.0, 0.3);
  EXPECT_NEAR(rs2, 4.0, 0.3);
  // Thick shaft (L/d = 5).
  const double L = 0.5, d = 0.1;
  const Section s = section(d, m);
  const auto et = errors(L, d);
  const double rt1 = std::log2(et[0] / et[1]), rt2 = std::log2(et[1] / et[2]);
  EXPECT_GT(rt1, 1.9);
  EXPECT_NEAR(rt2, 2.0, 0.3);
  const auto w = pinned_frequencies(L, d, m, 64);
  EXPECT_NEAR(w[0] / timoshenko_pinned(s, L, 1), 1.0, 1e-5);
  EXPECT_NEAR(w[1] / timoshenko_pinned(s, L, 2), 1.0, 1e-4);
  // Shear and rotary inertia matter here: Euler–Bernoulli is 4.7 % off.
  const double eb = std::pow(M_PI / L, 2) * std::sqrt(s.EI / s.rhoA);
  EXPECT_GT(eb / w[0] - 1.0, 0.03);
  // Slender shaft (L/d = 100): the Euler–Bernoulli closed form (n pi / L)^2 sqrt(EI / rho A).
  const double Ls = 2.0, ds = 0.02;
  const Section ss = section(ds, m);
  const auto ws = pinned_frequencies(Ls, ds, m, 24);
  for (int n = 1; n <= 2; ++n) {
    EXPECT_NEAR(ws[n - 1] / (std::pow(n * M_PI / Ls, 2) * std::sqrt(ss.EI / ss.rhoA)), 1.0, 5e-4 * n * n);
    EXPECT_NEAR(ws[n - 1] / timoshenko_pinned(ss, Ls, n), 1.0, 1e-5);
  }
  if (world_rank() == 0)
    std::printf(
        "[ rampup ] pinned-pinned mode 1 error for 2/4/8 elements: slender %.3e %.3e %.3e (orders "
        "%.2f %.2f); "
        "thick %.3e %.3e %.3e (orders %.2f %.2f)\n",
        es[0], es[1], es[2], rs1, rs2, et[0], et[1], et[2], rt1, rt2);
  expect_same_on_ranks(et[2], "element error");
}

TEST(RampupElement, FreeFreeRotorMatchesEulerBernoulli) {
  // Through the whole assembly: a free rotor (no bearing), its whirl frequencies at rest.
  const Material m;
  const double L = 2.0, d = 0.01;
  RotorSpec r;
  r.name = "free";
  for (int k = 0; k <= 20; ++k) r.z.push_back(L * k / 20);
  r.sections = {{d, 0.0, m}};
  const Assembly a({r}, {}, {});
  const auto lam = whirl_eigenvalues(a, 0.0);
  std::vector<double> w;
  for (auto l : lam)
    if (l.imag() > 1.0) w.push_back(l.imag());
  ASSERT_GE(w.size(), 4u);
  const Section s = section(d, m);
  const double w1 = std::pow(4.730040744862704, 2) * std::sqrt(s.EI / (s.rhoA * std::pow(L, 4)));
  EXPECT_NEAR(w[0] / w1, 1.0, 2e-4);
  EXPECT_NEAR(w[1] / w1, 1.0, 2e-4);  // the same mode in the other plane
  const double w2 = std::pow(7.853204624095838, 2) * std::sqrt(s.EI / (s.rhoA * std::pow(L, 4)));
  EXPECT_NEAR(w[2] / w2, 1.0, 5e-4);
}

TEST(RampupGyroscopic, CampbellDiagramOfADiskOnAMasslessShaft) {
  // Massless Timoshenko shaft on two isotropic ground bearings, disk at mid-span. Translation and
  // tilt decouple; with the bearings in series with the shaft:
  //   1/k_t = 1/(2 kb) + L^3/(48 EI) + L/(4 kappa G A),
  //   1/k_th = 2/(kb L^2) + L/(12 EI) + 1/(kappa G A L),
  //   w_t = sqrt(k_t/m),  Id w^2 -+ Ip Omega w - k_th = 0 (forward +, backward -).
  Material m;
  m.rho = 0.0;
  const double L = 0.8, d = 0.04, kb = 2e7, mass = 20, Ip = 0.4, Id = 0.25;
  RotorSpec r;
  r.name = "jeff";
  r.z = {0.0, L / 2, L};
  r.sections = {{d, 0.0, m}};
  r.disks = {{"disk", 1, mass, Ip, Id}};
  Bearing b1{"left", 0, 0, -1, -1, kb, kb, 0, 0, {}}, b2{"right", 0, 2, -1, -1, kb, kb, 0, 0, {}};
  const Assembly a({r}, {}, {b1, b2});
  const Section s = section(d, m);
  const double kt = 1.0 / (1.0 / (2 * kb) + std::pow(L, 3) / (48 * s.EI) + L / (4 * s.kGA));
  const double kth = 1.0 / (2.0 / (kb * L * L) + L / (12 * s.EI) + 1.0 / (s.kGA * L));
  const auto D = a.dense();
  for (int i = 0; i < D.n; ++i)
    for (int j = 0; j < D.n; ++j) ASSERT_EQ(D.G[i * D.n + j], -D.G[j * D.n + i]);
  double worst = 0;
  for (double omega : {0.0, 300.0, 1000.0, 3000.0, 10000.0}) {
    std::vector<double> ref = {std::sqrt(kt / mass), std::sqrt(kt / mass),
                               (-Ip * omega + std::sqrt(Ip * Ip * omega * omega + 4 * Id * kth)) / (2 * Id),
                               (Ip * omega + std::sqrt(Ip * Ip * omega * omega + 4 * Id * kth)) / (2 * Id)};
    std::sort(ref.begin(), ref.end());
    const auto lam = whirl_eigenvalues(a, omega);
    ASSERT_EQ(lam.size(), 4u) << "at " << omega;
    for (int k = 0; k < 4; ++k) {
      EXPECT_NEAR(lam[k].real(), 0.0, 1e-8 * ref[3]);
      worst = std::max(worst, std::fabs(lam[k].imag() / ref[k] - 1.0));
    }
  }
  EXPECT_LT(worst, 1e-9);
  // A real rotor (shaft mass, disks, two spools) keeps G exactly skew.
  RotorSpec r2 = r;
  r2.sections[0].material = Material{};
  r2.speed_ratio = -0.7;
  const auto D2 = Assembly({r, r2}, {}, {}).dense();
  for (int i = 0; i < D2.n; ++i)
    for (int j = 0; j < D2.n; ++j) ASSERT_EQ(D2.G[i * D2.n + j], -D2.G[j * D2.n + i]);
  expect_same_on_ranks(worst, "Campbell error");
}

TEST(RampupLoad, UnbalanceForceIsMinusTheMassTimesItsAcceleration) {
  // f = -me d^2/dt^2 (cos theta, sin theta), theta = s * angle(t) + phase, by finite differences
  // of the load case's own angle law, during the ramp (Omega' term) and after it.
  RotorSpec r;
  r.name = "r";
  r.z = {0.0};
  r.disks = {{"d", 0, 1.0, 0.1, 0.1}};
  r.unbalances = {{"d", 2e-3, 0.7}};
  r.speed_ratio = -1.3;
  const Assembly a({r}, {}, {});
  LoadCase lc;
  lc.omega_max = 400;
  lc.ramp_time = 2.0;
  for (double t : {0.0, 0.37, 1.2, 2.5}) {
    std::vector<double> f(a.n(), 0.0);
    a.add_unbalance(lc.speed(t), lc.acceleration(t), lc.angle(t), f.data());
    const double h = 1e-5;  // central differences: (W h)^2 / 12 ~ 2e-6 relative
    auto pos = [&](double tt, int c) {
      const double th = r.speed_ratio * lc.angle(tt) + 0.7;
      return c == 0 ? std::cos(th) : std::sin(th);
    };
    for (int c = 0; c < 2; ++c) {
      const double t0 = std::max(t, h);  // one-sided at t = 0 is not needed: use t >= h
      const double acc = (pos(t0 + h, c) - 2 * pos(t0, c) + pos(t0 - h, c)) / (h * h);
      std::vector<double> g(a.n(), 0.0);
      a.add_unbalance(lc.speed(t0), lc.acceleration(t0), lc.angle(t0), g.data());
      EXPECT_NEAR(g[c], -2e-3 * acc, 1e-4 * 2e-3 * std::pow(1.3 * 400, 2)) << "t = " << t0 << " c = " << c;
    }
  }
}

TEST(RampupIntegrate, JeffcottSteadyUnbalanceResponse) {
  // |X| = me W^2 / |k - m W^2 + i c W|, bearing force |k + i c W| |X|, at constant speed from rest
  // (the transient decays: zeta = 0.05, 16 time constants).
  const double m = 10, k = 1e6, me = 1e-4, zeta = 0.05, c = 2 * zeta * std::sqrt(k * m), W = 250;
  const Assembly a = jeffcott(m, k, c, me);
  LoadCase lc;
  lc.kind = LoadCase::Kind::Constant;
  lc.omega_max = W;
  IntegratorSettings s;
  const double period = 2 * M_PI / W;
  s.dt = period / 200;
  s.t_final = 1.0;
  double xmax = 0, fmax = 0, rmax = 0;
  const auto stats = integrate(a, lc, s, [&](const StepOutput& o) {
    if (o.t < s.t_final - period) return;
    xmax = std::max(xmax, std::fabs(o.x[0]));
    rmax = std::max(rmax, std::hypot(o.rotor_disp[0], o.rotor_disp[1]));
    fmax = std::max(fmax, std::hypot(o.force[0], o.force[1]));
    EXPECT_EQ(o.stator_disp[0], 0.0);
  });
  EXPECT_TRUE(stats.warnings.empty());
  const double X = me * W * W / std::abs(std::complex<double>(k - m * W * W, c * W));
  // Newmark's period error (W h)^2 / 12 = 8e-5, amplified ~5x by the resonance nearby.
  EXPECT_NEAR(xmax / X, 1.0, 1e-3);
  EXPECT_NEAR(rmax / X, 1.0, 1e-3);  // a circular orbit
  EXPECT_NEAR(fmax / (std::abs(std::complex<double>(k, c * W)) * X), 1.0, 1e-3);
  const auto Xf = unbalance_response(a, W, 0);
  EXPECT_NEAR(std::abs(Xf[0]) / X, 1.0, 1e-12);
  if (world_rank() == 0)
    std::printf("[ rampup ] Jeffcott |X| closed form %.6e, integrated %.6e, orbit %.6e\n", X, xmax, rmax);
  expect_same_on_ranks(xmax, "Jeffcott amplitude");
}

TEST(RampupIntegrate, NewmarkAndHHTAreSecondOrder) {
  // Undamped Jeffcott from rest at constant speed: x = A (cos W t - cos w t),
  // y = A (sin W t - (W / w) sin w t), A = me W^2 / (k - m W^2).
  const double m = 10, k = 1e6, me = 1e-4, W = 200, w = std::sqrt(k / m), A = me * W * W / (k - m * W * W);
  const Assembly a = jeffcott(m, k, 0.0, me);
  LoadCase lc;
  lc.kind = LoadCase::Kind::Constant;
  lc.omega_max = W;
  const double T = 0.1;
  for (double alpha : {0.0, -0.1}) {
    std::vector<double> err;
    for (int nsteps : {400, 800, 1600}) {
      IntegratorSettings s;
      s.dt = T / nsteps;
      s.t_final = T;
      s.alpha = alpha;
      double e = 0;
      integrate(a, lc, s, [&](const StepOutput& o) {
        const double x = A * (std::cos(W * o.t) - std::cos(w * o.t)),
                     y = A * (std::sin(W * o.t) - W / w * std::sin(w * o.t));
        e = std::max(e, std::hypot(o.x[0] - x, o.x[1] - y));
      });
      err.push_back(e / std::fabs(A));
    }
    const double r1 = std::log2(err[0] / err[1]), r2 = std::log2(err[1] / err[2]);
    EXPECT_NEAR(r1, 2.0, 0.1) << "alpha " << alpha;
    EXPECT_NEAR(r2, 2.0, 0.1) << "alpha " << alpha;
    if (world_rank() == 0)
      std::printf(
          "[ rampup ] alpha %.2f: max error / A for h, h/2, h/4: %.3e %.3e %.3e (orders %.3f "
          "%.3f)\n",
          alpha, err[0], err[1], err[2], r1, r2);
    expect_same_on_ranks(err[2], "Newmark error");
  }
}

TEST(RampupIntegrate, EnergyIsConservedWithGyroscopicTermsWhenUndampedAndUnforced) {
  StatorModes sm = stator_modes(chain_superelement(false), {101}, 1e4, 0.0);
  RotorSpec r;
  r.name = "r";
  r.z = {0.0, 0.2, 0.4, 0.6};
  r.sections = {{0.05, 0.0, Material{}}};
  r.disks = {{"d", 2, 8.0, 0.3, 0.2}};
  Bearing b1{"a", 0, 0, 0, 103, 4e6, 4e6, 0, 0, {}}, b2{"b", 0, 3, 0, 106, 4e6, 2e6, 0, 0, {}};
  const Assembly a({r}, {sm}, {b1, b2});
  LoadCase lc;
  lc.kind = LoadCase::Kind::Constant;
  lc.omega_max = 900;
  IntegratorSettings s;
  s.dt = 2e-5;
  s.t_final = 2000 * s.dt;
  s.x0.assign(a.n(), 0.0);
  for (int i = 0; i < a.n(); ++i) s.x0[i] = 1e-5 * std::sin(1.0 + 3.0 * i);
  const double e0 = a.energy(s.x0.data(), std::vector<double>(a.n(), 0.0).data());
  double worst = 0;
  integrate(a, lc, s, [&](const StepOutput& o) { worst = std::max(worst, std::fabs(a.energy(o.x, o.v) / e0 - 1)); });
  EXPECT_LT(worst, 1e-10);
  // HHT with alpha < 0 dissipates.
  s.alpha = -0.2;
  double last = 0;
  integrate(a, lc, s, [&](const StepOutput& o) { last = a.energy(o.x, o.v); });
  EXPECT_LT(last, 0.999 * e0);
  if (world_rank() == 0) std::printf("[ rampup ] Newmark energy drift over 2000 steps: %.2e\n", worst);
  expect_same_on_ranks(worst, "energy drift");
}

TEST_F(Rampup, StatorModalBasisOfTheClampedSuperelement) {
  const std::string file = path("chain.h5");
  write_rom(file, chain_superelement(true));
  const Superelement se = read_superelement(file);
  ASSERT_EQ(se.n, 18);
  ASSERT_EQ(se.n_b, 9);
  ASSERT_EQ(se.C.size(), 18u * 18u);
  const auto ref = chain_frequencies();
  // Everything kept: the 15 clamped frequencies.
  const StatorModes all = stator_modes(se, {101}, 1e5);
  ASSERT_EQ(all.n_modes, 15);
  ASSERT_EQ(all.n_total, 15);
  for (int i = 0; i < 15; ++i) EXPECT_NEAR(all.omega[i] / ref[i], 1.0, 1e-11) << "mode " << i;
  // Rayleigh C = 1e-5 K is diagonal in the modal basis: c_i = 1e-5 omega_i^2.
  for (int i = 0; i < 15; ++i) EXPECT_NEAR(all.damping[i] / (1e-5 * ref[i] * ref[i]), 1.0, 1e-9);
  EXPECT_LT(all.damping_offdiag, 1e-9);
  // Boundary rows: nodes 103 and 106, 6 DOFs; mass-normalized modes of unit masses have
  // sum over nodes of phi^2 = 1 per mode, so each boundary entry is at most 1.
  EXPECT_EQ(all.dof_node.size(), 6u);
  for (double p : all.phi) EXPECT_LE(std::fabs(p), 1.0 + 1e-12);
  // Truncation between the 7th and 8th frequencies keeps exactly 7.
  const double fcut = 0.5 * (ref[6] + ref[7]) / (2 * M_PI);
  const StatorModes cut = stator_modes(se, {101}, fcut, 0.01);
  EXPECT_EQ(cut.n_modes, 7);
  for (int i = 0; i < 7; ++i) {
    EXPECT_NEAR(cut.omega[i] / ref[i], 1.0, 1e-11);
    EXPECT_NEAR(cut.damping[i], 0.02 * ref[i], 1e-9 * ref[i]);
  }
  for (std::size_t r = 0; r < cut.dof_node.size(); ++r)
    for (int m = 0; m < 7; ++m) EXPECT_NEAR(std::fabs(cut.phi[r * 7 + m]), std::fabs(all.phi[r * 15 + m]), 1e-9);
  expect_same_on_ranks(cut.omega[6], "stator frequency");
  // The seed's default: 2.5x the top spin speed (the faster of two spools).
  RotorSpec lp, hp;
  lp.speed_ratio = 1.0;
  hp.speed_ratio = -1.6;
  EXPECT_NEAR(default_cut_hz({lp, hp}, 1000.0), 2.5 * 1600.0 / (2 * M_PI), 1e-9);
}

TEST(RampupIntegrate, CondensedStepEqualsTheDenseStep) {
  const Assembly a = rotor_on_chain();
  std::vector<double> fc, fd;
  condensed_and_dense_forces(a, &fc, &fd);
  ASSERT_EQ(fc.size(), fd.size());
  double fmax = 0, diff = 0;
  for (std::size_t i = 0; i < fc.size(); ++i) {
    fmax = std::max(fmax, std::fabs(fd[i]));
    diff = std::max(diff, std::fabs(fc[i] - fd[i]));
  }
  EXPECT_GT(fmax, 0.0);
  EXPECT_LT(diff, 1e-9 * fmax);
}

TEST(RampupIntegrate, SteadyStateOnAStatorMatchesTheFrequencyDomainSolution) {
  const Assembly a = rotor_on_chain();
  const double W = 500, s_ratio = 1.5, w = s_ratio * W;
  const auto X = unbalance_response(a, W, 0);
  // The bearing forces of Re(X e^{iwt}): F^ = F(Re X, Re(iwX)) + i F(Im X, Im(iwX)).
  const int n = a.n();
  std::vector<double> xr(n), xi(n), vr(n), vi(n), Fr(4), Fi(4);
  for (int i = 0; i < n; ++i) {
    xr[i] = X[i].real();
    xi[i] = X[i].imag();
    vr[i] = -w * X[i].imag();
    vi[i] = w * X[i].real();
  }
  a.bearing_state(xr.data(), vr.data(), Fr.data(), nullptr, nullptr);
  a.bearing_state(xi.data(), vi.data(), Fi.data(), nullptr, nullptr);
  LoadCase lc;
  lc.kind = LoadCase::Kind::Constant;
  lc.omega_max = W;
  IntegratorSettings s;
  s.dt = 2 * M_PI / w / 400;
  s.t_final = 0.05;
  s.x0 = xr;  // start on the steady state: x(0) = Re X, v(0) = Re(i w X)
  s.v0 = vr;
  double err = 0, fmax = 0;
  integrate(a, lc, s, [&](const StepOutput& o) {
    for (int j = 0; j < 4; ++j) {
      const double ref = Fr[j] * std::cos(w * o.t) - Fi[j] * std::sin(w * o.t);
      fmax = std::max(fmax, std::hypot(Fr[j], Fi[j]));
      err = std::max(err, std::fabs(o.force[j] - ref));
    }
  });
  // The remaining difference is the integrator's phase error, (w h)^2 / 12 ~ 2e-5 per radian,
  // over w t = 37 radians.
  EXPECT_LT(err / fmax, 2e-3);
  if (world_rank() == 0)
    std::printf(
        "[ rampup ] rotor on stator at %.0f rad/s: bearing force amplitude %.4e N, time vs "
        "frequency "
        "domain %.2e relative\n",
        W, fmax, err / fmax);
  expect_same_on_ranks(err, "steady state");
}

TEST(RampupIntegrate, SlowRampPeaksNearTheCriticalSpeed) {
  const double m = 10, k = 1e6, me = 1e-4, c = 2 * 0.02 * std::sqrt(k * m), wn = std::sqrt(k / m);
  const Assembly a = jeffcott(m, k, c, me);
  LoadCase lc;
  lc.omega_max = 2 * wn;
  lc.ramp_time = 4.0;
  IntegratorSettings s;
  s.dt = 2 * M_PI / lc.omega_max / 40;
  double peak = 0, at = 0;
  integrate(a, lc, s, [&](const StepOutput& o) {
    const double r = std::hypot(o.force[0], o.force[1]);
    if (r > peak) {
      peak = r;
      at = o.speed;
    }
  });
  // The slow-ramp peak lies a little above the critical speed, below the steady peak value.
  EXPECT_GT(at, wn);
  EXPECT_LT(at, 1.1 * wn);
  const double steady = me * wn * wn / (c * wn) * std::hypot(k, c * wn);
  EXPECT_LT(peak, steady);
  EXPECT_GT(peak, 0.5 * steady);
}

TEST_F(Rampup, BadInputGivesClearErrors) {
  using test::expect_error_parts;
  RotorSpec r;
  r.name = "lp";
  r.z = {0.0, 0.5};
  r.sections = {{0.05, 0.0, Material{}}};
  r.disks = {{"turbine", 1, 10, 0.1, 0.05}};
  StatorModes sm = stator_modes(chain_superelement(false), {101}, 1e4);
  Bearing b{"front", 0, 0, 0, 102, 1e6, 1e6, 0, 0, {}};  // 102 is an interior node
  expect_error_parts([&] { Assembly({r}, {sm}, {b}); }, {"bearing 'front'", "node 102", "not in the interface"},
                     "bearing on an interior node");
  b.node = 101;
  expect_error_parts([&] { Assembly({r}, {sm}, {b}); }, {"node 101", "clamped"}, "bearing on a clamped node");
  b.node = 103;
  b.kyy = -1;
  expect_error_parts([&] { Assembly({r}, {sm}, {b}); }, {"bearing 'front'", ">= 0", "kyy -1"}, "negative stiffness");
  b.kyy = 1e6;
  b.station = 7;
  expect_error_parts([&] { Assembly({r}, {sm}, {b}); }, {"station 7"}, "station out of range");
  RotorSpec bad = r;
  bad.unbalances = {{"fan", 1e-3, 0.0}};
  expect_error_parts([&] { rotor_matrices(bad); }, {"rotor 'lp'", "disk 'fan'", "no such disk"},
                     "unbalance on a missing disk");
  bad = r;
  bad.z = {0.0, 0.0};
  expect_error_parts([&] { rotor_matrices(bad); }, {"rotor 'lp'", "strictly increasing"}, "zero-length element");
  bad = r;
  bad.sections[0].d_inner = 0.06;
  expect_error_parts([&] { rotor_matrices(bad); }, {"rotor 'lp'", "element 0", "d_inner < d_outer"}, "bad section");
  expect_error_parts([&] { stator_modes(chain_superelement(false), {999}, 1e3); },
                     {"clamped node 999", "not a boundary"}, "unknown clamped node");
  expect_error_parts([&] { stator_modes(chain_superelement(false), {101}, 0.0); }, {"truncation frequency", "positive"},
                     "zero cut");
  {
    io::H5Output out(MPI_COMM_SELF, path("norom.h5"));
    out.write("/meta/x", std::vector<double>{1.0});
    out.commit();
  }
  expect_error_parts([&] { read_superelement(path("norom.h5")); }, {"norom.h5", "no /rom/K"}, "file without /rom");
  const Assembly a = jeffcott(10, 1e6, 0, 1e-4);
  LoadCase lc;
  lc.omega_max = 1000;
  lc.ramp_time = 1.0;
  IntegratorSettings s;
  expect_error_parts([&] { integrate(a, lc, s, nullptr); }, {"time step", "positive"}, "dt = 0");
  s.dt = 1e-3;
  s.alpha = -0.5;
  expect_error_parts([&] { integrate(a, lc, s, nullptr); }, {"HHT alpha", "[-1/3, 0]"}, "alpha");
  s.alpha = 0;
  s.t_final = 0.01;
  const auto st = integrate(a, lc, s, nullptr);  // 1000 rad/s, 1e-3 s: 6.3 steps per revolution
  ASSERT_EQ(st.warnings.size(), 1u);
  EXPECT_NE(st.warnings[0].find("steps per revolution"), std::string::npos);
  // A massless rotor DOF (shaft without density, no disk at one end) makes M singular.
  RotorSpec ml = r;
  ml.sections[0].material.rho = 0;
  ml.unbalances = {{"turbine", 1e-4, 0}};
  const Assembly am({ml}, {}, {});
  expect_error_parts([&] { integrate(am, lc, s, nullptr); }, {"mass matrix is singular"}, "massless DOF");
}

TEST(RampupPerformance, StepCostIsLinearInTheStatorModes) {
  // Synthetic stator modal bases of N modes (13 interface nodes), two 20-station rotors on five
  // bearings. Measures the condensed step against N, and the dense step for small N.
  auto model = [](int N) {
    StatorModes sm;
    sm.name = "synthetic";
    sm.n_modes = N;
    for (int i = 0; i < N; ++i) {
      sm.omega.push_back(2 * M_PI * (50.0 + 10.0 * i));
      sm.damping.push_back(0.04 * sm.omega.back());
    }
    for (int node = 1; node <= 13; ++node)
      for (int c = 1; c <= 3; ++c) {
        sm.dof_node.push_back(node);
        sm.dof_component.push_back(c);
        for (int i = 0; i < N; ++i) sm.phi.push_back(0.01 * std::sin(0.3 * node + 1.7 * c + 0.11 * i));
      }
    std::vector<RotorSpec> rotors(2);
    for (int k = 0; k < 2; ++k) {
      rotors[k].name = k ? "hp" : "lp";
      for (int st = 0; st < 20; ++st) rotors[k].z.push_back(0.1 * st);
      rotors[k].sections = {{0.08 - 0.02 * k, 0.04 - 0.02 * k, Material{}}};
      rotors[k].disks = {{"d", 10, 20.0, 0.5, 0.3}};
      rotors[k].unbalances = {{"d", 1e-3, 0}};
      rotors[k].speed_ratio = k ? 1.6 : 1.0;
    }
    std::vector<Bearing> b = {{"1", 0, 0, 0, 1, 1e8, 1e8, 1e3, 1e3, {}},
                              {"2", 0, 19, 0, 2, 1e8, 1e8, 1e3, 1e3, {}},
                              {"3", 1, 0, 0, 3, 1e8, 1e8, 1e3, 1e3, {}},
                              {"4", 1, 19, 0, 4, 1e8, 1e8, 1e3, 1e3, {}},
                              {"5", 1, 10, 0, 5, 5e7, 5e7, 1e3, 1e3, {}}};
    return Assembly(rotors, {sm}, b);
  };
  auto per_step = [](const Assembly& a, bool dense, int steps) {
    LoadCase lc;
    lc.omega_max = 1000;
    lc.ramp_time = 1.0;
    IntegratorSettings s;
    s.dt = 1e-5;
    s.t_final = steps * s.dt;
    s.dense = dense;
    s.output_every = steps;
    return integrate(a, lc, s, nullptr).seconds / steps;
  };
  std::vector<double> tc;
  const std::vector<int> Ns = {50, 250, 1000, 2000};
  for (int N : Ns) tc.push_back(per_step(model(N), false, 400));
  const double td100 = per_step(model(100), true, 20), td400 = per_step(model(400), true, 5);
  if (world_rank() == 0) {
    std::printf("[ rampup ] condensed step (R = 160 rotor DOFs, 10 bearing directions):");
    for (std::size_t i = 0; i < Ns.size(); ++i) std::printf(" N=%d %.1f us;", Ns[i], 1e6 * tc[i]);
    std::printf("\n[ rampup ] dense step: N=100 %.2f ms; N=400 %.2f ms\n", 1e3 * td100, 1e3 * td400);
  }
  // Linear: 8x the modes from 250 to 2000 costs at most ~8x (allow timing noise on a shared
  // machine); the dense step is cubic.
  EXPECT_LT(tc[3] / tc[1], 16.0);
  EXPECT_GT(td400, tc[2]);
}

TEST(RampupAssembly, BearingOnSeveralNodesSitsOnTheirMean) {
  // A housing spread over nodes 103 and 106 (equal weights): the housing displacement is the mean
  // of the nodes' x, y translations, and the bearing stiffness k w w^T with w = e_rotor - mean of
  // the nodes' basis rows, whatever the state.
  StatorModes sm = stator_modes(chain_superelement(false), {101}, 1e4, 0.0);
  RotorSpec r;
  r.name = "r";
  r.z = {0.0, 0.4};
  r.sections = {{0.05, 0.0, Material{}}};
  Bearing b{"seat", 0, 1, 0, -1, 3e6, 2e6, 0, 0, {103, 106}};
  const Assembly a({r}, {sm}, {b});
  const int n = a.n(), N = sm.n_modes;
  auto row = [&](std::int64_t node, int comp) {
    for (std::size_t i = 0; i < sm.dof_node.size(); ++i)
      if (sm.dof_node[i] == node && sm.dof_component[i] == comp)
        return std::vector<double>(sm.phi.begin() + i * N, sm.phi.begin() + (i + 1) * N);
    ADD_FAILURE() << "no row";
    return std::vector<double>(N, 0.0);
  };
  std::vector<double> x(n);
  for (int i = 0; i < n; ++i) x[i] = std::sin(0.7 * i + 0.3);
  double F[2], ur[2], us[2];
  a.bearing_state(x.data(), nullptr, F, ur, us);
  const AssembledMatrices A = a.dense();
  double worst = 0;
  for (int d = 0; d < 2; ++d) {
    const auto p3 = row(103, d + 1), p6 = row(106, d + 1);
    double u3 = 0, u6 = 0;
    for (int m = 0; m < N; ++m) u3 += p3[m] * x[m], u6 += p6[m] * x[m];
    const double k = d == 0 ? 3e6 : 2e6;
    worst = std::max(worst, std::fabs(us[d] - 0.5 * (u3 + u6)) / std::fabs(u3));
    worst = std::max(worst, std::fabs(F[d] - k * (ur[d] - 0.5 * (u3 + u6))) / std::fabs(F[d]));
    // The coupling block of K: K[rotor][m] = -k (p3 + p6)_m / 2.
    const int rd = a.rotor_dof(0, 1, d);
    for (int m = 0; m < N; ++m) worst = std::max(worst, std::fabs(A.K[rd * n + m] + 0.5 * k * (p3[m] + p6[m])) / k);
  }
  EXPECT_LT(worst, 1e-12);
  Bearing twice = b;
  twice.nodes = {103, 103};
  test::expect_error_parts([&] { Assembly({r}, {sm}, {twice}); }, {"bearing 'seat'", "node 103", "twice"},
                           "a node listed twice");
  expect_same_on_ranks(worst, "mean housing");
}

TEST(RampupErrors, FeatureErrorIsSeedEquation24) {
  // x_ref spans [-2, 3] (range 5); x = x_ref + 0.1 at one sample: eq. 24 gives 0.1 / 5.
  std::vector<double> ref = {0, 3, -2, 1, 0.5}, x = ref;
  EXPECT_EQ(feature_error(x.data(), ref.data(), 5, 1), 0.0);
  x[3] += 0.1;
  EXPECT_NEAR(feature_error(x.data(), ref.data(), 5, 1), 0.1 / 5, 1e-15);
  // Strided: the second of two interleaved features.
  std::vector<double> two(10), two_ref(10);
  for (int i = 0; i < 5; ++i) two[2 * i + 1] = x[i], two_ref[2 * i + 1] = ref[i], two[2 * i] = 7;
  EXPECT_NEAR(feature_error(two.data() + 1, two_ref.data() + 1, 5, 2), 0.1 / 5, 1e-15);
  // A constant reference that differs: infinite relative error.
  std::vector<double> c(3, 1.0), y = {1.0, 1.0, 1.5};
  EXPECT_TRUE(std::isinf(feature_error(y.data(), c.data(), 3, 1)));
}

TEST(RampupErrors, ErrorsAgainstTheLargestBearingRange) {
  // Two bearings: bearing 1 carries +-200 N (range 400 in x, 100 in y), bearing 2 +-0.01 N (range
  // 0.02). A deviation of 0.01 N on bearing 2 is eq. 24's 50 % but 0.0025 % of the largest range;
  // 4 N on bearing 1 x is 1 % of both.
  History ref, h;
  ref.n_bearings = h.n_bearings = 2;
  for (int i = 0; i < 5; ++i) {
    const double s = std::sin(1.3 * i);
    ref.t.push_back(0.1 * i);
    ref.omega.push_back(0);
    for (double v : {200 * s, 50 * s, 0.01 * s, 0.01 * s}) ref.force.push_back(v), ref.rotor_disp.push_back(1e-3 * v);
  }
  ref.stator_disp = ref.rotor_disp;
  h = ref;
  h.force[4 * 2 + 0] += 4.0;   // bearing 1 x at sample 2
  h.force[4 * 3 + 2] += 0.01;  // bearing 2 x at sample 3
  const auto e = compare(h, ref);
  double lo = 0, hi = 0;  // range of bearing 1 x over the samples
  for (int i = 0; i < 5; ++i) lo = std::min(lo, ref.force[4 * i]), hi = std::max(hi, ref.force[4 * i]);
  double lo2 = 0, hi2 = 0;
  for (int i = 0; i < 5; ++i) lo2 = std::min(lo2, ref.force[4 * i + 2]), hi2 = std::max(hi2, ref.force[4 * i + 2]);
  EXPECT_NEAR(e.force[0], 4.0 / (hi - lo), 1e-14);
  EXPECT_NEAR(e.force[2], 0.01 / (hi2 - lo2), 1e-12);
  EXPECT_EQ(e.force_dominant, 2);  // bearing 2 x sets eq. 24's worst
  EXPECT_NEAR(e.force_scale, hi - lo, 1e-12);
  EXPECT_NEAR(e.force_global[0], 4.0 / (hi - lo), 1e-14);
  EXPECT_NEAR(e.force_global[2], 0.01 / (hi - lo), 1e-14);
  EXPECT_NEAR(e.force_global_worst, 4.0 / (hi - lo), 1e-14);
  EXPECT_NEAR(e.force_global_mean, (4.0 + 0.01) / (hi - lo) / 4, 1e-14);
  EXPECT_EQ(e.displacement_global_worst, 0.0);
}

TEST(RampupErrors, ScoreReproducesSeedTable1) {
  // Seed 000 Table 1: (time t/t_ref, mean load error %, printed score /20), every row.
  const double rows[][3] = {{1.01, 1.1, 8.9},  {0.45, 10.2, 5.5}, {0.66, 1.5, 11.9}, {0.37, 2.6, 13.7},
                            {0.30, 3.3, 13.7}, {0.63, 1.2, 12.5}, {0.51, 1.7, 13.2}, {0.33, 5.0, 11.7},
                            {0.51, 1.8, 13.1}, {0.12, 24.9, 8.8}, {0.58, 4.0, 10.2}, {0.45, 9.3, 6.2}};
  for (const auto& r : rows) EXPECT_NEAR(score(r[1] / 100, r[0], 1.0), r[2], 0.051) << "row t = " << r[0];
}

// ------------------------------------------------------------------------------------------
// Intershaft bearings and torsion (docs/rampup-theory.md §4.2–4.3)

namespace {

// A rigid rotor: one station, one disk (diametral inertia half the polar one, at least 0.01).
RotorSpec rigid_rotor(const std::string& name, double m, double Ip, double ratio) {
  RotorSpec r;
  r.name = name;
  r.z = {0.0};
  r.disks = {{name + "_disk", 0, m, Ip, std::max(0.01, 0.5 * Ip)}};
  r.speed_ratio = ratio;
  return r;
}

}  // namespace

TEST(RampupAssembly, IntershaftBearingCouplesTwoRotors) {
  // Two rigid disks on ground springs k1, k2, joined by an intershaft spring k12; no spin
  // coupling (Ip = 0): the lateral frequencies are those of the 2-DOF chain, twice (x and y).
  const double m1 = 4, m2 = 9, k1 = 2e6, k2 = 5e6, k12 = 3e6;
  RotorSpec a = rigid_rotor("lp", m1, 0.0, 1.0), b = rigid_rotor("hp", m2, 0.0, 2.0);
  Bearing g1{"g1", 0, 0, -1, -1, k1, k1, 0, 0, {}};
  Bearing g2{"g2", 1, 0, -1, -1, k2, k2, 0, 0, {}};
  Bearing is{"inter", 0, 0, -1, -1, k12, k12, 0, 0, {}, 1, 0};
  const Assembly as({a, b}, {}, {g1, g2, is});
  const double p = (k1 + k12) / m1 + (k2 + k12) / m2, q = ((k1 + k12) * (k2 + k12) - k12 * k12) / (m1 * m2);
  const double w1 = std::sqrt(0.5 * (p - std::sqrt(p * p - 4 * q))),
               w2 = std::sqrt(0.5 * (p + std::sqrt(p * p - 4 * q)));
  // (The disks' tilts have no stiffness: their zero eigenvalues are left out.)
  std::vector<std::complex<double>> lam;
  for (const auto& l : whirl_eigenvalues(as, 100.0))
    if (l.imag() > 1.0) lam.push_back(l);
  ASSERT_EQ(lam.size(), 4u);
  EXPECT_NEAR(lam[0].imag(), w1, 1e-10 * w1);
  EXPECT_NEAR(lam[1].imag(), w1, 1e-10 * w1);
  EXPECT_NEAR(lam[2].imag(), w2, 1e-10 * w2);
  EXPECT_NEAR(lam[3].imag(), w2, 1e-10 * w2);
  // The force of the intershaft bearing is k12 (x_lp - x_hp); its "housing" is the hp station.
  std::vector<double> x(as.n(), 0.0), F(6), ur(6), uh(6);
  x[as.rotor_dof(0, 0, 0)] = 1e-3;
  x[as.rotor_dof(1, 0, 0)] = 4e-4;
  x[as.rotor_dof(1, 0, 1)] = -2e-4;
  as.bearing_state(x.data(), nullptr, F.data(), ur.data(), uh.data());
  EXPECT_NEAR(F[4], k12 * (1e-3 - 4e-4), 1e-9);
  EXPECT_NEAR(F[5], k12 * 2e-4, 1e-9);
  EXPECT_EQ(uh[4], 4e-4);
  // The condensed step equals the dense one with an intershaft bearing beside a stator (the
  // chain rotor's bearings) and a ground bearing: a second rotor hung on the first.
  const Assembly chain = rotor_on_chain();
  RotorSpec hp = rigid_rotor("core", 3.0, 0.01, 2.2);
  hp.unbalances = {{"core_disk", 5e-5, 1.0}};
  std::vector<Bearing> bs = chain.bearings();
  bs.push_back({"core_rear", 1, 0, -1, -1, 1e6, 1e6, 100, 100, {}});
  bs.push_back({"core_inter", 1, 0, -1, -1, 4e6, 3e6, 200, 150, {}, 0, 2});
  const Assembly two(std::vector<RotorSpec>{chain.rotors()[0], hp}, chain.stators(), bs);
  std::vector<double> fc, fd;
  condensed_and_dense_forces(two, &fc, &fd);
  ASSERT_EQ(fc.size(), fd.size());
  double fmax = 0, diff = 0, inter = 0;
  for (std::size_t i = 0; i < fc.size(); ++i) {
    fmax = std::max(fmax, std::fabs(fd[i]));
    diff = std::max(diff, std::fabs(fc[i] - fd[i]));
    if (i % 8 >= 6) inter = std::max(inter, std::fabs(fd[i]));
  }
  EXPECT_GT(inter, 0.0);
  EXPECT_LT(diff, 1e-9 * fmax);
  expect_same_on_ranks(diff, "intershaft condensed vs dense");
  // Bad intershaft bearings.
  using test::expect_error_parts;
  Bearing same{"same", 0, 0, -1, -1, 1e6, 1e6, 0, 0, {}, 0, 0};
  expect_error_parts([&] { Assembly({a, b}, {}, {same}); }, {"bearing 'same'", "two different rotors"}, "same rotor");
  Bearing far{"far", 0, 0, -1, -1, 1e6, 1e6, 0, 0, {}, 1, 3};
  expect_error_parts(
      [&] {
        Assembly({a, b}, {}, {far});
      },
      {"bearing 'far'", "station 3", "does not exist"}, "station out of range");
}

TEST(RampupTorsion, ShaftWithAnEndDiskConvergesToTheExactFrequency) {
  // A uniform shaft driven at z = 0 with a disk of polar inertia Id at z = L: the first torsional
  // frequency w = beta c / L, beta tan beta = rho J L / Id, c = sqrt(G / rho). Linear elements
  // with consistent mass converge from above at O(h^2).
  const double L = 0.8, d = 0.06, di = 0.03, Id = 0.05;
  const Material mat;
  const double J = M_PI * (std::pow(d, 4) - std::pow(di, 4)) / 32, G = mat.E / (2 * (1 + mat.nu)),
               c = std::sqrt(G / mat.rho), ratio = mat.rho * J * L / Id;
  double beta = 0.5;  // Newton on beta tan beta = ratio in (0, pi/2)
  for (int it = 0; it < 50; ++it) {
    const double f = beta * std::tan(beta) - ratio, df = std::tan(beta) + beta / std::pow(std::cos(beta), 2);
    beta -= f / df;
  }
  const double exact = beta * c / L;
  std::vector<double> err;
  for (int ne : {4, 8, 16, 32}) {
    RotorSpec r;
    r.name = "shaft";
    for (int k = 0; k <= ne; ++k) r.z.push_back(L * k / ne);
    r.sections = {{d, di, mat}};
    r.disks = {{"end", ne, 1.0, Id, 0.5 * Id}};
    Torsion t;
    t.drives = {{"motor", 0, 0}};
    const Assembly a({r}, {}, {}, t);
    ASSERT_EQ(a.n_torsion(), ne + 1);
    ASSERT_EQ(a.free_twists().size(), static_cast<std::size_t>(ne));
    const double w = a.torsion_frequencies().at(0);
    EXPECT_GT(w, exact);
    err.push_back((w - exact) / exact);
  }
  for (std::size_t k = 1; k < err.size(); ++k) EXPECT_NEAR(err[k - 1] / err[k], 4.0, 0.1) << "refinement " << k;
  EXPECT_LT(err.back(), 1e-4);
  if (world_rank() == 0)
    std::printf("[ rampup ] torsion of a shaft with an end disk: %.6f Hz exact, errors %.2e %.2e %.2e %.2e\n",
                exact / (2 * M_PI), err[0], err[1], err[2], err[3]);
  expect_same_on_ranks(err.back(), "torsion frequency");
}

TEST(RampupTorsion, GearedRampMatchesTheClosedFormAtSecondOrder) {
  // The LP disk J1 is driven (its speed is the ramp Omega = Omega' t); a gear stage of ratio n
  // turns the fan disk J2 at Omega / n against the aerodynamic torque -cT (Omega / n)^2. The fan's
  // twist obeys J2 phi'' + n^2 k phi = -J2 Omega' / n - cT (Omega' t / n)^2 from rest, whose
  // exact solution is phi = p0 + p2 t^2 - p0 cos(w t), w^2 = n^2 k / J2, p2 = B / (n^2 k),
  // p0 = (A - 2 J2 p2) / (n^2 k); the mesh torque is T = -n k phi and the drive's torque
  // J1 Omega' + T. Newmark converges to it at second order.
  const double J1 = 0.8, J2 = 6.0, n = 3.0, k = 4e5, cT = 0.02, wdot = 400.0;
  Torsion t;
  t.drives = {{"turbine", 0, 0}};
  t.gearboxes = {{"pgb", 0, 0, 1, 0, n, k, 0.0}};
  t.torques = {{"fan_aero", 1, 0, cT}};
  const Assembly a({rigid_rotor("lp", 10, J1, 1.0), rigid_rotor("fan", 40, J2, 1.0 / n)}, {}, {}, t);
  ASSERT_EQ(a.n_torsion(), 2);
  const double kk = n * n * k, w = std::sqrt(kk / J2), A = -J2 * wdot / n, B = -cT * wdot * wdot / (n * n), p2 = B / kk,
               p0 = (A - 2 * J2 * p2) / kk;
  ASSERT_NEAR(a.torsion_frequencies().at(0), w, 1e-12 * w);
  LoadCase lc;
  lc.omega_max = wdot * 0.5;
  lc.ramp_time = 0.5;
  std::vector<double> err_T, err_D;
  for (double dt : {1e-4, 5e-5, 2.5e-5}) {
    IntegratorSettings s;
    s.dt = dt;
    s.t_final = 0.1;
    double eT = 0, eD = 0, scale = 0;
    integrate(a, lc, s, [&](const StepOutput& o) {
      ASSERT_NE(o.gearbox_torque, nullptr);
      const double phi = p0 + p2 * o.t * o.t - p0 * std::cos(w * o.t), T = -n * k * phi;
      scale = std::max(scale, std::fabs(T));
      eT = std::max(eT, std::fabs(o.gearbox_torque[0] - T));
      eD = std::max(eD, std::fabs(o.drive_torque[0] - (J1 * wdot + T)));
    });
    err_T.push_back(eT / scale);
    err_D.push_back(eD / scale);
  }
  for (std::size_t i = 1; i < err_T.size(); ++i) {
    EXPECT_NEAR(err_T[i - 1] / err_T[i], 4.0, 0.3) << "mesh torque, refinement " << i;
    EXPECT_NEAR(err_D[i - 1] / err_D[i], 4.0, 0.3) << "drive torque, refinement " << i;
  }
  EXPECT_LT(err_T.back(), 1e-2);
  if (world_rank() == 0)
    std::printf("[ rampup ] geared ramp: mesh torque errors %.2e %.2e %.2e, drive %.2e %.2e %.2e\n", err_T[0], err_T[1],
                err_T[2], err_D[0], err_D[1], err_D[2]);
  expect_same_on_ranks(err_T.back(), "geared ramp");
  // Torsion is uncoupled from the lateral model: the bearing loads are bitwise the same with it.
  const Assembly chain = rotor_on_chain();
  Torsion tc;
  tc.drives = {{"d", 0, 0}};
  tc.torques = {{"aero", 0, 3, 1e-3}};
  const Assembly twisted(chain.rotors(), chain.stators(), chain.bearings(), tc);
  IntegratorSettings s;
  s.dt = 5e-5;
  LoadCase lr;
  lr.omega_max = 600;
  lr.ramp_time = 0.02;
  std::vector<double> f0, f1, dr;
  integrate(chain, lr, s, [&](const StepOutput& o) { f0.insert(f0.end(), o.force, o.force + 4); });
  integrate(twisted, lr, s, [&](const StepOutput& o) {
    f1.insert(f1.end(), o.force, o.force + 4);
    dr.push_back(o.drive_torque[0]);
  });
  EXPECT_EQ(f0, f1);
  EXPECT_GT(std::fabs(dr.back()), 0.0);
}

TEST(RampupTorsion, BadTorsionGivesClearErrors) {
  using test::expect_error_parts;
  const RotorSpec lp = rigid_rotor("lp", 10, 0.8, 1.0), fan = rigid_rotor("fan", 40, 6.0, 1.0 / 3.0);
  Torsion t;
  t.torques = {{"aero", 1, 0, 0.02}};
  expect_error_parts([&] { Assembly({lp, fan}, {}, {}, t); }, {"rotor 'lp'", "not driven"}, "no drive");
  t.drives = {{"turbine", 0, 0}};
  expect_error_parts([&] { Assembly({lp, fan}, {}, {}, t); }, {"rotor 'fan'", "not driven"}, "fan not geared");
  t.gearboxes = {{"pgb", 0, 0, 1, 0, 2.5, 1e5, 0.0}};
  expect_error_parts(
      [&] {
        Assembly({lp, fan}, {}, {}, t);
      },
      {"gearbox 'pgb'", "ratio 2.5", "speed ratios agree"}, "ratio mismatch");
  t.gearboxes[0].ratio = 3.0;
  t.gearboxes[0].k = 0.0;
  expect_error_parts([&] { Assembly({lp, fan}, {}, {}, t); }, {"gearbox 'pgb'", "mesh stiffness", "> 0"}, "k = 0");
  t.gearboxes[0].k = 1e5;
  t.drives.push_back({"again", 0, 0});
  expect_error_parts([&] { Assembly({lp, fan}, {}, {}, t); }, {"drive 'again'", "driven twice"}, "drive twice");
  t.drives.pop_back();
  t.torques[0].coefficient = -1;
  expect_error_parts([&] { Assembly({lp, fan}, {}, {}, t); }, {"torque 'aero'", ">= 0"}, "negative torque");
  t.torques[0].coefficient = 0.02;
  t.torques[0].station = 2;
  expect_error_parts([&] { Assembly({lp, fan}, {}, {}, t); }, {"torque 'aero'", "station 2"}, "torque station");
  t.torques[0].station = 0;
  // A massless free twist DOF: a shaft without density and no disk at its far end.
  RotorSpec ml;
  ml.name = "ml";
  ml.z = {0.0, 0.5};
  ml.sections = {{0.05, 0.0, Material{2.1e11, 0.3, 0.0}}};
  ml.disks = {{"d", 0, 1.0, 0.1, 0.05}};
  Torsion tm;
  tm.drives = {{"m", 0, 0}};
  const Assembly am({ml}, {}, {Bearing{"b", 0, 1, -1, -1, 1e6, 1e6, 0, 0, {}}}, tm);
  LoadCase lc;
  lc.omega_max = 100;
  lc.ramp_time = 1;
  IntegratorSettings s;
  s.dt = 1e-3;
  s.t_final = 0.01;
  expect_error_parts([&] { integrate(am, lc, s, nullptr); }, {"torsional mass matrix is singular"}, "massless twist");
}
