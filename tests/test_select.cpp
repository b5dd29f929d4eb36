// Fixed-interface mode ranking (seed 000 §2.2–2.3): cantilever effective-mass fractions against
// Euler–Bernoulli, the completeness identity of Kammer's P, the relations of eq. 17, exact
// reproduction of plain Craig–Bampton, truncation rules and bad input.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <fstream>

#include "morse/core/session.hpp"
#include "morse/eigen/eigen.hpp"
#include "morse/mesh/partition.hpp"
#include "morse/select/select.hpp"
#include "scratch.hpp"
#include "util.hpp"

using namespace morse;
using mesh::ElementType;

namespace {

struct Problem {
  mesh::LocalMesh lm;
  fe::DofLayout dofs;
  fe::Operators ops;
  cb::CBResult cb;
  select::InterfaceCoupling ic;
};

Problem make(MPI_Comm comm, const mesh::BoxSpec& b, const std::vector<std::string>& clamp, const std::string& boundary,
             PetscInt n_fixed) {
  Problem s;
  s.lm = test::box_mesh(comm, b);
  s.dofs = fe::number_dofs(s.lm, clamp);
  s.ops = fe::assemble(s.lm, s.dofs, test::steel());
  cb::CBSettings cs;
  cs.boundary_set = boundary;
  cs.n_fixed = n_fixed;
  cs.keep_basis = true;
  cs.prefix = "test_sel_";
  s.cb = cb::craig_bampton(test::model_of(s.lm, s.dofs, s.ops), cs);
  s.ic = select::interface_coupling(comm, s.ops.K.get(), s.ops.M.get(), s.cb);
  return s;
}

// A distorted box clamped at x0 with the boundary at x1, keeping all its n_i interior modes.
Problem all_interior_modes(PetscInt* n_i) {
  auto b = test::box_spec(ElementType::Hex8, 1.0, 0.3, 0.2, 5, 1, 1);
  b.distortion = 0.1;
  auto lm = test::box_mesh(PETSC_COMM_WORLD, b);
  auto dofs = fe::number_dofs(lm, {"x0"});
  *n_i = dofs.n_global - 3 * lm.node_set_sizes.at("x1");
  return make(PETSC_COMM_WORLD, b, {"x0"}, "x1", *n_i);
}

}  // namespace

// A slender cantilever (L = 50 h) whose interface is its clamped end face: the effective mass of
// each fixed-interface mode for a rigid translation of the interface in z, over the total mass,
// equals the Euler–Bernoulli modal effective-mass fractions 0.6131, 0.1883, 0.0647, 0.0331.
TEST(Select, CantileverEffectiveMassFractions) {
  auto b = test::box_spec(ElementType::Hex20, 1.0, 0.03, 0.02, 40, 3, 2);
  auto s = make(PETSC_COMM_WORLD, b, {}, "x0", 16);
  auto f = select::directional_mass_fractions(s.ic, s.ops.mass);
  // Modes bending in z: their z fraction dominates.
  std::vector<double> z;
  for (PetscInt i = 0; i < s.cb.n_phi; ++i)
    if (f[3 * i + 2] > 1e-3 && f[3 * i + 2] > 10 * (f[3 * i] + f[3 * i + 1])) z.push_back(f[3 * i + 2]);
  ASSERT_GE(z.size(), 4u);
  if (world_rank() == 0) std::printf("  z fractions: %.5f %.5f %.5f %.5f\n", z[0], z[1], z[2], z[3]);
  const double ref[4] = {0.61310, 0.18830, 0.06474, 0.03306};
  const double tol[4] = {0.01, 0.01, 0.03, 0.03};
  for (int k = 0; k < 4; ++k) EXPECT_NEAR(z[k] / ref[k], 1.0, tol[k]) << "bending mode " << k + 1 << ": " << z[k];
  // The plain trace fractions of eq. 12 mix directions: stored, not expected to match.
  auto eim = select::scores(PETSC_COMM_WORLD, select::Method::EIM, s.ic, s.cb, {}, nullptr);
  EXPECT_EQ((PetscInt)eim.size(), s.cb.n_phi);
}

