// The performance indicator (eval/indicator.hpp, seed 003 eq. 43–51): 1 for identical signals,
// hand-computed values for a tiny case, and monotone decrease as a signal is perturbed.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "given_options.hpp"
#include "morse/core/error.hpp"
#include "morse/core/session.hpp"
#include "morse/dyn/dyn.hpp"
#include "morse/eval/compare.hpp"
#include "morse/eval/indicator.hpp"
#include "morse/io/h5.hpp"

using namespace morse;

TEST(Indicator, IdenticalSignalsScoreOne) {
  std::vector<double> u = {0.0, 1.0, 0.5, -2.0, 0.0, 1.0, 3.0, -1.0};
  EXPECT_DOUBLE_EQ(eval::covariance(u, u), 1.0);
  EXPECT_DOUBLE_EQ(eval::energy_criterion(u, u), 1.0);
  EXPECT_DOUBLE_EQ(eval::peak_to_peak_criterion(u, u, 2), 1.0);
  EXPECT_DOUBLE_EQ(eval::displacement_criterion(u, u), 1.0);
  eval::Indicator ind;
  ind.e = {1, 1, 1, 1};
  EXPECT_DOUBLE_EQ(ind.I(), 1.0);
}

// Hand-computed: x1 = (1, 0), x2 = (1, 1): e1 = 1 / (1 * 2) = 0.5. Energies (3, 4) vs (3, 2):
// e2 = 1 - 2 / 5 = 0.6. Two tip DOFs over 3 samples: FOM (0, 2), (1, -1), (2, 1) -> o = (2, 3);
// ROM (0, 0), (1, 0), (1, 3) -> o = (1, 3): e3 = 1 - sqrt(((2-1)/2)^2 / 2) = 1 - sqrt(1/8).
// e4 = 1 - ||(0,2,0,-1,1,-2)|| / ||(0,2,1,-1,2,1)|| = 1 - sqrt(10 / 11).
TEST(Indicator, HandComputedTinyCase) {
  EXPECT_NEAR(eval::covariance({1, 0}, {1, 1}), 0.5, 1e-15);
  EXPECT_NEAR(eval::energy_criterion({3, 4}, {3, 2}), 0.6, 1e-15);
  std::vector<double> uf = {0, 2, 1, -1, 2, 1}, ur = {0, 0, 1, 0, 1, 3};
  EXPECT_NEAR(eval::peak_to_peak_criterion(uf, ur, 2), 1 - std::sqrt(1.0 / 8), 1e-15);
  EXPECT_NEAR(eval::displacement_criterion(uf, ur), 1 - std::sqrt(10.0 / 11), 1e-15);
  eval::Indicator ind;
  ind.e = {0.5, 0.6, 1 - std::sqrt(1.0 / 8), 1 - std::sqrt(10.0 / 11)};
  EXPECT_NEAR(ind.I(), 0.25 * (0.5 + 0.6 + 1 - std::sqrt(1.0 / 8) + 1 - std::sqrt(10.0 / 11)), 1e-15);
  EXPECT_DOUBLE_EQ(eval::energy_criterion({1, 1}, {5, 5}), 0.0) << "clipped at 0";
}

TEST(Indicator, FallsAsTheSignalIsPerturbed) {
  const int nt = 200;
  std::vector<double> ref(nt);
  for (int t = 0; t < nt; ++t) ref[t] = std::sin(0.1 * t);
  double prev[3] = {1.0, 1.0, 1.0};
  for (double eps : {0.01, 0.05, 0.2, 0.5}) {
    std::vector<double> p(nt);
    for (int t = 0; t < nt; ++t) p[t] = (1 + eps) * std::sin(0.1 * t + eps);
    const double c[3] = {eval::energy_criterion(ref, p), eval::peak_to_peak_criterion(ref, p, 1),
                         eval::displacement_criterion(ref, p)};
    for (int k = 0; k < 3; ++k) {
      EXPECT_LT(c[k], prev[k]) << "criterion " << k << " at eps " << eps;
      prev[k] = c[k];
    }
  }
  // Linear interpolation is exact on a linear signal.
  auto y = eval::interpolate({0, 1, 3}, {0, 10, 2, 12, 6, 16}, 2, {0.5, 2.0, 5.0});
  EXPECT_DOUBLE_EQ(y[0], 1.0);
  EXPECT_DOUBLE_EQ(y[1], 11.0);
  EXPECT_DOUBLE_EQ(y[2], 4.0);
  EXPECT_DOUBLE_EQ(y[3], 14.0);
  EXPECT_DOUBLE_EQ(y[4], 6.0);
}

