// The eigen solver's building blocks: inertia counts of K - sigma M against the eigenvalues of
// the dense pencil (Sylvester's law of inertia), and the N lowest modes by inertia search +
// spectrum slicing against the single-shift Krylov-Schur solve, and the guarantee that no mode is
// missed (Sylvester check, residuals, clusters against LAPACK).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "eigen/detail/testing.hpp"
#include "morse/cb/craig_bampton.hpp"
#include "morse/core/session.hpp"
#include "morse/eigen/eigen.hpp"
#include "morse/fe/model.hpp"
#include "util.hpp"

using namespace morse;
using eigen::set_default_option;

namespace {

struct Small {
  mesh::LocalMesh lm;
  fe::DofLayout dofs;
  fe::Operators ops;
};

// A 6 x 2 x 2 hex8 cantilever with a rectangular section (no repeated bending pairs): 162 free DOFs.
Small small_beam() {
  auto b = test::box_spec(mesh::ElementType::Hex8, 0.6, 0.1, 0.06, 6, 2, 2);
  Small s;
  s.lm = test::box_mesh(PETSC_COMM_WORLD, b);
  s.dofs = fe::number_dofs(s.lm, {"x0"});
  s.ops = fe::assemble(s.lm, s.dofs, test::steel());
  return s;
}

// max over the entries of |V_a^T M V_b - I| (V_a, V_b MPIDENSE with as many columns): 0 when V_b
// is M-orthonormal (V_a = V_b), or holds the same shapes and signs as V_a.
double identity_deviation(Mat M, Mat Va, Mat Vb) {
  UMat MV, X;
  MORSE_CALL(MatMatMult(M, Vb, MAT_INITIAL_MATRIX, PETSC_DEFAULT, MV.ptr()));
  MORSE_CALL(MatTransposeMatMult(Va, MV.get(), MAT_INITIAL_MATRIX, PETSC_DEFAULT, X.ptr()));
  PetscInt n = 0;
  MORSE_CALL(MatGetSize(X.get(), &n, nullptr));
  auto x = test::dense_matrix(X.get());
  double err = 0;
  for (PetscInt i = 0; i < n; ++i)
    for (PetscInt j = 0; j < n; ++j) err = std::max(err, std::abs(x[i * n + j] - (i == j ? 1.0 : 0.0)));
  return err;
}

}  // namespace

// Negative pivots of LDL^T(K - sigma M) = number of eigenvalues below sigma, for cutoffs in the
// gaps of the spectrum from the first to the last eigenvalue.
TEST(Eigen, InertiaCountsMatchTheDenseSpectrum) {
  auto s = small_beam();
  PetscInt n = 0;
  MORSE_CALL(MatGetSize(s.ops.K.get(), &n, nullptr));
  auto lam = eigen::dense_eigenvalues(static_cast<int>(n), test::dense_matrix(s.ops.K.get()),
                                      test::dense_matrix(s.ops.M.get()));
  eigen::InertiaCounter counter(s.ops.K.get(), s.ops.M.get(), "test_inertia_");
  for (PetscInt k : {PetscInt(0), PetscInt(1), PetscInt(5), PetscInt(40), n / 2, n - 2}) {
    const double sigma = 0.5 * (lam[k] + lam[k + 1]);
    EXPECT_EQ(counter.count(sigma), k + 1) << "cutoff between eigenvalues " << k << " and " << k + 1;
  }
  EXPECT_EQ(counter.count(0.5 * lam[0]), 0);
  EXPECT_EQ(counter.count(2.0 * lam[n - 1]), n);
  EXPECT_EQ(counter.factorizations(), 8);
}