// Completeness: with every interior mode, sum_i P_i^T P_i = W^T M_ii^{-1} W, W = M_ib + M_ii Psi,
// and (eq. 17) EIM = lambda VEIM = lambda^2 DEIM = lambda CMSchi = OMR / lambda per mode, OMR being
// evaluated from its own formula (eq. 15) with K_sm.
TEST(Select, IdentitiesWithAllInteriorModes) {
  PetscInt n_i = 0;
  Problem s = all_interior_modes(&n_i);
  const PetscInt nb = s.cb.n_b;
  auto P = s.ic.P();
  std::vector<double> sum(nb * nb, 0.0);
  for (PetscInt i = 0; i < s.cb.n_phi; ++i)
    for (PetscInt r = 0; r < nb; ++r)
      for (PetscInt c = 0; c < nb; ++c) sum[r * nb + c] += P[i * nb + r] * P[i * nb + c];
  const PetscInt n = s.cb.n();
  // W = interior rows of M T_b; M_ii^{-1} W via a direct solve; W^T (M_ii^{-1} W).
  std::vector<PetscInt> ii;
  PetscInt rs, re;
  MORSE_CALL(MatGetOwnershipRange(s.ops.M.get(), &rs, &re));
  std::vector<char> isb(re - rs, 0);
  for (auto g : s.cb.boundary_dofs)
    if (g >= rs && g < re) isb[g - rs] = 1;
  for (PetscInt g = rs; g < re; ++g)
    if (!isb[g - rs]) ii.push_back(g);
  UIS is_i;
  MORSE_CALL(ISCreateGeneral(PETSC_COMM_WORLD, (PetscInt)ii.size(), ii.data(), PETSC_COPY_VALUES, is_i.ptr()));
  UMat Mii;
  MORSE_CALL(MatCreateSubMatrix(s.ops.M.get(), is_i.get(), is_i.get(), MAT_INITIAL_MATRIX, Mii.ptr()));
  std::vector<double> ref(nb * nb, 0.0);
  for (PetscInt c = 0; c < nb; ++c) {
    Vec tc;
    UVec Mt, w, y;
    MORSE_CALL(MatDenseGetColumnVecRead(s.cb.T.get(), c, &tc));
    MORSE_CALL(VecDuplicate(tc, Mt.ptr()));
    MORSE_CALL(MatMult(s.ops.M.get(), tc, Mt.get()));
    MORSE_CALL(MatDenseRestoreColumnVecRead(s.cb.T.get(), c, &tc));
    Vec wi;
    MORSE_CALL(VecGetSubVector(Mt.get(), is_i.get(), &wi));
    MORSE_CALL(VecDuplicate(wi, y.ptr()));
    test::direct_solve(Mii.get(), wi, y.get());
    for (PetscInt r = 0; r < nb; ++r) {
      Vec tr;
      UVec Mr;
      MORSE_CALL(MatDenseGetColumnVecRead(s.cb.T.get(), r, &tr));
      MORSE_CALL(VecDuplicate(tr, Mr.ptr()));
      MORSE_CALL(MatMult(s.ops.M.get(), tr, Mr.get()));
      MORSE_CALL(MatDenseRestoreColumnVecRead(s.cb.T.get(), r, &tr));
      Vec wr;
      MORSE_CALL(VecGetSubVector(Mr.get(), is_i.get(), &wr));
      PetscScalar v;
      MORSE_CALL(VecDot(wr, y.get(), &v));
      ref[r * nb + c] = v;
      MORSE_CALL(VecRestoreSubVector(Mr.get(), is_i.get(), &wr));
    }
    MORSE_CALL(VecRestoreSubVector(Mt.get(), is_i.get(), &wi));
  }
  double scale = 0, err = 0;
  for (PetscInt k = 0; k < nb * nb; ++k) {
    scale = std::max(scale, std::abs(ref[k]));
    err = std::max(err, std::abs(ref[k] - sum[k]));
  }
  EXPECT_LT(err, 1e-8 * scale) << "completeness of P";
  (void)n;

  using select::Method;
  auto get = [&](Method m) { return select::scores(PETSC_COMM_WORLD, m, s.ic, s.cb, {}, nullptr); };
  auto eim = get(Method::EIM), veim = get(Method::VEIM), deim = get(Method::DEIM), omr = get(Method::OMR),
       chi = get(Method::CMSChi);
  double emax = *std::max_element(eim.begin(), eim.end());
  for (PetscInt i = 0; i < s.cb.n_phi; ++i) {
    const double l = s.ic.lambda[i];
    EXPECT_NEAR(l * veim[i], eim[i], 1e-9 * emax);
    EXPECT_NEAR(l * l * deim[i], eim[i], 1e-9 * emax);
    EXPECT_NEAR(l * chi[i], eim[i], 1e-9 * emax);
    EXPECT_NEAR(omr[i] / l, eim[i], 1e-7 * emax) << "mode " << i;
  }
}

