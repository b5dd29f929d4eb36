// The eigen solver's building blocks: inertia counts of K - sigma M against the eigenvalues of
// the dense pencil (Sylvester's law of inertia), and the N lowest modes by inertia search +
// spectrum slicing against the single-shift Krylov-Schur solve.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "morse/cb/craig_bampton.hpp"
#include "morse/cb/eigen.hpp"
#include "morse/core/session.hpp"
#include "morse/fe/model.hpp"
#include "util.hpp"

using namespace morse;

namespace {

struct Small {
  mesh::LocalMesh lm;
  fe::DofMap dofs;
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

// The whole matrix, row-major, on every rank.
std::vector<double> dense(Mat A) {
  PetscInt n = 0, rs = 0, re = 0;
  MORSE_CALL(MatGetSize(A, &n, nullptr));
  MORSE_CALL(MatGetOwnershipRange(A, &rs, &re));
  std::vector<double> d(static_cast<std::size_t>(n) * n, 0.0);
  for (PetscInt r = rs; r < re; ++r) {
    PetscInt nc;
    const PetscInt* cols;
    const PetscScalar* vals;
    MORSE_CALL(MatGetRow(A, r, &nc, &cols, &vals));
    for (PetscInt k = 0; k < nc; ++k) d[r * n + cols[k]] = PetscRealPart(vals[k]);
    MORSE_CALL(MatRestoreRow(A, r, &nc, &cols, &vals));
  }
  MPI_Allreduce(MPI_IN_PLACE, d.data(), static_cast<int>(d.size()), MPI_DOUBLE, MPI_SUM, PETSC_COMM_WORLD);
  return d;
}

}  // namespace

// Negative pivots of LDL^T(K - sigma M) = number of eigenvalues below sigma, for cutoffs in the
// gaps of the spectrum from the first to the last eigenvalue.
TEST(Eigen, InertiaCountsMatchTheDenseSpectrum) {
  auto s = small_beam();
  PetscInt n = 0;
  MORSE_CALL(MatGetSize(s.ops.K.get(), &n, nullptr));
  auto lam = cb::dense_eigenvalues(static_cast<int>(n), dense(s.ops.K.get()), dense(s.ops.M.get()));
  cb::InertiaCounter counter(s.ops.K.get(), s.ops.M.get(), "test_inertia_");
  for (PetscInt k : {PetscInt(0), PetscInt(1), PetscInt(5), PetscInt(40), n / 2, n - 2}) {
    const double sigma = 0.5 * (lam[k] + lam[k + 1]);
    EXPECT_EQ(counter.count(sigma), k + 1) << "cutoff between eigenvalues " << k << " and " << k + 1;
  }
  EXPECT_EQ(counter.count(0.5 * lam[0]), 0);
  EXPECT_EQ(counter.count(2.0 * lam[n - 1]), n);
  EXPECT_EQ(counter.factorizations(), 8);
}

// Count mode by slicing (forced with a low threshold) gives the same N lowest eigenvalues as one
// shift, M-orthonormal eigenvectors with the same shapes (MAC 1), and reports its cutoff.
TEST(Eigen, CountBySlicingMatchesOneShift) {
  auto s = small_beam();
  cb::EigenSettings one;
  one.nev = 30;
  one.prefix = "test_one_";
  one.count_slicing = 0;
  cb::EigenSettings sliced = one;
  sliced.prefix = "test_sliced_";
  sliced.count_slicing = 10;
  auto w = cb::sign_reference(s.lm, s.dofs);
  auto a = cb::solve_eigen(s.ops.K.get(), s.ops.M.get(), one, w.get());
  auto b = cb::solve_eigen(s.ops.K.get(), s.ops.M.get(), sliced, w.get());
  EXPECT_FALSE(a.slicing);
  EXPECT_TRUE(b.slicing);
  EXPECT_GT(b.inertia_counts, 0);
  ASSERT_EQ(b.omega2.size(), 30u);
  EXPECT_GE(b.slice_omega2, b.omega2.back());
  for (int k = 0; k < 30; ++k) EXPECT_NEAR(b.omega2[k] / a.omega2[k], 1.0, 1e-9) << "mode " << k;
  // V_b^T M V_b = I and V_a^T M V_b = I (same shapes and signs: non-repeated eigenvalues).
  UMat MVb, G, X;
  MORSE_CALL(MatMatMult(s.ops.M.get(), b.V.get(), MAT_INITIAL_MATRIX, PETSC_DEFAULT, MVb.ptr()));
  MORSE_CALL(MatTransposeMatMult(b.V.get(), MVb.get(), MAT_INITIAL_MATRIX, PETSC_DEFAULT, G.ptr()));
  MORSE_CALL(MatTransposeMatMult(a.V.get(), MVb.get(), MAT_INITIAL_MATRIX, PETSC_DEFAULT, X.ptr()));
  auto g = dense(G.get()), x = dense(X.get());
  double err_g = 0, err_x = 0;
  for (int i = 0; i < 30; ++i)
    for (int j = 0; j < 30; ++j) {
      err_g = std::max(err_g, std::abs(g[i * 30 + j] - (i == j ? 1.0 : 0.0)));
      err_x = std::max(err_x, std::abs(x[i * 30 + j] - (i == j ? 1.0 : 0.0)));
    }
  EXPECT_LT(err_g, 1e-8);
  EXPECT_LT(err_x, 1e-6);
}