// Count mode by slicing (forced with a low threshold) gives the same N lowest eigenvalues as one
// shift, M-orthonormal eigenvectors with the same shapes (MAC 1), and reports its cutoff; so do
// the slices solved concurrently on one subcommunicator per rank.
TEST(Eigen, CountBySlicingMatchesOneShift) {
  auto s = small_beam();
  eigen::EigenSettings one;
  one.nev = 30;
  one.prefix = "test_one_";
  one.count_slicing = 0;
  one.solver = "krylovschur";  // count by slicing is a path of the SLEPc solver
  eigen::EigenSettings sliced = one;
  sliced.prefix = "test_sliced_";
  sliced.count_slicing = 10;
  auto w = cb::sign_reference(test::model_of(s.lm, s.dofs, s.ops));
  auto a = eigen::solve_eigen(s.ops.K.get(), s.ops.M.get(), one, w.get());
  auto b = eigen::solve_eigen(s.ops.K.get(), s.ops.M.get(), sliced, w.get());
  EXPECT_FALSE(a.slicing);
  EXPECT_TRUE(b.slicing);
  EXPECT_GT(b.inertia_counts, 0);
  ASSERT_EQ(b.omega2.size(), 30u);
  EXPECT_GE(b.slice_omega2, b.omega2.back());
  for (int k = 0; k < 30; ++k) EXPECT_NEAR(b.omega2[k] / a.omega2[k], 1.0, 1e-9) << "mode " << k;
  // V_b^T M V_b = I and V_a^T M V_b = I (same shapes and signs: non-repeated eigenvalues).
  EXPECT_LT(identity_deviation(s.ops.M.get(), b.V.get(), b.V.get()), 1e-8);
  EXPECT_LT(identity_deviation(s.ops.M.get(), a.V.get(), b.V.get()), 1e-6);

  // The slices solved concurrently, one subcommunicator per rank (SLEPc's Krylov–Schur
  // partitions, -<prefix>eps_krylovschur_partitions): the same pairs, checked by the same
  // inertia count.
  int size = 1;
  MPI_Comm_size(PETSC_COMM_WORLD, &size);
  eigen::EigenSettings par = sliced;
  par.prefix = "test_sliced_par_";
  set_default_option("-test_sliced_par_eps_krylovschur_partitions", std::to_string(size));
  auto c = eigen::solve_eigen(s.ops.K.get(), s.ops.M.get(), par, w.get());
  EXPECT_EQ(c.partitions, size);
  ASSERT_EQ(c.omega2.size(), 30u);
  EXPECT_EQ(c.inertia_count, b.inertia_count);
  for (int k = 0; k < 30; ++k) EXPECT_NEAR(c.omega2[k] / b.omega2[k], 1.0, 1e-9) << "mode " << k;
  EXPECT_LT(identity_deviation(s.ops.M.get(), c.V.get(), b.V.get()), 1e-6);
}

namespace {

// A pencil with clusters: K = blockdiag(A, A, A) + the same A shifted (three identical copies of
// a stiff chain, so every eigenvalue is triple) with a lumped M = I. Distributed over the ranks.
void clustered(PetscInt m, UMat* K, UMat* M) {
  const PetscInt n = 3 * m;
  for (UMat* A : {K, M}) {
    MORSE_CALL(MatCreateAIJ(PETSC_COMM_WORLD, PETSC_DECIDE, PETSC_DECIDE, n, n, 3, nullptr, 2, nullptr, A->ptr()));
  }
  PetscInt rs = 0, re = 0;
  MORSE_CALL(MatGetOwnershipRange(K->get(), &rs, &re));
  for (PetscInt r = rs; r < re; ++r) {
    const PetscInt i = r % m;  // position in its copy
    // A chain fixed at one end with springs k_i = 1 + i / m (not uniform: no extra degeneracy).
    const double k_left = 1.0 + static_cast<double>(i) / m, k_right = 1.0 + static_cast<double>(i + 1) / m;
    MORSE_CALL(MatSetValue(K->get(), r, r, 1e6 * (k_left + (i + 1 < m ? k_right : 0.0)), INSERT_VALUES));
    if (i + 1 < m) MORSE_CALL(MatSetValue(K->get(), r, r + 1, -1e6 * k_right, INSERT_VALUES));
    if (i > 0) MORSE_CALL(MatSetValue(K->get(), r, r - 1, -1e6 * k_left, INSERT_VALUES));
    MORSE_CALL(MatSetValue(M->get(), r, r, 1.0, INSERT_VALUES));
  }
  for (UMat* A : {K, M}) {
    MORSE_CALL(MatAssemblyBegin(A->get(), MAT_FINAL_ASSEMBLY));
    MORSE_CALL(MatAssemblyEnd(A->get(), MAT_FINAL_ASSEMBLY));
    MORSE_CALL(MatSetOption(A->get(), MAT_SYMMETRIC, PETSC_TRUE));
  }
}

}  // namespace

