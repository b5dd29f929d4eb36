// St Venant–Kirchhoff forces, tangent and energy (fe/nonlinear.hpp) against exact identities and
// closed forms: Taylor test of the tangent (error ~ eps^2), symmetry, frame indifference under a
// large rigid rotation, the uniform-stretch closed form, K_T(0) = K and g_nl(0) = 0 exactly,
// g_nl exactly quadratic + cubic, the matrix-free tangent product, the block evaluation, and the midpoint energy
// identity.
#include <gtest/gtest.h>

#include <cmath>

#include "morse/fe/nonlinear.hpp"
#include "util.hpp"

using namespace morse;
using mesh::ElementType;

namespace {

constexpr ElementType kAllTypes[] = {ElementType::Tet4,    ElementType::Tet10, ElementType::Wedge6,
                                     ElementType::Wedge15, ElementType::Hex8,  ElementType::Hex20};

using Fixture = test::Model;

Fixture distorted_box(ElementType t, std::vector<std::string> clamp = {"x0"}) {
  auto b = test::box_spec(t, 1.0, 0.4, 0.3, 3, 2, 2);
  b.distortion = 0.2;
  return test::assembled_box(PETSC_COMM_WORLD, b, clamp);
}

// A smooth displacement with gradients of order `scale`.
UVec smooth_field(const Fixture& f, double scale, double seed) {
  return test::nodal_vector(f.lm, f.dofs, [=](double x, double y, double z, int d) {
    return scale * (std::sin(1.3 * x + seed * (d + 1)) * std::cos(0.7 * y - seed) + 0.5 * z * (x + d * y) +
                    0.3 * std::sin(2.1 * z + seed * d) * x);
  });
}

double norm(Vec v) {
  double n;
  MORSE_CALL(VecNorm(v, NORM_2, &n));
  return n;
}

UVec dup(Vec v) {
  UVec w;
  MORSE_CALL(VecDuplicate(v, w.ptr()));
  return w;
}

}  // namespace

class SvkByType : public ::testing::TestWithParam<ElementType> {};

// ||f(u + e v) - f(u) - e K_T(u) v|| decays as e^2, and K_T is symmetric.
TEST_P(SvkByType, TangentTaylorTestAndSymmetry) {
  auto f = distorted_box(GetParam());
  fe::Svk svk(f.lm, f.dofs, test::steel(), f.ops.K.get());
  auto u = smooth_field(f, 0.05, 0.3);
  auto v = smooth_field(f, 0.05, 1.1);
  auto fu = dup(u.get()), fe_ = dup(u.get()), Ktv = dup(u.get()), ue = dup(u.get());
  svk.internal_force(u.get(), fu.get());
  auto Kt = svk.create_tangent();
  svk.tangent(u.get(), Kt.get());
  MORSE_CALL(MatMult(Kt.get(), v.get(), Ktv.get()));
  std::vector<double> err;
  for (double eps : {1e-2, 5e-3, 2.5e-3}) {
    MORSE_CALL(VecWAXPY(ue.get(), eps, v.get(), u.get()));
    svk.internal_force(ue.get(), fe_.get());
    MORSE_CALL(VecAXPY(fe_.get(), -1.0, fu.get()));
    MORSE_CALL(VecAXPY(fe_.get(), -eps, Ktv.get()));
    err.push_back(norm(fe_.get()));
  }
  const double ref = norm(Ktv.get()) * 1e-2;
  EXPECT_GT(err[0], 1e-8 * ref) << "nonlinear part too small to test";
  EXPECT_NEAR(err[0] / err[1], 4.0, 0.1) << mesh::element_name(GetParam());
  EXPECT_NEAR(err[1] / err[2], 4.0, 0.1) << mesh::element_name(GetParam());
  PetscBool sym = PETSC_FALSE;
  double kmax;
  MORSE_CALL(MatNorm(Kt.get(), NORM_INFINITY, &kmax));
  MORSE_CALL(MatIsSymmetric(Kt.get(), 1e-12 * kmax, &sym));
  EXPECT_TRUE(sym);
  // The matrix-free product equals the assembled tangent's.
  auto y = dup(u.get());
  svk.tangent_apply(u.get(), v.get(), y.get());
  MORSE_CALL(VecAXPY(y.get(), -1.0, Ktv.get()));
  EXPECT_LT(norm(y.get()), 1e-13 * norm(Ktv.get())) << mesh::element_name(GetParam());
}

