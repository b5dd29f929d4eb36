// Craig–Bampton superelement (seed 000 eq. 3–6): Guyan exactness in statics, convergence of the
// reduced frequencies from above, exactness with every interior mode, independence of the rank
// count, and cutoff selection.
#include <petscsys.h>
#include <gtest/gtest.h>
#include <petscblaslapack.h>

#include <cmath>

#include "morse/cb/craig_bampton.hpp"
#include "morse/core/units.hpp"
#include "util.hpp"

using namespace morse;
using mesh::ElementType;

namespace {

struct Case {
  mesh::LocalMesh lm;
  fe::DofLayout dofs;
  fe::Operators ops;
};

// A cantilever with a rectangular, non-square section (no repeated frequencies), clamped at x0;
// the interface is the free end face x1.
Case beam(MPI_Comm comm, ElementType type = ElementType::Hex20, int nx = 12) {
  mesh::BoxSpec b;
  b.type = type;
  b.lx = 1.0;
  b.ly = 0.08;
  b.lz = 0.05;
  b.nx = nx;
  b.ny = 2;
  b.nz = 1;
  Case c;
  c.lm = test::box_mesh(comm, b);
  c.dofs = fe::number_dofs(c.lm, {"x0"});
  c.ops = fe::assemble(c.lm, c.dofs, test::steel());
  return c;
}

cb::CBResult reduce(const Case& c, PetscInt n_fixed, bool keep = false, double fmax = -1) {
  cb::CBSettings s;
  s.boundary_set = "x1";
  s.n_fixed = n_fixed;
  s.fmax_hz = fmax;
  s.keep_basis = keep;
  return cb::craig_bampton(test::model_of(c.lm, c.dofs, c.ops), s);
}

double max_abs(const std::vector<double>& v) {
  double m = 0;
  for (double x : v) m = std::max(m, std::abs(x));
  return m;
}

}  // namespace

