// Reduced St Venant–Kirchhoff forces (nlrom/nlrom.hpp) against exact identities: the element-wise
// projected tensors reproduce W^T g_nl(Phi q) computed on the full model for arbitrary q; the
// block reduced-force evaluation equals full-model evaluations; STEP (eq. 29–37) identifies the
// same tensors as the exact projection to round-off (St Venant–Kirchhoff is exactly cubic), also
// with POD filtering, where the reference is Phi^T Phi_f Phi_f^T g_nl.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include "given_options.hpp"
#include "morse/cb/craig_bampton.hpp"
#include "morse/core/session.hpp"
#include "morse/eigen/eigen.hpp"
#include "morse/io/h5.hpp"
#include "morse/nlrom/nlrom.hpp"
#include "scratch.hpp"
#include "util.hpp"

using namespace morse;
using mesh::ElementType;

namespace {

using test::Model;

Model box(ElementType t, int nx = 3) {
  auto b = test::box_spec(t, 1.0, 0.3, 0.2, nx, 1, 1);
  b.distortion = 0.15;
  return test::assembled_box(PETSC_COMM_WORLD, b);
}

// A basis of r smooth fields with displacements of order `scale`.
UMat smooth_basis(const Model& m, int r, double scale) {
  UMat P;
  MORSE_CALL(MatCreateDense(PETSC_COMM_WORLD, m.dofs.n_owned, PETSC_DECIDE, m.dofs.n_global, r, nullptr, P.ptr()));
  for (int j = 0; j < r; ++j) {
    auto v = test::nodal_vector(m.lm, m.dofs, [=](double x, double y, double z, int d) {
      return scale * x *
             (std::sin(1.1 * (j + 1) * x + 0.7 * d + 0.3 * j) + 0.4 * y * (d + j) - 0.3 * z * std::cos(j * x));
    });
    Vec c;
    MORSE_CALL(MatDenseGetColumnVecWrite(P.get(), j, &c));
    MORSE_CALL(VecCopy(v.get(), c));
    MORSE_CALL(MatDenseRestoreColumnVecWrite(P.get(), j, &c));
  }
  return P;
}

// W^T g_nl(Phi q) on the full model.
std::vector<double> direct(const fe::Svk& svk, Mat Phi, Mat W, const std::vector<double>& q) {
  UVec u, g, c;
  MORSE_CALL(MatCreateVecs(Phi, c.ptr(), u.ptr()));
  MORSE_CALL(VecDuplicate(u.get(), g.ptr()));
  PetscInt r;
  MORSE_CALL(MatGetSize(Phi, nullptr, &r));
  for (PetscInt i = 0; i < r; ++i) MORSE_CALL(VecSetValue(c.get(), i, q[i], INSERT_VALUES));
  MORSE_CALL(VecAssemblyBegin(c.get()));
  MORSE_CALL(VecAssemblyEnd(c.get()));
  MORSE_CALL(MatMult(Phi, c.get(), u.get()));
  svk.nonlinear_force(u.get(), g.get());
  return nlrom::project_vector(W, g.get());
}

double max_abs(const std::vector<double>& v) {
  double m = 0;
  for (double x : v) m = std::max(m, std::abs(x));
  return m;
}

}  // namespace

class NlromByType : public ::testing::TestWithParam<ElementType> {};

// Exact tensors reproduce Phi^T g_nl(Phi q); so does the block evaluation (also with W != Phi).
TEST_P(NlromByType, ExactTensorsMatchFullModel) {
  auto m = box(GetParam());
  fe::Svk svk(m.lm, m.dofs, test::steel(), m.ops.K.get());
  const int r = 5;
  auto Phi = smooth_basis(m, r, 0.02);
  auto W = smooth_basis(m, 3, 1.0);
  auto f = nlrom::exact_forces(svk, Phi.get());
  ASSERT_EQ(f.A.size(), nlrom::n_quadratic(r) * r);
  ASSERT_EQ(f.B.size(), nlrom::n_cubic(r) * r);
  std::mt19937 gen(7);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  const int nf = 4;
  std::vector<double> Q(r * nf);
  for (auto& x : Q) x = U(gen);
  auto block = svk.reduced_nonlinear_forces(Phi.get(), nullptr, Q, nf, 3);
  auto blockW = svk.reduced_nonlinear_forces(Phi.get(), W.get(), Q, nf, 2);
  for (int k = 0; k < nf; ++k) {
    std::vector<double> q(Q.begin() + k * r, Q.begin() + (k + 1) * r), g(r);
    auto ref = direct(svk, Phi.get(), Phi.get(), q);
    auto refW = direct(svk, Phi.get(), W.get(), q);
    f.evaluate(q.data(), g.data());
    const double s = max_abs(ref);
    ASSERT_GT(s, 0.0);
    for (int p = 0; p < r; ++p) {
      EXPECT_NEAR(g[p], ref[p], 1e-11 * s) << "tensors, field " << k << " output " << p;
      EXPECT_NEAR(block[k * r + p], ref[p], 1e-12 * s) << "block, field " << k << " output " << p;
    }
    for (int p = 0; p < 3; ++p) EXPECT_NEAR(blockW[k * 3 + p], refW[p], 1e-12 * max_abs(refW));
  }
}

// STEP identifies the exact tensors (to round-off) on a Craig-Bampton basis (boundary x1).
TEST_P(NlromByType, StepEqualsExactOnCraigBampton) {
  auto m = box(GetParam(), 2);
  fe::Svk svk(m.lm, m.dofs, test::steel(), m.ops.K.get());
  auto cbr = test::cb_basis(m, "x1", 3);
  nlrom::StepSettings ss;
  ss.displacement = 0.01;
  ss.chunk = 50;
  auto st = nlrom::step_forces(svk, cbr.T.get(), ss);
  auto ex = nlrom::exact_forces(svk, cbr.T.get());
  ASSERT_EQ(st.A.size(), ex.A.size());
  ASSERT_EQ(st.B.size(), ex.B.size());
  const double sa = ex.max_abs_A(), sb = ex.max_abs_B();
  double da = 0, db = 0;
  for (std::size_t i = 0; i < ex.A.size(); ++i) da = std::max(da, std::abs(st.A[i] - ex.A[i]));
  for (std::size_t i = 0; i < ex.B.size(); ++i) db = std::max(db, std::abs(st.B[i] - ex.B[i]));
  EXPECT_LT(da, 1e-8 * sa) << mesh::element_name(GetParam());
  EXPECT_LT(db, 1e-8 * sb) << mesh::element_name(GetParam());
}

