// Models free in rigid-body motion (no clamp): a free-free beam, and a beam held only by its
// Craig–Bampton interface. The eigen solvers detect the singular K, solve about a negative shift
// and return the six rigid-body modes at zero frequency (M-orthonormal, spanning the rigid
// motions, in a basis fixed by the mesh); the flexible modes against Euler–Bernoulli; select on a
// model held by its interface only, against the clamped model's modes (the fixed-interface modes)
// and against the rigid motions.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "morse/cb/craig_bampton.hpp"
#include "morse/core/session.hpp"
#include "morse/core/units.hpp"
#include "morse/eigen/eigen.hpp"
#include "morse/fe/model.hpp"
#include "morse/select/select.hpp"
#include "scratch.hpp"
#include "util.hpp"

using namespace morse;

namespace {

// A slender hex20 beam along x (L = 0.4 m, section 0.02 x 0.01 m, L / h = 40), steel.
constexpr double kL = 0.4, kB = 0.02, kH = 0.01;

struct Beam {
  mesh::LocalMesh lm;
  fe::DofLayout dofs;
  fe::Operators ops;
  UVec w;  // sign reference
};

Beam beam(const std::vector<std::string>& clamp) {
  Beam s;
  s.lm = test::box_mesh(PETSC_COMM_WORLD, test::box_spec(mesh::ElementType::Hex20, kL, kB, kH, 20, 2, 1));
  s.dofs = fe::number_dofs(s.lm, clamp);
  s.ops = fe::assemble(s.lm, s.dofs, test::steel());
  s.w = cb::sign_reference(test::model_of(s.lm, s.dofs, s.ops));
  return s;
}

// Euler–Bernoulli bending frequency [Hz] of the thin direction (I / A = h^2 / 12) for the root
// beta L of the boundary conditions.
double euler_bernoulli_hz(double beta_l) {
  const auto mat = test::steel();
  return beta_l * beta_l / (kTwoPi * kL * kL) * std::sqrt(mat.E * kH * kH / 12.0 / mat.rho);
}

// The six rigid motions (translations, rotations about the origin) as DOF vectors.
std::vector<UVec> rigid_motions(const Beam& s) {
  std::vector<UVec> r;
  for (int t = 0; t < 3; ++t)
    r.push_back(test::nodal_vector(s.lm, s.dofs, [t](double, double, double, int d) { return d == t ? 1.0 : 0.0; }));
  for (int a = 0; a < 3; ++a)
    r.push_back(test::nodal_vector(s.lm, s.dofs, [a](double x, double y, double z, int d) {
      const double p[3] = {x, y, z};
      // (e_a x p)_d
      const int b = (a + 1) % 3, c = (a + 2) % 3;
      return d == b ? -p[c] : d == c ? p[b] : 0.0;
    }));
  return r;
}

// Column j of V as a new vector.
UVec column(Mat V, PetscInt j) {
  Vec c;
  UVec out;
  MORSE_CALL(MatDenseGetColumnVecRead(V, j, &c));
  MORSE_CALL(VecDuplicate(c, out.ptr()));
  MORSE_CALL(VecCopy(c, out.get()));
  MORSE_CALL(MatDenseRestoreColumnVecRead(V, j, &c));
  return out;
}

double m_dot(Mat M, Vec a, Vec b) {
  UVec Mb;
  MORSE_CALL(VecDuplicate(b, Mb.ptr()));
  MORSE_CALL(MatMult(M, b, Mb.get()));
  PetscScalar d = 0;
  MORSE_CALL(VecDot(a, Mb.get(), &d));
  return PetscRealPart(d);
}

// Checks of the six zero modes of V (its first six columns): M-orthonormal among themselves and
// against the flexible ones, spanning the rigid motions (each rigid motion r: ||r - X X^T M r||_M
// / ||r||_M small), and in the canonical basis (C = X^T M W upper triangular with a positive
// diagonal, W = eigen::zero_mode_references): the same basis whatever the solver or rank count.
void check_zero_modes(const Beam& s, const eigen::Eigenpairs& e, const std::string& what) {
  Mat M = s.ops.M.get();
  ASSERT_EQ(e.zero_modes, 6) << what;
  const auto n = static_cast<PetscInt>(e.omega2.size());
  for (PetscInt j = 0; j < 6; ++j) EXPECT_EQ(e.omega2[j], 0.0) << what;
  for (PetscInt j = 6; j < n; ++j) EXPECT_GT(e.omega2[j], 1e3) << what << " mode " << j + 1;
  std::vector<UVec> x;
  for (PetscInt j = 0; j < n; ++j) x.push_back(column(e.V.get(), j));
  for (PetscInt i = 0; i < 6; ++i)
    for (PetscInt j = 0; j < n; ++j)
      EXPECT_NEAR(m_dot(M, x[i].get(), x[j].get()), i == j ? 1.0 : 0.0, 1e-9) << what << " (" << i << "," << j << ")";
  for (auto& r : rigid_motions(s)) {
    UVec res;
    MORSE_CALL(VecDuplicate(r.get(), res.ptr()));
    MORSE_CALL(VecCopy(r.get(), res.get()));
    for (PetscInt j = 0; j < 6; ++j) MORSE_CALL(VecAXPY(res.get(), -m_dot(M, x[j].get(), r.get()), x[j].get()));
    EXPECT_LT(std::sqrt(m_dot(M, res.get(), res.get()) / m_dot(M, r.get(), r.get())), 1e-7) << what;
  }
  const auto W = eigen::zero_mode_references(s.w.get(), 6);
  for (PetscInt j = 0; j < 6; ++j)
    for (PetscInt a = 0; a < 6; ++a) {
      const double c = m_dot(M, x[a].get(), W[j].get());
      if (a > j) {
        EXPECT_NEAR(c, 0.0, 1e-8 * std::sqrt(m_dot(M, W[j].get(), W[j].get()))) << what;
      } else if (a == j) {
        EXPECT_GT(c, 0.0) << what;
      }
    }
}

// The lowest flexible frequency (after the six zero modes) and its clamped counterpart against
// Euler–Bernoulli: free-free beta L = 4.7300, clamped-free 1.8751 (the hex20 beam is within 1.5 %:
// shear and Poisson stiffening of a solid).
constexpr double kFreeFree = 4.730040745, kClampedFree = 1.875104069;

}  // namespace

