// Reduced St Venant–Kirchhoff forces (nlrom/nlrom.hpp) against exact identities: the element-wise
// projected tensors reproduce W^T g_nl(Phi q) computed on the full model for arbitrary q; the
// block reduced-force evaluation equals full-model evaluations; STEP (eq. 29–37) identifies the
// same tensors as the exact projection to round-off (St Venant–Kirchhoff is exactly cubic), also
// with POD filtering, where the reference is Phi^T Phi_f Phi_f^T g_nl.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "morse/cb/craig_bampton.hpp"
#include "morse/nlrom/nlrom.hpp"
#include "util.hpp"

using namespace morse;
using mesh::ElementType;

namespace {

struct Model {
  mesh::LocalMesh lm;
  fe::DofMap dofs;
  fe::Operators ops;
};

Model box(ElementType t, int nx = 3) {
  auto b = test::box_spec(t, 1.0, 0.3, 0.2, nx, 1, 1);
  b.distortion = 0.15;
  Model m;
  m.lm = test::box_mesh(PETSC_COMM_WORLD, b);
  m.dofs = fe::number_dofs(m.lm, {"x0"});
  m.ops = fe::assemble(m.lm, m.dofs, test::steel());
  return m;
}

// A basis of r smooth fields with displacements of order `scale`.
UMat smooth_basis(const Model& m, int r, double scale) {
  UMat P;
  MORSE_CALL(MatCreateDense(PETSC_COMM_WORLD, m.dofs.n_owned, PETSC_DECIDE, m.dofs.n_global, r, nullptr, P.ptr()));
  for (int j = 0; j < r; ++j) {
    auto v = test::nodal_vector(m.lm, m.dofs, [=](double x, double y, double z, int d) {
      return scale * x * (std::sin(1.1 * (j + 1) * x + 0.7 * d + 0.3 * j) + 0.4 * y * (d + j) - 0.3 * z * std::cos(j * x));
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
  UVec out;
  MORSE_CALL(MatCreateVecs(W, out.ptr(), nullptr));
  MORSE_CALL(MatMultTranspose(W, g.get(), out.get()));
  PetscInt nw;
  MORSE_CALL(VecGetSize(out.get(), &nw));
  std::vector<double> res(nw);
  // Gather to every rank.
  VecScatter sc;
  Vec all;
  MORSE_CALL(VecScatterCreateToAll(out.get(), &sc, &all));
  MORSE_CALL(VecScatterBegin(sc, out.get(), all, INSERT_VALUES, SCATTER_FORWARD));
  MORSE_CALL(VecScatterEnd(sc, out.get(), all, INSERT_VALUES, SCATTER_FORWARD));
  const double* a;
  MORSE_CALL(VecGetArrayRead(all, &a));
  std::copy(a, a + nw, res.begin());
  MORSE_CALL(VecRestoreArrayRead(all, &a));
  MORSE_CALL(VecScatterDestroy(&sc));
  MORSE_CALL(VecDestroy(&all));
  return res;
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
  cb::CBSettings cs;
  cs.boundary_set = "x1";
  cs.n_fixed = 3;
  cs.keep_basis = true;
  auto cbr = cb::craig_bampton(m.lm, m.dofs, m.ops.K.get(), m.ops.M.get(), cs);
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

INSTANTIATE_TEST_SUITE_P(AllTypes, NlromByType, ::testing::ValuesIn({ElementType::Tet10, ElementType::Wedge15,
                                                                     ElementType::Hex8, ElementType::Hex20}),
                         [](const auto& i) { return mesh::element_name(i.param); });

// POD-filtered STEP (eq. 38–39) equals the exact tensors of Phi^T Phi_f Phi_f^T g_nl, checked on
// sample points against the full model.
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