// Guyan is exact in statics: a load on the boundary DOFs gives the same boundary displacement in
// the full and the reduced model, and the interior displacement is Psi u_b. The identity is
// exact; the round-off floor of both sides grows like cond(K) * eps, so a stocky part (L/h = 5)
// is used for the 1e-10 check (a slender L/h = 20 beam reaches a few 1e-10).
TEST(CraigBampton, StaticLoadOnBoundaryIsExact) {
  Case c;
  {
    mesh::BoxSpec b;
    b.type = ElementType::Hex20;
    b.lx = 0.5;
    b.ly = 0.15;
    b.lz = 0.1;
    b.nx = 6;
    b.ny = 2;
    b.nz = 2;
    b.distortion = 0.1;
    c.lm = test::box_mesh(PETSC_COMM_WORLD, b);
    c.dofs = fe::number_dofs(c.lm, {"x0"});
    c.ops = fe::assemble(c.lm, c.dofs, test::steel());
  }
  auto r = reduce(c, 6, true);
  const PetscInt nb = r.n_b, n = r.n();
  // Coupling between boundary and modes vanishes in K_CB (K_ii Psi = -K_ib).
  double kmax = max_abs(r.K), coupling = 0;
  for (PetscInt i = 0; i < nb; ++i)
    for (PetscInt j = nb; j < n; ++j) coupling = std::max(coupling, std::abs(r.K[i * n + j]));
  EXPECT_LT(coupling, 1e-10 * kmax);

  // Load: a fixed pattern on the boundary DOFs (in reduced order).
  std::vector<double> fb(nb);
  for (PetscInt i = 0; i < nb; ++i) fb[i] = 1e3 * std::cos(1.0 + 0.7 * i) + (i % 3 == 2 ? 2e3 : 0.0);
  // Reduced: K_CB,bb u_b = f_b (LAPACK Cholesky).
  std::vector<double> Kbb(nb * nb), ub_rom(fb);
  for (PetscInt i = 0; i < nb; ++i)
    for (PetscInt j = 0; j < nb; ++j) Kbb[i * nb + j] = r.K[i * n + j];
  PetscBLASInt N = nb, one = 1, info = 0;
  LAPACKpotrf_("U", &N, Kbb.data(), &N, &info);
  ASSERT_EQ(info, 0);
  LAPACKpotrs_("U", &N, &one, Kbb.data(), &N, ub_rom.data(), &N, &info);
  ASSERT_EQ(info, 0);

  // Full: K u = f with f = T_b f_b (T's boundary rows are the identity).
  UVec f, u, fT;
  MORSE_CALL(MatCreateVecs(c.ops.K.get(), u.ptr(), f.ptr()));
  UVec fr;
  MORSE_CALL(VecCreateSeq(PETSC_COMM_SELF, n, fr.ptr()));
  {
    std::vector<double> full(n, 0.0);
    std::copy(fb.begin(), fb.end(), full.begin());
    // f = T_b * f_b on boundary rows: build via T restricted to boundary rows, i.e. assemble
    // from the boundary DOF positions directly.
    std::vector<PetscInt> bdofs;
    for (std::size_t i = 0; i < r.boundary_global_nodes.size(); ++i) {
      auto k = c.lm.local_of_global(r.boundary_global_nodes[i]);
      if (k >= 0 && c.lm.owns(k))
        for (int d = 0; d < 3; ++d) {
          PetscInt g = c.dofs.node_dof[3 * k + d];
          MORSE_CALL(VecSetValue(f.get(), g, fb[3 * i + d], INSERT_VALUES));
        }
    }
    MORSE_CALL(VecAssemblyBegin(f.get()));
    MORSE_CALL(VecAssemblyEnd(f.get()));
  }
  test::direct_solve(c.ops.K.get(), f.get(), u.get());
  {  // one step of iterative refinement, so the reference is accurate beyond cond(K) * eps
    UVec res, du;
    MORSE_CALL(VecDuplicate(f.get(), res.ptr()));
    MORSE_CALL(VecDuplicate(u.get(), du.ptr()));
    MORSE_CALL(MatMult(c.ops.K.get(), u.get(), res.get()));
    MORSE_CALL(VecAYPX(res.get(), -1.0, f.get()));
    test::direct_solve(c.ops.K.get(), res.get(), du.get());
    MORSE_CALL(VecAXPY(u.get(), 1.0, du.get()));
  }
  // u_b of the full model in reduced order, gathered on every rank.
  std::vector<double> ub_full(nb, 0.0);
  const PetscScalar* a;
  MORSE_CALL(VecGetArrayRead(u.get(), &a));
  for (std::size_t i = 0; i < r.boundary_global_nodes.size(); ++i) {
    auto k = c.lm.local_of_global(r.boundary_global_nodes[i]);
    if (k >= 0 && c.lm.owns(k))
      for (int d = 0; d < 3; ++d) ub_full[3 * i + d] = a[c.dofs.node_dof[3 * k + d] - c.dofs.first];
  }
  MORSE_CALL(VecRestoreArrayRead(u.get(), &a));
  MPI_Allreduce(MPI_IN_PLACE, ub_full.data(), nb, MPI_DOUBLE, MPI_SUM, PETSC_COMM_WORLD);
  double err = 0, ref = max_abs(ub_full);
  for (PetscInt i = 0; i < nb; ++i) err = std::max(err, std::abs(ub_full[i] - ub_rom[i]));
  EXPECT_LT(err, 1e-10 * ref) << "boundary displacement error " << err << " of " << ref;

  // Interior: u = T [u_b; 0] everywhere.
  UVec q, u_rom;
  MORSE_CALL(MatCreateVecs(r.T.get(), q.ptr(), u_rom.ptr()));
  for (PetscInt i = 0; i < nb; ++i) MORSE_CALL(VecSetValue(q.get(), i, ub_rom[i], INSERT_VALUES));
  MORSE_CALL(VecAssemblyBegin(q.get()));
  MORSE_CALL(VecAssemblyEnd(q.get()));
  MORSE_CALL(MatMult(r.T.get(), q.get(), u_rom.get()));
  PetscReal unorm, enorm;
  MORSE_CALL(VecNorm(u.get(), NORM_INFINITY, &unorm));
  MORSE_CALL(VecAXPY(u_rom.get(), -1.0, u.get()));
  MORSE_CALL(VecNorm(u_rom.get(), NORM_INFINITY, &enorm));
  EXPECT_LT(enorm, 1e-10 * unorm);
}

// The fixed-interface block is diagonal: Phi^T M_ii Phi = I and Phi^T K_ii Phi = Omega.
TEST(CraigBampton, ModalBlockIsDiagonal) {
  auto c = beam(PETSC_COMM_WORLD);
  auto r = reduce(c, 8);
  const PetscInt nb = r.n_b, n = r.n();
  for (PetscInt i = 0; i < r.n_phi; ++i)
    for (PetscInt j = 0; j < r.n_phi; ++j) {
      double m = r.M[(nb + i) * n + nb + j], k = r.K[(nb + i) * n + nb + j];
      EXPECT_NEAR(m, i == j ? 1.0 : 0.0, 1e-9);
      EXPECT_NEAR(k, i == j ? r.fixed_omega2[i] : 0.0, 1e-9 * r.fixed_omega2.back());
    }
}

