// The external NASA rotor 37 blade deck (../shared/meshes/rotor37-nlstep, CalculiX, C3D15):
// it loads on every rank count, has the documented size and clamped set, and `modes` gives its
// clamped frequencies, identical on one rank and on all ranks. Skipped when ../shared is absent.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <functional>

#include "morse/cb/craig_bampton.hpp"
#include "morse/fe/element.hpp"
#include "scratch.hpp"
#include "util.hpp"

using namespace morse;

namespace {

std::string deck_path() { return test::shared_data_path("meshes/rotor37-nlstep/blade.inp"); }

bool deck_exists() { return std::ifstream(deck_path()).good(); }

struct Result {
  std::int64_t n_free = 0, n_clamped = 0;
  double volume = 0, mass = 0, rho = 0;
  std::vector<double> omega2;
};

Result solve(MPI_Comm comm, int nev) {
  Result r;
  auto lm = mesh::read_and_distribute(comm, deck_path());
  auto dofs = fe::number_dofs(lm, {mesh::kDeckBoundarySet});
  mesh::Material none;
  auto ops = fe::assemble(lm, dofs, none);
  r.n_free = dofs.n_global;
  r.n_clamped = dofs.n_clamped_global;
  r.volume = ops.volume;
  r.mass = ops.mass;
  r.rho = lm.mesh.materials.at(0).rho;
  eigen::EigenSettings es;
  es.nev = nev;
  es.prefix = "test_r37_";
  auto w = cb::sign_reference(test::model_of(lm, dofs, ops));
  r.omega2 = eigen::solve_eigen(ops.K.get(), ops.M.get(), es, w.get()).omega2;
  return r;
}

}  // namespace

TEST(Rotor37, LoadsAndGivesClampedFrequencies) {
  if (!deck_exists()) GTEST_SKIP() << "external mesh not found: " << deck_path();
  int rank = 0, size = 1;
  MPI_Comm_rank(PETSC_COMM_WORLD, &rank);
  MPI_Comm_size(PETSC_COMM_WORLD, &size);
  const int nev = 6;
  auto r = solve(PETSC_COMM_WORLD, nev);
  // README of the deck: 20,831 nodes, 465 root nodes clamped in x, y, z, 61,098 free DOFs.
  EXPECT_EQ(r.n_free, 61098);
  EXPECT_EQ(r.n_clamped, 3 * 465);
  EXPECT_NEAR(r.mass, r.rho * r.volume, 1e-12 * r.mass);
  ASSERT_EQ((int)r.omega2.size(), nev);
  for (int k = 0; k < nev; ++k) {
    EXPECT_GT(r.omega2[k], 0.0);
    if (k) {
      EXPECT_GE(r.omega2[k], r.omega2[k - 1]);
    }
  }
  if (rank == 0) {
    std::printf("  rotor 37 deck, clamped frequencies [Hz]:");
    for (double l : r.omega2) std::printf(" %.3f", std::sqrt(l) / (2 * M_PI));
    std::printf("\n");
  }
  // The same frequencies from a one-rank solve. The agreement is limited by the eigen solver's
  // residual tolerance (1e-10) and the conditioning of this 61k-DOF problem, not by the
  // partition: a few 1e-10 is observed.
  if (size > 1) {
    std::string msg;
    if (rank == 0) {
      auto s = solve(PETSC_COMM_SELF, nev);
      for (int k = 0; k < nev; ++k)
        if (std::abs(s.omega2[k] / r.omega2[k] - 1.0) > 1e-9)
          msg = cat("mode ", k + 1, ": relative difference ", s.omega2[k] / r.omega2[k] - 1.0);
    }
    EXPECT_FALSE(any_rank(PETSC_COMM_WORLD, !msg.empty())) << msg;
  }
}

// Global patch test on the real deck (every element, converted from C3D15 ordering): the
// free-free stiffness annihilates the six rigid-body fields and stores exactly the
// constant-strain energy V ε:D:ε of a linear field. (The ordering itself is proven by the
// positive Jacobians of every element in test_abaqus and by its per-type node mapping test:
// an isoparametric element passes the patch test for any node placement.)
TEST(Rotor37, PatchTestOnTheRealDeck) {
  if (!deck_exists()) GTEST_SKIP() << "external mesh not found: " << deck_path();
  auto lm = mesh::read_and_distribute(PETSC_COMM_WORLD, deck_path());
  auto dofs = fe::number_dofs(lm, {});
  mesh::Material none;
  auto ops = fe::assemble(lm, dofs, none);
  const auto& mat = lm.mesh.materials.at(0);
  const double c[3] = {500.0, 10.0, 5.0};  // rotation centre near the blade
  const double A[3][3] = {{1e-4, 2e-5, -3e-5}, {4e-5, -6e-5, 1e-5}, {-2e-5, 3e-5, 5e-5}};
  std::vector<std::function<double(double, double, double, int)>> rigid = {
      [](double, double, double, int d) { return d == 0 ? 1.0 : 0.0; },
      [](double, double, double, int d) { return d == 1 ? 1.0 : 0.0; },
      [](double, double, double, int d) { return d == 2 ? 1.0 : 0.0; },
      [&](double, double y, double z, int d) { return d == 1   ? -(z - c[2])
                                                      : d == 2 ? (y - c[1])
                                                               : 0.0; },
      [&](double x, double, double z, int d) { return d == 0   ? (z - c[2])
                                                      : d == 2 ? -(x - c[0])
                                                               : 0.0; },
      [&](double x, double y, double, int d) { return d == 0   ? -(y - c[1])
                                                      : d == 1 ? (x - c[0])
                                                               : 0.0; }};
  // Scale of K: its action on the linear field.
  auto lin = test::nodal_vector(
      lm, dofs, [&](double x, double y, double z, int d) { return A[d][0] * x + A[d][1] * y + A[d][2] * z; });
  UVec Ku;
  MORSE_CALL(VecDuplicate(lin.get(), Ku.ptr()));
  MORSE_CALL(MatMult(ops.K.get(), lin.get(), Ku.get()));
  PetscReal scale;
  MORSE_CALL(VecNorm(Ku.get(), NORM_INFINITY, &scale));
  for (std::size_t r = 0; r < rigid.size(); ++r) {
    auto u = test::nodal_vector(lm, dofs, rigid[r]);
    PetscReal unorm, fnorm;
    MORSE_CALL(VecNorm(u.get(), NORM_INFINITY, &unorm));
    MORSE_CALL(VecScale(u.get(), 1e-4 / unorm));  // same displacement magnitude as the linear field
    MORSE_CALL(MatMult(ops.K.get(), u.get(), Ku.get()));
    MORSE_CALL(VecNorm(Ku.get(), NORM_INFINITY, &fnorm));
    EXPECT_LT(fnorm, 1e-9 * scale) << "rigid-body field " << r;
  }
  // Constant strain energy.
  const double eps[6] = {A[0][0], A[1][1], A[2][2], A[1][2] + A[2][1], A[0][2] + A[2][0], A[0][1] + A[1][0]};
  auto D = fe::isotropic_elasticity(mat.E, mat.nu);
  double eDe = 0;
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 6; ++j) eDe += eps[i] * D[6 * i + j] * eps[j];
  MORSE_CALL(MatMult(ops.K.get(), lin.get(), Ku.get()));
  PetscScalar uKu;
  MORSE_CALL(VecDot(lin.get(), Ku.get(), &uKu));
  EXPECT_NEAR(uKu / (ops.volume * eDe), 1.0, 1e-10);
}
