// The repeatable factorization (morse/core/factor.hpp, -factor_repeatable): MUMPS on rank 0 of the
// matrix gathered there, behind a factor Mat that does what MUMPS's does. Checked against exact
// identities (residuals of the solves, Sylvester's inertia against the dense spectrum, the null
// pivots of a free body), against MUMPS's own parallel factor, and for the property it exists
// for: two factorizations and two solves in the same run give the same bits.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include "morse/core/factor.hpp"
#include "morse/core/session.hpp"
#include "morse/eigen/eigen.hpp"
#include "util.hpp"

using namespace morse;

namespace {

struct Beam {
  mesh::LocalMesh lm;
  fe::DofLayout dofs;
  fe::Operators ops;
};

// A 6 x 2 x 2 hex8 cantilever (162 free DOFs), or the same beam free (180 DOFs, 6 rigid modes).
Beam beam(bool clamped) {
  auto b = test::box_spec(mesh::ElementType::Hex8, 0.6, 0.1, 0.06, 6, 2, 2);
  Beam s;
  s.lm = test::box_mesh(PETSC_COMM_WORLD, b);
  s.dofs = fe::number_dofs(s.lm, clamped ? std::vector<std::string>{"x0"} : std::vector<std::string>{});
  s.ops = fe::assemble(s.lm, s.dofs, test::steel());
  return s;
}

int ranks() {
  int size = 1;
  MPI_Comm_size(PETSC_COMM_WORLD, &size);
  return size;
}

// A Cholesky (LDL^T) factor of A by the given solver type, with ICNTL(24) = 1 (null pivots).
UMat factor(Mat A, const char* type, PetscInt icntl24 = 1) {
  UMat F;
  MORSE_CALL(MatGetFactor(A, type, MAT_FACTOR_CHOLESKY, F.ptr()));
  MORSE_CALL(MatMumpsSetIcntl(F.get(), 24, icntl24));
  MORSE_CALL(MatMumpsSetIcntl(F.get(), 13, 1));  // MUMPS's inertia on several ranks
  MatFactorInfo info;
  MORSE_CALL(MatFactorInfoInitialize(&info));
  MORSE_CALL(MatCholeskyFactorSymbolic(F.get(), A, nullptr, &info));
  MORSE_CALL(MatCholeskyFactorNumeric(F.get(), A, &info));
  return F;
}

// A right-hand side with every entry set (a fixed smooth pattern of the global index).
UVec rhs(Mat A, double phase) {
  UVec b;
  MORSE_CALL(MatCreateVecs(A, nullptr, b.ptr()));
  PetscInt lo = 0, hi = 0;
  MORSE_CALL(VecGetOwnershipRange(b.get(), &lo, &hi));
  for (PetscInt i = lo; i < hi; ++i) MORSE_CALL(VecSetValue(b.get(), i, std::sin(0.37 * i + phase), INSERT_VALUES));
  MORSE_CALL(VecAssemblyBegin(b.get()));
  MORSE_CALL(VecAssemblyEnd(b.get()));
  return b;
}

double relative_residual(Mat A, Vec x, Vec b) {
  UVec r;
  MORSE_CALL(VecDuplicate(b, r.ptr()));
  MORSE_CALL(MatMult(A, x, r.get()));
  MORSE_CALL(VecAXPY(r.get(), -1.0, b));
  PetscReal nr = 0, nb = 0, na = 0, nx = 0;
  MORSE_CALL(VecNorm(r.get(), NORM_INFINITY, &nr));
  MORSE_CALL(VecNorm(b, NORM_INFINITY, &nb));
  MORSE_CALL(VecNorm(x, NORM_INFINITY, &nx));
  MORSE_CALL(MatNorm(A, NORM_INFINITY, &na));
  return nr / (na * nx + nb);
}

// The whole vector on every rank.
std::vector<double> gathered(Vec x) {
  PetscInt n = 0, lo = 0, hi = 0;
  MORSE_CALL(VecGetSize(x, &n));
  MORSE_CALL(VecGetOwnershipRange(x, &lo, &hi));
  std::vector<double> all(static_cast<std::size_t>(n), 0.0);
  const PetscScalar* a = nullptr;
  MORSE_CALL(VecGetArrayRead(x, &a));
  for (PetscInt i = lo; i < hi; ++i) all[i] = PetscRealPart(a[i - lo]);
  MORSE_CALL(VecRestoreArrayRead(x, &a));
  MPI_Allreduce(MPI_IN_PLACE, all.data(), static_cast<int>(n), MPI_DOUBLE, MPI_SUM, PETSC_COMM_WORLD);
  return all;
}

bool same_bits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
}

// Restores -factor_repeatable's setting at the end of a test.
struct RepeatableOn {
  bool before = repeatable_factorization();
  RepeatableOn() { set_repeatable_factorization(true); }
  ~RepeatableOn() { set_repeatable_factorization(before); }
};

}  // namespace