INSTANTIATE_TEST_SUITE_P(AllTypes, NlromByType,
                         ::testing::ValuesIn({ElementType::Tet10, ElementType::Wedge15, ElementType::Hex8,
                                              ElementType::Hex20}),
                         [](const auto& i) { return mesh::element_name(i.param); });

// POD-filtered STEP (eq. 38–39) equals the exact tensors of Phi^T Phi_f Phi_f^T g_nl, checked on
// sample points against the full model.
// The memory of the reduced force, known before the basis is built: for r = 324 the cubic
// coefficients B are 14.8 GB (the figure) and A 0.14 GB more, STEP adds its imposed
// fields and their forces; a basis whose force cannot fit is refused naming r and what it needs.
TEST(Nlrom, ForceMemoryCheckedBeforeTheBasis) {
  const double rr = 324;
  EXPECT_DOUBLE_EQ(nlrom::force_bytes(324, false), 8 * rr * (rr * (rr + 1) / 2 + rr * (rr + 1) * (rr + 2) / 6));
  EXPECT_NEAR(nlrom::force_bytes(324, false) / 1e9, 14.97, 0.01);
  EXPECT_DOUBLE_EQ(nlrom::force_bytes(324, true) - nlrom::force_bytes(324, false),
                   16 * rr * static_cast<double>(nlrom::step_evaluations(324)));
  EXPECT_NO_THROW(nlrom::check_force_memory(PETSC_COMM_WORLD, 10, true));
  try {
    nlrom::check_force_memory(PETSC_COMM_WORLD, 100000, false);
    ADD_FAILURE() << "no error for r = 100000";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()).rfind("nlrom r = 100000 needs ", 0), 0u) << e.what();
    EXPECT_NE(std::string(e.what()).find("for the cubic tensor"), std::string::npos) << e.what();
  }
}

TEST(Nlrom, FilteredStepMatchesFilteredForces) {
  auto m = box(ElementType::Hex8);
  fe::Svk svk(m.lm, m.dofs, test::steel(), m.ops.K.get());
  const int r = 4;
  auto Phi = smooth_basis(m, r, 1.0);
  auto Pf = smooth_basis(m, 6, 1.0);
  // Orthonormalize the filter basis (its columns are independent smooth fields).
  {
    std::vector<UVec> cols(6);
    for (PetscInt j = 0; j < 6; ++j) {
      Vec c;
      MORSE_CALL(MatDenseGetColumnVecRead(Pf.get(), j, &c));
      MORSE_CALL(VecDuplicate(c, cols[j].ptr()));
      MORSE_CALL(VecCopy(c, cols[j].get()));
      MORSE_CALL(MatDenseRestoreColumnVecRead(Pf.get(), j, &c));
      for (PetscInt i = 0; i < j; ++i) {
        double d;
        MORSE_CALL(VecDot(cols[j].get(), cols[i].get(), &d));
        MORSE_CALL(VecAXPY(cols[j].get(), -d, cols[i].get()));
      }
      MORSE_CALL(VecNormalize(cols[j].get(), nullptr));
      MORSE_CALL(MatDenseGetColumnVecWrite(Pf.get(), j, &c));
      MORSE_CALL(VecCopy(cols[j].get(), c));
      MORSE_CALL(MatDenseRestoreColumnVecWrite(Pf.get(), j, &c));
    }
  }
  nlrom::StepSettings ss;
  ss.filter = Pf.get();
  auto st = nlrom::step_forces(svk, Phi.get(), ss);
  auto P = cb::transpose_product(PETSC_COMM_WORLD, Phi.get(), Pf.get());  // r x 6
  std::vector<double> q = {0.003, -0.002, 0.001, 0.004}, g(r);
  auto gf = direct(svk, Phi.get(), Pf.get(), q);
  st.evaluate(q.data(), g.data());
  std::vector<double> ref(r, 0.0);
  for (int p = 0; p < r; ++p)
    for (int l = 0; l < 6; ++l) ref[p] += P[p * 6 + l] * gf[l];
  const double s = max_abs(ref);
  ASSERT_GT(s, 0.0);
  for (int p = 0; p < r; ++p) EXPECT_NEAR(g[p], ref[p], 1e-8 * s);
}

// ---- Bases.

namespace {

double column_dot(Mat A, PetscInt i, Mat M, Mat B, PetscInt j) {  // A_i^T M B_j
  Vec a, b;
  UVec Mb;
  MORSE_CALL(MatCreateVecs(M, Mb.ptr(), nullptr));
  MORSE_CALL(MatDenseGetColumnVecRead(B, j, &b));
  MORSE_CALL(MatMult(M, b, Mb.get()));
  MORSE_CALL(MatDenseRestoreColumnVecRead(B, j, &b));
  MORSE_CALL(MatDenseGetColumnVecRead(A, i, &a));
  double d;
  MORSE_CALL(VecDot(a, Mb.get(), &d));
  MORSE_CALL(MatDenseRestoreColumnVecRead(A, i, &a));
  return d;
}

// Largest |V(g, j) - [g == boundary j]| over the boundary rows (u_b = q_b, eq. 9).
double boundary_defect(Mat V, const std::vector<PetscInt>& bdofs) {
  PetscInt lo, hi, r;
  MORSE_CALL(MatGetOwnershipRange(V, &lo, &hi));
  MORSE_CALL(MatGetSize(V, nullptr, &r));
  double worst = 0;
  for (std::size_t k = 0; k < bdofs.size(); ++k) {
    if (bdofs[k] < lo || bdofs[k] >= hi) continue;
    for (PetscInt j = 0; j < r; ++j) {
      PetscScalar v;
      PetscInt row = bdofs[k];
      MORSE_CALL(MatGetValues(V, 1, &row, 1, &j, &v));
      worst = std::max(worst, std::abs(v - (j == static_cast<PetscInt>(k) ? 1.0 : 0.0)));
    }
  }
  MPI_Allreduce(MPI_IN_PLACE, &worst, 1, MPI_DOUBLE, MPI_MAX, PETSC_COMM_WORLD);
  return worst;
}

}  // namespace