// Selecting every mode gives plain Craig–Bampton; truncation by count and by fraction.
TEST(Select, TruncationAndAllModes) {
  auto b = test::box_spec(ElementType::Wedge15, 1.0, 0.1, 0.06, 8, 2, 1);
  auto s = make(PETSC_COMM_WORLD, b, {"x0"}, "x1", 12);
  auto eim = select::scores(PETSC_COMM_WORLD, select::Method::EIM, s.ic, s.cb, {}, nullptr);
  auto all = select::truncate(select::Method::EIM, eim, -1, 1.0);
  ASSERT_EQ((PetscInt)all.selected.size(), s.cb.n_phi);
  EXPECT_EQ(select::restrict_operator(s.cb.M, s.cb.n_b, s.cb.n(), all.selected), s.cb.M);
  EXPECT_EQ(select::restrict_operator(s.cb.K, s.cb.n_b, s.cb.n(), all.selected), s.cb.K);
  auto five = select::truncate(select::Method::EIM, eim, 5, 1.0);
  ASSERT_EQ(five.selected.size(), 5u);
  for (PetscInt k = 0; k < 5; ++k)
    for (PetscInt j = 5; j < s.cb.n_phi; ++j) EXPECT_GE(eim[five.ranking[k]], eim[five.ranking[j]]);
  auto frac = select::truncate(select::Method::EIM, eim, -1, 0.9);
  EXPECT_GE(frac.retained, 0.9);
  const std::size_t k = frac.selected.size();
  EXPECT_LT(frac.cumulative[k - 2], 0.9);  // the shortest such prefix
  auto freq = select::truncate(select::Method::Frequency, eim, 4, 1.0);
  EXPECT_EQ(freq.selected, (std::vector<PetscInt>{0, 1, 2, 3}));
  EXPECT_THROW(select::truncate(select::Method::EIM, eim, 100, 1.0), Error);
}

// EBR: the default excitation (every boundary DOF alone, at several frequencies) ranks modes that
// load the interface; an all-zero excitation is an error.
TEST(Select, EbrExcitation) {
  auto b = test::box_spec(ElementType::Hex20, 1.0, 0.08, 0.05, 10, 2, 1);
  auto s = make(PETSC_COMM_WORLD, b, {"x0"}, "x1", 10);
  select::Excitation ex;
  ex.freq_hz = {100, 500, 1500};
  ex.amplitude = {1, 1, 1};
  ex.phase_deg = {0, 0, 0};
  auto e = select::scores(PETSC_COMM_WORLD, select::Method::EBR, s.ic, s.cb, ex, nullptr);
  ASSERT_EQ((PetscInt)e.size(), s.cb.n_phi);
  double total = 0;
  for (double v : e) total += v;
  EXPECT_GT(total, 0.0);
  ex.amplitude = {0, 0, 0};
  EXPECT_THROW(select::scores(PETSC_COMM_WORLD, select::Method::EBR, s.ic, s.cb, ex, nullptr), Error);
}