// The solver type: the repeatable one only when asked for and on several ranks.
TEST(Factor, SolverTypeFollowsTheOptionAndTheRankCount) {
  EXPECT_STREQ(cholesky_solver(PETSC_COMM_WORLD), MATSOLVERMUMPS);
  RepeatableOn on;
  EXPECT_STREQ(cholesky_solver(PETSC_COMM_WORLD), ranks() > 1 ? kRepeatableSolver : MATSOLVERMUMPS);
  EXPECT_STREQ(cholesky_solver(PETSC_COMM_SELF), MATSOLVERMUMPS);
}

// One and several right-hand sides: residuals at round-off, the same solution as MUMPS's parallel
// factor to the conditioning, and the same bits from a second factorization and a second solve.
TEST(Factor, SolvesAsMumpsAndRepeatsItsBits) {
  auto s = beam(true);
  Mat K = s.ops.K.get();
  auto F = factor(K, kRepeatableSolver);
  auto P = factor(K, MATSOLVERMUMPS);
  MatSolverType type = nullptr;
  MORSE_CALL(MatFactorGetSolverType(F.get(), &type));
  EXPECT_STREQ(type, kRepeatableSolver);

  auto b = rhs(K, 0.0);
  UVec x, y, z;
  MORSE_CALL(VecDuplicate(b.get(), x.ptr()));
  MORSE_CALL(VecDuplicate(b.get(), y.ptr()));
  MORSE_CALL(VecDuplicate(b.get(), z.ptr()));
  MORSE_CALL(MatSolve(F.get(), b.get(), x.get()));
  MORSE_CALL(MatSolve(P.get(), b.get(), y.get()));
  EXPECT_LT(relative_residual(K, x.get(), b.get()), 1e-14);
  const auto xa = gathered(x.get()), ya = gathered(y.get());
  double dmax = 0, xmax = 0;
  for (std::size_t i = 0; i < xa.size(); ++i) {
    dmax = std::max(dmax, std::abs(xa[i] - ya[i]));
    xmax = std::max(xmax, std::abs(xa[i]));
  }
  EXPECT_LT(dmax / xmax, 1e-9) << "against MUMPS's parallel factor";

  // The same solve again, and a second factor of the same matrix: the same bits.
  MORSE_CALL(MatSolve(F.get(), b.get(), z.get()));
  EXPECT_TRUE(same_bits(xa, gathered(z.get())));
  auto F2 = factor(K, kRepeatableSolver);
  MORSE_CALL(MatSolve(F2.get(), b.get(), z.get()));
  EXPECT_TRUE(same_bits(xa, gathered(z.get())));

  // Five right-hand sides at once (MatMatSolve): each column solves its own system.
  PetscInt m = 0, n = 0;
  MORSE_CALL(MatGetLocalSize(K, &m, nullptr));
  MORSE_CALL(MatGetSize(K, &n, nullptr));
  const PetscInt k = 5;
  UMat B, X;
  MORSE_CALL(MatCreateDense(PETSC_COMM_WORLD, m, PETSC_DECIDE, n, k, nullptr, B.ptr()));
  MORSE_CALL(MatCreateDense(PETSC_COMM_WORLD, m, PETSC_DECIDE, n, k, nullptr, X.ptr()));
  for (PetscInt j = 0; j < k; ++j) {
    auto bj = rhs(K, 0.9 * j);
    Vec col;
    MORSE_CALL(MatDenseGetColumnVecWrite(B.get(), j, &col));
    MORSE_CALL(VecCopy(bj.get(), col));
    MORSE_CALL(MatDenseRestoreColumnVecWrite(B.get(), j, &col));
  }
  MORSE_CALL(MatMatSolve(F.get(), B.get(), X.get()));
  for (PetscInt j = 0; j < k; ++j) {
    Vec bj, xj;
    MORSE_CALL(MatDenseGetColumnVecRead(B.get(), j, &bj));
    MORSE_CALL(MatDenseGetColumnVecRead(X.get(), j, &xj));
    EXPECT_LT(relative_residual(K, xj, bj), 1e-14) << "column " << j;
    if (j == 0) {
      const auto x0 = gathered(xj);
      double d = 0;
      for (std::size_t i = 0; i < x0.size(); ++i) d = std::max(d, std::abs(x0[i] - xa[i]));
      EXPECT_LT(d / xmax, 1e-13) << "MatMatSolve against MatSolve";
    }
    MORSE_CALL(MatDenseRestoreColumnVecRead(X.get(), j, &xj));
    MORSE_CALL(MatDenseRestoreColumnVecRead(B.get(), j, &bj));
  }
}