// Modal derivatives: symmetric (psi_ij = psi_ji), zero on the boundary, and they solve eq. 22
// on the interior, checked with the assembled tangent: K psi_ij = -(K_T(e phi_i) - K_T(-e phi_i)) phi_j / 2e.
TEST(Nlrom, ModalDerivativesSymmetricAndSolveEq22) {
  auto m = box(ElementType::Hex20, 4);
  fe::Svk svk(m.lm, m.dofs, test::steel(), m.ops.K.get());
  auto c = test::cb_basis(m, "x1", 3);
  const PetscInt i = 1, j = c.n_b + 1;  // a constraint mode and a fixed-interface mode
  auto Psi = nlrom::modal_derivatives(svk, c.T.get(), c.boundary_dofs, {{i, j}, {j, i}, {j, j}});
  UVec a, b, Ka, ti, tj, up, y1, y2;
  MORSE_CALL(MatCreateVecs(m.ops.K.get(), a.ptr(), b.ptr()));
  for (UVec* v : {&Ka, &ti, &tj, &up, &y1, &y2}) MORSE_CALL(VecDuplicate(a.get(), v->ptr()));
  auto col = [](Mat A, PetscInt k, Vec out) {
    Vec x;
    MORSE_CALL(MatDenseGetColumnVecRead(A, k, &x));
    MORSE_CALL(VecCopy(x, out));
    MORSE_CALL(MatDenseRestoreColumnVecRead(A, k, &x));
  };
  col(Psi.get(), 0, a.get());
  col(Psi.get(), 1, b.get());
  double na, d;
  MORSE_CALL(VecNorm(a.get(), NORM_INFINITY, &na));
  ASSERT_GT(na, 0.0);
  MORSE_CALL(VecAXPY(b.get(), -1.0, a.get()));
  MORSE_CALL(VecNorm(b.get(), NORM_INFINITY, &d));
  EXPECT_LT(d, 1e-10 * na) << "psi_ij != psi_ji";
  // Eq. 22 on the interior with the assembled tangent.
  col(c.T.get(), i, ti.get());
  col(c.T.get(), j, tj.get());
  double mi;
  MORSE_CALL(VecNorm(ti.get(), NORM_INFINITY, &mi));
  const double e = 1e-4 / mi;
  auto Kt = svk.create_tangent();
  MORSE_CALL(VecAXPBY(up.get(), e, 0.0, ti.get()));
  svk.tangent(up.get(), Kt.get());
  MORSE_CALL(MatMult(Kt.get(), tj.get(), y1.get()));
  MORSE_CALL(VecScale(up.get(), -1.0));
  svk.tangent(up.get(), Kt.get());
  MORSE_CALL(MatMult(Kt.get(), tj.get(), y2.get()));
  MORSE_CALL(VecAXPY(y1.get(), -1.0, y2.get()));
  MORSE_CALL(VecScale(y1.get(), 0.5 / e));  // dK_T/dq_i phi_j
  MORSE_CALL(MatMult(m.ops.K.get(), a.get(), Ka.get()));
  double nr;
  MORSE_CALL(VecNorm(y1.get(), NORM_INFINITY, &nr));
  MORSE_CALL(VecAXPY(Ka.get(), 1.0, y1.get()));
  PetscInt lo, hi;
  MORSE_CALL(VecGetOwnershipRange(Ka.get(), &lo, &hi));
  for (PetscInt g : c.boundary_dofs)
    if (g >= lo && g < hi) MORSE_CALL(VecSetValue(Ka.get(), g, 0.0, INSERT_VALUES));
  MORSE_CALL(VecAssemblyBegin(Ka.get()));
  MORSE_CALL(VecAssemblyEnd(Ka.get()));
  MORSE_CALL(VecNorm(Ka.get(), NORM_INFINITY, &d));
  EXPECT_LT(d, 1e-8 * nr) << "K_ii psi_ij + (dK_T/dq_i phi_j)_i";
  EXPECT_LT(boundary_defect(Psi.get(), {}), 1.0);  // collective no-op guard
  // Boundary rows are zero.
  UMat Z = nlrom::modal_derivatives(svk, c.T.get(), c.boundary_dofs, {{0, 0}});
  double bmax = 0;
  for (PetscInt g : c.boundary_dofs)
    if (g >= lo && g < hi) {
      PetscScalar v;
      PetscInt zero = 0;
      MORSE_CALL(MatGetValues(Z.get(), 1, &g, 1, &zero, &v));
      bmax = std::max(bmax, std::abs(v));
    }
  MPI_Allreduce(MPI_IN_PLACE, &bmax, 1, MPI_DOUBLE, MPI_MAX, PETSC_COMM_WORLD);
  EXPECT_EQ(bmax, 0.0);
}