// K_T(0) = K and g_nl(0) = 0 exactly; g_nl is exactly quadratic + cubic along a line.
TEST_P(SvkByType, ExactAtZeroAndExactlyCubic) {
  auto f = distorted_box(GetParam());
  fe::Svk svk(f.lm, f.dofs, test::steel(), f.ops.K.get());
  auto zero = smooth_field(f, 0.0, 0.0);
  auto g = dup(zero.get());
  svk.nonlinear_force(zero.get(), g.get());
  EXPECT_EQ(norm(g.get()), 0.0);
  auto Kt = svk.create_tangent();
  svk.tangent(zero.get(), Kt.get());
  MORSE_CALL(MatAXPY(Kt.get(), -1.0, f.ops.K.get(), SAME_NONZERO_PATTERN));
  double d;
  MORSE_CALL(MatNorm(Kt.get(), NORM_FROBENIUS, &d));
  EXPECT_EQ(d, 0.0);

  // g(s v) = s^2 a + s^3 b: a, b from s = +-1, then predict s = 2 and s = -3.
  auto v = smooth_field(f, 0.02, 0.7);
  auto sv = dup(v.get()), gp = dup(v.get()), gm = dup(v.get()), a = dup(v.get()), b = dup(v.get());
  auto eval = [&](double s, Vec out) {
    MORSE_CALL(VecCopy(v.get(), sv.get()));
    MORSE_CALL(VecScale(sv.get(), s));
    svk.nonlinear_force(sv.get(), out);
  };
  eval(1.0, gp.get());
  eval(-1.0, gm.get());
  MORSE_CALL(VecWAXPY(a.get(), 1.0, gp.get(), gm.get()));   // 2a
  MORSE_CALL(VecWAXPY(b.get(), -1.0, gm.get(), gp.get()));  // 2b
  for (double s : {2.0, -3.0}) {
    eval(s, g.get());
    MORSE_CALL(VecAXPY(g.get(), -0.5 * s * s, a.get()));
    MORSE_CALL(VecAXPY(g.get(), -0.5 * s * s * s, b.get()));
    EXPECT_LT(norm(g.get()), 1e-12 * norm(b.get()) * std::abs(s * s * s)) << "s = " << s;
  }
  EXPECT_GT(norm(a.get()), 0.0);
  EXPECT_GT(norm(b.get()), 0.0);
}

// A large rigid rotation of the unloaded body: zero internal force and energy (frame
// indifference), although K u alone is large.
TEST_P(SvkByType, RigidRotationIsStressFree) {
  auto f = distorted_box(GetParam(), {});
  fe::Svk svk(f.lm, f.dofs, test::steel(), f.ops.K.get());
  // Rotation by 70 degrees about the axis (1, 2, 2)/3.
  const double th = 70.0 * M_PI / 180.0, n[3] = {1.0 / 3, 2.0 / 3, 2.0 / 3};
  const double c = std::cos(th), s = std::sin(th);
  double R[3][3];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const double eps = (i == j) ? 0 : ((j == (i + 1) % 3) ? -n[3 - i - j] : n[3 - i - j]);
      R[i][j] = (i == j ? c : 0.0) + (1 - c) * n[i] * n[j] + s * eps;
    }
  auto u = test::nodal_vector(f.lm, f.dofs, [&](double x, double y, double z, int d) {
    const double X[3] = {x, y, z};
    return R[d][0] * x + R[d][1] * y + R[d][2] * z - X[d];
  });
  auto fu = dup(u.get()), Ku = dup(u.get());
  svk.internal_force(u.get(), fu.get());
  MORSE_CALL(MatMult(f.ops.K.get(), u.get(), Ku.get()));
  EXPECT_LT(norm(fu.get()), 1e-12 * norm(Ku.get()));
  auto e = svk.energy(u.get());
  EXPECT_LT(std::abs(e.total()), 1e-12 * e.linear);
}