// Every mode, guaranteed: a cutoff solve on a pencil whose eigenvalues are all triple returns
// each cluster whole (LAPACK on the dense pencil is the reference), its count equals Sylvester's
// inertia, the residuals ||Kx - w^2 Mx|| / (||K|| ||x||) are below the tolerance and V^T M V = I;
// a solve made to lose its highest pair (fault injection) is refused, by cutoff and by count.
TEST(Eigen, EveryModeGuaranteedBySylvesterInertia) {
  for (const std::string solver : {"krylovschur", "block"}) {
    SCOPED_TRACE(solver);
    const PetscInt m = 40, n = 3 * m;
    UMat K, M;
    clustered(m, &K, &M);
    auto lam = eigen::dense_eigenvalues(static_cast<int>(n), test::dense_matrix(K.get()), test::dense_matrix(M.get()));
    // Cutoff between clusters 10 and 11 (eigenvalues 30..32 and 33..35).
    const double cutoff = 0.5 * (lam[29] + lam[30]);
    eigen::EigenSettings s;
    s.omega2_max = cutoff;
    s.solver = solver;
    s.prefix = "test_cluster_" + solver + "_";
    auto e = eigen::solve_eigen(K.get(), M.get(), s, nullptr);
    ASSERT_EQ(e.omega2.size(), 30u);
    EXPECT_EQ(e.inertia_count, 30);
    for (int k = 0; k < 30; ++k) EXPECT_NEAR(e.omega2[k], lam[k], 1e-9 * lam[k]) << "eigenvalue " << k;
    EXPECT_LE(e.max_residual, 1e-10);
    auto r = eigen::relative_residuals(K.get(), M.get(), e.V.get(), e.omega2);
    for (int k = 0; k < 30; ++k) EXPECT_LE(r[k], 1e-10) << "pair " << k;
    EXPECT_LT(identity_deviation(M.get(), e.V.get(), e.V.get()), 1e-10);
    // A wrong pair is caught by the residual check: perturb one eigenvalue.
    auto wrong = e.omega2;
    wrong[7] *= 1.0 + 1e-6;
    EXPECT_GT(eigen::relative_residuals(K.get(), M.get(), e.V.get(), wrong)[7], 1e-10);

    // Count mode with one shift: the 29 lowest (the cut falls inside the 10th cluster, so the
    // other converged copies of eigenvalue 29 tie at the window's edge) and the 12 nearest to a
    // shift between clusters 5 and 6 are checked by inertia and pass.
    for (const auto& [nev, shift] : {std::pair<PetscInt, double>{29, 0.0}, {12, 0.5 * (lam[14] + lam[15])}}) {
      eigen::EigenSettings t;
      t.nev = nev;
      t.shift = shift;
      t.solver = solver;
      t.count_slicing = 0;
      t.prefix = cat("test_check_", solver, "_", nev, "_");
      auto c = eigen::solve_eigen(K.get(), M.get(), t, nullptr);
      EXPECT_GE(c.inertia_count, nev) << "count mode was not checked by inertia";
      EXPECT_LE(c.inertia_count, nev + 2);
      if (shift > 0) {
        EXPECT_GT(c.check_lo, 0.0);
      }
    }

    // The check itself, on hand-made results with the eigenvalues of LAPACK: the 29 lowest cut the
    // 10th cluster, whose third copy is not among the pairs (an unconverged tie): accepted, with
    // 30 counted; the 29 lowest but the first (a missed mode) and a cluster copy dropped from
    // inside the window are refused.
    {
      eigen::EigenSettings t;
      t.nev = 29;
      t.prefix = cat("test_check_hand_", solver, "_");
      eigen::Eigenpairs tie;
      tie.omega2.assign(lam.begin(), lam.begin() + 29);
      eigen::check_count_by_inertia(K.get(), M.get(), t, {}, &tie);
      EXPECT_EQ(tie.inertia_count, 30);
      for (int variant = 0; variant < 2; ++variant) {
        eigen::Eigenpairs miss;
        if (variant == 0)
          miss.omega2.assign(lam.begin() + 1, lam.begin() + 30);  // the lowest lost
        else {
          miss.omega2.assign(lam.begin(), lam.begin() + 30);
          miss.omega2.erase(miss.omega2.begin() + 13);  // one copy of the 5th cluster lost
        }
        std::string msg;
        try {
          eigen::check_count_by_inertia(K.get(), M.get(), t, {}, &miss);
        } catch (const Error& err) {
          msg = err.what();
        }
        EXPECT_NE(msg.find("missed modes"), std::string::npos) << "variant " << variant << ": " << msg;
      }
    }

    // Fault injection: the solve loses a pair (by cutoff and count by slicing the highest, by
    // count with one shift the lowest); the Sylvester check refuses it.
    for (const std::string mode : {"cutoff", "count_slicing", "count"}) {
      if (mode == "count_slicing" && solver == "block") continue;  // the block solver does not slice
      eigen::EigenSettings t = s;
      t.prefix = cat("test_drop_", mode, "_", solver, "_");
      if (mode != "cutoff") {
        t.omega2_max = -1;
        t.nev = 30;
        t.count_slicing = mode == "count" ? 0 : 10;
      }
      eigen::detail::DropForTest drop(1);
      try {
        eigen::solve_eigen(K.get(), M.get(), t, nullptr);
        ADD_FAILURE() << "a truncated solve passed the Sylvester check (" << mode << ")";
      } catch (const Error& err) {
        const std::string msg = err.what();
        EXPECT_NE(msg.find("Sylvester"), std::string::npos) << msg;
        EXPECT_NE(msg.find("missed modes"), std::string::npos) << msg;
      }
    }
  }
}