// CB + MD: the boundary stays physical, the derivatives are M-orthonormal among themselves and
// to the fixed-interface modes (1e-12), the W weights select the pairs in descending order, and
// STEP equals the exact tensors on this basis too.
TEST(Nlrom, ModalDerivativeBasis) {
  auto m = box(ElementType::Hex20, 4);
  fe::Svk svk(m.lm, m.dofs, test::steel(), m.ops.K.get());
  dyn::NodalLoad l;
  l.set = "x1";
  l.dir[1] = 1.0;
  l.amplitude = 1e4;
  l.omega = 2000.0;
  dyn::Loads loads(m.lm, m.dofs, {l});
  nlrom::BasisSettings s;
  s.kind = nlrom::BasisKind::CBMD;
  s.boundary_set = "x1";
  s.n_fixed = 2;
  s.n_derivatives = 4;
  s.training = &loads;
  s.training_tfinal = 10 * 2 * M_PI / 2000.0;
  s.training_dt = 2e-5;
  auto b = nlrom::build_basis(test::model_of(m), svk, s);
  ASSERT_EQ(b.r(), b.n_b + 2 + 4);
  EXPECT_LT(boundary_defect(b.V.get(), b.cb.boundary_dofs), 1e-14);
  const PetscInt f0 = b.n_b;
  double worst = 0;
  for (PetscInt i = f0; i < b.r(); ++i)
    for (PetscInt j = f0; j < b.r(); ++j)
      worst = std::max(worst, std::abs(column_dot(b.V.get(), i, m.ops.M.get(), b.V.get(), j) - (i == j ? 1.0 : 0.0)));
  EXPECT_LT(worst, 1e-12) << "fixed-interface modes and derivatives are not M-orthonormal";
  // Weights: the selected pairs are the first independent ones in descending W.
  ASSERT_EQ(b.md_weights.size(), b.md_pairs.size());
  double wmin_sel = 1e300, wmax_all = 0;
  for (std::size_t k = 0; k < b.md_weights.size(); ++k) {
    EXPECT_GE(b.md_weights[k], 0.0);
    wmax_all = std::max(wmax_all, b.md_weights[k]);
    if (b.md_selected[k]) wmin_sel = std::min(wmin_sel, b.md_weights[k]);
  }
  EXPECT_GT(wmax_all, 0.0);
  int above = 0;  // pairs heavier than the lightest selected one that were not selected (dependent)
  for (std::size_t k = 0; k < b.md_weights.size(); ++k)
    if (!b.md_selected[k] && b.md_weights[k] > wmin_sel) ++above;
  EXPECT_LE(above, static_cast<int>(b.md_pairs.size()) - 4);
  auto st = nlrom::step_forces(svk, b.V.get(), {});
  auto ex = nlrom::exact_forces(svk, b.V.get());
  double da = 0, db = 0;
  for (std::size_t i = 0; i < ex.A.size(); ++i) da = std::max(da, std::abs(st.A[i] - ex.A[i]));
  for (std::size_t i = 0; i < ex.B.size(); ++i) db = std::max(db, std::abs(st.B[i] - ex.B[i]));
  EXPECT_LT(da, 1e-8 * ex.max_abs_A());
  EXPECT_LT(db, 1e-8 * ex.max_abs_B());
}

// POD by the method of snapshots against a snapshot matrix with known singular values.
TEST(Nlrom, PodRecoversKnownSingularValues) {
  auto m = box(ElementType::Hex8, 4);
  const int k = 3, ns = 6;
  auto U = smooth_basis(m, k, 1.0);
  {  // orthonormalize U
    std::vector<UVec> cols(k);
    for (PetscInt j = 0; j < k; ++j) {
      Vec c;
      MORSE_CALL(MatDenseGetColumnVecRead(U.get(), j, &c));
      MORSE_CALL(VecDuplicate(c, cols[j].ptr()));
      MORSE_CALL(VecCopy(c, cols[j].get()));
      MORSE_CALL(MatDenseRestoreColumnVecRead(U.get(), j, &c));
      for (PetscInt i = 0; i < j; ++i) {
        double d;
        MORSE_CALL(VecDot(cols[j].get(), cols[i].get(), &d));
        MORSE_CALL(VecAXPY(cols[j].get(), -d, cols[i].get()));
      }
      MORSE_CALL(VecNormalize(cols[j].get(), nullptr));
      MORSE_CALL(MatDenseGetColumnVecWrite(U.get(), j, &c));
      MORSE_CALL(VecCopy(cols[j].get(), c));
      MORSE_CALL(MatDenseRestoreColumnVecWrite(U.get(), j, &c));
    }
  }
  // X = U diag(sigma) W^T with W (ns x k) orthonormal columns (a scaled Hadamard-like set).
  const double sig[k] = {5.0, 2.0, 0.5};
  const double Wt[k][ns] = {{1, 1, 1, 1, 1, 1}, {1, -1, 1, -1, 1, -1}, {1, 1, -1, -1, 1, 1}};
  double wn[k];
  for (int a = 0; a < k; ++a) {
    wn[a] = 0;
    for (int t = 0; t < ns; ++t) wn[a] += Wt[a][t] * Wt[a][t];
    wn[a] = std::sqrt(wn[a]);
  }
  // Rows 1 and 3 are orthogonal? (1,1,-1,-1,1,1).(1,1,1,1,1,1) = 2: make row 3 orthogonal to 1, 2.
  double W3[ns];
  {
    double d1 = 0, d2 = 0;
    for (int t = 0; t < ns; ++t) d1 += Wt[2][t] * Wt[0][t] / wn[0], d2 += Wt[2][t] * Wt[1][t] / wn[1];
    double n = 0;
    for (int t = 0; t < ns; ++t) {
      W3[t] = Wt[2][t] - d1 * Wt[0][t] / wn[0] - d2 * Wt[1][t] / wn[1];
      n += W3[t] * W3[t];
    }
    for (int t = 0; t < ns; ++t) W3[t] /= std::sqrt(n);
  }
  UMat X;
  PetscInt mloc;
  MORSE_CALL(MatGetLocalSize(U.get(), &mloc, nullptr));
  MORSE_CALL(MatCreateDense(PETSC_COMM_WORLD, mloc, PETSC_DECIDE, m.dofs.n_global, ns, nullptr, X.ptr()));
  for (int t = 0; t < ns; ++t) {
    Vec x;
    MORSE_CALL(MatDenseGetColumnVecWrite(X.get(), t, &x));
    MORSE_CALL(VecSet(x, 0.0));
    for (int a = 0; a < k; ++a) {
      const double w = a < 2 ? Wt[a][t] / wn[a] : W3[t];
      Vec u;
      MORSE_CALL(MatDenseGetColumnVecRead(U.get(), a, &u));
      MORSE_CALL(VecAXPY(x, sig[a] * w, u));
      MORSE_CALL(MatDenseRestoreColumnVecRead(U.get(), a, &u));
    }
    MORSE_CALL(MatDenseRestoreColumnVecWrite(X.get(), t, &x));
  }
  std::vector<double> sigma;
  auto P = nlrom::pod(X.get(), k, &sigma);
  ASSERT_EQ(sigma.size(), static_cast<std::size_t>(ns));
  for (int a = 0; a < k; ++a) EXPECT_NEAR(sigma[a], sig[a], 1e-12 * sig[0]);
  for (int a = k; a < ns; ++a) EXPECT_LT(sigma[a], 1e-6 * sig[0]);
  // POD modes = +-U columns.
  auto G = cb::transpose_product(PETSC_COMM_WORLD, P.get(), U.get());
  for (int a = 0; a < k; ++a) EXPECT_NEAR(std::abs(G[a * k + a]), 1.0, 1e-12);
  EXPECT_THROW(nlrom::pod(X.get(), ns, &sigma), Error) << "rank-deficient request must be refused";
  // STEP identifies the exact tensors on a POD basis as well (Euclidean-normalized columns).
  fe::Svk svk(m.lm, m.dofs, test::steel(), m.ops.K.get());
  nlrom::StepSettings ss;
  ss.displacement = 0.01;
  auto st = nlrom::step_forces(svk, P.get(), ss);
  auto ex = nlrom::exact_forces(svk, P.get());
  double da = 0, db = 0;
  for (std::size_t i = 0; i < ex.A.size(); ++i) da = std::max(da, std::abs(st.A[i] - ex.A[i]));
  for (std::size_t i = 0; i < ex.B.size(); ++i) db = std::max(db, std::abs(st.B[i] - ex.B[i]));
  EXPECT_GT(ex.max_abs_B(), 0.0);
  EXPECT_LT(da, 1e-8 * ex.max_abs_A());
  EXPECT_LT(db, 1e-8 * ex.max_abs_B());
}