// Sylvester's law of inertia: the negative pivots of K - sigma M count the eigenvalues of the
// dense pencil below sigma; the inertia counter takes the repeatable factor when asked.
TEST(Factor, InertiaCountsTheDenseSpectrum) {
  auto s = beam(true);
  PetscInt n = 0;
  MORSE_CALL(MatGetSize(s.ops.K.get(), &n, nullptr));
  const auto lam = eigen::dense_eigenvalues(static_cast<int>(n), test::dense_matrix(s.ops.K.get()),
                                            test::dense_matrix(s.ops.M.get()));
  RepeatableOn on;
  eigen::InertiaCounter counter(s.ops.K.get(), s.ops.M.get(), "test_factor_inertia_");
  for (PetscInt k : {PetscInt(0), PetscInt(7), n / 2, n - 2}) {
    const double sigma = 0.5 * (lam[k] + lam[k + 1]);
    EXPECT_EQ(counter.count(sigma), k + 1) << "cutoff between eigenvalues " << k << " and " << k + 1;
  }
  // Zero and positive pivots too (ICNTL(24) = 1), at a shift between two eigenvalues.
  UMat A;
  MORSE_CALL(MatDuplicate(s.ops.K.get(), MAT_COPY_VALUES, A.ptr()));
  MORSE_CALL(MatAXPY(A.get(), -0.5 * (lam[3] + lam[4]), s.ops.M.get(), SAME_NONZERO_PATTERN));
  auto F = factor(A.get(), cholesky_solver(PETSC_COMM_WORLD));
  PetscInt nneg = -1, nzero = -1, npos = -1;
  MORSE_CALL(MatGetInertia(F.get(), &nneg, &nzero, &npos));
  EXPECT_EQ(nneg, 4);
  EXPECT_EQ(nzero, 0);
  EXPECT_EQ(npos, n - 4);
}

// A free body: K is singular, and the null pivots are seen (INFOG(28) > 0), as with MUMPS's own
// factor; its rigid-body modes then come out of the eigen solver at zero frequency.
TEST(Factor, NullPivotsOfAFreeBody) {
  auto s = beam(false);
  RepeatableOn on;
  auto F = factor(s.ops.K.get(), cholesky_solver(PETSC_COMM_WORLD));
  PetscInt nulls = 0;
  MORSE_CALL(MatMumpsGetInfog(F.get(), 28, &nulls));
  EXPECT_GT(nulls, 0);
  EXPECT_EQ(eigen::mumps_null_pivots(F.get()), nulls);
  eigen::EigenSettings es;
  es.nev = 10;
  es.solver = "block";
  es.prefix = "test_factor_free_";
  auto e = eigen::solve_eigen(s.ops.K.get(), s.ops.M.get(), es, nullptr);
  ASSERT_EQ(e.omega2.size(), 10u);
  for (int k = 0; k < 6; ++k) EXPECT_EQ(e.omega2[k], 0.0) << "rigid-body mode " << k;
  EXPECT_GT(e.omega2[6], 1e3);
}

// The eigen solver (block solver: MatMatSolve on the factor, inertia check) gives the same modes
// with the repeatable factor, to the solver's tolerance, and the same bits twice.
TEST(Factor, EigenSolveRepeatsItsBits) {
  auto s = beam(true);
  eigen::EigenSettings es;
  es.nev = 12;
  es.solver = "block";
  es.prefix = "test_factor_eigen_";
  const auto ref = eigen::solve_eigen(s.ops.K.get(), s.ops.M.get(), es, nullptr);
  RepeatableOn on;
  const auto a = eigen::solve_eigen(s.ops.K.get(), s.ops.M.get(), es, nullptr);
  const auto b = eigen::solve_eigen(s.ops.K.get(), s.ops.M.get(), es, nullptr);
  ASSERT_EQ(a.omega2.size(), 12u);
  for (int k = 0; k < 12; ++k) EXPECT_NEAR(a.omega2[k] / ref.omega2[k], 1.0, 1e-10) << "mode " << k;
  EXPECT_TRUE(same_bits(a.omega2, b.omega2));
}

// A failure of rank 0's MUMPS (a structurally singular matrix without null-pivot detection) is
// an error on every rank, not a hang.
TEST(Factor, FailureOnRankZeroIsAnErrorOnEveryRank) {
  PetscInt n = 12;
  UMat A;
  MORSE_CALL(MatCreateAIJ(PETSC_COMM_WORLD, PETSC_DECIDE, PETSC_DECIDE, n, n, 1, nullptr, 0, nullptr, A.ptr()));
  PetscInt lo = 0, hi = 0;
  MORSE_CALL(MatGetOwnershipRange(A.get(), &lo, &hi));
  for (PetscInt i = lo; i < hi; ++i) MORSE_CALL(MatSetValue(A.get(), i, i, i == 5 ? 0.0 : 1.0 + i, INSERT_VALUES));
  MORSE_CALL(MatAssemblyBegin(A.get(), MAT_FINAL_ASSEMBLY));
  MORSE_CALL(MatAssemblyEnd(A.get(), MAT_FINAL_ASSEMBLY));
  MORSE_CALL(MatSetOption(A.get(), MAT_SYMMETRIC, PETSC_TRUE));
  std::string err;
  try {
    factor(A.get(), kRepeatableSolver, 0);
  } catch (const std::exception& e) {
    err = e.what();
  }
  int failed = err.empty() ? 0 : 1, all = 0;
  MPI_Allreduce(&failed, &all, 1, MPI_INT, MPI_SUM, PETSC_COMM_WORLD);
  EXPECT_EQ(all, ranks()) << err;
}