// The block solver (multi-RHS solves, BLAS-3 Gram-Schmidt, Krylov-Schur restarts) gives the
// lowest modes of the beam as SLEPc's Krylov-Schur does: the same eigenvalues (1e-10) and the
// same shapes (MAC 1, signs included), for blocks of 1, 4 and 16 and a small basis that forces
// restarts; M-orthonormal vectors; its factor is kept for reuse.
TEST(Eigen, BlockSolverMatchesKrylovSchur) {
  auto s = small_beam();
  eigen::EigenSettings ks;
  ks.nev = 20;
  ks.prefix = "test_ks_";
  ks.count_slicing = 0;
  auto w = cb::sign_reference(test::model_of(s.lm, s.dofs, s.ops));
  auto ref = eigen::solve_eigen(s.ops.K.get(), s.ops.M.get(), ks, w.get());
  for (auto [block, dim] : {std::pair<int, int>{1, 0}, {4, 0}, {16, 0}, {4, 32}}) {
    SCOPED_TRACE(cat("block ", block, " max dim ", dim));
    eigen::EigenSettings bs = ks;
    bs.solver = "block";
    bs.prefix = cat("test_blk_", block, "_", dim, "_");
    set_default_option("-" + bs.prefix + "block_size", std::to_string(block));
    if (dim) set_default_option("-" + bs.prefix + "block_max_dim", std::to_string(dim));
    auto e = eigen::solve_eigen(s.ops.K.get(), s.ops.M.get(), bs, w.get());
    ASSERT_EQ(e.omega2.size(), 20u);
    EXPECT_NE(e.factor(), nullptr);
    for (int k = 0; k < 20; ++k) EXPECT_NEAR(e.omega2[k] / ref.omega2[k], 1.0, 1e-10) << "mode " << k;
    if (dim) {
      EXPECT_GT(e.iterations, 0) << "no restart with a 32-vector basis";
    }
    EXPECT_LT(identity_deviation(s.ops.M.get(), ref.V.get(), e.V.get()), 1e-6);
  }
}