// EBR with per-DOF amplitudes and phases. Below sqrt(3) omega_1 every mode's signed period-mean
// energy is >= 0 for any boundary load (eta_i = w^2 c_i / (lambda_i - w^2) gives
// e_i = eta_i^2 (3 lambda_i - w^2) / 2), so the scores obey the superposition rules of a
// time-averaged quadratic form exactly: loads in quadrature add their energies
// (s(A + iB) = s(A) + s(B)), in-phase and anti-phase loads obey the parallelogram law
// (s(A + B) + s(A - B) = 2 s(A) + 2 s(B)), and a common phase changes nothing.
TEST(Select, EbrPhasesFollowTimeAveragedEnergy) {
  auto b = test::box_spec(ElementType::Hex20, 1.0, 0.08, 0.05, 10, 2, 1);
  auto s = make(PETSC_COMM_WORLD, b, {"x0"}, "x1", 10);
  const PetscInt nb = s.cb.n_b;
  const double f1 = std::sqrt(s.cb.fixed_omega2[0]) / (2 * M_PI);
  using C = std::complex<double>;
  const PetscInt dof_a = 1, dof_b = 3 * (s.cb.boundary_node_ids.size() - 1) + 1;  // y of first and last node
  auto score = [&](C fa, C fb) {
    select::Excitation ex;
    ex.all_components = false;
    ex.freq_hz = {0.5 * f1, 0.9 * f1};
    std::vector<C> f(nb, 0.0);
    f[dof_a] = fa;
    f[dof_b] = fb;
    ex.load = {f, f};
    return select::scores(PETSC_COMM_WORLD, select::Method::EBR, s.ic, s.cb, ex, nullptr);
  };
  const C i(0.0, 1.0);
  auto sa = score(1.0, 0.0), sb = score(0.0, 2.0), s90 = score(1.0, 2.0 * i), s0 = score(1.0, 2.0),
       s180 = score(1.0, -2.0), srot = score(std::polar(1.0, 0.7), std::polar(2.0, 0.7));
  double smax = 0, cross = 0;
  for (PetscInt k = 0; k < s.cb.n_phi; ++k) smax = std::max(smax, sa[k] + sb[k]);
  for (PetscInt k = 0; k < s.cb.n_phi; ++k) {
    EXPECT_NEAR(s90[k], sa[k] + sb[k], 1e-10 * smax) << "mode " << k;
    EXPECT_NEAR(s0[k] + s180[k], 2 * (sa[k] + sb[k]), 1e-10 * smax) << "mode " << k;
    EXPECT_NEAR(srot[k], s0[k], 1e-10 * smax) << "mode " << k;
    cross = std::max(cross, std::abs(s0[k] - sa[k] - sb[k]) / smax);
  }
  EXPECT_GT(cross, 1e-2);  // the phase does matter: in phase, the two loads interfere
}