// nlrom::write_stored_model writes what read_stored_model reads: the reduced matrices and tensors
// to the last bit, the basis at every node (the gathered columns of V), the node sets and the
// boundary nodes; and the attributes of StoredInfo.
TEST(Nlrom, StoredModelRoundTrips) {
  auto m = box(ElementType::Hex8);
  const int r = 4;
  nlrom::Basis basis;
  basis.V = smooth_basis(m, r, 1e-3);
  basis.n_b = 3;
  basis.n_fixed = 1;
  basis.labels = {"u_x", "u_y", "u_z", "phi_1"};
  basis.cb.boundary_node_ids = {7};
  basis.cb.boundary_dof_node = {7, 7, 7};
  basis.cb.boundary_dof_component = {1, 2, 3};
  basis.seconds = 1.5;
  nlrom::ReducedModel rm;
  auto fill = [](std::size_t n, double s) {
    std::vector<double> v(n);
    for (std::size_t k = 0; k < n; ++k) v[k] = s * std::sin(0.37 * (k + 1)) + 1e-3 * k;
    return v;
  };
  rm.M = fill(r * r, 1.0), rm.K = fill(r * r, 1e6), rm.C = fill(r * r, 3.0);
  rm.g.A = fill(nlrom::n_quadratic(r) * r, 1e9);
  rm.g.B = fill(nlrom::n_cubic(r) * r, 1e12);
  rm.damping_omega = {10.0, 20.0};
  nlrom::StoredInfo info;
  info.boundary_set = "x1";
  info.forces = "exact";
  info.t2_forces_seconds = 2.5;
  info.damping = "rayleigh";
  info.rayleigh_alpha = 10.0;
  info.rayleigh_beta = 1e-7;
  int pid = world_rank() == 0 ? static_cast<int>(getpid()) : 0;
  MPI_Bcast(&pid, 1, MPI_INT, 0, PETSC_COMM_WORLD);
  const std::string file = cat("/tmp/morse_test_nlrom_stored_", pid, ".h5");
  {
    io::H5Output out(PETSC_COMM_WORLD, file);
    io::write_provenance(out, "nlrom", "SI");
    nlrom::write_stored_model(out, m.lm, m.dofs, basis, rm, info);
    out.commit();
  }
  const auto sm = nlrom::read_stored_model(PETSC_COMM_WORLD, file, {"x1"});
  EXPECT_EQ(sm.model.r, r);
  EXPECT_EQ(sm.model.M, rm.M);
  EXPECT_EQ(sm.model.K, rm.K);
  EXPECT_EQ(sm.model.C, rm.C);
  {
    // A file written before the damping model was recorded (no /nlrom@damping) reads as before.
    MPI_Barrier(PETSC_COMM_WORLD);
    if (world_rank() == 0) {
      EXPECT_EQ(io::read_string_attribute(file, "/nlrom", "damping"), "rayleigh");
      const hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
      EXPECT_GE(H5Adelete_by_name(f, "/nlrom", "damping", H5P_DEFAULT), 0);
      H5Fclose(f);
    }
    MPI_Barrier(PETSC_COMM_WORLD);
    EXPECT_EQ(io::read_string_attribute(file, "/nlrom", "damping"), "");
    EXPECT_EQ(nlrom::read_stored_model(PETSC_COMM_WORLD, file, {"x1"}).model.C, rm.C);
    MPI_Barrier(PETSC_COMM_WORLD);
  }
  EXPECT_EQ(sm.model.g.A, rm.g.A);
  EXPECT_EQ(sm.model.g.B, rm.g.B);
  EXPECT_EQ(sm.boundary_nodes, basis.cb.boundary_node_ids);
  // The boundary coordinates: (node, component) of each.
  EXPECT_EQ(sm.boundary_dof_node, basis.cb.boundary_dof_node);
  EXPECT_EQ(sm.boundary_dof_component, basis.cb.boundary_dof_component);
  {
    // A file written before /nlrom/boundary_dofs existed reads as the translations of its nodes.
    MPI_Barrier(PETSC_COMM_WORLD);
    if (world_rank() == 0) {
      const hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
      EXPECT_GE(H5Ldelete(f, "/nlrom/boundary_dofs", H5P_DEFAULT), 0);
      H5Fclose(f);
    }
    MPI_Barrier(PETSC_COMM_WORLD);
    const auto old = nlrom::read_stored_model(PETSC_COMM_WORLD, file, {"x1"});
    EXPECT_EQ(old.boundary_dof_node, sm.boundary_dof_node);
    EXPECT_EQ(old.boundary_dof_component, sm.boundary_dof_component);
    EXPECT_EQ(old.model.n_b, sm.model.n_b);
  }
  EXPECT_EQ(sm.units, "SI");
  ASSERT_EQ(sm.node_ids.size(), static_cast<std::size_t>(m.lm.n_global_nodes));
  // The basis: the gathered columns of V, in the order of /mesh/node_ids.
  for (int j = 0; j < r; ++j) {
    Vec c;
    MORSE_CALL(MatDenseGetColumnVecRead(basis.V.get(), j, &c));
    auto col = io::gather_nodal(m.lm, m.dofs, c);
    MORSE_CALL(MatDenseRestoreColumnVecRead(basis.V.get(), j, &c));
    if (world_rank() == 0) {
      EXPECT_TRUE(std::equal(col.begin(), col.end(), sm.basis.begin() + j * col.size())) << "column " << j;
    }
  }
  // The set x1: its owned nodes on every rank are the set read back (count and sum of ids).
  std::int64_t mine[2] = {0, 0}, all[2];
  for (auto k : m.lm.mesh.node_sets.at("x1"))
    if (m.lm.node_owner[k] == world_rank()) ++mine[0], mine[1] += m.lm.mesh.node_ids[k];
  MPI_Allreduce(mine, all, 2, MPI_INT64_T, MPI_SUM, PETSC_COMM_WORLD);
  std::int64_t sum = 0;
  for (auto row : sm.sets.at("x1")) sum += sm.node_ids[row];
  EXPECT_EQ(static_cast<std::int64_t>(sm.sets.at("x1").size()), all[0]);
  EXPECT_EQ(sum, all[1]);
  if (world_rank() == 0) {
    double x = 0;
    std::string err;
    EXPECT_TRUE(io::read_attribute(file, "/nlrom", "r", &x, &err) && x == r) << err;
    EXPECT_TRUE(io::read_attribute(file, "/nlrom", "t1_basis_seconds", &x, &err) && x == 1.5) << err;
    EXPECT_TRUE(io::read_attribute(file, "/nlrom", "t2_forces_seconds", &x, &err) && x == 2.5) << err;
    EXPECT_EQ(io::read_string_attribute(file, "/nlrom", "forces"), "exact");
    EXPECT_EQ(io::read_string_attribute(file, "/nlrom", "boundary_set"), "x1");
    EXPECT_TRUE(io::read_attribute(file, "/nlrom", "rayleigh_alpha", &x, &err) && x == 10.0) << err;
    EXPECT_TRUE(io::read_attribute(file, "/nlrom", "rayleigh_beta", &x, &err) && x == 1e-7) << err;
    std::vector<double> w;
    std::vector<hsize_t> d;
    EXPECT_TRUE(io::read_doubles(file, "/nlrom/damping/omega", &w, &d, &err) && w == rm.damping_omega) << err;
    std::remove(file.c_str());
  }
  // An unknown damping model is refused when read, naming the file and the attribute.
  info.damping = "viscous";
  {
    io::H5Output out(PETSC_COMM_WORLD, file);
    io::write_provenance(out, "nlrom", "SI");
    nlrom::write_stored_model(out, m.lm, m.dofs, basis, rm, info);
    out.commit();
  }
  test::expect_error_parts([&] { nlrom::read_stored_model(PETSC_COMM_WORLD, file, {"x1"}); },
                           {file + ": /nlrom@damping is 'viscous' (none, modal or rayleigh)"}, "an unknown damping");
  info.damping = "none";
  // A NaN in a stored operator is refused when read, naming the file and the dataset (it used to
  // surface as "the reduced mass matrix is not positive definite").
  rm.K[5] = std::nan("");
  {
    io::H5Output out(PETSC_COMM_WORLD, file);
    io::write_provenance(out, "nlrom", "SI");
    nlrom::write_stored_model(out, m.lm, m.dofs, basis, rm, info);
    out.commit();
  }
  try {
    nlrom::read_stored_model(PETSC_COMM_WORLD, file, {"x1"});
    ADD_FAILURE() << "a NaN in /nlrom/K was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(file + ": /nlrom/K holds a non-finite value (nan at entry 5)"),
              std::string::npos)
        << e.what();
  }
  MPI_Barrier(PETSC_COMM_WORLD);
  if (world_rank() == 0) std::remove(file.c_str());
}