// Homogeneous stretch F = diag(1+a, 1+b, 1+c) of a free body: the energy is V W(E) and the
// resultant of the nodal forces on the face x = lx is P_11 * A0, with P = F S.
TEST_P(SvkByType, UniformStretchClosedForm) {
  auto f = distorted_box(GetParam(), {});
  fe::Svk svk(f.lm, f.dofs, test::steel(), f.ops.K.get());
  const double st[3] = {0.08, -0.03, 0.05};
  auto u = test::nodal_vector(f.lm, f.dofs, [&](double x, double y, double z, int d) {
    const double X[3] = {x, y, z};
    return st[d] * X[d];
  });
  const auto m = test::steel();
  const double lam = m.E * m.nu / ((1 + m.nu) * (1 - 2 * m.nu)), mu = m.E / (2 * (1 + m.nu));
  double E[3], trE = 0, EE = 0;
  for (int d = 0; d < 3; ++d) {
    E[d] = 0.5 * ((1 + st[d]) * (1 + st[d]) - 1);
    trE += E[d];
    EE += E[d] * E[d];
  }
  const double V = 1.0 * 0.4 * 0.3, A0 = 0.4 * 0.3;
  const double W = V * (0.5 * lam * trE * trE + mu * EE);
  auto e = svk.energy(u.get());
  EXPECT_NEAR(e.total(), W, 1e-11 * W);
  const double P11 = (1 + st[0]) * (lam * trE + 2 * mu * E[0]);
  auto fu = dup(u.get());
  svk.internal_force(u.get(), fu.get());
  auto sel = test::nodal_vector(
      f.lm, f.dofs, [&](double x, double, double, int d) { return (d == 0 && std::abs(x - 1.0) < 1e-9) ? 1.0 : 0.0; });
  double R;
  MORSE_CALL(VecDot(fu.get(), sel.get(), &R));
  EXPECT_NEAR(R, P11 * A0, 1e-10 * P11 * A0);
}

// The block evaluation equals field-by-field evaluation; the midpoint force satisfies
// f_alg(a, b) . (b - a) = W(b) - W(a) exactly.
TEST_P(SvkByType, BlockAndMidpointIdentities) {
  auto f = distorted_box(GetParam());
  fe::Svk svk(f.lm, f.dofs, test::steel(), f.ops.K.get());
  const PetscInt nv = 5;
  UMat U, G;
  MORSE_CALL(MatCreateDense(PETSC_COMM_WORLD, f.dofs.n_owned, PETSC_DECIDE, f.dofs.n_global, nv, nullptr, U.ptr()));
  MORSE_CALL(MatDuplicate(U.get(), MAT_DO_NOT_COPY_VALUES, G.ptr()));
  for (PetscInt j = 0; j < nv; ++j) {
    auto uj = smooth_field(f, 0.03, 0.2 + j);
    Vec c;
    MORSE_CALL(MatDenseGetColumnVecWrite(U.get(), j, &c));
    MORSE_CALL(VecCopy(uj.get(), c));
    MORSE_CALL(MatDenseRestoreColumnVecWrite(U.get(), j, &c));
  }
  svk.nonlinear_force_block(U.get(), G.get(), 2);
  double worst = 0;
  for (PetscInt j = 0; j < nv; ++j) {
    Vec uj, gj;
    MORSE_CALL(MatDenseGetColumnVecRead(U.get(), j, &uj));
    auto g1 = dup(uj);
    svk.nonlinear_force(uj, g1.get());
    MORSE_CALL(MatDenseRestoreColumnVecRead(U.get(), j, &uj));
    MORSE_CALL(MatDenseGetColumnVecRead(G.get(), j, &gj));
    const double ref = norm(g1.get());
    MORSE_CALL(VecAXPY(g1.get(), -1.0, gj));
    MORSE_CALL(MatDenseRestoreColumnVecRead(G.get(), j, &gj));
    worst = std::max(worst, norm(g1.get()) / ref);
  }
  EXPECT_LT(worst, 1e-14);

  auto a = smooth_field(f, 0.04, 0.5), b = smooth_field(f, 0.06, 0.9);
  auto g = dup(a.get()), d = dup(a.get());
  MORSE_CALL(VecWAXPY(d.get(), 1.0, a.get(), b.get()));
  // The algorithmic force is g_mid + K (a + b)/2.
  svk.midpoint_nonlinear_force(a.get(), b.get(), g.get());
  MORSE_CALL(VecScale(d.get(), 0.5));
  MORSE_CALL(MatMultAdd(f.ops.K.get(), d.get(), g.get(), g.get()));
  MORSE_CALL(VecWAXPY(d.get(), -1.0, a.get(), b.get()));
  double work;
  MORSE_CALL(VecDot(g.get(), d.get(), &work));
  const double dW = svk.energy(b.get()).total() - svk.energy(a.get()).total();
  EXPECT_NEAR(work, dW, 1e-12 * svk.energy(b.get()).total());
  // And it reduces to f_int when a = b.
  auto g2 = dup(a.get()), g3 = dup(a.get());
  svk.midpoint_nonlinear_force(a.get(), a.get(), g2.get());
  svk.nonlinear_force(a.get(), g3.get());
  MORSE_CALL(VecAXPY(g2.get(), -1.0, g3.get()));
  EXPECT_LT(norm(g2.get()), 1e-14 * norm(g3.get()));
}

INSTANTIATE_TEST_SUITE_P(AllTypes, SvkByType, ::testing::ValuesIn(kAllTypes),
                         [](const auto& info) { return std::string(mesh::element_name(info.param)); });