// The EBR load table: per-DOF lines grouped by frequency into harmonics, phases in degrees;
// every bad line is an error naming the file and the line.
TEST(Select, EbrLoadTable) {
  auto b = test::box_spec(ElementType::Hex20, 1.0, 0.08, 0.05, 4, 1, 1);
  auto s = make(PETSC_COMM_WORLD, b, {"x0"}, "x1", 4);
  const auto& ids = s.cb.boundary_node_ids;
  const test::SharedScratchDir scratch("ebr");
  const std::string path = scratch.path("load.txt");
  auto write = [&](const std::string& text) {
    if (world_rank() == 0) {
      std::ofstream f(path);
      f << text;
    }
    MPI_Barrier(PETSC_COMM_WORLD);
  };
  // A rotating load on the first node (x cos, y sin) at 120 Hz, and z on the last node at 300 Hz.
  write(cat("# rotating bearing load\n", "120 ", ids[0], " x 2.0 0\n", "120, ", ids[0], ", 2, 2.0, -90  # y\n",
            "\n300 ", ids.back(), " Z 0.5\n"));
  auto ex = select::read_ebr_load(PETSC_COMM_WORLD, path, s.cb);
  ASSERT_EQ(ex.freq_hz.size(), 2u);
  EXPECT_EQ(ex.freq_hz[0], 120.0);
  EXPECT_EQ(ex.freq_hz[1], 300.0);
  ASSERT_EQ((PetscInt)ex.load[0].size(), s.cb.n_b);
  EXPECT_NEAR(std::abs(ex.load[0][0] - std::complex<double>(2.0, 0.0)), 0.0, 1e-15);
  EXPECT_NEAR(std::abs(ex.load[0][1] - std::complex<double>(0.0, -2.0)), 0.0, 1e-15);
  const std::size_t last_z = 3 * (ids.size() - 1) + 2;
  EXPECT_EQ(ex.load[1][last_z], std::complex<double>(0.5, 0.0));
  double others = 0;
  for (std::size_t k = 0; k < ex.load[0].size(); ++k)
    if (k > 1) others += std::abs(ex.load[0][k]);
  for (std::size_t k = 0; k < ex.load[1].size(); ++k)
    if (k != last_z) others += std::abs(ex.load[1][k]);
  EXPECT_EQ(others, 0.0);
  auto e = select::scores(PETSC_COMM_WORLD, select::Method::EBR, s.ic, s.cb, ex, nullptr);
  EXPECT_GT(*std::max_element(e.begin(), e.end()), 0.0);

  std::int64_t outside = 0;  // a node id not on the interface
  while (std::find(ids.begin(), ids.end(), outside) != ids.end()) ++outside;
  const std::vector<std::pair<std::string, std::string>> bad = {
      {cat("100 ", ids[0], " x\n"), ":1: expected"},
      {cat("# c\n100 ", outside, " x 1\n"), ":2: node " + std::to_string(outside) + " is not in the boundary set"},
      {cat("100 ", ids[0], " w 1\n"), ":1: component 'w'"},
      {cat("-5 ", ids[0], " x 1\n"), ":1: frequency -5 Hz must be > 0"},
      {cat("100 ", ids[0], " x one\n"), ":1: amplitude 'one' is not a number"},
      {cat("100 ", ids[0], " x 1\n100 ", ids[0], " 1 2\n"),
       ":2: node " + std::to_string(ids[0]) + " component 1 at 100 Hz is already loaded on line 1"},
      {"# nothing\n", "no load line"},
  };
  for (const auto& [text, expect] : bad) {
    write(text);
    try {
      select::read_ebr_load(PETSC_COMM_WORLD, path, s.cb);
      ADD_FAILURE() << "no error for: " << text;
    } catch (const Error& err) {
      EXPECT_NE(std::string(err.what()).find(path), std::string::npos) << err.what();
      EXPECT_NE(std::string(err.what()).find(expect), std::string::npos) << err.what();
    }
  }
  if (world_rank() == 0) std::remove(path.c_str());
  EXPECT_THROW(select::read_ebr_load(PETSC_COMM_WORLD, path, s.cb), Error);  // missing file
}

// Seed 000's situation on morse's stator (thin vanes with many local modes): at 95 % of the
// effective interface mass, EIM ranking keeps clearly fewer fixed-interface modes than frequency
// order over the same candidates, and the modes it drops carry little interface mass.
TEST(Select, StatorEimKeepsFewerModesThanFrequencyOrder) {
  auto lm = mesh::read_and_distribute(PETSC_COMM_WORLD, MORSE_SOURCE_DIR "/meshes/stator_coarse.msh");
  auto dofs = fe::number_dofs(lm, {"mount"});
  auto ops = fe::assemble(lm, dofs, mesh::Material{});
  cb::CBSettings cs;
  cs.boundary_set = "interface";
  cs.n_fixed = 40;
  cs.keep_basis = true;
  cs.prefix = "test_sel_";
  auto res = cb::craig_bampton(test::model_of(lm, dofs, ops), cs);
  auto ic = select::interface_coupling(PETSC_COMM_WORLD, ops.K.get(), ops.M.get(), res);
  auto eim = select::scores(PETSC_COMM_WORLD, select::Method::EIM, ic, res, {}, nullptr);
  auto by_eim = select::truncate(select::Method::EIM, eim, -1, 0.95);
  auto by_freq = select::truncate(select::Method::Frequency, eim, -1, 0.95);
  if (world_rank() == 0)
    std::printf("  stator coarse, 40 candidates: EIM 95%% keeps %zu, frequency order %zu\n", by_eim.selected.size(),
                by_freq.selected.size());
  EXPECT_LT(2 * by_eim.selected.size(), by_freq.selected.size() + 2);  // at most about half
  // The dropped modes together carry at most 5 % of the effective interface mass.
  EXPECT_GE(by_eim.retained, 0.95);
}