namespace {

// x_i^T C x_i / (2 omega_i) of every mode i of (K, M) (x_i M-normalized: the modal damping ratio),
// the omega_i, and the largest |x_i^T C x_j| / (2 sqrt(omega_i omega_j)) over i != j.
struct ModalRatios {
  std::vector<double> ratio, omega;
  double coupling = 0;
};
ModalRatios modal_ratios(const nlrom::ReducedModel& rm) {
  const std::size_t r = static_cast<std::size_t>(rm.r);
  std::vector<double> X;
  const auto w = eigen::dense_eigenvalues(static_cast<int>(r), rm.K, rm.M, &X);
  ModalRatios out;
  for (std::size_t i = 0; i < r; ++i) out.omega.push_back(std::sqrt(w[i]));
  for (std::size_t i = 0; i < r; ++i)
    for (std::size_t j = 0; j < r; ++j) {
      double c = 0;
      for (std::size_t a = 0; a < r; ++a)
        for (std::size_t b = 0; b < r; ++b) c += X[a * r + i] * rm.C[a * r + b] * X[b * r + j];
      if (i == j)
        out.ratio.push_back(c / (2 * out.omega[i]));
      else
        out.coupling = std::max(out.coupling, std::abs(c) / (2 * std::sqrt(out.omega[i] * out.omega[j])));
    }
  return out;
}

}  // namespace

