// The option registry and the unknown-option check derived from it (morse/core/options.hpp).
#include <petscsys.h>
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "given_options.hpp"
#include "morse/core/error.hpp"
#include "morse/core/options.hpp"
#include "util.hpp"

namespace {

namespace opt = morse::options;

using morse::test::GivenOptions;

// A command's option block: -casing_clearance, -contact_mu and, under prefix c1_, -load_sets.
PetscErrorCode read_options(double* clearance, double* mu) {
  PetscOptionsBegin(PETSC_COMM_WORLD, nullptr, "test options", "");
  PetscCall(MorseOptionsReal("-casing_clearance", "Casing: nominal radial clearance [m]", "", *clearance, clearance,
                             nullptr));
  PetscCall(MorseOptionsReal("-contact_mu", "Coulomb friction coefficient", "", *mu, mu, nullptr));
  PetscOptionsEnd();
  char* sets[4];
  PetscInt n = 4;
  PetscOptionsBegin(PETSC_COMM_WORLD, "c1_", "test options with a prefix", "");
  PetscCall(MorseOptionsStringArray("-load_sets", "Node sets carrying a load", "", sets, &n, nullptr));
  PetscOptionsEnd();
  return PETSC_SUCCESS;
}

std::string early_error() {
  try {
    opt::check_unknown(PETSC_COMM_WORLD, true);
  } catch (const morse::Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(Options, EditDistanceCountsTranspositionsAsOne) {
  EXPECT_EQ(opt::edit_distance("export_fromat", "export_format"), 1u);
  EXPECT_EQ(opt::edit_distance("contact_muu", "contact_mu"), 1u);
  EXPECT_EQ(opt::edit_distance("casing_clearence", "casing_clearance"), 1u);
  EXPECT_EQ(opt::edit_distance("", "abc"), 3u);
  EXPECT_EQ(opt::edit_distance("abc", "abc"), 0u);
  EXPECT_EQ(opt::edit_distance("kitten", "sitting"), 3u);
}

TEST(Options, RegistrationUnderTheBlockPrefix) {
  GivenOptions given;
  double c = 1e-3, mu = 0.1;
  ASSERT_EQ(read_options(&c, &mu), 0);
  EXPECT_TRUE(opt::registered("-casing_clearance"));
  EXPECT_TRUE(opt::registered("contact_mu"));
  EXPECT_TRUE(opt::registered("-c1_load_sets"));
  EXPECT_FALSE(opt::registered("-load_sets"));
  EXPECT_EQ(opt::help("-contact_mu"), "Coulomb friction coefficient");
  EXPECT_EQ(opt::names(), (std::vector<std::string>{"-c1_load_sets", "-casing_clearance", "-contact_mu"}));
  // Reading the same options again (a second command, a loop) is one registration.
  ASSERT_EQ(read_options(&c, &mu), 0);
  EXPECT_TRUE(opt::conflicts().empty());
}

TEST(Options, OneHelpTextPerName) {
#ifndef NDEBUG
  GTEST_SKIP() << "a conflict is an assertion in debug builds";
#endif
  GivenOptions given;
  opt::add("-boundary", "Node set of the interface");
  opt::add("-boundary", "Node set of the interface");
  EXPECT_TRUE(opt::conflicts().empty());
  opt::add(nullptr, "-boundary", "Node set kept as physical DOFs");
  ASSERT_EQ(opt::conflicts().size(), 1u);
  EXPECT_NE(opt::conflicts()[0].find("-boundary registered with two help texts"), std::string::npos);
  // The early check refuses to run with a conflict.
  EXPECT_NE(early_error().find("internal error: -boundary registered with two help texts"), std::string::npos);
}

TEST(Options, ClosestSuggestsOnlyNearNames) {
  GivenOptions given;
  opt::add("-casing_clearance", "c0");
  opt::add("-casing_bump_height", "hb");
  opt::add("-contact_mu", "mu");
  opt::add("-export_format", "formats");
  opt::add("-out", "file");
  EXPECT_EQ(opt::closest("-casing_clearence"), "-casing_clearance");
  EXPECT_EQ(opt::closest("contact_muu"), "-contact_mu");
  EXPECT_EQ(opt::closest("-export_fromat"), "-export_format");
  EXPECT_EQ(opt::closest("-ot"), "-out");
  EXPECT_EQ(opt::closest("-Contact_MUU"), "-contact_mu");  // PETSc's names ignore case
  EXPECT_EQ(opt::closest("-casing_width"), "");
  EXPECT_EQ(opt::closest("-ksp_view"), "");
}

TEST(Options, SuspiciousByFirstWordOrDistanceNotInnerNorGlobal) {
  GivenOptions given;
  opt::add("-casing_clearance", "c0");
  opt::add("-cb_num_fixed_modes", "n");
  opt::add("-mesh", "file");
  opt::add_prefix("cb_", opt::Solver::Eigen);
  opt::add_prefix("static_", opt::Solver::Nonlinear);
  EXPECT_TRUE(opt::suspicious("-casing_width"));       // first word casing
  EXPECT_TRUE(opt::suspicious("-cb_num_fixed_mode"));  // first word cb, not an inner object
  EXPECT_TRUE(opt::suspicious("-mesj"));               // one edit from -mesh
  EXPECT_TRUE(opt::suspicious("-Casing_width"));       // names ignore case
  EXPECT_FALSE(opt::suspicious("-CB_EPS_TOL"));
  EXPECT_FALSE(opt::suspicious("-casing_clearance"));  // registered
  EXPECT_FALSE(opt::suspicious("-cb_eps_tol"));        // the eigen solver's EPS
  EXPECT_FALSE(opt::suspicious("-cb_st_mat_mumps_icntl_14"));
  EXPECT_FALSE(opt::suspicious("-cb_block_size"));
  EXPECT_FALSE(opt::suspicious("-cb_eigen_solver"));
  EXPECT_FALSE(opt::suspicious("-static_snes_monitor"));
  EXPECT_FALSE(opt::inner("-static_eps_tol"));    // a SNES has no EPS
  EXPECT_FALSE(opt::suspicious("-ksp_monitor"));  // an unrelated PETSc option: the final check's
  EXPECT_FALSE(opt::suspicious("-log_view"));
  EXPECT_FALSE(opt::suspicious("-malloc_debug"));
  EXPECT_FALSE(opt::suspicious("-options_left"));
  EXPECT_FALSE(opt::suspicious("-info"));
  EXPECT_FALSE(opt::suspicious("-help"));
}

TEST(Options, EarlyCheckRefusesMisspellingsNamingTheClosest) {
  GivenOptions given({{"-casing_clearence", "1e-3"}, {"-contact_mu", "0.2"}, {"-ksp_monitor", nullptr}});
  double c = 1e-3, mu = 0.1;
  ASSERT_EQ(read_options(&c, &mu), 0);
  EXPECT_DOUBLE_EQ(mu, 0.2);
  EXPECT_EQ(early_error(), "unknown option(s): -casing_clearence (did you mean -casing_clearance?) (see -help)");
  // The final check refuses every option nobody used, the unrelated one too.
  std::string final_error;
  try {
    opt::check_unknown(PETSC_COMM_WORLD, false);
  } catch (const morse::Error& e) {
    final_error = e.what();
  }
  EXPECT_EQ(final_error,
            "unknown option(s): -casing_clearence (did you mean -casing_clearance?) -ksp_monitor "
            "(see -help)");
}

TEST(Options, DynamicNamesAndTheirListOption) {
  // -c1_load_set (the list option misspelled) is refused, and so is the per-set option it would
  // have named.
  GivenOptions given({{"-c1_load_set", "x1"}, {"-c1_load_x1_dir", "z"}});
  double c = 1e-3, mu = 0.1;
  ASSERT_EQ(read_options(&c, &mu), 0);
  EXPECT_EQ(early_error(), "unknown option(s): -c1_load_set (did you mean -c1_load_sets?) -c1_load_x1_dir (see -help)");
}

TEST(Options, EarlyCheckPassesInnerAndUnrelatedOptions) {
  GivenOptions given({{"-cb_eps_tol", "1e-10"}, {"-ksp_monitor", nullptr}, {"-contact_mu", "0.2"}});
  double c = 1e-3, mu = 0.1;
  ASSERT_EQ(read_options(&c, &mu), 0);
  opt::add_prefix("cb_", opt::Solver::Eigen);
  EXPECT_EQ(early_error(), "");
}