// The default block basis is capped by memory (-<prefix>block_memory_gb, else 70 % of what is
// available after the factorization): with room for 33 vectors on the node the 20 modes still
// come out (blocks of 4, a 32-vector basis, so with restarts) and equal Krylov-Schur's; with
// room for fewer than nev + 2 blocks the solve stops and says what it needs.
TEST(Eigen, BlockBasisCappedByMemory) {
  auto s = small_beam();
  eigen::EigenSettings ks;
  ks.nev = 20;
  ks.prefix = "test_mks_";
  ks.count_slicing = 0;
  auto w = cb::sign_reference(test::model_of(s.lm, s.dofs, s.ops));
  auto ref = eigen::solve_eigen(s.ops.K.get(), s.ops.M.get(), ks, w.get());
  PetscInt n = 0;
  MORSE_CALL(MatGetSize(s.ops.K.get(), &n, nullptr));
  // Every rank of these tests runs on one machine: the node holds all n rows.
  auto gb_for = [&](double vectors) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.17g", 2.0 * sizeof(double) * static_cast<double>(n) * vectors / 1e9);
    return std::string(buf);
  };
  eigen::EigenSettings bs = ks;
  bs.solver = "block";
  bs.prefix = "test_mem_";
  set_default_option("-test_mem_block_size", "4");
  set_default_option("-test_mem_block_memory_gb", gb_for(33.5));
  auto e = eigen::solve_eigen(s.ops.K.get(), s.ops.M.get(), bs, w.get());
  ASSERT_EQ(e.omega2.size(), 20u);
  EXPECT_GT(e.iterations, 0) << "a 32-vector basis must restart";
  for (int k = 0; k < 20; ++k) EXPECT_NEAR(e.omega2[k] / ref.omega2[k], 1.0, 1e-10) << "mode " << k;
  EXPECT_LE(e.max_residual, 1e-10);
  bs.prefix = "test_mem_small_";
  set_default_option("-test_mem_small_block_size", "4");
  set_default_option("-test_mem_small_block_memory_gb", gb_for(20.5));
  std::string msg;
  try {
    eigen::solve_eigen(s.ops.K.get(), s.ops.M.get(), bs, w.get());
  } catch (const std::exception& x) {
    msg = x.what();
  }
  EXPECT_NE(msg.find("needs at least 28 vectors"), std::string::npos) << msg;
  EXPECT_NE(msg.find("-test_mem_small_eigen_solver krylovschur"), std::string::npos) << msg;
}

// The block solver's result does not depend on the block size: on the pencil whose eigenvalues
// are all triple, blocks of 1, 2, 5 and 16 (and a basis small enough to restart) give the 30
// lowest eigenvalues of LAPACK to 1e-10 and the same subspace for every cluster (subspace MAC:
// the singular values of V_a^T M V_b over a cluster are all 1). With a shift inside the spectrum
// (theta of both signs, every Ritz pair computed) the 12 nearest pairs are found.
TEST(Eigen, BlockSolverIndependentOfBlockSize) {
  const PetscInt m = 40, n = 3 * m;
  UMat K, M;
  clustered(m, &K, &M);
  auto lam = eigen::dense_eigenvalues(static_cast<int>(n), test::dense_matrix(K.get()), test::dense_matrix(M.get()));
  std::vector<eigen::Eigenpairs> runs;
  for (auto [block, dim] : {std::pair<int, int>{1, 0}, {2, 0}, {5, 0}, {16, 0}, {5, 50}}) {
    SCOPED_TRACE(cat("block ", block, " max dim ", dim));
    eigen::EigenSettings s;
    s.nev = 30;
    s.solver = "block";
    s.prefix = cat("test_bsz_", block, "_", dim, "_");
    set_default_option("-" + s.prefix + "block_size", std::to_string(block));
    if (dim) set_default_option("-" + s.prefix + "block_max_dim", std::to_string(dim));
    auto e = eigen::solve_eigen(K.get(), M.get(), s, nullptr);
    ASSERT_EQ(e.omega2.size(), 30u);
    for (int k = 0; k < 30; ++k) EXPECT_NEAR(e.omega2[k], lam[k], 1e-10 * lam[k]) << "eigenvalue " << k;
    EXPECT_LE(e.max_residual, 1e-10);
    runs.push_back(std::move(e));
  }
  // Subspace MAC per cluster against the first run: V_a^T M V_b restricted to a cluster is
  // orthogonal (3 x 3), so each column has unit norm.
  for (std::size_t r = 1; r < runs.size(); ++r) {
    UMat MV, X;
    MORSE_CALL(MatMatMult(M.get(), runs[r].V.get(), MAT_INITIAL_MATRIX, PETSC_DEFAULT, MV.ptr()));
    MORSE_CALL(MatTransposeMatMult(runs[0].V.get(), MV.get(), MAT_INITIAL_MATRIX, PETSC_DEFAULT, X.ptr()));
    auto x = test::dense_matrix(X.get());
    double worst = 0;
    for (int c = 0; c < 10; ++c)
      for (int j = 3 * c; j < 3 * c + 3; ++j) {
        double s2 = 0;
        for (int i = 3 * c; i < 3 * c + 3; ++i) s2 += x[i * 30 + j] * x[i * 30 + j];
        worst = std::max(worst, std::abs(1.0 - s2));
      }
    EXPECT_LT(worst, 1e-8) << "run " << r << ": a cluster's subspace differs from the first run's";
  }
  // A shift between clusters 5 and 6: the 12 eigenvalues nearest to it, from both sides.
  eigen::EigenSettings s;
  s.nev = 12;
  s.solver = "block";
  s.prefix = "test_bsz_shift_";
  s.shift = 0.5 * (lam[14] + lam[15]);
  set_default_option("-" + s.prefix + "block_size", "4");
  auto e = eigen::solve_eigen(K.get(), M.get(), s, nullptr);
  std::vector<double> nearest(lam.begin(), lam.end());
  std::sort(nearest.begin(), nearest.end(),
            [&](double a, double b) { return std::abs(a - s.shift) < std::abs(b - s.shift); });
  nearest.resize(12);
  std::sort(nearest.begin(), nearest.end());
  ASSERT_EQ(e.omega2.size(), 12u);
  for (int k = 0; k < 12; ++k) EXPECT_NEAR(e.omega2[k], nearest[k], 1e-10 * nearest[k]) << "eigenvalue " << k;
}