// The boundary coordinates of a six-DOF point come before a solid node with a larger id: the
// solid node's translations start after the point's six coordinates, not at 3k; a node with a
// clamped translation or outside the boundary cannot carry contact (refused naming it).
TEST(Nlrom, BoundaryTranslationsAfterASixDofPoint) {
  nlrom::StoredModel sm;
  sm.file = "model.h5";
  sm.node_ids = {3, 5, 7, 9};
  sm.boundary_nodes = {5, 7, 9};
  for (int c = 1; c <= 6; ++c) sm.boundary_dof_node.push_back(5), sm.boundary_dof_component.push_back(c);
  for (int c = 1; c <= 3; ++c) sm.boundary_dof_node.push_back(7), sm.boundary_dof_component.push_back(c);
  for (int c : {1, 2}) sm.boundary_dof_node.push_back(9), sm.boundary_dof_component.push_back(c);  // z clamped
  sm.sets["solid"] = {2};
  sm.sets["both"] = {1, 2};
  sm.sets["clamped"] = {2, 3};
  sm.sets["inner"] = {0};
  EXPECT_EQ(sm.boundary_translations("solid"), (std::vector<std::size_t>{6}));
  EXPECT_EQ(sm.boundary_translations("both"), (std::vector<std::size_t>{0, 6}));
  test::expect_error_parts([&] { sm.boundary_translations("clamped"); },
                           {"model.h5", "node 9 of set clamped", "three translations"}, "a partly clamped node");
  test::expect_error_parts([&] { sm.boundary_translations("inner"); },
                           {"model.h5", "node 3 of set inner", "not a physical boundary node"}, "an interior node");
}

// -nlrom_damping_modes all (seed 003 §2: proportional damping, xi on every mode): every mode of the
// reduced model has the ratio xi, and the modes stay uncoupled; the partial form damps the first k
// and leaves the others at zero.
TEST(Nlrom, ModalDampingOnEveryMode) {
  const auto m = box(ElementType::Hex8);
  const auto c = test::cb_basis(m, "x1", 5);
  const double xi = 5e-4;
  const auto rm = nlrom::project_model(PETSC_COMM_WORLD, c.T.get(), m.ops.K.get(), m.ops.M.get(), xi, nlrom::kAllModes);
  const auto mr = modal_ratios(rm);
  ASSERT_EQ(rm.r, c.n());
  ASSERT_EQ(rm.damping_omega.size(), static_cast<std::size_t>(rm.r));
  for (PetscInt i = 0; i < rm.r; ++i) {
    EXPECT_NEAR(mr.ratio[i], xi, 1e-10) << "mode " << i;
    EXPECT_NEAR(rm.damping_omega[i], mr.omega[i], 1e-10 * mr.omega[i]) << "mode " << i;
  }
  EXPECT_LT(mr.coupling, 1e-10);
  const PetscInt k = 3;
  const auto part = nlrom::project_model(PETSC_COMM_WORLD, c.T.get(), m.ops.K.get(), m.ops.M.get(), xi, k);
  const auto pr = modal_ratios(part);
  ASSERT_EQ(part.damping_omega.size(), static_cast<std::size_t>(k));
  for (PetscInt i = 0; i < part.r; ++i) EXPECT_NEAR(pr.ratio[i], i < k ? xi : 0.0, 1e-10) << "mode " << i;
}

// Rayleigh damping C~ = A M~ + B K~: every mode has the ratio A / (2 omega) + B omega / 2, and the
// modes stay uncoupled. Refused on a massless model.
TEST(Nlrom, RayleighDampingRatios) {
  const auto m = box(ElementType::Hex8);
  const auto c = test::cb_basis(m, "x1", 5);
  auto rm = nlrom::project_model(PETSC_COMM_WORLD, c.T.get(), m.ops.K.get(), m.ops.M.get(), 0.0, 0);
  // A and B with comparable shares at the lowest mode.
  const double w1 = std::sqrt(eigen::dense_eigenvalues(static_cast<int>(rm.r), rm.K, rm.M)[0]);
  const double A = 2e-3 * w1, B = 2e-3 / w1;
  nlrom::rayleigh_damping(&rm, A, B);
  EXPECT_TRUE(rm.damping_omega.empty());
  const auto mr = modal_ratios(rm);
  for (PetscInt i = 0; i < rm.r; ++i) {
    const double expected = A / (2 * mr.omega[i]) + B * mr.omega[i] / 2;
    EXPECT_NEAR(mr.ratio[i], expected, 1e-10 * std::max(1.0, expected)) << "mode " << i;
  }
  EXPECT_LT(mr.coupling, 1e-10);
  rm.massless = true;
  test::expect_error_parts([&] { nlrom::rayleigh_damping(&rm, A, B); }, {"Rayleigh", "massless"}, "massless model");
}