// A free-free beam: K is singular; every solver, with no option, returns the six rigid-body
// modes at zero frequency and the same flexible modes; the count and cutoff modes agree.
TEST(FreeFree, EverySolverReturnsTheRigidBodyModes) {
  auto s = beam({});
  const double f1 = euler_bernoulli_hz(kFreeFree);
  std::vector<double> reference;
  struct Case {
    std::string name, options;
    bool cutoff;
  };
  const std::vector<Case> cases = {{"block", "", false},
                                   {"krylovschur", "-ff_eigen_solver krylovschur", false},
                                   {"block slices", "-ff_block_slices 2", false},
                                   {"krylovschur slicing", "-ff_eigen_solver krylovschur -ff_count_slicing 4", false},
                                   {"block cutoff", "", true},
                                   {"krylovschur cutoff", "-ff_eigen_solver krylovschur", true}};
  for (const auto& c : cases) {
    PetscOptionsClearValue(nullptr, "-ff_eigen_solver");
    PetscOptionsClearValue(nullptr, "-ff_block_slices");
    PetscOptionsClearValue(nullptr, "-ff_count_slicing");
    if (!c.options.empty()) MORSE_CALL(PetscOptionsInsertString(nullptr, c.options.c_str()));
    eigen::EigenSettings es;
    es.prefix = "ff_";
    es.what = "free-free " + c.name;
    if (c.cutoff)
      es.omega2_max = omega2_of_hz(3.0 * f1);  // the rigid modes and the two lowest bending pairs
    else
      es.nev = 10;
    auto e = eigen::solve_eigen(s.ops.K.get(), s.ops.M.get(), es, s.w.get());
    check_zero_modes(s, e, c.name);
    ASSERT_GE(e.omega2.size(), 7u) << c.name;
    // The lowest flexible mode: bending in the thin direction.
    EXPECT_NEAR(hz(e.omega2[6]) / f1, 1.0, 0.015) << c.name;
    if (reference.empty())
      reference = e.omega2;
    else
      for (std::size_t j = 6; j < std::min(reference.size(), e.omega2.size()); ++j)
        EXPECT_NEAR(e.omega2[j] / reference[j], 1.0, 1e-8) << c.name << " mode " << j + 1;
  }
  PetscOptionsClearValue(nullptr, "-ff_eigen_solver");
  PetscOptionsClearValue(nullptr, "-ff_block_slices");
  PetscOptionsClearValue(nullptr, "-ff_count_slicing");
}

// Fewer modes asked for than the model has zero modes: the pairs returned are zero modes, and
// Sylvester's count says how many exist (no spurious-pair error from the count check).
TEST(FreeFree, FewerModesThanRigidMotions) {
  auto s = beam({});
  eigen::EigenSettings es;
  es.prefix = "ff3_";
  es.what = "free-free, 3 modes";
  es.nev = 3;
  auto e = eigen::solve_eigen(s.ops.K.get(), s.ops.M.get(), es, s.w.get());
  ASSERT_EQ(e.omega2.size(), 3u);
  EXPECT_EQ(e.zero_modes, 3);
  for (double w2 : e.omega2) EXPECT_EQ(w2, 0.0);
}