// Spectrum slicing with the block solver (-<prefix>block_slices, -<prefix>block_partitions: one
// subcommunicator per rank here), on the pencil whose eigenvalues are all triple: by cutoff, the
// 30 eigenvalues below it equal LAPACK's (1e-10), each cluster comes out whole and once
// (V^T M V = I: no copy found by two slices, none lost between them), the count equals
// Sylvester's; by count, the 30 lowest of the beam equal the one-shift block solve's, shapes and
// signs included; a slice that loses a pair is refused; partitions that do not divide the ranks
// are refused with the option's name.
TEST(Eigen, BlockSlicesOnSubcommunicators) {
  int size = 1;
  MPI_Comm_size(PETSC_COMM_WORLD, &size);
  const PetscInt m = 40, n = 3 * m;
  UMat K, M;
  clustered(m, &K, &M);
  auto lam = eigen::dense_eigenvalues(static_cast<int>(n), test::dense_matrix(K.get()), test::dense_matrix(M.get()));
  eigen::EigenSettings s;
  s.omega2_max = 0.5 * (lam[29] + lam[30]);
  s.solver = "block";
  s.prefix = "test_bslice_cut_";
  set_default_option("-test_bslice_cut_block_slices", "3");
  set_default_option("-test_bslice_cut_block_partitions", std::to_string(size));
  set_default_option("-test_bslice_cut_block_size", "2");
  auto e = eigen::solve_eigen(K.get(), M.get(), s, nullptr);
  EXPECT_TRUE(e.slicing);
  EXPECT_EQ(e.partitions, size);
  EXPECT_EQ(e.inertia_count, 30);
  ASSERT_EQ(e.omega2.size(), 30u);
  for (int k = 0; k < 30; ++k) EXPECT_NEAR(e.omega2[k], lam[k], 1e-10 * lam[k]) << "eigenvalue " << k;
  EXPECT_LE(e.max_residual, 1e-10);
  EXPECT_LT(identity_deviation(M.get(), e.V.get(), e.V.get()), 1e-10);

  auto b = small_beam();
  auto w = cb::sign_reference(test::model_of(b.lm, b.dofs, b.ops));
  eigen::EigenSettings one;
  one.nev = 30;
  one.solver = "block";
  one.prefix = "test_bslice_one_";
  auto a = eigen::solve_eigen(b.ops.K.get(), b.ops.M.get(), one, w.get());
  eigen::EigenSettings sl = one;
  sl.prefix = "test_bslice_cnt_";
  set_default_option("-test_bslice_cnt_block_slices", "4");
  set_default_option("-test_bslice_cnt_block_partitions", std::to_string(size));
  auto c = eigen::solve_eigen(b.ops.K.get(), b.ops.M.get(), sl, w.get());
  EXPECT_TRUE(c.slicing);
  ASSERT_EQ(c.omega2.size(), 30u);
  EXPECT_GE(c.inertia_count, 30);
  EXPECT_GE(c.slice_omega2, c.omega2.back());
  for (int k = 0; k < 30; ++k) EXPECT_NEAR(c.omega2[k] / a.omega2[k], 1.0, 1e-10) << "mode " << k;
  EXPECT_LT(identity_deviation(b.ops.M.get(), c.V.get(), c.V.get()), 1e-10);
  EXPECT_LT(identity_deviation(b.ops.M.get(), a.V.get(), c.V.get()), 1e-6);

  // Fault injection: the highest slice loses a pair.
  eigen::EigenSettings d = s;
  d.prefix = "test_bslice_drop_";
  set_default_option("-test_bslice_drop_block_slices", "3");
  set_default_option("-test_bslice_drop_block_partitions", std::to_string(size));
  std::string msg;
  try {
    eigen::detail::DropForTest drop(1);
    eigen::solve_eigen(K.get(), M.get(), d, nullptr);
  } catch (const Error& err) {
    msg = err.what();
  }
  EXPECT_NE(msg.find("Sylvester"), std::string::npos) << msg;
  EXPECT_NE(msg.find("missed modes"), std::string::npos) << msg;

  eigen::EigenSettings bad = s;
  bad.prefix = "test_bslice_bad_";
  set_default_option("-test_bslice_bad_block_partitions", std::to_string(size + 1));
  msg.clear();
  try {
    eigen::solve_eigen(K.get(), M.get(), bad, nullptr);
  } catch (const Error& err) {
    msg = err.what();
  }
  EXPECT_NE(msg.find("block_partitions"), std::string::npos) << msg;
}