// -nlrom_damping_modes takes a count or all, strictly; -nlrom_rayleigh takes two finite values >= 0,
// and not with modal damping nor a massless boundary. Each refusal names the option.
TEST(Options, OfflineDamping) {
  auto read = [](std::initializer_list<std::pair<const char*, const char*>> given) {
    test::GivenOptions g(given);
    nlrom::OfflineSettings s;
    s.basis.boundary_set = "root";
    EXPECT_EQ(s.set_from_options(PETSC_COMM_WORLD), PETSC_SUCCESS);
    return s;
  };
  auto s = read({{"-nlrom_damping_modal", "5e-4"}, {"-nlrom_damping_modes", "all"}});
  EXPECT_EQ(s.error, "");
  EXPECT_EQ(s.damping_modes, nlrom::kAllModes);
  EXPECT_EQ(s.damping(), "modal");
  s = read({{"-nlrom_damping_modal", "5e-4"}, {"-nlrom_damping_modes", "7"}});
  EXPECT_EQ(s.error, "");
  EXPECT_EQ(s.damping_modes, 7);
  EXPECT_EQ(s.damping(), "modal");
  EXPECT_EQ(read({}).damping(), "none");
  for (const char* bad : {"5abc", "-2", "1e3", "99999999999999999999999", "All"})
    EXPECT_EQ(read({{"-nlrom_damping_modes", bad}}).error,
              cat("-nlrom_damping_modes ", bad, ": expected a number of modes >= 0 or all"))
        << bad;
  s = read({{"-nlrom_rayleigh", "2,1e-6"}});
  EXPECT_EQ(s.error, "");
  EXPECT_EQ(s.damping(), "rayleigh");
  EXPECT_EQ(s.rayleigh_alpha, 2.0);
  EXPECT_EQ(s.rayleigh_beta, 1e-6);
  EXPECT_EQ(read({{"-nlrom_rayleigh", "1"}}).error, "-nlrom_rayleigh takes two values alpha,beta (got 1)");
  EXPECT_EQ(read({{"-nlrom_rayleigh", "1,2,3"}}).error, "-nlrom_rayleigh takes two values alpha,beta (got 3)");
  EXPECT_EQ(read({{"-nlrom_rayleigh", "1,-2"}}).error, "-nlrom_rayleigh 1,-2: alpha and beta must be finite and >= 0");
  test::expect_error_parts(
      [&] {
        read({{"-nlrom_rayleigh", "nan,0"}});
      },
      {"-nlrom_rayleigh nan,0: item 'nan': expected a finite number"}, "nan");
  EXPECT_EQ(read({{"-nlrom_rayleigh", "1,0"}, {"-nlrom_damping_modal", "0.01"}, {"-nlrom_damping_modes", "3"}}).error,
            "-nlrom_rayleigh and -nlrom_damping_modal are two damping models: give one of them");
  EXPECT_NE(read({{"-nlrom_rayleigh", "1,0"}, {"-nlrom_boundary_mass", "massless"}})
                .error.find("-nlrom_rayleigh is not defined on the massless model"),
            std::string::npos);
}

// The offline settings read their options and validate them with the boundary set.
TEST(Options, OfflineSettings) {
  test::GivenOptions g{
      {"-nlrom_basis", "cbmd"}, {"-nlrom_num_derivatives", "4"}, {"-nlrom_derivative_selection", "random"}};
  nlrom::OfflineSettings s;
  s.basis.boundary_set = "root";
  ASSERT_EQ(s.set_from_options(PETSC_COMM_WORLD), PETSC_SUCCESS);
  EXPECT_EQ(s.error, "");
  EXPECT_EQ(s.basis.kind, nlrom::BasisKind::CBMD);
  EXPECT_EQ(s.basis.n_derivatives, 4);
  EXPECT_TRUE(s.basis.random_derivatives);
  nlrom::OfflineSettings t;
  ASSERT_EQ(t.set_from_options(PETSC_COMM_WORLD), PETSC_SUCCESS);
  EXPECT_EQ(t.error, "morse nlrom: no boundary set given: use -boundary SET");
  test::GivenOptions h{{"-nlrom_basis", "svd"}};
  nlrom::OfflineSettings u;
  ASSERT_EQ(u.set_from_options(PETSC_COMM_WORLD), PETSC_SUCCESS);
  EXPECT_EQ(u.error, "-nlrom_basis svd: unknown (cb, cbmd or pod)");
}

// A given training step or length must be a finite positive time (-1 used to mean "the default").
TEST(Options, OfflineTrainingTimesMustBeFinitePositive) {
  {
    // Not a number: refused when read, naming the option and the text.
    test::GivenOptions g{{"-nlrom_training_dt", "nan"}};
    nlrom::OfflineSettings s;
    try {
      s.set_from_options(PETSC_COMM_WORLD);
      ADD_FAILURE() << "nan accepted";
    } catch (const Error& e) {
      EXPECT_EQ(std::string(e.what()), "-nlrom_training_dt nan: expected a finite number");
    }
  }
  for (const char* bad : {"-1", "0"}) {
    test::GivenOptions g{{"-nlrom_training_dt", bad}};
    nlrom::OfflineSettings s;
    s.basis.boundary_set = "root";
    ASSERT_EQ(s.set_from_options(PETSC_COMM_WORLD), PETSC_SUCCESS);
    EXPECT_EQ(s.error,
              cat("-nlrom_training_dt must be a finite positive time step [s] (got ", s.basis.training_dt, ")"))
        << bad;
  }
  test::GivenOptions g{{"-nlrom_training_tfinal", "-2"}};
  nlrom::OfflineSettings s;
  s.basis.boundary_set = "root";
  ASSERT_EQ(s.set_from_options(PETSC_COMM_WORLD), PETSC_SUCCESS);
  EXPECT_EQ(s.error, "-nlrom_training_tfinal must be a finite positive time [s] (got -2)");
  test::GivenOptions h{{"-nlrom_training_tfinal", "1e-3"}, {"-nlrom_training_dt", "1e-5"}};
  nlrom::OfflineSettings t;
  t.basis.boundary_set = "root";
  ASSERT_EQ(t.set_from_options(PETSC_COMM_WORLD), PETSC_SUCCESS);
  EXPECT_EQ(t.error, "");
}