// eval::write_compare adds /compare to a simulate file (replacing an earlier one) and keeps what
// the file held; the values read back are those written. Each rank uses its own file.
TEST(Indicator, WriteCompareRoundTrips) {
  int pid = world_rank() == 0 ? static_cast<int>(getpid()) : 0;
  MPI_Bcast(&pid, 1, MPI_INT, 0, PETSC_COMM_WORLD);
  const std::string file = cat("/tmp/morse_test_eval_compare_", pid, "_r", world_rank(), ".h5");
  {
    io::H5Output out(PETSC_COMM_SELF, file);
    out.write("/sim/time", std::vector<double>{0.0, 1.0});
    out.commit();
  }
  eval::Indicator ind;
  ind.e = {0.9, 0.8, 0.7, 0.6};
  ind.w = {0.1, 0.2, 0.3, 0.4};
  eval::write_compare(file, ind, 2.5e-3, 2.4e-3, "fom.h5", "tip");
  ind.e[0] = 0.95;
  eval::write_compare(file, ind, 2.5e-3, 2.4e-3, "fom.h5", "tip");  // replaces /compare
  std::vector<double> e, w, I, tmax, tsnap, time;
  std::vector<hsize_t> d;
  std::string err;
  ASSERT_TRUE(io::read_doubles(file, "/compare/e", &e, &d, &err)) << err;
  ASSERT_TRUE(io::read_doubles(file, "/compare/weights", &w, &d, &err)) << err;
  ASSERT_TRUE(io::read_doubles(file, "/compare/I", &I, &d, &err)) << err;
  ASSERT_TRUE(io::read_doubles(file, "/compare/t_max", &tmax, &d, &err)) << err;
  ASSERT_TRUE(io::read_doubles(file, "/compare/t_snapshot", &tsnap, &d, &err)) << err;
  ASSERT_TRUE(io::read_doubles(file, "/sim/time", &time, &d, &err)) << err;
  EXPECT_EQ(e, (std::vector<double>{0.95, 0.8, 0.7, 0.6}));
  EXPECT_EQ(w, (std::vector<double>{0.1, 0.2, 0.3, 0.4}));
  EXPECT_EQ(I, std::vector<double>{ind.I()});
  EXPECT_EQ(tmax, std::vector<double>{2.5e-3});
  EXPECT_EQ(tsnap, std::vector<double>{2.4e-3});
  EXPECT_EQ(time, (std::vector<double>{0.0, 1.0}));
  EXPECT_EQ(io::read_string_attribute(file, "/compare", "fom"), "fom.h5");
  EXPECT_EQ(io::read_string_attribute(file, "/compare", "tip_set"), "tip");
  std::remove(file.c_str());
}

// t_max of e1 from the runs' stored load: the fom file's, else the simulate file's; loads given
// on the command line override it; -compare_weights needs four values. Each rank uses its own
// files.
TEST(Compare, TmaxFromTheStoredLoadAndSettings) {
  int pid = world_rank() == 0 ? static_cast<int>(getpid()) : 0;
  MPI_Bcast(&pid, 1, MPI_INT, 0, PETSC_COMM_WORLD);
  const std::string fom = cat("/tmp/morse_test_eval_tmax_fom_", pid, "_r", world_rank(), ".h5");
  const std::string rom = cat("/tmp/morse_test_eval_tmax_sim_", pid, "_r", world_rank(), ".h5");
  dyn::LoadDescription ld;
  ld.loads.resize(1);
  ld.loads[0].set = "tip", ld.loads[0].dir[0] = 1, ld.loads[0].amplitude = 1, ld.loads[0].omega = 100;
  {
    io::H5Output out(PETSC_COMM_SELF, fom);
    out.write("/fom/time", std::vector<double>{0.0, 1.0});
    out.commit();
  }
  {
    io::H5Output out(PETSC_COMM_SELF, rom);
    out.write("/sim/time", std::vector<double>{0.0, 1.0});
    dyn::write_load_description(out, "/sim/load", ld);
    out.commit();
  }
  std::string stored;
  EXPECT_NEAR(eval::load_tmax(fom, rom, {}, &stored), M_PI / 2 / 100, 1e-15);
  EXPECT_EQ(stored, rom);
  auto given = ld.loads;
  given[0].omega = 200;
  EXPECT_NEAR(eval::load_tmax(fom, rom, given, &stored), M_PI / 2 / 200, 1e-15);
  EXPECT_EQ(stored, rom);
  std::remove(fom.c_str());
  std::remove(rom.c_str());

  test::GivenOptions g{{"-compare_weights", "0.5,0.5"}, {"-compare_tip", "edge"}};
  eval::CompareSettings s;
  ASSERT_EQ(s.set_from_options(PETSC_COMM_WORLD), PETSC_SUCCESS);
  EXPECT_EQ(s.tip, "edge");
  EXPECT_EQ(s.w, (std::vector<double>{0.25, 0.25, 0.25, 0.25}));
  EXPECT_EQ(s.error, "-compare_weights takes four values w1,w2,w3,w4");
}

// A given -compare_tmax must be a finite time >= 0: -1 is not "from the load", nan is refused.
TEST(Compare, TmaxGivenMustBeAFiniteTime) {
  {
    test::GivenOptions g{{"-compare_tmax", "-1"}};
    eval::CompareSettings s;
    ASSERT_EQ(s.set_from_options(PETSC_COMM_WORLD), PETSC_SUCCESS);
    EXPECT_EQ(s.error, "-compare_tmax must be a finite time >= 0 [s] (got -1)");
  }
  // Non-finite values are refused when read, naming the option and the text.
  for (const char* bad : {"nan", "inf"}) {
    test::GivenOptions g{{"-compare_tmax", bad}};
    eval::CompareSettings s;
    try {
      s.set_from_options(PETSC_COMM_WORLD);
      ADD_FAILURE() << bad << " accepted";
    } catch (const Error& e) {
      EXPECT_EQ(std::string(e.what()), cat("-compare_tmax ", bad, ": expected a finite number"));
    }
  }
  test::GivenOptions g{{"-compare_tmax", "0.25"}};
  eval::CompareSettings s;
  ASSERT_EQ(s.set_from_options(PETSC_COMM_WORLD), PETSC_SUCCESS);
  EXPECT_EQ(s.error, "");
  EXPECT_EQ(s.tmax, 0.25);
}