// The count check refactoring the block solver's own factor in place (keep_factor = false, as
// morse modes runs): the same Sylvester counts as a check with its own factorization, against
// LAPACK's eigenvalues (the 29 lowest cut the 10th triple cluster: 30 counted; the 12 nearest a
// shift between clusters 5 and 6), no factor left to the caller, and a solve made to lose its
// lowest pair refused.
TEST(Eigen, CountCheckRefactorsTheSolverFactor) {
  const PetscInt m = 40, n = 3 * m;
  UMat K, M;
  clustered(m, &K, &M);
  auto lam = eigen::dense_eigenvalues(static_cast<int>(n), test::dense_matrix(K.get()), test::dense_matrix(M.get()));
  for (const auto& [nev, shift] : {std::pair<PetscInt, double>{29, 0.0}, {12, 0.5 * (lam[14] + lam[15])}}) {
    SCOPED_TRACE(cat("nev ", nev));
    eigen::EigenSettings t;
    t.nev = nev;
    t.shift = shift;
    t.solver = "block";
    t.keep_factor = false;
    t.prefix = cat("test_reuse_", nev, "_");
    auto e = eigen::solve_eigen(K.get(), M.get(), t, nullptr);
    EXPECT_EQ(e.factor(), nullptr);
    // LAPACK: the eigenvalues in the checked window.
    PetscInt expected = 0;
    for (double l : lam) expected += l >= e.check_lo && l <= e.check_hi ? 1 : 0;
    EXPECT_EQ(e.inertia_count, expected);
    EXPECT_GE(e.inertia_count, nev);
    eigen::EigenSettings own = t;
    own.keep_factor = true;
    own.prefix = cat("test_own_", nev, "_");
    auto f = eigen::solve_eigen(K.get(), M.get(), own, nullptr);
    EXPECT_NE(f.factor(), nullptr);
    EXPECT_EQ(f.inertia_count, e.inertia_count);
  }
  eigen::EigenSettings d;
  d.nev = 30;
  d.solver = "block";
  d.keep_factor = false;
  d.prefix = "test_reuse_drop_";
  std::string msg;
  try {
    eigen::detail::DropForTest drop(1);
    eigen::solve_eigen(K.get(), M.get(), d, nullptr);
  } catch (const Error& err) {
    msg = err.what();
  }
  EXPECT_NE(msg.find("missed modes"), std::string::npos) << msg;
}