// Rayleigh–Ritz: reduced eigenvalues bound the full ones from above and decrease as modes are
// added; with every interior mode they coincide.
TEST(CraigBampton, FrequenciesConvergeFromAbove) {
  auto c = beam(PETSC_COMM_WORLD);
  eigen::EigenSettings es;
  es.nev = 10;
  es.prefix = "test_fom_";
  auto fom = eigen::solve_eigen(c.ops.K.get(), c.ops.M.get(), es, nullptr);
  std::vector<double> prev_err(6, 1e300), guyan_err;
  for (PetscInt nphi : {0, 2, 4, 8, 16, 32}) {
    auto r = reduce(c, nphi);
    auto rom = eigen::dense_eigenvalues(static_cast<int>(r.n()), r.K, r.M);
    for (int k = 0; k < 6; ++k) {
      double rel = (rom[k] - fom.omega2[k]) / fom.omega2[k];
      EXPECT_GT(rel, -1e-9) << "mode " << k << " with " << nphi << " modes below the full model";
      EXPECT_LE(rel, prev_err[k] * (1 + 1e-9) + 1e-12) << "mode " << k << " not converging at " << nphi;
      prev_err[k] = rel;
    }
    if (nphi == 0) guyan_err = prev_err;
  }
  EXPECT_LT(prev_err[0], 1e-5);
  for (int k = 0; k < 6; ++k) EXPECT_LT(prev_err[k], 1e-2 * guyan_err[k]) << "mode " << k;
}

TEST(CraigBampton, AllInteriorModesReproduceTheFullModel) {
  // A tiny model so every interior mode can be computed.
  mesh::BoxSpec b;
  b.type = ElementType::Hex8;
  b.lx = 1.0;
  b.ly = 0.3;
  b.lz = 0.2;
  b.nx = 5;
  b.ny = 1;
  b.nz = 1;
  Case c;
  c.lm = test::box_mesh(PETSC_COMM_WORLD, b);
  c.dofs = fe::number_dofs(c.lm, {"x0"});
  c.ops = fe::assemble(c.lm, c.dofs, test::steel());
  const PetscInt n_i = c.dofs.n_global - 3 * c.lm.node_set_sizes.at("x1");
  auto r = reduce(c, n_i);
  ASSERT_EQ(r.n(), c.dofs.n_global);
  auto rom = eigen::dense_eigenvalues(static_cast<int>(r.n()), r.K, r.M);
  eigen::EigenSettings es;
  es.nev = 12;
  es.prefix = "test_fom_";
  auto fom = eigen::solve_eigen(c.ops.K.get(), c.ops.M.get(), es, nullptr);
  for (int k = 0; k < 12; ++k) EXPECT_NEAR(rom[k] / fom.omega2[k], 1.0, 1e-9) << "mode " << k;
}

// The same superelement on one rank (PETSC_COMM_SELF on rank 0) and on all ranks.
TEST(CraigBampton, IndependentOfRankCount) {
  int rank = 0;
  MPI_Comm_rank(PETSC_COMM_WORLD, &rank);
  std::vector<double> Ks, Ms;
  PetscInt n = 0;
  if (rank == 0) {
    auto c = beam(PETSC_COMM_SELF, ElementType::Wedge15, 10);
    auto r = reduce(c, 10);
    Ks = r.K;
    Ms = r.M;
    n = r.n();
  }
  auto c = beam(PETSC_COMM_WORLD, ElementType::Wedge15, 10);
  auto r = reduce(c, 10);
  std::string msg;
  if (rank == 0) {
    EXPECT_EQ(n, r.n());
    double kref = max_abs(Ks), mref = max_abs(Ms), kerr = 0, merr = 0;
    for (std::size_t i = 0; i < Ks.size() && i < r.K.size(); ++i) {
      kerr = std::max(kerr, std::abs(Ks[i] - r.K[i]));
      merr = std::max(merr, std::abs(Ms[i] - r.M[i]));
    }
    if (kerr > 1e-10 * kref || merr > 1e-10 * mref) msg = cat("K err ", kerr / kref, " M err ", merr / mref);
  }
  EXPECT_FALSE(any_rank(PETSC_COMM_WORLD, !msg.empty())) << msg;
}

// Selection by cutoff (spectrum slicing) finds exactly the modes below the cutoff and gives the
// same superelement as selection by count.
TEST(CraigBampton, CutoffSelectionMatchesCount) {
  auto c = beam(PETSC_COMM_WORLD);
  auto by_count = reduce(c, 12);
  const double f11 = hz(by_count.fixed_omega2[10]);
  const double f12 = hz(by_count.fixed_omega2[11]);
  auto by_cut = reduce(c, -1, false, 0.5 * (f11 + f12));
  ASSERT_EQ(by_cut.n_phi, 11);
  for (int k = 0; k < 11; ++k) EXPECT_NEAR(by_cut.fixed_omega2[k] / by_count.fixed_omega2[k], 1.0, 1e-10);
  const PetscInt n = by_cut.n(), n2 = by_count.n();
  double kref = max_abs(by_cut.K), err = 0;
  for (PetscInt i = 0; i < n; ++i)
    for (PetscInt j = 0; j < n; ++j) err = std::max(err, std::abs(by_cut.K[i * n + j] - by_count.K[i * n2 + j]));
  EXPECT_LT(err, 1e-9 * kref);
}