// A beam held only by its interface (the root face x0, no clamp): the Craig–Bampton
// fixed-interface modes are the clamped beam's modes; select's check finds the six rigid-body
// modes of the full model at zero frequency, each matched by one superelement mode (MAC 1), and
// the flexible ones as with a clamp.
TEST(FreeFree, SelectOnAModelHeldByItsInterface) {
  auto free = beam({});
  auto clamped = beam({"x0"});
  cb::CBSettings cs;
  cs.boundary_set = "x0";
  cs.n_fixed = 8;
  cs.keep_basis = true;
  cs.prefix = "ffcb_";
  auto res = cb::craig_bampton(test::model_of(free.lm, free.dofs, free.ops), cs);
  // The fixed-interface modes against the clamped beam's modes (an independent solve) and
  // against Euler–Bernoulli.
  eigen::EigenSettings es;
  es.prefix = "ffcl_";
  es.what = "clamped beam";
  es.nev = 8;
  auto cl = eigen::solve_eigen(clamped.ops.K.get(), clamped.ops.M.get(), es, clamped.w.get());
  ASSERT_EQ(res.fixed_omega2.size(), 8u);
  EXPECT_EQ(cl.zero_modes, 0);
  for (std::size_t j = 0; j < 8; ++j) EXPECT_NEAR(res.fixed_omega2[j] / cl.omega2[j], 1.0, 1e-8) << "mode " << j + 1;
  EXPECT_NEAR(hz(cl.omega2[0]) / euler_bernoulli_hz(kClampedFree), 1.0, 0.015);

  select::VerifySettings vs;
  vs.methods = {select::Method::Frequency, select::Method::EIM};
  vs.names = {"frequency", "eim"};
  vs.num_modes = 8;
  vs.fmax_analysis_hz = 2.0 * euler_bernoulli_hz(kFreeFree);
  auto v = select::verify(PETSC_COMM_WORLD, free.ops.K.get(), free.ops.M.get(), res, free.w.get(), vs);
  ASSERT_GE(v.fom_omega2.size(), 7u);
  for (int j = 0; j < 6; ++j) EXPECT_EQ(v.fom_omega2[j], 0.0);
  EXPECT_NEAR(hz(v.fom_omega2[6]) / euler_bernoulli_hz(kFreeFree), 1.0, 0.015);
  for (const auto& m : v.methods) {
    ASSERT_GE(m.rom_f.size(), 7u) << m.name;
    for (int j = 0; j < 6; ++j) {
      EXPECT_EQ(m.rom_f[j], 0.0) << m.name;
      EXPECT_GT(m.best_mac[j], 1.0 - 1e-8) << m.name << " rigid mode " << j + 1;
    }
    // All eight fixed-interface modes kept: the flexible modes in the band match too.
    for (std::size_t j = 6; j < v.fom_omega2.size(); ++j) EXPECT_GT(m.best_mac[j], 0.99) << m.name << " mode " << j + 1;
    EXPECT_EQ(m.matches, static_cast<PetscInt>(v.fom_omega2.size())) << m.name;
    EXPECT_LT(m.worst_err, 0.01) << m.name;
  }
}

// A negated K (an assembled matrix of the wrong sign): the factorization at shift 0 shows
// negative pivots, and the error says K is not positive semi-definite instead of a solver that
// does not converge.
TEST(FreeFree, IndefiniteStiffnessIsNamed) {
  auto s = beam({"x0"});
  MORSE_CALL(MatScale(s.ops.K.get(), -1.0));
  for (const std::string solver : {"block", "krylovschur"}) {
    eigen::EigenSettings es;
    es.prefix = "neg_";
    es.what = "negated K";
    es.solver = solver;
    es.nev = 4;
    test::expect_error_parts([&] { eigen::solve_eigen(s.ops.K.get(), s.ops.M.get(), es, s.w.get()); },
                             {"K is not positive semi-definite"}, solver);
  }
}

// Krylov-Schur's slicing partitions must divide the ranks (SLEPc crashed in its split).
TEST(FreeFree, KrylovSchurPartitionsChecked) {
  auto s = beam({"x0"});
  int size = 1;
  MPI_Comm_size(PETSC_COMM_WORLD, &size);
  const std::string bad = std::to_string(size + 1);
  MORSE_CALL(PetscOptionsSetValue(nullptr, "-ksp_parts_eps_krylovschur_partitions", bad.c_str()));
  eigen::EigenSettings es;
  es.prefix = "ksp_parts_";
  es.what = "partitions";
  es.solver = "krylovschur";
  es.omega2_max = omega2_of_hz(2000.0);
  test::expect_error_parts([&] { eigen::solve_eigen(s.ops.K.get(), s.ops.M.get(), es, s.w.get()); },
                           {"-ksp_parts_eps_krylovschur_partitions " + bad + " must divide"}, "partitions");
  MORSE_CALL(PetscOptionsClearValue(nullptr, "-ksp_parts_eps_krylovschur_partitions"));
}