// select::verify on a superelement that keeps every interior mode: the superelement is exact, so
// each full-model mode below the cutoff is matched with MAC 1 to round-off and no frequency error,
// the full-model eigenvalues (SLEPc on K, M) equal those of the dense reduced pair (LAPACK on
// K_CB, M_CB) computed here, and a method truncated to two modes matches fewer.
TEST(Select, VerifyMatchesExactSuperelement) {
  PetscInt n_i = 0;
  Problem s = all_interior_modes(&n_i);
  auto lam = eigen::dense_eigenvalues(static_cast<int>(s.cb.n()), s.cb.K, s.cb.M);
  auto hz = [](double l) { return std::sqrt(l) / (2 * M_PI); };
  select::VerifySettings vs;
  vs.methods = {select::Method::EIM, select::Method::Frequency};
  vs.names = {"eim", "frequency"};
  vs.fmax_analysis_hz = 0.5 * (hz(lam[5]) + hz(lam[6]));
  auto w = cb::sign_reference(test::model_of(s.lm, s.dofs, s.ops));
  // All candidates for every method (a count of n_i), then two for the frequency order.
  vs.num_modes = n_i;
  const auto all = select::verify(PETSC_COMM_WORLD, s.ops.K.get(), s.ops.M.get(), s.cb, w.get(), vs);
  ASSERT_EQ(all.fom_omega2.size(), 6u);
  for (int j = 0; j < 6; ++j) EXPECT_NEAR(all.fom_omega2[j] / lam[j], 1.0, 1e-8) << "full-model mode " << j;
  EXPECT_EQ(all.cb_in_band, 6);
  ASSERT_EQ(all.methods.size(), 2u);
  for (const auto& m : all.methods) {
    EXPECT_EQ(static_cast<PetscInt>(m.sel.selected.size()), n_i) << m.name;
    EXPECT_EQ(m.in_band, 6) << m.name;
    EXPECT_EQ(m.matches, 6) << m.name;
    EXPECT_EQ(m.subspace_matches, 6) << m.name;
    EXPECT_LT(m.worst_err, 1e-8) << m.name;
    for (int j = 0; j < 6; ++j) {
      EXPECT_NEAR(m.best_mac[j], 1.0, 1e-8) << m.name << " mode " << j;
      EXPECT_NEAR(m.subspace_mac[j], 1.0, 1e-8) << m.name << " mode " << j;
      EXPECT_NEAR(m.rom_f[j] / hz(lam[j]), 1.0, 1e-12) << m.name << " mode " << j;
    }
  }
  double eim_sum = 0;
  for (double f : all.eim_fractions) eim_sum += f;
  EXPECT_NEAR(eim_sum, 1.0, 1e-12);
  vs.num_modes = 2;
  const auto two = select::verify(PETSC_COMM_WORLD, s.ops.K.get(), s.ops.M.get(), s.cb, w.get(), vs);
  const auto& f2 = two.methods[1];
  EXPECT_EQ(f2.sel.selected, (std::vector<PetscInt>{0, 1}));
  // Rayleigh-Ritz on a smaller space: some mode unmatched or a matched frequency above its own.
  EXPECT_TRUE(f2.matches < 6 || f2.worst_err > 1e-10) << f2.matches << " " << f2.worst_err;
  EXPECT_LE(f2.in_band, static_cast<PetscInt>(s.cb.n_b + 2));
  // Unchecked (-select_check false): the same rankings, selections and superelement frequencies,
  // no full-model modes and no MAC.
  vs.check = false;
  const auto unchecked = select::verify(PETSC_COMM_WORLD, s.ops.K.get(), s.ops.M.get(), s.cb, w.get(), vs);
  EXPECT_FALSE(unchecked.checked);
  EXPECT_TRUE(unchecked.fom_omega2.empty());
  ASSERT_EQ(unchecked.methods.size(), two.methods.size());
  for (std::size_t i = 0; i < two.methods.size(); ++i) {
    const auto &u = unchecked.methods[i], &c = two.methods[i];
    EXPECT_EQ(u.sel.selected, c.sel.selected) << c.name;
    EXPECT_EQ(u.score, c.score) << c.name;
    EXPECT_EQ(u.rom_f, c.rom_f) << c.name;
    EXPECT_EQ(u.in_band, c.in_band) << c.name;
    EXPECT_TRUE(u.mac.empty() && u.best_mac.empty() && u.matches == 0) << c.name;
  }
}