TEST(CraigBampton, ModalDamping) {
  auto c = beam(PETSC_COMM_WORLD);
  cb::CBSettings s;
  s.boundary_set = "x1";
  s.n_fixed = 4;
  s.damping = 0.02;
  auto r = cb::craig_bampton(test::model_of(c.lm, c.dofs, c.ops), s);
  const PetscInt n = r.n();
  for (PetscInt i = 0; i < n; ++i)
    for (PetscInt j = 0; j < n; ++j) {
      double expect = (i == j && i >= r.n_b) ? 2 * 0.02 * std::sqrt(r.fixed_omega2[i - r.n_b]) : 0.0;
      EXPECT_DOUBLE_EQ(r.C[i * n + j], expect);
    }
}

TEST(CraigBampton, BadInputIsACollectiveError) {
  auto c = beam(PETSC_COMM_WORLD, ElementType::Hex8, 4);
  auto expect_error = [&](cb::CBSettings s, const std::string& needle) {
    try {
      cb::craig_bampton(test::model_of(c.lm, c.dofs, c.ops), s);
      ADD_FAILURE() << "no error for " << needle;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  cb::CBSettings s;
  s.boundary_set = "nosuchset";
  s.n_fixed = 2;
  expect_error(s, "nosuchset");
  s.boundary_set = "x0";  // clamped
  expect_error(s, "clamped");
  s.boundary_set = "x1";
  s.n_fixed = 100000;
  expect_error(s, "interior DOFs");
}

// The dense generalized eigen solver: with a cutoff, the eigenvectors below it (LAPACK sygvx)
// satisfy K v = lambda M v and v^T M v = 1 like the full solve's, the other columns are zero,
// and the eigenvalues are those of the full solve. A pencil with a 3-fold eigenvalue checks
// that the vectors of a cluster come out M-orthonormal.
TEST(DenseEigen, VectorsBelowACutoff) {
  const int n = 30;
  // M = R R^T and K = R S R^T with R invertible and S diagonal: K v = lambda M v <=> S u = lambda u
  // with u = R^T v, so the eigenvalues are S's: 2 (three times), then 3.5, 4, 4.5, ...
  std::vector<double> R(n * n), M(n * n, 0.0), K(n * n, 0.0);
  for (int i = 0; i < n * n; ++i) R[i] = std::sin(1.0 + 0.37 * i);
  for (int i = 0; i < n; ++i) R[i * n + i] += n;
  auto s_of = [](int k) { return k < 3 ? 2.0 : 2.0 + 0.5 * k; };
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      for (int k = 0; k < n; ++k) {
        M[i * n + j] += R[i * n + k] * R[j * n + k];
        K[i * n + j] += R[i * n + k] * s_of(k) * R[j * n + k];
      }
  std::vector<double> all, some;
  auto w_all = eigen::dense_eigenvalues(n, K, M, &all);
  auto w_some = eigen::dense_eigenvalues(n, K, M, &some, 0.5 * (w_all[5] + w_all[6]));
  for (int k = 0; k < n; ++k) EXPECT_NEAR(w_some[k], w_all[k], 1e-12 * w_all.back());
  for (int m = 0; m < n; ++m) {
    double res = 0, scale = 0, zero = 0;
    for (int i = 0; i < n; ++i) {
      double kv = 0, mv = 0;
      for (int j = 0; j < n; ++j) kv += K[i * n + j] * some[j * n + m], mv += M[i * n + j] * some[j * n + m];
      res = std::max(res, std::abs(kv - w_some[m] * mv));
      scale = std::max(scale, std::abs(kv));
      zero += std::abs(some[i * n + m]);
    }
    if (m <= 5) {
      EXPECT_LT(res, 1e-10 * scale) << "mode " << m;
      for (int p = 0; p <= m; ++p) {  // M-orthonormality, inside the cluster too
        double vmv = 0;
        for (int i = 0; i < n; ++i)
          for (int j = 0; j < n; ++j) vmv += some[i * n + p] * M[i * n + j] * some[j * n + m];
        EXPECT_NEAR(vmv, p == m ? 1.0 : 0.0, 1e-10) << p << "," << m;
      }
    } else {
      EXPECT_EQ(zero, 0.0) << "mode " << m;
    }
  }
  for (int k = 0; k < n; ++k) EXPECT_NEAR(w_all[k], s_of(k), 1e-12 * s_of(n - 1)) << k;
}
